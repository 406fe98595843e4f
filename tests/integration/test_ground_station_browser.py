"""The web viewer in a real browser during a live warp-60 mission: Debian's chromium driven by
Playwright (never a downloaded browser), software WebGL.

What is measured: the viewer's latency, the mission clock (from ``fleet/clock`` on the bus)
minus the time the page shows (its time cursor, `ground_station.viewer_state`), in wall
seconds; how long a page opened after the mission takes to show all of it; and, by pixel
statistics of screenshots, that the map shows the fleet. The figures are printed and kept in
``test-artifacts/ground_station_browser.json``.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from cotsfleet.mission.pacing import HOLD_WARP
from fleet_bus.clock import WarpClock
from fleet_bus.credentials import STATION_ID, load_auth
from fleet_bus.mission import clock_of, fetch_clock
from fleet_bus.session import client_config, open_session
from ground_station import palette
from ground_station.viewer import free_port
from ground_station.viewer_state import READ_STATE_JS, cursor_s, latency_figures, wall_behind_s

REPO = Path(__file__).resolve().parents[2]
CHROMIUM = Path("/usr/bin/chromium")
ARTIFACTS = REPO / "test-artifacts"
ARTIFACT = ARTIFACTS / "ground_station_web_viewer.png"
FIGURES = ARTIFACTS / "ground_station_browser.json"
CHROMIUM_ARGS = ["--no-sandbox", "--disable-background-networking",
                 "--enable-unsafe-swiftshader", "--use-angle=swiftshader"]
VIEWPORT = {"width": 1400, "height": 900}
WARP = 60.0
# Wall seconds behind the mission once the page has loaded: measured and written to FIGURES,
# not asserted. How far the viewer lags is the host's speed: an idle Xeon host kept it at a
# median 1.5 s (max 3.3 s, `benchmarks/dashboard_bench.py`, stop 54), a host about 3.5 times
# slower showed the first picture after 30 s and stayed 12-35 s behind at warp 60 (stop 55),
# so the latency targets are the dashboard benchmark's, on an idle host. Caught up means
# within LATENCY_LIMIT_S.
LATENCY_LIMIT_S = 5.0
LATE_PAGE_WAIT_S = 120.0  # how long a page opened after the mission has to show all of it
# About 70 s at warp 60; a browser's stall on a busy machine may make the operator slow the
# clock (docs/fleet_agent.md, "The clock never outruns the fleet"): the rest then runs slower.
MISSION_LIMIT_S = 420.0
SCREENSHOT_AT_S = 2400.0  # the screenshot kept: the fleet at work, after auv2's abort

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


def wait_for(path: Path, pattern: str, proc: subprocess.Popen, timeout_s: float) -> str:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if path.exists():
            m = re.search(pattern, path.read_text(errors="replace"))
            if m:
                return m.group(1)
        assert proc.poll() is None, f"cotsfleet run ended early (see {path.parent})"
        time.sleep(0.2)
    raise AssertionError(f"{pattern!r} not in {path} within {timeout_s} s")


@contextlib.contextmanager
def mission_clock(endpoint: str, creds: Path) -> Iterator[WarpClock]:
    """The mission clock, asked on the bus and followed like every fleet process does (the
    operator slows it when the machine falls behind): the router admits only the run's
    logins, so this logs in as the ground station and checks the operator's signature."""
    auth = load_auth(creds)
    with open_session(client_config([endpoint], credentials=creds)) as session:
        record = fetch_clock(session, threading.Event(), 120.0, auth=auth)
        assert record is not None, "no fleet/clock record"
        clock, follower = clock_of(session, record, auth)
        try:
            yield clock
        finally:
            follower.undeclare()


