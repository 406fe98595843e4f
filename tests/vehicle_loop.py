"""A vehicle and the agent's model of it, wired as the agent wires them, for tests.

`Loop` holds a simulated vehicle (`reef_sim.vehicle.SimVehicle`) and the agent's
`fleet_agent.motion.OwnVehicle`, passes the vehicle's reports to the model and the model's
command to the vehicle whenever it changes (what `Agent.step` does), and nothing else: no
radio, no replanning. So a test can check that what the agent expects is what the vehicle
does, however often it is stepped.
"""

from __future__ import annotations

import math
from typing import Callable, Sequence

from fleet_agent.motion import Activity, Cleared, Conduct, Inspected, OwnVehicle, ReachedHome
from fleet_bus.vehicle_port import Arrived, Injected, Looked, NavFix
from hfc_core.model.paths import path_function
from hfc_core.model.problem import Problem
from reef_sim.camera import ReefCamera
from reef_sim.vehicle import SimVehicle

Event = Cleared | Inspected | ReachedHome


def conduct(not_before: Callable[[int], float] = lambda task: 0.0,
            needs_look: Callable[[int], bool] = lambda task: False,
            inspect_s: float = 0.0, reserve_s: float = 0.0,
            held_back: Callable[[int, float], float] | None = None,
            settled_by: Callable[[], float] | None = None) -> Conduct:
    return Conduct(not_before, needs_look, inspect_s, reserve_s, held_back, settled_by)


class Loop:
    def __init__(self, problem: Problem, index: int = 0, rules: Conduct | None = None,
                 camera: ReefCamera | None = None) -> None:
        self.own = OwnVehicle(problem, index, path_function(problem), rules or conduct())
        self.sim = SimVehicle(problem, index, camera=camera)
        self.events: list[Event] = []
        self._key: object = None
        self.step(0.0)

    @property
    def t_s(self) -> float:
        return self.own.t_s

    def set_route(self, route: Sequence[int]) -> None:
        self.own.set_route(route)
        self._command()

    def abort(self) -> None:
        self.own.abort()
        self._command()

    def run_until(self, t_s: float) -> list[Event]:
        """Step at every report and timer due by ``t_s``, then at ``t_s``; what happened."""
        start = len(self.events)
        while (due := self.next_s()) <= t_s:
            self.step(due)
        self.step(t_s)
        return self.events[start:]

    def run_home(self, limit_s: float = 100_000.0) -> list[Event]:
        start = len(self.events)
        while not self.own.done and (due := self.next_s()) <= limit_s:
            self.step(due)
        return self.events[start:]

    def next_s(self) -> float:
        due = self.sim.next_report_s()
        times = [math.inf if due is None else due]
        if self.own.activity is Activity.WAITING and self.own.busy_until_s is not None:
            times.append(self.own.busy_until_s)
        return min(times)

    def step(self, t_s: float) -> None:
        own = self.own
        for r in self.sim.poll(t_s):
            if isinstance(r, NavFix):
                own.fix(r)
            elif isinstance(r, Arrived):
                self._keep(own.arrived(r.target, r.t_s))
            elif isinstance(r, Injected):
                self._keep(own.injected(r.task, r.t_s))
            elif isinstance(r, Looked):
                self._keep(own.looked(r.task, r.service_s if r.present else None, r.t_s))
        own.wake(t_s)
        self._command()

    def _keep(self, event: Event | None) -> None:
        if event is not None:
            self.events.append(event)

    def _command(self) -> None:
        key = self.own.command_key()
        if key != self._key:
            self._key = key
            cmd = self.own.command()
            if cmd is not None:
                self.sim.command(cmd, self.own.t_s)
