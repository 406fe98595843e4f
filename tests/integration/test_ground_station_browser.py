"""The web viewer in a real browser during a live mission: Debian's chromium driven by
Playwright (never a downloaded browser), software WebGL; the screenshot must show the map
with the fleet on it, judged by pixel statistics."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from ground_station import palette
from ground_station.viewer import free_port

REPO = Path(__file__).resolve().parents[2]
CHROMIUM = Path("/usr/bin/chromium")
ARTIFACT = REPO / "test-artifacts" / "ground_station_web_viewer.png"
CHROMIUM_ARGS = ["--no-sandbox", "--disable-background-networking",
                 "--enable-unsafe-swiftshader", "--use-angle=swiftshader"]
VIEWPORT = {"width": 1400, "height": 900}

pytestmark = [
    pytest.mark.integration, pytest.mark.browser,
    pytest.mark.skipif(not CHROMIUM.exists(), reason="needs Debian's chromium at /usr/bin/chromium"
                       " (.ci/run installs it: apt-get install chromium)"),
]


def map_statistics(rgb: np.ndarray, n_vehicles: int) -> dict:
    """Where the COTS field is on screen and how much of each vehicle colour lies on it.

    The field is found as the bounding box of pixels close to the sea colormap; the vehicles
    (points, heading arrows, trails, routes) by their palette colours inside that box, so the
    time-series plots, drawn in the same colours beside the map, do not count.
    """
    img = rgb[..., :3].astype(np.int16)
    ramp = palette.sea_colormap(np.linspace(0.0, 1.0, 48)).astype(np.int16)
    small = img[::3, ::3]  # the field is large: a third of the pixels locate it
    dist = np.abs(small[:, :, None, :] - ramp[None, None, :, :]).sum(axis=3).min(axis=2)
    sea = dist <= 12
    stats: dict = {"sea_pixels": int(sea.sum()) * 9}
    if sea.sum() < 100:
        return stats | {"box": None, "sea_share": 0.0, "vehicle_pixels": [0] * n_vehicles}
    ys, xs = np.nonzero(sea)
    y0, y1 = (np.percentile(ys, [1, 99]) * 3).astype(int)
    x0, x1 = (np.percentile(xs, [1, 99]) * 3).astype(int)
    box = img[y0:y1, x0:x1]
    stats["box"] = (int(x0), int(y0), int(x1), int(y1))
    stats["sea_share"] = float(sea[y0 // 3:y1 // 3, x0 // 3:x1 // 3].mean())
    stats["vehicle_pixels"] = [
        int((np.abs(box - np.array(c)).sum(axis=2) <= 45).sum())
        for c in palette.VEHICLE_COLORS[:n_vehicles]]
    return stats


def shows_the_fleet(stats: dict) -> bool:
    box = stats.get("box")
    return (box is not None and box[2] - box[0] >= 300 and box[3] - box[1] >= 300
            and stats["sea_share"] >= 0.5 and min(stats["vehicle_pixels"]) >= 40)


def test_statistics_tell_a_fleet_from_an_empty_or_fleetless_map():
    blank = np.full((900, 1400, 3), 30, np.uint8)
    assert not shows_the_fleet(map_statistics(blank, 3))
    field = blank.copy()
    field[100:600, 100:600] = palette.sea_colormap(np.linspace(0, 1, 500))[None, :, :]
    assert not shows_the_fleet(map_statistics(field, 3))  # a map but no vehicles
    for i, c in enumerate(palette.VEHICLE_COLORS[:3]):
        field[200 + 50 * i:210 + 50 * i, 200:210] = c
    stats = map_statistics(field, 3)
    assert shows_the_fleet(stats), stats
    field[:, 1000:1010] = palette.VEHICLE_COLORS[0]  # a plot line beside the map: not counted
    assert map_statistics(field, 3)["vehicle_pixels"][0] == stats["vehicle_pixels"][0]


def wait_for_url(log: Path, proc: subprocess.Popen, timeout_s: float) -> str:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if log.exists():
            m = re.search(r"web viewer at (\S+)", log.read_text(errors="replace"))
            if m:
                return m.group(1)
        assert proc.poll() is None, f"cotsfleet run ended early: {proc.stdout.read()[-2000:]}"
        time.sleep(0.2)
    raise AssertionError(f"no web viewer URL in {log} within {timeout_s} s")


def test_web_viewer_shows_the_fleet_during_a_live_mission(tmp_path):
    from PIL import Image
    from playwright.sync_api import sync_playwright

    run_dir = tmp_path / "run"
    web_port = free_port()
    mission = subprocess.Popen(
        [sys.executable, "-m", "cotsfleet", "run", "--viewer", "web", "--web-port", str(web_port),
         "--warp", "40", "--seed", "4", "--run-dir", str(run_dir)],
        cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
        start_new_session=True)
    shot = tmp_path / "web_viewer.png"
    history = []
    try:
        url = wait_for_url(run_dir / "ground_station.log", mission, timeout_s=120)
        assert url.startswith(f"http://127.0.0.1:{web_port}/") and "renderer=webgl" in url
        with sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path=str(CHROMIUM), headless=True,
                                         args=CHROMIUM_ARGS)
            try:
                page = browser.new_page(viewport=VIEWPORT)
                page.goto(url)
                deadline = time.monotonic() + 120
                while time.monotonic() < deadline:
                    time.sleep(4)
                    assert mission.poll() is None, "the mission ended before the map showed"
                    page.screenshot(path=str(shot))
                    stats = map_statistics(np.asarray(Image.open(shot).convert("RGB")), 3)
                    history.append(stats)
                    if shows_the_fleet(stats):
                        break
            finally:
                browser.close()
    finally:
        if mission.poll() is None:
            os.killpg(mission.pid, signal.SIGINT)  # Ctrl-C: the launcher stops its fleet
            try:
                mission.wait(30)
            except subprocess.TimeoutExpired:
                os.killpg(mission.pid, signal.SIGKILL)
                mission.wait(10)
        if shot.exists():
            ARTIFACT.parent.mkdir(exist_ok=True)
            ARTIFACT.write_bytes(shot.read_bytes())
    print(f"screenshot {ARTIFACT}: {history[-1] if history else None}")
    assert history and shows_the_fleet(history[-1]), history
