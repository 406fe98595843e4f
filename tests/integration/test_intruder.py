"""A real 3-AUV mission (`cotsfleet run`) under an intruder on the bus.

The bus is TLS (the credentials are made by `cotsfleet credentials`). First the intruder
knows only the router's address and the mission's public CA certificate: it cannot even get
in. Then it holds the router's own TLS key and certificate (leaked: the access control lets
that identity do anything) but none of the fleet's signing keys, and it sends abort and
stop commands, a forged mission and clock record, link partitions and total loss, forged
telemetry, ready announcements, link records and stats, and floods one agent's deliveries
and the relay's input with garbage and forged envelopes (about 2,000 messages/s for 20 s).
Nothing changes: no vehicle aborts or stops, all 3 come home, no spot is treated twice, the
flooded agent's memory stays flat, no process dies, and the report counts what was refused.
Every process is gone at the end."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from cotsfleet.mission.bus_intruder import BusIntruder
from fleet_bus.session import free_tcp_endpoint
from reef_sim.scenarios.field import GeneratorParams, generate_doc
from leftovers import alive

REPO = Path(__file__).resolve().parents[2]
pytestmark = [pytest.mark.integration, pytest.mark.slow]
VEHICLES = ("auv1", "auv2", "auv3")
FLOOD_S, FLOOD_RATE = 20.0, 2000.0  # messages per second, over both targets
RSS_LIMIT_MB = 60.0


@pytest.fixture(scope="module")
def mission(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("intruder")
    doc = generate_doc(GeneratorParams(name="intruded", n_tasks=24, n_vehicles=3, size_m=500.0,
                                       battery_s=1800.0, service_s=60.0),
                       np.random.default_rng(9))
    (tmp / "scenario.json").write_text(json.dumps(doc), encoding="utf-8")
    creds = tmp / "credentials"  # made beforehand so the intruder can steal the router's key
    subprocess.run([sys.executable, "-m", "cotsfleet", "credentials", str(creds), "--scenario",
                    str(tmp / "scenario.json")], cwd=REPO, check=True, capture_output=True)
    endpoint = free_tcp_endpoint(proto="tls")
    run_dir = tmp / "run"
    proc = subprocess.Popen(
        [sys.executable, "-m", "cotsfleet", "run", "--scenario", str(tmp / "scenario.json"),
         "--viewer", "none", "--warp", "25", "--run-dir", str(run_dir), "--seed", "2",
         "--listen", endpoint, "--credentials", str(creds)],
        cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    stop = threading.Event()
    intruder: BusIntruder | None = None
    pids: dict[str, list[int]] = {}
    lines: list[str] = []
    try:
        assert proc.stdout is not None
        for line in proc.stdout:  # the mission runs: the intruder strikes
            lines.append(line)
            if line.startswith("t="):
                break
        pids = json.loads((run_dir / "pids.json").read_text())
        intruder = BusIntruder(endpoint, creds / "router", VEHICLES,
                               agent=pids["auv1"][0], relay=pids["relay"][0], flood_s=FLOOD_S,
                               rate_hz=FLOOD_RATE)
        attacker = threading.Thread(target=intruder.run, args=(stop,), daemon=True)
        attacker.start()
        rest, _ = proc.communicate(timeout=400)
        lines.append(rest)
        stop.set()
        attacker.join(30)
    finally:
        stop.set()
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        time.sleep(1.0)
        left = [(n, p) for n, group in pids.items() for p in group if alive(p)]
        for _, pid in left:
            os.killpg(pid, signal.SIGKILL)
    report = json.loads((run_dir / "report.json").read_text())
    return report, intruder, proc.returncode, "".join(lines), left


def test_the_intruder_without_a_certificate_cannot_get_in(mission):
    _, intruder, _, _, _ = mission
    assert intruder.refused_login
    assert intruder.error == ""


def test_the_fleet_did_its_mission_as_if_alone(mission):
    report, _, code, out, _ = mission
    assert code == 0, out[-3000:]
    assert "failure" not in report
    assert all(c == 0 for c in report["exit_codes"].values()), report["exit_codes"]
    for v in report["vehicles"]:
        assert v["home"] and not v["aborted"] and v["state"] == "home", v
    assert report["fleet"]["vehicles_home"] == 3
    assert report["fleet"]["duplicate_treatments"] == 0
    assert report["fleet"]["spots_cleared"] > 0
    # no forged partition or loss reached the channel
    link = report["messages"]["link"]
    assert link.get("partition", 0) == 0


def test_the_flood_was_delivered_and_cost_the_agent_little_memory(mission):
    _, intruder, _, _, _ = mission
    flood = intruder.sent["flood_agent"] + intruder.sent["flood_relay"]
    assert intruder.flood_wall_s >= FLOOD_S * 0.9
    assert flood >= 0.5 * FLOOD_RATE * FLOOD_S, intruder.sent  # a loaded machine is slower
    assert max(intruder.rss_mb) - intruder.rss_mb[0] < RSS_LIMIT_MB, intruder.rss_mb


def test_what_was_refused_is_counted_in_the_report(mission):
    report, intruder, _, _, _ = mission
    sec = report["security"]
    relay, agents, operator = sec["relay"], sec["agents"], sec["operator"]
    # the relay refused the flood on fleet/tx/auv2 and the forged link control and truths
    relay_refused = sum(n for k, n in relay.items() if k.startswith("auth_"))
    assert relay_refused >= intruder.sent["flood_relay"] * 0.9, relay
    # auv1 refused the flood on its deliveries and the forged commands
    assert sum(agents["auv1"].values()) >= intruder.sent["flood_agent"] * 0.9, agents
    for vid in VEHICLES:
        assert agents[vid].get("malformed", 0) > 0  # at least the plain commands
    # the operator refused forged statuses, events and ready announcements
    assert operator.get("malformed", 0) > 0 and operator.get("bad_signature", 0) > 0, operator
    assert sec["refused_total"] >= intruder.sent["flood_agent"] + intruder.sent["flood_relay"]


def test_every_process_it_started_is_gone(mission):
    _, _, _, _, left = mission
    assert left == []
