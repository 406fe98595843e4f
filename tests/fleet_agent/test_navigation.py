"""Navigation as it is (`fleet_agent.policies.navigation`): a helm whose fixes stop, and a
vehicle that lags its plan, each driven through the real `AgentDriver` on a simulated vehicle
(the vehicle under test: `reef_sim.vehicle.SimVehicle`, wrapped to drop its fixes, or
slower than the agent's plan assumes), deterministically on mission time."""

from __future__ import annotations

import copy
from dataclasses import replace
import functools
import math
from typing import Sequence

import numpy as np
import pytest

from fleet_agent.agent import Agent
from fleet_agent.config import AgentConfig
from fleet_agent.driver import AgentDriver
from fleet_agent.fleet import Fleet
from fleet_agent.io_types import Helm, Output, Publish
from fleet_agent.journal import MemoryJournal
from fleet_bus.modem_port import WATER_SPEC
from fleet_bus.telemetry import Event
from fleet_bus.vehicle_port import (
    HOME_TARGET,
    Abort,
    Arrived,
    GoTo,
    NavFix,
    StationKeep,
    VehicleReport,
    Work,
)
from hfc_core.formats.scenario import problem_from_dict
from hfc_core.model.problem import Problem
from reef_sim.navigation import DeadReckoning, NavigationParams
from reef_sim.scenarios.field import GeneratorParams, generate_doc
from reef_sim.vehicle import SimVehicle, at_surface

KEY = bytes(range(16))
CONFIG = AgentConfig(nav_hold_s=10.0, nav_limit_s=120.0, late_after_s=60.0).with_key(KEY)


@functools.lru_cache(maxsize=None)
def scenario() -> dict:
    params = GeneratorParams(name="nav", n_tasks=10, n_vehicles=1, size_m=800.0,
                             battery_s=2400.0, service_s=60.0)
    return generate_doc(params, np.random.default_rng(7))


@functools.lru_cache(maxsize=None)
def problem() -> Problem:
    return problem_from_dict(scenario())


@functools.lru_cache(maxsize=None)
def fleet() -> Fleet:
    return Fleet.build(problem(), KEY, 7, CONFIG, run_id="nav-test")


class FixGap:
    """The simulated vehicle with its navigation silent from ``from_s`` to ``until_s``: it
    moves as told, its fixes are dropped (a DVL that lost bottom lock, a dead nav process)."""

    name = "sim"

    def __init__(self, vehicle: SimVehicle, from_s: float, until_s: float = math.inf) -> None:
        self.vehicle, self.from_s, self.until_s = vehicle, from_s, until_s
        self.last_fix: NavFix | None = None

    def command(self, cmd, t_s: float) -> None:
        self.vehicle.command(cmd, t_s)

    def poll(self, until_s: float) -> list[VehicleReport]:
        out = []
        for r in self.vehicle.poll(until_s):
            if isinstance(r, NavFix) and self.from_s <= r.t_s < self.until_s:
                continue
            if isinstance(r, NavFix):
                self.last_fix = r
            out.append(r)
        return out

    def next_report_s(self) -> float | None:
        return self.vehicle.next_report_s()

    def close(self) -> None:
        self.vehicle.close()


class Sink:
    """The modem and the telemetry: what went out, kept."""

    spec = WATER_SPEC

    def __init__(self) -> None:
        self.events: list[Event] = []

    def transmit(self, frames, kind, sent_s=None) -> None:
        pass

    def publish(self, topic: str, payload) -> None:
        if topic == "event":
            self.events.append(payload)

    def close(self) -> None:
        pass


def fly(vehicle, horizon_s: float = 2600.0, config: AgentConfig = CONFIG
        ) -> tuple[Agent, Sink, list[tuple[float, Output]]]:
    """One agent driving ``vehicle`` until it is home or ``horizon_s``; every helm command
    with the mission time it was given."""
    agent = Agent(fleet(), 0, config, 0.0)
    sink = Sink()
    commands: list[tuple[float, Output]] = []
    driver = AgentDriver(agent, vehicle, sink, sink, MemoryJournal(),
                         tap=lambda outs: commands.extend(
                             (agent.t, o) for o in outs if isinstance(o, Helm)))
    t = 0.0
    while t < horizon_s and not agent.quiet:
        driver.tick(t)
        t = max(t + 1e-6, min(driver.next_wakeup(), horizon_s))
    return agent, sink, commands


