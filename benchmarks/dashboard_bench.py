"""The ground station's dashboard: how big an hour's recording is, and how far behind the
mission the web viewer is in headless chromium.

Two real missions (``cotsfleet run``, the demo: paper preset, 3 AUVs, one-hour batteries,
auv2 aborting at 1200 s):

- ``--viewer none --rrd``: the recording's size, chunks, rows and entities;
- ``--viewer web`` at warp 60, the page opened while the fleet plans (as an operator does),
  Debian's chromium through Playwright with software WebGL: the latency, the mission clock
  (``fleet/clock``) minus the page's time cursor (`ground_station.viewer_state`), in wall
  seconds, once the page has loaded; then a page opened after the mission, and how long it
  takes to show all of it.

``--repo DIR`` measures another checkout (e.g. an older commit, for a before/after) with the
same script: its ``cotsfleet`` and ``ground_station`` run, this script measures.

    python -m benchmarks.dashboard_bench [--no-write] [--repo DIR] [--no-browser]
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import re
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections import Counter
from pathlib import Path

from benchmarks.results import markdown_table, write_section

REPO = Path(__file__).resolve().parents[1]
CHROMIUM = Path("/usr/bin/chromium")
CHROMIUM_ARGS = ["--no-sandbox", "--disable-background-networking",
                 "--enable-unsafe-swiftshader", "--use-angle=swiftshader"]
VIEWPORT = {"width": 1400, "height": 900}
MISSION = ["--seed", "0", "--abort", "auv2@1200"]  # the demo
CAUGHT_UP_S = 5.0  # a page counts as caught up once it is this close to the mission


def free_port() -> int:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def run_env(repo: Path) -> dict[str, str]:
    return {**os.environ, "PYTHONPATH": str(repo)}


def recording(repo: Path, warp: float, work: Path) -> dict:
    """A mission recorded with ``--viewer none --rrd``: size, chunks, rows, entities."""
    from rerun.chunk import RrdReader

    rrd = work / f"mission-{warp:g}.rrd"
    t0 = time.monotonic()
    proc = subprocess.run(
        [sys.executable, "-m", "cotsfleet", "run", "--viewer", "none", "--rrd", str(rrd),
         "--warp", str(warp), *MISSION, "--run-dir", str(work / f"run-rrd-{warp:g}")],
        cwd=repo, env=run_env(repo), capture_output=True, text=True, timeout=900)
    if proc.returncode != 0:
        raise RuntimeError(f"cotsfleet run failed: {proc.stdout[-1500:]}{proc.stderr[-1500:]}")
    end = json.loads((work / f"run-rrd-{warp:g}" / "report.json").read_text())["end_s"]
    chunks, rows, entities = 0, 0, Counter()
    for chunk in RrdReader(rrd).stream():
        chunks += 1
        n = chunk.to_record_batch().num_rows
        rows += n
        entities[chunk.entity_path] += n
    return {"warp": warp, "mission_s": end, "wall_s": time.monotonic() - t0,
            "bytes": rrd.stat().st_size, "chunks": chunks, "rows": rows,
            "entities": len(entities), "top": entities.most_common(5)}


def _wait_for(path: Path, pattern: str, proc: subprocess.Popen, timeout_s: float) -> str:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if path.exists():
            m = re.search(pattern, path.read_text(errors="replace"))
            if m:
                return m.group(1)
        if proc.poll() is not None:
            raise RuntimeError(f"cotsfleet run ended early (see {path.parent})")
        time.sleep(0.2)
    raise RuntimeError(f"{pattern!r} not in {path} within {timeout_s} s")


def followed_clock(bus: str, run_dir: Path, stack: contextlib.ExitStack):
    """The mission clock as the fleet follows it (slowed when the machine falls behind). The
    router admits only the run's logins; a checkout from before them has none."""
    from fleet_bus.mission import clock_of, fetch_clock
    from fleet_bus.session import client_config, open_session

    creds = run_dir / "credentials" / "station"
    auth = None
    if creds.is_dir():
        from fleet_bus.credentials import load_auth
        auth = load_auth(creds)
    session = stack.enter_context(open_session(
        client_config([bus], credentials=creds if auth else None)))
    record = fetch_clock(session, threading.Event(), 180.0, auth=auth)
    if record is None:
        raise RuntimeError("no fleet/clock record")
    clock, follower = clock_of(session, record, auth)
    stack.callback(follower.undeclare)
    return clock


