"""`cotsfleet link`: the link budget at a range, the table against range, the plot, errors."""

from __future__ import annotations

import json
import math

import pytest

from comms_sim.config import PRESETS
from cotsfleet.cli import main


def run_json(capsys, *argv: str) -> dict:
    assert main(["link", *argv, "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def test_one_range_prints_the_link_budget(capsys) -> None:
    doc = run_json(capsys, "--modem", "psk_1k", "--range", "1000")
    # TL by hand: 15 log10(1000) + Thorp(25 kHz) 6.104805 dB/km * 1 km
    assert doc["frequency_khz"] == 25.0
    assert doc["transmission_loss_db"] == pytest.approx(51.10, abs=0.01)
    assert doc["snr_db"] == pytest.approx(185.0 - 51.105 - doc["noise_db"], abs=0.02)
    assert doc["delivery_probability"] == pytest.approx(
        PRESETS["psk_1k"].delivery_probability(1000.0, 64), abs=1e-4)
    assert doc["nbytes"] == 64 and doc["model"] == "physical"


def test_sea_state_flags_change_noise_and_delivery(capsys) -> None:
    reef = run_json(capsys, "--range", "2000")
    open_sea = run_json(capsys, "--range", "2000", "--shrimp", "none")
    stormy = run_json(capsys, "--range", "2000", "--shrimp", "none", "--wind", "20")
    assert open_sea["noise_db"] < stormy["noise_db"] < reef["noise_db"]
    assert open_sea["delivery_probability"] >= stormy["delivery_probability"] \
        >= reef["delivery_probability"]
    assert open_sea["shrimp_db"] is None and reef["shrimp_db"] > 60


def test_small_frame_modem_defaults_to_its_largest_frame(capsys) -> None:
    doc = run_json(capsys, "--modem", "micromodem_rate0", "--range", "3000")
    assert doc["nbytes"] == 32 and doc["bitrate_bps"] == 80.0
    assert doc["bandwidth_khz"] == 4.0


def test_table_against_range(capsys) -> None:
    doc = run_json(capsys)
    curve = [row["delivery_probability"] for row in doc["ranges"]]
    assert all(b <= a for a, b in zip(curve, curve[1:]))
    assert doc["range_90_m"] < doc["range_50_m"] < doc["range_10_m"]
    assert doc["range_50_m"] == pytest.approx(2000.0, abs=25.0)
    assert main(["link", "--modem", "empirical_psk_1k"]) == 0
    text = capsys.readouterr().out
    assert "empirical model" in text and "50 % at 2000 m" in text


def test_plot_writes_a_png(tmp_path, capsys) -> None:
    pytest.importorskip("matplotlib")
    out = tmp_path / "psk.png"
    assert main(["link", "--modem", "evologics_s2c_18_34", "--plot", str(out)]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert f"wrote {out}" in capsys.readouterr().out


def test_channel_file(tmp_path, capsys) -> None:
    cfg = tmp_path / "c.toml"
    cfg.write_text('preset = "psk_1k"\n[modem]\nsource_level_db = 195.0\n')
    louder = run_json(capsys, "--config", str(cfg), "--range", "2000")
    assert louder["snr_db"] == pytest.approx(run_json(capsys, "--range", "2000")["snr_db"] + 10)


@pytest.mark.parametrize("argv", [
    ["--modem", "nope"], ["--range", "-1"], ["--range", "nan"], ["--bytes", "65"],
    ["--modem", "micromodem_rate0", "--bytes", "33"], ["--bytes", "0"],
    ["--wind", "-3"], ["--shipping", "2"], ["--shrimp", "loud"], ["--wind", "inf"],
    ["--range", "100", "--plot", "x.png"], ["--config", "/nonexistent/c.toml"],
    ["--plot", "/nonexistent-dir/x.png"],
])
def test_bad_arguments_exit_2_with_one_line(argv, capsys) -> None:
    assert main(["link", *argv]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("cotsfleet link: error:") and "\n" not in err


def test_nan_free_output(capsys) -> None:
    for row in run_json(capsys, "--modem", "micromodem_psk5")["ranges"]:
        assert all(not (isinstance(v, float) and math.isnan(v)) for v in row.values())