def kinds(sink: Sink, kind: str) -> list[Event]:
    return [e for e in sink.events if e.kind == kind]


def test_fixes_that_stop_briefly_hold_station_then_the_route_goes_on() -> None:
    sim = SimVehicle(problem(), 0)
    agent, sink, commands = fly(FixGap(sim, 150.0, 220.0))
    nav = kinds(sink, "navigation")
    assert "keeping station" in nav[0].detail and 160.0 <= nav[0].t_s <= 172.0
    assert "back after" in nav[1].detail and 220.0 <= nav[1].t_s <= 230.0
    held = [(t, o.command) for t, o in commands if isinstance(o.command, StationKeep)
            and o.command.work is Work.WAIT]
    assert held and 160.0 <= held[0][0] <= 172.0 and held[0][1].task == -1
    # After the gap: on from the new fix (a GoTo from where the vehicle really was).
    after = [o.command for t, o in commands if t >= nav[1].t_s and isinstance(o.command, GoTo)]
    assert after
    assert agent.counters["nav_stale"] == 1 and agent.counters["nav_back"] == 1
    assert "nav_lost" not in agent.counters
    assert agent.own.done and agent.state == "home"
    assert agent.counters["nav_fixes"] > 0


def test_fixes_that_stop_for_good_send_it_home_from_the_last_fix() -> None:
    sim = SimVehicle(problem(), 0)
    gap = FixGap(sim, 300.0)
    agent, sink, commands = fly(gap)
    last = gap.last_fix
    assert last is not None and last.t_s < 300.0
    lost = [e for e in kinds(sink, "navigation") if "heading home" in e.detail]
    assert len(lost) == 1 and 120.0 < lost[0].t_s - last.t_s <= 120.0 + 15.0
    abort = kinds(sink, "abort")
    assert len(abort) == 1 and "no navigation" in abort[0].detail
    assert agent.counters["nav_lost"] == 1 and agent.own.aborted
    # Never a position it was not given: its own position stays the last fix's, and every
    # command after the fixes stopped holds there or heads home through the rendezvous.
    assert agent.own.pos == pytest.approx(last.pos)
    after = [o.command for t, o in commands if t >= 300.0]
    assert not [c for c in after if isinstance(c, GoTo)]
    home = [c for c in after if isinstance(c, Abort)]
    assert home and home[-1].waypoints[-1] == pytest.approx(problem().vehicles[0].rendezvous)
    due = sim.next_report_s()  # the vehicle flies on home by itself
    assert due is not None
    assert [r.target for r in sim.poll(due) if isinstance(r, Arrived)] == [HOME_TARGET]


def slow_problem(factor: float) -> Problem:
    """The scenario with the vehicle ``factor`` as fast as the plan assumes (a slow helm)."""
    doc = copy.deepcopy(scenario())
    doc["speed_mps"] = float(doc.get("speed_mps", 1.0)) * factor
    return problem_from_dict(doc)


def test_a_vehicle_that_lags_its_plan_is_late_and_refitted_from_where_it_is() -> None:
    sim = SimVehicle(slow_problem(0.6), 0)
    agent, sink, commands = fly(sim, horizon_s=4000.0)
    late = kinds(sink, "late")
    assert late, "a vehicle at 60 % of its planned speed is seen late"
    assert agent.counters["late"] == len(late)
    first = late[0]
    assert 60.0 <= float(first.detail.split()[0]) < 100.0  # seconds behind its plan
    assert first.t_s < 200.0  # at 60 % speed, 60 s behind within the first 150 s
    on_time = fly(SimVehicle(problem(), 0))[0]
    # The slow vehicle treats less: each refit from where it really is drops what no
    # longer fits. (The agent's model keeps the planned speed for the legs ahead, so a
    # vehicle that stays this slow still ends past its battery: 151 s here.)
    assert len(agent.know.treated) < len(on_time.know.treated)
    assert agent.own.done
    assert "late" not in on_time.counters


def test_the_agents_position_is_the_vehicles_fix_when_it_replans() -> None:
    sim = SimVehicle(slow_problem(0.6), 0)
    agent = Agent(fleet(), 0, CONFIG, 0.0)
    sink = Sink()
    seen: list[tuple[tuple[float, float, float], tuple[float, float, float]]] = []

    def tap(outs: Sequence[Output]) -> None:
        for o in outs:
            if isinstance(o, Publish) and o.topic == "event" and o.payload.kind == "late":
                seen.append((agent.own.pos, sim.pos))

    driver = AgentDriver(agent, sim, sink, sink, MemoryJournal(), tap=tap)
    t = 0.0
    while t < 4000.0 and not agent.quiet and not seen:
        driver.tick(t)
        t = min(driver.next_wakeup(), 4000.0)
    assert seen
    believed, real = seen[0]
    assert believed == pytest.approx(real)  # the simulated vehicle's fix is exact


