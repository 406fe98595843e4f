"""The one definition of what the fleet collected (`FleetLedger.collected`): on the real reef
when there is one, on the map's spots otherwise; duplicates by spot, whatever the ids."""

from __future__ import annotations

import pytest

from fleet_bus.ledger import FleetLedger, RealReef, SpotValues, cumulative
from fleet_bus.telemetry import Event, Status, position_detail

# A map of three predicted spots (ids 1-3); the reef: spot 1 holds real spot 0, spot 2 real
# spot 1, spot 3 is empty, and real spot 2 (at 500, 500) is one the map missed.
PREDICTED = {1: 10.0, 2: 20.0, 3: 30.0}
REEF = RealReef(priority=(12.0, 25.0, 40.0),
                positions=((100.0, 0.0, -5.0), (200.0, 0.0, -5.0), (500.0, 500.0, -6.0)),
                of_task={1: 0, 2: 1}, unmapped=frozenset({2}))
MAP, REAL = SpotValues(PREDICTED), SpotValues(PREDICTED, REEF)
FIND = 100  # a find's id (a slot of its finder: beyond the predicted ids)


def status(vid: str, t: float, treated: list[int]) -> Status:
    return Status(t, vid, "transit", (0.0, 0.0, 0.0), 100.0, 10.0, [], treated, 0, 0.0, 0.0)


def ledger_of(*records: Event | Status) -> FleetLedger:
    ledger = FleetLedger()
    for r in records:
        if isinstance(r, Event):
            ledger.add_event(r)
        else:
            ledger.add_status(r)
    return ledger


def found(t: float, vid: str, pos: tuple[float, float, float], rho: float) -> Event:
    return Event(t, vid, "found", [FIND], detail=f"{position_detail(pos)} rho {rho:g}")


def cleared(t: float, vid: str, task: int, pos: tuple[float, float, float] | None = None
            ) -> Event:
    return Event(t, vid, "cleared", [task], detail=position_detail(pos) if pos else "")


def test_on_the_map_priority_is_the_maps_and_out_of_the_scenarios_total() -> None:
    c = ledger_of(cleared(10, "a", 1), cleared(20, "b", 2), cleared(30, "b", 1)).collected(MAP)
    assert (c.on_reef, c.spots, c.spots_of, c.priority, c.priority_of) == \
        (False, 2, 3, 30.0, 60.0)
    assert (c.treatments, c.duplicates) == (3, 1)
    assert c.by_vehicle == {"a": (1, 10.0), "b": (2, 30.0)}
    assert c.spot_word == "spots"


def test_on_a_reef_every_figure_is_the_real_reefs() -> None:
    """A find of the aggregation the map missed counts with its real priority, an empty
    predicted spot counts nothing, and the totals are the reef's."""
    ledger = ledger_of(found(5, "a", (500.0, 500.0, -6.0), 39.0), cleared(10, "a", 1),
                       cleared(40, "a", FIND, (500.0, 500.0, -6.0)),
                       Event(50, "b", "empty", [3]))
    c = ledger.collected(REAL)
    assert (c.on_reef, c.spots, c.spots_of, c.priority, c.priority_of) == \
        (True, 2, 3, 52.0, 77.0)
    assert c.spot_word == "real spots" and c.duplicates == 0
    assert ledger.found_spots(REAL) == {2} and ledger.empty == {3}


def test_one_aggregation_treated_under_two_ids_is_a_duplicate() -> None:
    """A vehicle that finds a mapped aggregation before it reaches the predicted spot, and
    treats both, injected the same real spot twice (Green Island: 7 such, counted as 2
    before: only different vehicles counted)."""
    at_spot_1 = (100.0, 0.0, -5.0)
    ledger = ledger_of(found(5, "a", at_spot_1, 12.0), cleared(10, "a", FIND, at_spot_1),
                       cleared(20, "a", 1))
    c = ledger.collected(REAL)
    assert (c.spots, c.treatments, c.duplicates, c.priority) == (1, 2, 1, 12.0)
    assert c.by_vehicle == {"a": (1, 12.0)}
    # on the map the two ids are two spots: the map cannot see the duplicate
    assert ledger.collected(MAP).duplicates == 0


def test_statuses_count_too_and_the_earliest_report_dates_a_treatment() -> None:
    """A status may list a treatment before its event arrives (the processes backend):
    counted once, dated by the event."""
    ledger = ledger_of(status("a", 100.0, [1, 2]), cleared(60.0, "a", 2),
                       status("a", 200.0, [1, 2]))
    assert ledger.treatments == 2
    assert [(t.task, t.t_s) for t in ledger.treatments_of(MAP)] == [(2, 60.0), (1, 100.0)]


def test_a_find_is_matched_within_a_metre_in_as_many_dimensions_as_given() -> None:
    assert REEF.spot_at((500.4, 500.4, -6.0)) == 2
    assert REEF.spot_at((500.4, 500.4)) == 2
    assert REEF.spot_at((502.0, 500.0, -6.0)) is None
    ledger = ledger_of(cleared(10, "a", FIND, (900.0, 900.0, -6.0)))
    c = ledger.collected(REAL)
    assert (c.spots, c.treatments, c.priority) == (0, 0, 0.0)  # nothing real is there


@pytest.mark.parametrize("values", [MAP, REAL])
def test_over_time_the_series_end_at_the_figures(values: SpotValues) -> None:
    ledger = ledger_of(cleared(30, "b", 2), cleared(10, "a", 1), cleared(50, "a", 2),
                       found(60, "b", (500.0, 500.0, -6.0), 40.0),
                       cleared(70, "b", FIND, (500.0, 500.0, -6.0)))
    c = ledger.collected(values)
    t_s, total, per = cumulative(ledger.treatments_of(values), values)
    assert t_s == sorted(t_s) and total[-1] == pytest.approx(c.priority)
    for vid, (_, vals) in per.items():
        assert vals[-1] == pytest.approx(c.by_vehicle[vid][1])