def browser_latency(repo: Path, warp: float, work: Path) -> dict:
    """The web viewer's latency during a live mission, and a late page's catch-up."""
    from playwright.sync_api import sync_playwright

    from ground_station.viewer_state import READ_STATE_JS, cursor_s, latency_figures

    run_dir, out = work / f"run-web-{warp:g}", work / f"web-{warp:g}.out"
    bus = f"tcp/127.0.0.1:{free_port()}"
    with open(out, "w") as log:
        mission = subprocess.Popen(
            [sys.executable, "-m", "cotsfleet", "run", "--viewer", "web", "--web-port",
             str(free_port()), "--warp", str(warp), *MISSION, "--run-dir", str(run_dir),
             "--listen", bus, "--hold-viewer"],
            cwd=repo, env=run_env(repo), stdout=log, stderr=subprocess.STDOUT,
            start_new_session=True)
    # wall since open, mission, warp, shown
    samples: list[tuple[float, float, float, float | None]] = []
    result: dict = {"warp": warp}
    try:
        url = _wait_for(run_dir / "ground_station.log", r"web viewer at (\S+)", mission, 180)
        with sync_playwright() as pw, contextlib.ExitStack() as stack:
            browser = pw.chromium.launch(executable_path=str(CHROMIUM), headless=True,
                                         args=CHROMIUM_ARGS)
            try:
                page = browser.new_page(viewport=VIEWPORT)
                opened = time.monotonic()
                page.goto(url)
                clock = followed_clock(bus, run_dir, stack)
                while "mission over" not in out.read_text(errors="replace"):
                    if mission.poll() is not None or time.monotonic() - opened > 600:
                        raise RuntimeError("the mission did not end normally")
                    time.sleep(1.0)
                    shown = cursor_s(page.evaluate(READ_STATE_JS))
                    samples.append((time.monotonic() - opened, clock.now(), clock.warp, shown))
                end = json.loads((run_dir / "report.json").read_text())["end_s"]
                result |= latency_figures(samples, end, CAUGHT_UP_S, warp)
                last = max(s for _, _, _, s in samples if s is not None)
                late = browser.new_page(viewport=VIEWPORT)
                page.close()
                late_opened = time.monotonic()
                late.goto(url)
                while time.monotonic() - late_opened < 600:
                    time.sleep(1.0)
                    shown = cursor_s(late.evaluate(READ_STATE_JS))
                    if shown is not None and shown >= last - 1.0:
                        result["late_page_s"] = time.monotonic() - late_opened
                        break
            finally:
                browser.close()
    finally:
        if mission.poll() is None:
            os.killpg(mission.pid, signal.SIGINT)
            try:
                mission.wait(30)
            except subprocess.TimeoutExpired:
                os.killpg(mission.pid, signal.SIGKILL)
                mission.wait(10)
    return result


def _fmt(x: object, unit: str = "") -> str:
    return "-" if x is None else (f"{x:.1f}{unit}" if isinstance(x, float) else f"{x}{unit}")


def main(repo: Path, browser: bool, write: bool) -> None:
    label = "this checkout" if repo == REPO else str(repo)
    with tempfile.TemporaryDirectory(prefix="dashboard-bench-") as tmp:
        work = Path(tmp)
        size = recording(repo, 60.0, work)
        print(f"recording at warp 60: {size['bytes'] / 1e6:.2f} MB, {size['chunks']} chunks, "
              f"{size['rows']} rows, {size['entities']} entities; largest {size['top']}",
              flush=True)
        web = {}
        if browser and CHROMIUM.exists():
            web = browser_latency(repo, 60.0, work)
            print(f"web viewer at warp 60: {web}", flush=True)
        elif browser:
            print(f"no browser figures: {CHROMIUM} is missing", flush=True)
    body = (
        f"Code measured: {label}. The demo mission (`cotsfleet run {' '.join(MISSION)}`: "
        f"paper preset, 3 AUVs, {size['mission_s']:.0f} s of mission).\n\n"
        + markdown_table(
            ["figure", "value"],
            [["recording (`--viewer none --rrd`, warp 60)", f"{size['bytes'] / 1e6:.2f} MB"],
             ["chunks / rows / entities in it",
              f"{size['chunks']} / {size['rows']} / {size['entities']}"],
             ["web viewer: page first shows data after", _fmt(web.get("first_shown_s"), " s")],
             [f"web viewer: caught up (< {CAUGHT_UP_S:g} s behind) after",
              _fmt(web.get("caught_up_s"), " s")],
             ["web viewer latency once caught up: median / max",
              f"{_fmt(web.get('latency_median_s'), ' s')} / "
              f"{_fmt(web.get('latency_max_s'), ' s')}"],
             ["web viewer latency at the end of the mission", _fmt(web.get("latency_end_s"), " s")],
             ["a page opened after the mission shows all of it after",
              _fmt(web.get("late_page_s"), " s")]])
        + "\n\nLatency: wall seconds since the mission clock (`fleet/clock`) read the time the "
        "page shows (its time cursor), from the clock's own history, since the warp changes "
        "(`viewer_state.wall_behind_s`); sampled every second while the mission runs; headless "
        "Debian chromium, software WebGL (swiftshader), 1400x900, on this machine with "
        "whatever else it was running.\n")
    print(body)
    if write:
        write_section("dashboard", "ground_station: recording size and web viewer latency", body)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repo", type=Path, default=REPO,
                        help="the checkout whose cotsfleet and ground_station run (default: this)")
    parser.add_argument("--no-browser", action="store_true", help="only the recording's size")
    parser.add_argument("--no-write", action="store_true",
                        help="print the figures without touching RESULTS.md")
    parser.add_argument("--quick", action="store_true", help="same as --no-browser --no-write")
    args = parser.parse_args()
    main(args.repo.resolve(), browser=not (args.no_browser or args.quick),
         write=not (args.no_write or args.quick))
