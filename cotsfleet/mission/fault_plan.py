"""Faults planned once (issue 27, item 5): the runner's schedule as a pure list of steps,
which both backends carry out through one small interface (`FleetControl`).

A fault is one step at its time; an attack adds one step per hostile frame, the first a
second after the attack begins and then every `ATTACK_SPACING_S`. The in-process backend
puts each step on its event loop; the process backend applies the steps whose time the
mission clock has passed. What a step does is the backend's (`FleetControl.apply`, `attack`);
when it happens is decided here, the same for both.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable, Protocol, Sequence

from cotsfleet.mission.faults import ATTACK_SPACING_S, ATTACKS, Fault

FIRST_FRAME_S = 1.0  # an attack's first hostile frame, after the attack begins
PENDING_KINDS = ("restart", "abort")  # faults the mission must wait for before it may end


@dataclass(frozen=True)
class Step:
    """``fault`` at ``t_s``: the fault itself (``frame`` None), or its attack's ``frame``-th
    hostile frame."""

    t_s: float
    fault: Fault
    frame: int | None = None


class FleetControl(Protocol):
    """What a backend does for a step (`carry_out`)."""

    def apply(self, fault: Fault, now: float) -> None:
        """The fault, at ``now``."""

    def attack(self, fault: Fault, now: float) -> None:
        """One hostile frame (or busy flag) of the attack ``fault``, at ``now``."""


def plan(faults: Iterable[Fault]) -> list[Step]:
    """Every step of ``faults``, in time order (a fault before its own frames)."""
    steps: list[Step] = []
    for f in faults:
        steps.append(Step(f.t_s, f))
        if f.kind in ATTACKS:
            steps += [Step(f.t_s + FIRST_FRAME_S + ATTACK_SPACING_S * i, f, i)
                      for i in range(int(f.value))]
    return sorted(steps, key=lambda s: (s.t_s, s.frame is not None))


def carry_out(step: Step, control: FleetControl, now: float) -> None:
    if step.frame is None:
        control.apply(step.fault, now)
    else:
        control.attack(step.fault, now)


def awaited(steps: Sequence[Step], now: float) -> bool:
    """Whether a restart or an abort is still to come after ``now`` (the mission waits)."""
    return any(s.t_s > now and s.frame is None and s.fault.kind in PENDING_KINDS
               for s in steps)
