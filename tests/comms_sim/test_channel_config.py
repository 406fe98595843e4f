"""Channel parameters validate themselves; presets and config files."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from comms_sim.acoustics.modems import MODEMS
from comms_sim.config import PRESETS, ChannelConfig, Partition, TdmaConfig, config_from_dict, \
    load_config


@pytest.mark.parametrize("bad", [
    {"sound_speed_mps": 0.0}, {"bitrate_bps": -1.0}, {"max_frame_bytes": 0},
    {"max_frame_bytes": 64.5}, {"extra_loss": 1.01}, {"extra_loss": -0.1},
    {"range_d50_m": float("nan")}, {"max_range_m": float("inf")}, {"preamble_s": -0.1},
    {"partitions": ({"start_s": 0},)}, {"model": "quantum"}, {"wind_mps": -1.0},
    {"shipping": 1.5}, {"shrimp_db": float("nan")}, {"spreading_k": 0.0},
    {"rician_k": -1.0}, {"absorption_db_per_km": -0.5}, {"modem": "psk_1k"},
])
def test_invalid_settings_are_refused(bad: dict) -> None:
    with pytest.raises(ValueError):
        ChannelConfig(**bad)


def test_partition_validation_and_groups() -> None:
    with pytest.raises(ValueError):
        Partition(5.0, 5.0, (("a",),))
    with pytest.raises(ValueError):
        Partition(0.0, 1.0, (("a", "b"), ("b",)))
    with pytest.raises(ValueError):
        Partition(0.0, 1.0, ())
    split = Partition(0.0, 10.0, (("a", "b"), ("c",)))
    assert split.cuts("a", "c", 1.0, 2.0) and split.cuts("d", "a", 1.0, 2.0)
    assert not split.cuts("a", "b", 1.0, 2.0)
    assert not split.cuts("a", "c", 10.0, 11.0)  # half-open window
    assert split.cuts("a", "c", 9.5, 11.0)  # any overlap with the reception


def test_partition_from_dict() -> None:
    p = Partition.from_dict({"duration_s": 30, "groups": [["a"]]}, now_s=100.0)
    assert (p.start_s, p.end_s, p.groups) == (100.0, 130.0, (frozenset({"a"}),))
    for bad in ({"groups": [["a"]]}, {"end_s": 5, "groups": ["ab"]}, {"end_s": 5},
                {"end_s": "x", "groups": [["a"]]}):
        with pytest.raises(ValueError):
            Partition.from_dict(bad)


def test_default_link_is_workable_for_a_reef_fleet() -> None:
    """The issue's check on the default modem, and the fleet's working range (a 1 km reef)."""
    c = ChannelConfig()
    assert c.model == "physical" and c.modem.name == "psk_1k"
    assert c.max_frame_bytes == 64 and c.sound_speed_mps == 1500.0
    ranges = np.linspace(0.0, 10_000.0, 201)
    curve = [c.delivery_probability(r, 64) for r in ranges]
    assert all(b <= a for a, b in zip(curve, curve[1:]))  # non-increasing with range
    assert c.delivery_probability(300.0, 64) >= 0.9
    assert c.delivery_probability(8000.0, 64) <= 0.05
    assert c.delivery_probability(1000.0) > 0.98
    assert 0.9 < c.delivery_probability(1500.0) < 0.95
    assert c.delivery_probability(2000.0) == pytest.approx(0.5, abs=0.01)  # the calibration
    assert c.delivery_probability(3000.0) < 0.05
    assert c.airtime_s(64) < 1.0  # a full frame, so 20 vehicles every 20 s fit on air


def test_empirical_preset_is_the_earlier_default() -> None:
    c = PRESETS["empirical_psk_1k"]
    assert c.delivery_probability(1000.0) > 0.95
    assert 0.75 < c.delivery_probability(1500.0) < 0.85
    assert c.delivery_probability(3000.0) < 0.05 and c.delivery_probability(3000.1) == 0.0
    assert c.horizon_m == 3000.0 and c.airtime_s(64) == ChannelConfig().airtime_s(64)


def test_config_files(tmp_path: Path) -> None:
    toml = tmp_path / "c.toml"
    toml.write_text('preset = "micromodem_rate0"\nextra_loss = 0.1\n'
                    '[tdma]\nslot_s = 6.0\norder = ["a", "b"]\n'
                    '[[partitions]]\nstart_s = 10\nend_s = 20\ngroups = [["a"]]\n')
    c = load_config(toml)
    assert c.bitrate_bps == 80.0 and c.extra_loss == 0.1
    assert c.tdma == TdmaConfig(slot_s=6.0, order=("a", "b"))
    assert c.partitions == (Partition(10.0, 20.0, (("a",),)),)
    js = tmp_path / "c.json"
    js.write_text(json.dumps({"bitrate_bps": 500}))
    assert load_config(js) == PRESETS["psk_500"]
    sea = tmp_path / "sea.toml"
    sea.write_text('preset = "evologics_s2c_18_34"\nwind_mps = 12.0\nshipping = 0.9\n'
                   'shrimp_db = -inf\nrician_k = 4.0\n')
    c = load_config(sea)
    assert (c.wind_mps, c.shipping, c.shrimp_db, c.rician_k) == (12.0, 0.9, -math.inf, 4.0)
    assert c.modem == MODEMS["evologics_s2c_18_34"] and c.bitrate_bps == 13900.0
    assert config_from_dict({"modem": "micromodem_rate0"}).modem == MODEMS["micromodem_rate0"]
    louder = config_from_dict({"modem": {"source_level_db": 190.0}})
    assert louder.modem == replace(MODEMS["psk_1k"], source_level_db=190.0)
    tabled = config_from_dict({"modem": {"error_table": {
        "snr_db": [0, 3], "frame_error": [1, 0], "frame_bytes": 64}}})
    assert tabled.modem.modulation == "table" and tabled.modem.error_table is not None
    assert tabled.delivery_probability(100.0) > tabled.delivery_probability(2000.0)
    for bad in ({"preset": "nope"}, {"warp": 3}, {"tdma": {"slot": 1}}, {"modem": "nope"},
                {"modem": 5}, {"modem": {"colour": "red"}}, {"shipping": 2},
                {"modem": {"error_table": {"snr_db": [3, 0], "frame_error": [1, 0],
                                           "frame_bytes": 64}}}):
        with pytest.raises(ValueError):
            config_from_dict(bad)
    with pytest.raises(ValueError):
        load_config(tmp_path / "c.yaml")


def test_with_tdma_sizes_the_slot_for_the_largest_frame() -> None:
    from comms_sim.config import with_tdma

    c = with_tdma(PRESETS["empirical_psk_1k"], ["b", "a"])
    assert c.tdma == TdmaConfig(slot_s=2.9, order=("b", "a"), guard_s=2.0)  # 0.812 + 2 s
    physical = with_tdma(ChannelConfig(), ["a"])  # guard: propagation over the hearing range
    assert physical.tdma is not None
    assert physical.tdma.guard_s == pytest.approx(ChannelConfig().horizon_m / 1500.0)
    assert physical.tdma.slot_s == pytest.approx(
        math.ceil((0.812 + physical.tdma.guard_s) * 10) / 10)
    slow = with_tdma(PRESETS["micromodem_rate0"], ["a"], guard_s=1.0)
    assert slow.tdma is not None and slow.tdma.slot_s == pytest.approx(4.7)  # 3.7 + 1 s
