"""The battery table of `benchmarks.dynamic_budget`: medians of the fleet's books against the
clairvoyant plan's split."""

from __future__ import annotations

from benchmarks.dynamic_budget import rate, section
from reef_sim.timebook import ACTIVITIES


def row(seed: int, injecting: float, looks_empty: float, unused: float) -> dict:
    fleet = dict.fromkeys(ACTIVITIES, 0.0)
    fleet.update(transit=4000.0, homing=1000.0, injecting=injecting, look_empty=looks_empty,
                 recovered=unused)
    return {"seed": seed, "fleet": fleet,
            "clairvoyant": {"transit": 5000.0, "injecting": 5600.0, "unused": 10.0},
            "fleet_priority": injecting * 0.9, "fleet_treated": 60 + seed,
            "clair_priority": 5600.0 * 0.9, "clair_treated": 75}


def test_the_table_gives_medians_per_use_of_battery_and_every_seed() -> None:
    rows = [row(0, 4900.0, 300.0, 200.0), row(1, 5000.0, 200.0, 100.0),
            row(2, 5100.0, 400.0, 150.0)]
    text = section(rows)
    assert "| flying (transit and home) | 5,000 | 5,000 |" in text
    assert "| looking, found bare seabed | 300 | 0 |" in text
    assert "| injecting | 5,000 | 5,600 |" in text
    assert "| unused (at the rendezvous early) | 150 | 10 |" in text
    assert "| aggregations treated | 61 | 75 |" in text
    assert "| priority per second injecting | 0.900 | 0.900 |" in text
    assert "| 2 | 4590 | 5040 | 5000 | 5000 | 0 / 400 | 5100 | 5600 | 0 | 150 | 10 |" in text
    assert text.count("\n| ") == 9 + 1 + 3  # 9 uses and figures; a header and 3 seeds


def test_no_injection_is_a_rate_of_zero_not_an_error() -> None:
    r = row(0, 0.0, 0.0, 0.0)
    assert rate(r, "fleet") == 0.0 and rate(r, "clair") == 0.9
