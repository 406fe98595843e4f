"""The mission runner: one loop for both backends (in-process simulation, OS processes).

The runner owns what a mission is: its horizon (the longest battery plus two minutes), its
fault schedule (checked before anything starts, `faults.check_schedule`), its end (every
vehicle home, aborted or dead, and no abort or restart still to come), and its report
(`report.build_report`). A backend owns how the fleet runs: it starts the vehicles, lets
mission time pass (`advance`), applies each fault at its time, and hands over the telemetry
(`FleetLedger`), the link counters and what it alone can add to the report.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any, Callable, Protocol, Sequence

from comms_sim.stats import LinkCounts
from cotsfleet.mission.faults import Fault, check_schedule
from cotsfleet.mission.report import build_report
from cotsfleet.mission.report_model import MissionReport
from fleet_bus.ledger import FleetLedger
from hfc_core.model.problem import Problem
from reef_sim.truth import Reef

HORIZON_MARGIN_S = 120.0
Progress = Callable[[float], None]


def horizon_of(problem: Problem) -> float:
    """When a mission ends at the latest: every battery is empty by then."""
    return max(v.battery_s for v in problem.vehicles) + HORIZON_MARGIN_S


class MissionStopped(RuntimeError):
    """The mission could not go on (e.g. the router died); the report is still written, with
    this message as its ``failure``. So it is when the fleet is not ready in time, or the
    launcher's own disk fails it: whatever ends a mission, it ends with a report."""


class Backend(Protocol):
    mode: str  # "sim" | "run": the report's name for how the fleet ran

    @property
    def ledger(self) -> FleetLedger:
        """What the fleet reported (read only: the runner never replaces it)."""
    applied: list[Fault]  # faults as applied, with the mission time they were
    interrupted: bool  # the operator stopped the mission early (Ctrl-C, SIGTERM, SIGHUP)

    def check(self, faults: Sequence[Fault]) -> None:
        """Raise `FaultError` for a fault this backend cannot apply (before anything runs)."""

    def start(self, faults: Sequence[Fault]) -> None:
        """Start every vehicle at mission time 0 and arm the fault schedule."""

    def now(self) -> float: ...

    def advance(self, t_s: float) -> None:
        """Let the mission run until mission time ``t_s`` (faults due meanwhile applied)."""

    def finished(self) -> bool:
        """Every vehicle has left the mission and no abort or restart is still to come."""

    def link_counts(self) -> LinkCounts | None: ...

    def extra(self) -> dict[str, Any]:
        """What this backend adds to the report."""

    def close(self) -> None:
        """Stop everything this backend started (idempotent)."""


@dataclass
class Outcome:
    report: MissionReport
    wall_s: float


def run_mission(problem: Problem, backend: Backend, faults: Sequence[Fault], *, seed: int,
                step_s: float, horizon_s: float | None = None,
                progress: Progress | None = None, reef: Reef | None = None) -> Outcome:
    """Run ``backend``'s fleet through ``faults`` to the end of the mission and report."""
    horizon = horizon_s if horizon_s is not None else horizon_of(problem)
    check_schedule(faults, [v.id for v in problem.vehicles], horizon)
    backend.check(faults)
    wall = time.perf_counter()
    failure = ""
    try:
        backend.start(faults)
        t = 0.0
        while t < horizon:
            t = min(horizon, t + step_s)
            backend.advance(t)
            if progress is not None:
                progress(t)
            if backend.finished():
                break
    except KeyboardInterrupt:
        backend.interrupted = True
    except MissionStopped as exc:
        failure = str(exc)
    except TimeoutError as exc:  # e.g. agents not ready in time: still a report
        failure = str(exc)
    except OSError as exc:  # e.g. a full disk under the launcher itself
        failure = f"{exc} (the launcher)"
    finally:
        backend.close()
    end = max(0.0, min(backend.now(), horizon))
    extra = backend.extra()  # last words first: final statuses may still reach the ledger
    if failure:
        extra["failure"] = failure
    report = build_report(problem, backend.ledger, backend.link_counts(), backend.applied,
                          mode=backend.mode, seed=seed, end_s=end, extra=extra, reef=reef)
    return Outcome(report, time.perf_counter() - wall)
