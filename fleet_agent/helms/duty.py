"""The command a live helm carries out, as its adapter keeps it (pure; the adapter locks).

A live helm does not know the agent's spots: it is told to follow a path, to keep station or
to surface. The adapter numbers each path it sends (a *leg*), remembers which spot or the
rendezvous the leg ends at, and turns the helm's "leg n ended" into ``Arrived(target)`` once;
it times a look or an injection on the mission clock and owes ``Looked``/``Injected`` when
its duration is up (the vehicle keeps station meanwhile). Refusals are owed once per command.
"""

from __future__ import annotations

from dataclasses import dataclass

from fleet_bus.vehicle_port import (
    HOME_TARGET,
    Abort,
    GoTo,
    HelmCommand,
    ReturnHome,
    StationKeep,
    Work,
)


@dataclass
class Duty:
    """The command under way: its kind, the leg it drives (0: none) and what it owes."""

    kind: str = ""
    leg: int = 0
    target: int | None = None  # spot index, HOME_TARGET, or None (no path under way)
    arrived: bool = False
    work: Work | None = None
    task: int = -1
    work_end_s: float | None = None
    refused: bool = False

    def start(self, cmd: HelmCommand, t_s: float) -> None:
        """Take ``cmd`` (it replaces the one under way); a path gets the next leg number."""
        self.kind = type(cmd).__name__
        self.refused = False
        self.arrived = False
        self.work, self.task, self.work_end_s = None, -1, None
        if isinstance(cmd, GoTo):
            self.leg, self.target = self.leg + 1, cmd.target
        elif isinstance(cmd, ReturnHome) or (isinstance(cmd, Abort) and not cmd.surface):
            self.leg, self.target = self.leg + 1, HOME_TARGET
        elif isinstance(cmd, StationKeep):
            self.target = None
            self.work, self.task = cmd.work, cmd.task
            if cmd.work is not Work.WAIT:
                self.work_end_s = t_s + max(0.0, cmd.duration_s)
        else:  # Abort by surfacing
            self.target = None

    def arrival(self, leg: int) -> int | None:
        """The target reached if the helm says leg ``leg`` ended and it is ours (once)."""
        if leg != self.leg or self.target is None or self.arrived:
            return None
        self.arrived = True
        return self.target

    def due_work(self, until_s: float) -> tuple[Work, int, float] | None:
        """The look or injection whose time is up by ``until_s`` (once)."""
        if self.work_end_s is None or self.work is None or self.work_end_s > until_s:
            return None
        out = (self.work, self.task, self.work_end_s)
        self.work_end_s = None
        return out

    def refuse(self) -> str | None:
        """The kind of the command to refuse, once per command (None: nothing under way)."""
        if not self.kind or self.refused:
            return None
        self.refused = True
        return self.kind
