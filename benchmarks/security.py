"""Attack figures: what an intruder on the bus achieves, and what a flood costs the fleet.

``python -m benchmarks.security [--quick] [--seed N] [--warp W] [--insiders]``

(``--insiders``: only part 3, `benchmarks.insider_attacks`: every insider attack of issue 31
against an unattacked run, in process and as real processes.)

1. Per-message cost of the checks, in-process with real keys: sealing, opening a genuine
   envelope, refusing garbage and refusing a forged envelope (one Ed25519 verification), and
   the relay's whole `on_tx` path for each.
2. The same 3-AUV mission twice as real processes (`cotsfleet run`'s launcher): alone, then
   under `cotsfleet.mission.bus_intruder.BusIntruder` holding the router's own login and no
   fleet key (every forgery, a rival mission and clock record, and a 2,000 msg/s flood of one
   agent's deliveries and the relay's input for 20 s). The table compares the outcomes, the
   refusals by part, and the CPU each flooded process spent per flood message beyond its calm
   rate, measured from /proc.
"""

from __future__ import annotations

import argparse
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

from benchmarks.results import markdown_table, write_section
from comms_sim.channel import Channel, ChannelConfig
from comms_sim.relay import Relay
from cotsfleet.mission.bus_intruder import BusIntruder, forged_envelope
from cotsfleet.mission.processes import ProcessBackend, ProcessOptions
from cotsfleet.mission.runner import run_mission
from fleet_bus import keys
from fleet_bus.clock import ManualClock
from fleet_bus.credentials import load_auth, load_login, write_run_credentials
from fleet_bus.telemetry import Truth
from hfc_core.formats.scenario import problem_from_dict
from reef_sim.scenarios.field import GeneratorParams, generate_doc

VEHICLES = ("auv1", "auv2", "auv3")


def _per_call_us(fn, items: list) -> float:
    t0 = time.perf_counter()
    for item in items:
        fn(item)
    return (time.perf_counter() - t0) / len(items) * 1e6


def micro(n: int) -> list[list[object]]:
    """µs per message of each check, in this process."""
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp) / "c"
        write_run_credentials(root, VEHICLES)
        auv1 = load_auth(root / "auv1", "auv1")
        relay_auth = load_auth(root / "relay", "relay")
        key = keys.tx_key("auv1")
        rng = np.random.default_rng(0)
        frame = rng.bytes(64)
        rows: list[list[object]] = []
        sealed = [auv1.seal(key, frame) for _ in range(n)]
        rows.append(["seal a 64-byte frame (vehicle)", round(_per_call_us(
            lambda _: auv1.seal(key, frame), list(range(n))), 1)])

        def opener(envs: list[bytes]) -> float:
            return _per_call_us(lambda e: relay_auth.open_payload(key, e), envs)

        rows.append(["open a genuine envelope", round(opener(sealed), 1)])
        rows.append(["refuse its replay", round(opener(sealed), 1)])
        rows.append(["refuse garbage", round(opener([rng.bytes(int(rng.integers(1, 120)))
                                                     for _ in range(n)]), 1)])
        rows.append(["refuse a forged envelope (signature check)", round(opener(
            [forged_envelope(rng, "auv1", frame) for _ in range(n)]), 1)])
        relay = Relay(Channel(ChannelConfig(range_d50_m=1e7), np.random.default_rng(0)),
                      ManualClock(0.0), lambda *_: None, frozenset(VEHICLES), relay_auth)
        relay.on_truth("auv1", auv1.seal(keys.truth_key("auv1"),
                                         Truth(0.0, (0.0, 0.0, 0.0)).encode()))
        rows.append(["relay on_tx: garbage", round(_per_call_us(
            lambda e: relay.on_tx("auv1", e), [rng.bytes(60) for _ in range(n)]), 1)])
        rows.append(["relay on_tx: forged envelope", round(_per_call_us(
            lambda e: relay.on_tx("auv1", e), [forged_envelope(rng, "auv1", frame)
                                               for _ in range(n)]), 1)])
        return rows


def mission(doc: dict, seed: int, warp: float, attack: bool, flood_s: float, rate: float
            ) -> tuple[dict, BusIntruder | None]:
    problem = problem_from_dict(doc)
    with tempfile.TemporaryDirectory() as tmp:
        creds = Path(tmp) / "credentials"
        write_run_credentials(creds, VEHICLES)
        backend = ProcessBackend(problem, doc, seed, ProcessOptions(
            warp=warp, progress_every_s=0, run_dir=Path(tmp) / "run", credentials=creds),
            out=lambda s: None)
        result: dict = {}
        thread = threading.Thread(target=lambda: result.update(report=run_mission(
            problem, backend, (), seed=seed, step_s=warp * 0.25).report.to_dict()), daemon=True)
        thread.start()
        intruder, stop = None, threading.Event()
        if attack:
            assert backend.started.wait(300), "the mission never started"
            intruder = BusIntruder(backend.endpoint, load_login(creds / "router"), VEHICLES,
                                   agent=backend.children["auv1"].popen.pid,
                                   relay=backend.children["relay"].popen.pid,
                                   flood_s=flood_s, rate_hz=rate)
            threading.Thread(target=intruder.run, args=(stop,), daemon=True).start()
        thread.join(900)
        stop.set()
        return result["report"], intruder


