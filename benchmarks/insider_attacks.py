"""Insider attacks (issue 31): one vehicle's leaked credentials against the fleet.

``python -m benchmarks.insider_attacks [--quick] [--warp W]`` (also ``python -m
benchmarks.security --insiders``)

Every attack of `cotsfleet.mission.insider` by auv1 at t=600 s, against an unattacked run of
the same seed:

1. In process (`cotsfleet sim`), the paper preset seed 7: all-cleared, claim-own, claim-all
   (in auv2's name), abort-as (auv2's, forged and told as news); its dynamic version seed 7
   (`cotsfleet scenario --paper --dynamic`): phantom (24 finds of priority 500) and
   all-cleared.
2. As real processes (`cotsfleet run`'s launcher, warp W): the unattacked mission, all-cleared
   (the frames through the relay from auv1's position) and busy-hold (auv1's own bus login
   says it plans every 3.7 s for 10 minutes), with the clock's effective warp and expired
   holds. Every child of each run is checked gone at its end.

The bound (issue 31): each costs at most the insider's own share of the plan: at least 0.6
of the unattacked priority, 0 duplicates, and the attack named in the report.
"""

from __future__ import annotations

import argparse
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

from benchmarks.results import markdown_table, write_section
from cotsfleet.cli import build_parser
from cotsfleet.commands.mission_args import mission_args
from cotsfleet.mission.faults import parse_faults
from cotsfleet.mission.inprocess import simulate
from cotsfleet.mission.processes import ProcessBackend, ProcessOptions
from cotsfleet.mission.report_model import MissionReport
from cotsfleet.mission.runner import run_mission
from hfc_core.formats.scenario import problem_from_dict
from reef_sim.scenarios.field import paper_preset_doc

INSIDER, AT_S = "auv1", 600.0
STATIC = ("all-cleared", "claim-own", "claim-all", "abort-as")
DYNAMIC = ("phantom", "all-cleared")
PROCESSES = ("all-cleared", "busy-hold")


def sim(argv: list[str]) -> MissionReport:
    m = mission_args(build_parser().parse_args(["sim", *argv]))
    return simulate(m.problem, m.config, seed=m.seed, loss=m.loss, faults=m.faults,
                    reef=m.reef).report


def attack_args(kind: str | None) -> list[str]:
    return [] if kind is None else ["--attack", f"{kind}@{AT_S:g}", "--insider", INSIDER]


def row(setting: str, kind: str | None, r: MissionReport, base: float,
        extra: list[Any] | None = None) -> list[Any]:
    f = r.fleet
    refused = sum(r.messages.dropped_by_agents.values())
    suspects = ", ".join(f"{k} ({sum(v.values())})" for k, v in (r.suspects or {}).items())
    named = any(x.kind == kind for x in r.faults) if kind else True
    return [setting, kind or "none", round(f.priority, 1), f"{f.priority / base:.3f}",
            f.duplicate_treatments, f.false_alarms, f.vehicles_home, refused, suspects or "-",
            "yes" if named else "NO", *(extra or [])]


def in_process(dynamic_doc: Path) -> list[list[Any]]:
    rows = []
    base = sim(["--seed", "7"])
    rows.append(row("paper preset", None, base, base.fleet.priority))
    for kind in STATIC:
        rows.append(row("paper preset", kind, sim(["--seed", "7", *attack_args(kind)]),
                        base.fleet.priority))
        print(rows[-1], flush=True)
    dbase = sim(["--scenario", str(dynamic_doc), "--seed", "7"])
    rows.append(row("dynamic", None, dbase, dbase.fleet.priority))
    for kind in DYNAMIC:
        rows.append(row("dynamic", kind, sim(["--scenario", str(dynamic_doc), "--seed", "7",
                                               *attack_args(kind)]), dbase.fleet.priority))
        print(rows[-1], flush=True)
    return rows


def processes(warp: float, kind: str | None) -> tuple[MissionReport, bool]:
    """One `cotsfleet run` mission of the paper preset seed 7; whether every child it
    started is gone at its end."""
    doc = paper_preset_doc(7)
    problem = problem_from_dict(doc)
    faults = parse_faults(attacks=[f"{kind}@{AT_S:g}"], insider=INSIDER) if kind else []
    with tempfile.TemporaryDirectory() as tmp:
        backend = ProcessBackend(problem, doc, 7, ProcessOptions(
            warp=warp, progress_every_s=0, run_dir=Path(tmp) / "run"), out=lambda s: None)
        out: dict[str, MissionReport] = {}
        thread = threading.Thread(target=lambda: out.update(report=run_mission(
            problem, backend, faults, seed=7, step_s=warp * 0.25).report), daemon=True)
        thread.start()
        thread.join(4 * 3600 / warp + 600)
        time.sleep(1.0)
        gone = all(c.popen.poll() is not None for c in backend.children.values())
        return out["report"], gone


def main(warp: float, quick: bool) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        dynamic_doc = Path(tmp) / "d7.json"
        from cotsfleet.cli import main as cli

        assert cli(["scenario", "--paper", "--dynamic", "--seed", "7", "-o",
                    str(dynamic_doc)]) == 0
        rows = in_process(dynamic_doc)
    prow: list[list[Any]] = []
    if not quick:
        base, gone = processes(warp, None)
        runs = [(None, base, gone)] + [(k, *processes(warp, k)) for k in PROCESSES]
        for kind, r, gone in runs:
            clock = r.clock
            prow.append(row(f"processes, warp {warp:g}", kind, r, base.fleet.priority, [
                "-" if clock is None else clock.effective_warp,
                "-" if clock is None else clock.holds_expired,
                "yes" if gone else "NO"]))
            print(prow[-1], flush=True)
    head = ["setting", "attack by auv1 at 600 s", "priority", "of unattacked", "duplicates",
            "false alarms", "home", "frames refused", "suspects (refusals)", "in report"]
    body = (
        "Every insider attack of `cotsfleet.mission.insider` (`--attack KIND@600 --insider "
        "auv1`): auv1's leaked credentials (its chain seed, the fleet MAC key, its bus login) "
        "used while auv1 keeps working. In process: the paper preset seed 7 (an unattacked run "
        "collects 4194) and its dynamic version (`cotsfleet scenario --paper --dynamic --seed "
        "7`). 'frames refused': the agents' dropped frames (a frame in another's name fails "
        "its tag or comes after its key could be out); 'suspects': refusals of implausible "
        "frames, by accused (`fleet_agent.policies.plausible`). Target: at least 0.6 of the "
        "unattacked priority, 0 duplicates, the attack in the report.\n\n"
        + markdown_table(head, rows))
    if prow:
        body += ("\n\nAs real processes (`cotsfleet run`'s launcher, paper preset seed 7, warp "
                 f"{warp:g}): the frames enter the relay from auv1's last reported position; "
                 "busy-hold is auv1's own login saying it plans every 3.7 s for 10 minutes. "
                 "'holds expired': holds the clock ended at its limit (10 wall s, then 40 s "
                 "refused). 'children gone': every process the run started had exited when it "
                 "returned.\n\n"
                 + markdown_table(head + ["effective warp", "holds expired", "children gone"],
                                  prow))
    print(body)
    if not quick:
        write_section("security_insiders", "Security: insider attacks (one vehicle's "
                      "credentials leaked)", body)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="in process only; writes nothing")
    parser.add_argument("--warp", type=float, default=30.0)
    args = parser.parse_args()
    main(args.warp, args.quick)