def group_gone(pgid: int, timeout_s: float = 10.0) -> bool:
    """Whether every process of the group has exited (given a moment to finish exiting)."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        try:
            os.killpg(pgid, 0)
        except ProcessLookupError:
            return True
        time.sleep(0.2)
    return False


def chromium_processes(profile: Path) -> list[int]:
    pids = []
    for proc in Path("/proc").iterdir():
        try:
            if proc.name.isdigit() and str(profile) in (proc / "cmdline").read_text():
                pids.append(int(proc.name))
        except OSError:
            pass
    return pids


def test_web_viewer_follows_a_live_warp_60_mission(tmp_path):
    from PIL import Image
    from playwright.sync_api import sync_playwright

    run_dir, out = tmp_path / "run", tmp_path / "cotsfleet.out"
    web_port, bus = free_port(), f"tcp/127.0.0.1:{free_port()}"
    with open(out, "w") as log:
        mission = subprocess.Popen(
            [sys.executable, "-m", "cotsfleet", "run", "--viewer", "web", "--web-port",
             str(web_port), "--warp", str(WARP), "--seed", "4", "--abort", "auv2@1200",
             "--run-dir", str(run_dir), "--listen", bus, "--hold-viewer"],
            cwd=REPO, stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
    profile = tmp_path / "chromium-profile"
    shot, samples, history, figures = tmp_path / "web_viewer.png", [], [], {}
    trace: list[tuple[float, float, float]] = []  # the clock: (wall, mission, warp)
    kept = False
    try:
        url = wait_for(run_dir / "ground_station.log", r"web viewer at (\S+)", mission, 120)
        assert url.startswith(f"http://127.0.0.1:{web_port}/") and "renderer=webgl" in url
        with sync_playwright() as pw, contextlib.ExitStack() as stack:
            browser = pw.chromium.launch_persistent_context(
                str(profile), executable_path=str(CHROMIUM), headless=True,
                args=CHROMIUM_ARGS, viewport=VIEWPORT)
            try:
                # as an operator does: open the printed URL while the fleet is still planning
                page = browser.new_page()
                opened = time.monotonic()
                page.goto(url)
                # served once every agent is ready
                clock = stack.enter_context(
                    mission_clock(bus, run_dir / "credentials" / STATION_ID))
                # held while an agent plans, slowed while a host is behind (`pacing`: a
                # loaded machine, make test's -n 2, read 21.3), never faster than asked
                assert HOLD_WARP <= clock.warp <= WARP
                next_shot = time.monotonic() + 6.0
                while "mission over" not in out.read_text(errors="replace"):
                    assert mission.poll() is None, "cotsfleet run ended before the mission did"
                    assert time.monotonic() - opened < MISSION_LIMIT_S, "the mission took too long"
                    time.sleep(1.0)
                    shown = cursor_s(page.evaluate(READ_STATE_JS))
                    wall, now, warp = time.monotonic() - opened, clock.now(), clock.warp
                    trace.append((wall, now, warp))
                    samples.append({"wall_s": wall, "mission_s": now, "warp": warp,
                                    "viewer_s": shown, "latency_s": None if shown is None
                                    else wall_behind_s(trace, shown, WARP)})
                    if time.monotonic() >= next_shot and shown is not None:
                        next_shot = time.monotonic() + 6.0
                        page.screenshot(path=str(shot))
                        stats = map_statistics(np.asarray(Image.open(shot).convert("RGB")), 3)
                        history.append(stats)
                        if shows_the_fleet(stats) and (not kept or shown < SCREENSHOT_AT_S):
                            # kept: the last one before mid-mission (the README's picture)
                            ARTIFACTS.mkdir(exist_ok=True)
                            ARTIFACT.write_bytes(shot.read_bytes())
                            kept = True
                report = json.loads((run_dir / "report.json").read_text())
                figures = latency_figures(
                    [(x["wall_s"], x["mission_s"], x["warp"], x["viewer_s"]) for x in samples],
                    report["end_s"], LATENCY_LIMIT_S, WARP)
                # a page opened now, after the mission: how long until it shows all of it
                last_logged = max(s["viewer_s"] or 0.0 for s in samples)
                late = browser.new_page()
                page.close()
                late_opened = time.monotonic()
                late.goto(url)
                while time.monotonic() - late_opened < LATE_PAGE_WAIT_S:
                    time.sleep(1.0)
                    shown = cursor_s(late.evaluate(READ_STATE_JS))
                    if shown is not None and shown >= last_logged - 1.0:
                        figures["late_page_s"] = time.monotonic() - late_opened
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
        ARTIFACTS.mkdir(exist_ok=True)
        FIGURES.write_text(json.dumps({"warp": WARP, **figures, "samples": samples}, indent=1))
    print(f"latency: {json.dumps(figures)}; screenshot {ARTIFACT}: "
          f"{history[-1] if history else None}")
    # nothing this test started outlives it: the launcher's process group (router, relay,
    # agents, station and its web server) and the browser
    assert group_gone(mission.pid), "a process of the mission outlived it"
    assert chromium_processes(profile) == []
    assert any(shows_the_fleet(h) for h in history), history
    shown = [x["viewer_s"] for x in samples if x["viewer_s"] is not None]
    assert len(shown) >= 3 and shown[-1] > shown[0], samples  # live: the picture moved on
    # a page opened after the mission showed all of it (within LATE_PAGE_WAIT_S: 32 to
    # 51 s on the slow host of stop 55)
    assert "late_page_s" in figures, figures