def main(seed: int, warp: float, quick: bool) -> None:
    rows = micro(200 if quick else 2000)
    for name, us in rows:
        print(f"{name}: {us} µs")
    doc = generate_doc(GeneratorParams(name="security", n_tasks=24, n_vehicles=3, size_m=500.0,
                                       battery_s=1800.0, service_s=60.0),
                       np.random.default_rng(seed))
    flood_s = 5.0 if quick else 20.0
    runs = []
    for attack in (False, True):
        report, intruder = mission(doc, seed, warp, attack, flood_s, 2000.0)
        runs.append((report, intruder))
        f = report["fleet"]
        print(f"{'attacked' if attack else 'alone'}: {f['spots_cleared']} spots, "
              f"priority {f['priority']:.0f}, home {f['vehicles_home']}, duplicates "
              f"{f['duplicate_treatments']}, refused {report['security']['refused_total']}")
    outcome = []
    for (report, intruder) in runs:
        f, sec = report["fleet"], report["security"]
        aborted = sum(1 for v in report["vehicles"] if v["state"] == "aborted")
        outcome.append(["under the intruder" if intruder else "alone", f["spots_cleared"],
                        round(f["priority"], 1), f["vehicles_home"], aborted,
                        f["duplicate_treatments"],
                        sum(1 for c in report["exit_codes"].values() if c != 0),
                        sec["refused_total"], sum(sec["operator"].values()),
                        sum(sec["relay"].values()),
                        sum(sum(r.values()) for r in sec["agents"].values())])
    intruder = runs[1][1]
    assert intruder is not None
    flood = [["messages sent to auv1's deliveries", intruder.sent["flood_agent"]],
             ["messages sent to the relay's input", intruder.sent["flood_relay"]],
             ["other forgeries (commands, records, telemetry, link control)",
              intruder.sent["attacks"]],
             ["flood rate achieved (msg/s)", round((intruder.sent["flood_agent"]
                                                    + intruder.sent["flood_relay"])
                                                   / max(intruder.flood_wall_s, 1e-9))],
             ["login without the password refused", intruder.refused_login],
             ["auv1 CPU per flood message (µs)", _fmt(intruder.cost_us("agent"))],
             ["relay CPU per flood message (µs)", _fmt(intruder.cost_us("relay"))],
             ["auv1 RSS before / max after (MB)",
              f"{intruder.rss_mb[0]:.0f} / {max(intruder.rss_mb):.0f}"]]
    for name, value in flood:
        print(f"{name}: {value}")
    body = (
        f"A 3-AUV mission (24 spots, 500 m, 1800 s batteries, seed {seed}) as real processes "
        f"at warp {warp:g}, alone and then under an intruder that holds the router's own "
        f"Zenoh login (its password leaked; the access control lets that login do anything) "
        f"but no fleet key: abort and stop commands, forged statuses, events, ready "
        f"announcements, truths, link control, link records and frames, plain and in "
        f"envelopes with random signatures, a rival mission and clock record, and a "
        f"{flood_s:g} s flood at 2,000 msg/s split between auv1's deliveries and the relay's "
        f"input (half garbage, half forged envelopes). CPU per flood message: the flooded "
        f"process's CPU time during the flood less its calm rate over the same wall time "
        f"(/proc, 10 ms ticks). The machine was shared with other developers' work: wall "
        f"and CPU figures are upper bounds.\n\n"
        + markdown_table(["mission", "spots cleared", "priority", "vehicles home", "aborted",
                          "duplicates", "processes failed", "refused", "by operator",
                          "by relay", "by agents"], outcome)
        + "\n\n" + markdown_table(["flood", "figure"], flood)
        + "\n\nPer-message cost of the checks, in-process (µs, mean over "
        f"{200 if quick else 2000} messages):\n\n"
        + markdown_table(["check", "µs per message"], rows) + "\n")
    if not quick:
        write_section("security", "Security: an intruder on the bus, and the cost of a flood",
                      body)


def _fmt(us: float | None) -> str:
    return "-" if us is None else f"{us:.0f}"


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="short flood, writes nothing")
    parser.add_argument("--seed", type=int, default=9)
    parser.add_argument("--warp", type=float, default=25.0)
    parser.add_argument("--insiders", action="store_true",
                        help="only the insider attacks (benchmarks.insider_attacks)")
    args = parser.parse_args()
    if args.insiders:
        from benchmarks import insider_attacks

        insider_attacks.main(args.warp, args.quick)
    else:
        main(args.seed, args.warp, args.quick)