def test_a_vehicle_on_time_with_its_fixes_is_left_alone() -> None:
    agent, sink, commands = fly(SimVehicle(problem(), 0))
    assert not kinds(sink, "navigation") and not kinds(sink, "late")
    assert agent.own.done and not agent.own.aborted
    assert agent.counters["nav_fixes"] >= len(commands)
    assert agent.counters.get("nav_delay_max_ms", 0) == 0  # a simulated fix is never late
    assert not [c for _, c in commands if isinstance(c.command, StationKeep)
                and c.command.work is Work.WAIT and c.command.task == -1]


DRIFTING = NavigationParams(drift_pct=2.0, walk_m_per_sqrt_km=0.5, start_sigma_m=1.0)
CLIMBING = replace(CONFIG, surface_sigma_m=3.0)


class Sigmas(FixGap):
    """The simulated vehicle with its navigation drifting: every fix's sigma kept (no gap in
    its fixes). With ``gps`` False its helm never leaves its depth (a climb asked for is
    flown level): no fix at the surface ever comes."""

    def __init__(self, gps: bool = True) -> None:
        start = problem().vehicles[0].start
        super().__init__(SimVehicle(problem(), 0, navigation=DeadReckoning(DRIFTING, 3, 0, start)),
                         math.inf)
        self.gps = gps
        self.sigmas: list[tuple[float, float]] = []  # (t, sigma) of every fix

    def command(self, cmd, t_s: float) -> None:
        if not self.gps and isinstance(cmd, GoTo):
            cmd = GoTo(cmd.target, tuple(w for w in cmd.waypoints[:-1] if not at_surface(w))
                       + cmd.waypoints[-1:], cmd.ahead)
        super().command(cmd, t_s)

    def poll(self, until_s: float) -> list[VehicleReport]:
        out = super().poll(until_s)
        self.sigmas += [(r.t_s, r.sigma_m) for r in out if isinstance(r, NavFix)]
        return out


def _climbs(commands: list[tuple[float, Output]]) -> list[GoTo]:
    return [c.command for _, c in commands if isinstance(c.command, GoTo)
            and any(at_surface(w) for w in c.command.waypoints[:-1])]


def test_a_drifting_vehicle_climbs_for_a_gps_fix_and_its_error_stays_bounded() -> None:
    """Past ``surface_sigma_m`` (3 m) the vehicle climbs where it is on its way to the next
    spot; the fix at the surface brings its error back, so it never grows far past the
    threshold. Without the rule (0) the same vehicle's error grows with the distance run."""
    climbing, sink, commands = fly(vehicle := Sigmas(), config=CLIMBING)
    level = Sigmas()
    staying, _, _ = fly(level, config=replace(CONFIG, surface_sigma_m=0.0))
    climbs = _climbs(commands)
    assert climbs and climbing.counters["surfaced"] == len(kinds(sink, "navigation")) >= 2
    assert all(c.waypoints[0][2] == 0.0 for c in climbs)  # straight up, then on to the spot
    assert "surface_no_fix" not in climbing.counters
    assert climbing.own.done and not climbing.own.aborted
    # Until its last spot, the error grows at most a step's run past the threshold between
    # climbs (on the way home, to the surface anyway, it is left to grow).
    last = max(e.t_s for e in kinds(sink, "cleared"))
    assert max(sg for t, sg in vehicle.sigmas if t <= last) < 1.5 * 3.0
    assert max(sg for t, sg in level.sigmas if t <= last) > 3 * 3.0
    assert len(climbing.know.treated) >= len(staying.know.treated) - 1  # climbs cost seconds


def test_climbs_that_bring_no_fix_stop_after_three() -> None:
    """A helm whose navigation takes no GPS (here: one that never leaves its depth) does not
    make the vehicle climb forever: three climbs without a fix, then it stays down."""
    agent, sink, commands = fly(Sigmas(gps=False), config=CLIMBING)
    assert agent.counters["surfaced"] == agent.counters["surface_no_fix"] == 3
    assert len(_climbs(commands)) == 3
    assert agent.own.done and not agent.own.aborted
