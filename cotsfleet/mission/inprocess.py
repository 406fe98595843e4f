"""The in-process backend: the whole fleet in one process, on the deterministic transport.

The same `Agent` logic and the same `AgentDriver` as the multi-process deployment, on
`comms_sim.des`: each driver wakes at its agent's `next_wakeup`, frames cross the same
`Channel` model, time is a `ManualClock` that jumps from one event to the next. Faults are
applied at their exact times on the event loop. Seeded: the same seed gives the same
mission, frame for frame.
"""

from __future__ import annotations

import gc
from dataclasses import dataclass, field, replace
from functools import partial
from typing import Any, Callable, Sequence

import numpy as np

from comms_sim.channel import Channel
from comms_sim.config import ChannelConfig
from comms_sim.control import apply_control
from comms_sim.des import EventLoop, Handle, InProcessNetwork
from comms_sim.seeds import MISSION_STREAMS, channel_rng
from comms_sim.link_event import LinkEvent
from comms_sim.stats import LinkCounts
from cotsfleet.mission.fault_plan import Step, awaited, carry_out, plan
from cotsfleet.mission.faults import ATTACKS, INSIDER_ATTACKS, Fault, FaultError
from cotsfleet.mission.insider import Insider, insider_rng
from cotsfleet.mission.intruder import NODE as INTRUDER
from cotsfleet.mission.intruder import Intruder, intruder_rng
from cotsfleet.mission.report_model import MissionReport, Oracle
from cotsfleet.mission.runner import Outcome, horizon_of, run_mission
from cotsfleet.mission.topside import forged_order, topside_of
from fleet_agent.agent import Agent
from fleet_agent.config import AgentConfig
from fleet_agent.driver import AgentDriver
from fleet_agent.helms.sim import camera_figures, sim_vehicle
from fleet_agent.fleet import Fleet
from fleet_agent.io_types import Output
from fleet_agent.journal import MemoryJournal
from fleet_agent.motion import Conduct, OwnVehicle
from fleet_agent.plans import Live, Planner
from fleet_agent.routing import fit_route
from fleet_bus.commands import ABORT
from fleet_bus.ledger import FleetLedger
from fleet_bus.link import LinkControl, Partition
from fleet_bus.modem_port import WATER_SPEC
from fleet_bus.orders import TOPSIDE
from fleet_bus.states import EventKind, FaultKind
from fleet_bus.telemetry import Event, Status, Truth
from hfc_core.model.problem import Problem
from reef_sim.navigation import NavigationParams
from reef_sim.truth import Reef

STEP_S = 60.0  # the runner looks at the mission (progress, end) this often
YOUNG_OBJECTS = 10_000  # the young generation's collection threshold during a mission (`simulate`)
Tap = Callable[[str, Sequence[Output]], None]  # (vehicle, outputs of one step): for tests


@dataclass
class Seat:
    """One vehicle's seat in the simulation: its driver (None while killed) and journal."""

    vid: str
    journal: MemoryJournal
    driver: AgentDriver | None = None
    handle: Handle | None = None
    stall: Fault | None = None  # its host is starved of CPU (a "stall" fault)

    def thaw_at(self, t_s: float) -> float | None:
        """When this seat's stalled host runs again if frozen at ``t_s``, else None."""
        return None if self.stall is None else self.stall.thaw_at(t_s)

    @property
    def agent(self) -> Agent | None:
        return None if self.driver is None else self.driver.agent


class _SeatModem:
    """A seat's modem on the emulated water: its frames into the in-process network (the
    deliveries come back through `InProcessBackend._deliver`)."""

    spec = WATER_SPEC

    def __init__(self, backend: "InProcessBackend", seat: Seat) -> None:
        self.backend, self.seat = backend, seat

    def transmit(self, frames: Sequence[bytes], kind: str, sent_s: float | None = None) -> None:
        for frame in frames:
            self.backend.net.send(self.seat.vid, frame, kind, sent_s)

    def close(self) -> None:
        pass  # the seat stays in the water: a restarted agent takes it again


class _SeatTelemetry:
    """A seat's telemetry: truths place it in the channel, the rest goes to the ledger."""

    def __init__(self, backend: "InProcessBackend", seat: Seat) -> None:
        self.backend, self.seat = backend, seat

    def publish(self, topic: str, payload: Status | Event | Truth) -> None:
        if isinstance(payload, Truth):  # where the vehicle is, for the channel: as the relay
            self.backend.channel.set_position(self.seat.vid, payload.pos, payload.t_s)
        elif isinstance(payload, Status):
            self.backend.ledger.add_status(payload)
        elif isinstance(payload, Event):
            self.backend.ledger.add_event(payload)


class InProcessBackend:
    mode = "sim"

    def __init__(self, problem: Problem, config: AgentConfig, *, seed: int = 0,
                 loss: float = 0.0, channel: ChannelConfig | None = None,
                 planner: Planner | None = None, key: bytes | None = None,
                 oracle_iterations: int = 300, tap: Tap | None = None,
                 reef: Reef | None = None, navigation: NavigationParams | None = None) -> None:
        self.problem = problem
        self.seed = seed
        self.reef = reef  # the hidden reef (dynamic mission), seen only through the camera
        self.navigation = navigation  # the vehicles' navigation error (None: exact)
        key = key or np.random.default_rng(
            np.random.SeedSequence(seed).spawn(MISSION_STREAMS)[2]).bytes(16)
        self.config = config.with_key(key)
        # A simulated run is named by its seed, as its fleet key is: the same seed replays
        # the same mission bit for bit.
        self.fleet = Fleet.build(problem, key, seed, self.config, planner, run_id=f"sim-{seed}",
                                 camera=None if reef is None else camera_figures(reef))
        self.loop = EventLoop()
        water = mac_of(replace(channel or ChannelConfig(), extra_loss=loss), self.fleet, problem)
        self.channel = Channel(water, channel_rng(seed),
                               self.fleet.schedule if water.tdma is not None else None)
        self.net = InProcessNetwork(self.channel, self.loop)
        self.net.add_listener(self._overhear)
        self.intruder = Intruder(problem, intruder_rng(seed))
        self.insiders: dict[str, Insider] = {}
        self.topside = topside_of(problem, self.fleet, self.config)
        self.oracle_iterations = oracle_iterations
        self.tap = tap
        self.ledger = FleetLedger()
        self.applied: list[Fault] = []
        self.interrupted = False
        self.seats: dict[str, Seat] = {}
        self.oracle: dict[str, Any] = {}
        self.at_kill: dict[str, tuple[Status, frozenset[int]]] = {}  # status, cleared set
        self.positions_at_kill: dict[str, dict[str, tuple[float, ...]]] = {}
        self._pending: list[Step] = []  # the fault plan (`fault_plan.plan`)
        self._stuck = 0
        self._topside_wake: Handle | None = None

    # -- the runner's interface --------------------------------------------------------------

    def check(self, faults: Sequence[Fault]) -> None:
        if any(f.kind == FaultKind.BUSY_HOLD for f in faults):
            raise FaultError("busy-hold holds the paced clock of `cotsfleet run`; a "
                             "simulation has none to hold")

    def start(self, faults: Sequence[Fault]) -> None:
        for v in self.problem.vehicles:
            self._start_agent(v.id, 0.0, MemoryJournal())
        if any((f.kind in ATTACKS and f.kind not in INSIDER_ATTACKS)
               or (f.kind == FaultKind.CTL and f.unsigned) for f in faults):
            self.channel.set_position(INTRUDER, self.intruder.position(), 0.0)
        if any(f.kind == FaultKind.CTL for f in faults):  # the operator's modem, at the boat
            self.net.attach(TOPSIDE, self._topside_hear)
            self.channel.set_position(TOPSIDE, self.topside.position, 0.0)
        self._pending = plan(faults)
        for s in self._pending:
            self.loop.call_at(s.t_s, partial(self._carry_out, s))

    def _carry_out(self, step: Step) -> None:
        carry_out(step, self, self.loop.now())

    def _topside_hear(self, data: bytes, t_s: float) -> None:
        self.topside.hear(data, t_s)  # an acknowledgement it heard (the report counts it)

    def now(self) -> float:
        return self.loop.now()

    def advance(self, t_s: float) -> None:
        self.loop.run_until(t_s)

    def finished(self) -> bool:
        now = self.now()
        if awaited(self._pending, now):
            return False
        dead = {vid for vid, s in self.seats.items() if s.driver is None}
        return self.ledger.all_final(list(self.seats), dead)

    def link_counts(self) -> LinkCounts:
        return self.channel.stats()

    def extra(self) -> dict[str, Any]:
        end = self.now()
        for s in self.seats.values():
            if s.driver is not None:
                s.driver.final_status(end)
        # The no-communication baseline: every vehicle flies its initial plan, as it fits its
        # battery with the configured reserve, and nothing else (what the fleet collects with
        # no link at all; the reference a lossy link must never fall below).
        plan = []
        for v, r in enumerate(self.fleet.base_routes):
            own = OwnVehicle(self.problem, v, self.fleet.paths,
                             Conduct(lambda task: 0.0, lambda task: False))
            own.set_route(list(r))
            plan += fit_route(own, list(r), self.config.battery_reserve_s)
        out: dict[str, Any] = {"baseline": {
            "priority": round(float(sum(self.problem.priority[t] for t in plan)), 2),
            "spots": len(plan)}}
        if self.topside.orders or any(f.kind == FaultKind.CTL for f in self.applied):
            out["commands"] = self.topside.section(
                {v: dict(st.counters) for v, st in self.ledger.statuses.items()})
        if not self.oracle:
            return out
        after = self._collected_after(self.oracle["t_s"], set(self.oracle["survivors"]),
                                      set(self.oracle["cleared_before"]))
        ratio = after / self.oracle["priority"] if self.oracle["priority"] > 0 else 1.0
        out["oracle"] = {**{k: v for k, v in self.oracle.items() if k != "cleared_before"},
                         "collected": round(after, 2), "ratio": round(ratio, 4)}
        return out

    def close(self) -> None:
        pass  # nothing outlives a Python object graph

    def inject(self, vid: str, t_s: float, data: bytes) -> None:
        """Hand ``data`` to ``vid``'s agent at ``t_s`` as if its modem had received it."""
        self.loop.call_at(t_s, lambda: self._deliver(vid, data, self.loop.now()))

    # -- vehicles ---------------------------------------------------------------------------

    def _start_agent(self, vid: str, now: float, journal: MemoryJournal) -> None:
        index = self.problem.vehicle_index[vid]
        seat = self.seats.get(vid)
        if seat is None:
            seat = self.seats[vid] = Seat(vid, journal)
            self.net.attach(vid, partial(self._deliver, vid))
        seat.journal = journal
        agent = Agent(self.fleet, index, self.config, now, journal.records)
        # The vehicle is where the agent last knew it was (a restarted agent: its last
        # checkpoint; the vehicle was dead in the water meanwhile).
        vehicle = sim_vehicle(self.problem, index, seed=self.seed, reef=self.reef, t_s=now,
                              pos=agent.own.pos, odometer_m=agent.own.distance_m,
                              navigation=self.navigation)
        seat.driver = AgentDriver(agent, vehicle, _SeatModem(self, seat),
                                  _SeatTelemetry(self, seat), journal,
                                  truth=vehicle.true_pose,
                                  truth_period_s=self.config.truth_period_s,
                                  tap=None if self.tap is None else partial(self.tap, vid))
        self._step(seat, lambda d: d.tick(now))

    def _deliver(self, vid: str, data: bytes, t_s: float) -> None:
        seat = self.seats[vid]
        thaw = seat.thaw_at(self.loop.now())
        if thaw is not None:  # a frozen host reads its modem's frames when it runs again,
            self.loop.call_at(thaw, lambda: self._deliver(vid, data, t_s))  # dated as they came
        elif seat.driver is not None:
            self._step(seat, lambda d: d.frame(data, t_s), tick=False)

    def _wake(self, seat: Seat) -> None:
        seat.handle = None
        thaw = seat.thaw_at(self.loop.now())
        if thaw is not None:
            seat.handle = self.loop.call_at(thaw, lambda: self._wake(seat))
        elif seat.driver is not None:
            now = self.loop.now()
            self._step(seat, lambda d: d.tick(now))

    def _step(self, seat: Seat, feed: Any, tick: bool = True) -> None:
        driver = seat.driver
        assert driver is not None
        feed(driver)
        due = driver.next_wakeup()
        if due <= self.loop.now() and tick:
            self._stuck += 1
            if self._stuck > 10_000:  # a logic bug must fail loudly, never hang a test
                raise RuntimeError(f"agent {seat.vid} makes no progress at t={self.loop.now()}")
        else:
            self._stuck = 0
        if seat.handle is not None:
            if seat.handle.t_s <= due and not seat.handle.cancelled:
                return
            seat.handle.cancel()
        seat.handle = self.loop.call_at(due, lambda: self._wake(seat))

    # -- faults -----------------------------------------------------------------------------

    def apply(self, f: Fault, now: float) -> None:
        """A fault at ``now`` (`fault_plan.FleetControl`)."""
        self.applied.append(Fault(f.kind, now, f.vid, f.value, f.words))
        seat = self.seats.get(f.vid)
        if f.kind == FaultKind.ABORT and seat is not None and seat.driver is not None:
            self._step(seat, lambda d: d.command(ABORT, now), tick=False)
        elif f.kind == FaultKind.KILL and seat is not None and seat.driver is not None:
            agent = seat.driver.agent
            self._snapshot_oracle(f.vid, now)
            # What the dead agent knew (for tests); the fleet and the report only have what it
            # last published, as in a real mission.
            self.at_kill[f.vid] = (agent.status(now), frozenset(agent.know.cleared))
            # Where everyone was (the truth): who was within reach of the dead vehicle.
            self.positions_at_kill[f.vid] = {
                v: tuple(s.agent.own.pos) for v, s in self.seats.items() if s.agent is not None}
            seat.driver = None
            if seat.handle is not None:
                seat.handle.cancel()
                seat.handle = None
        elif f.kind == FaultKind.RESTART and seat is not None and seat.driver is None:
            self._start_agent(f.vid, now, seat.journal.reopen())
        elif f.kind == FaultKind.PARTITION:
            alone = (frozenset((f.vid,)),)  # the vehicle cut off from everyone
            apply_control(LinkControl(partition=Partition(now, now + f.value, alone)),
                          self.channel)
        elif f.kind == FaultKind.STALL and seat is not None:
            seat.stall = f
        elif f.kind == FaultKind.LOSS:
            apply_control(LinkControl(extra_loss=f.value), self.channel)
        elif f.kind == FaultKind.CTL and f.unsigned:  # an insider: the fleet key, not the chain
            self.net.send(INTRUDER, forged_order(self.fleet, f.order(), now), "data")
        elif f.kind == FaultKind.CTL:
            self.topside.submit(f.order(), now)
            self._topside_send()

    def _topside_send(self) -> None:
        """The topside's frames due now, and its next turn."""
        now = self.loop.now()
        for frame in self.topside.frames(now):
            self.net.send(TOPSIDE, frame, "data")
        due = self.topside.next_s(now)
        if due is not None and (self._topside_wake is None or self._topside_wake.cancelled
                                or self._topside_wake.t_s != due):
            if self._topside_wake is not None:
                self._topside_wake.cancel()
            self._topside_wake = self.loop.call_at(due, self._topside_send)

    def _overhear(self, event: LinkEvent) -> None:
        if event.delivered and event.src != INTRUDER:
            self.intruder.overhear(event.frame)

    def attack(self, f: Fault, now: float) -> None:
        """One hostile frame of ``f`` (`fault_plan.FleetControl`): the intruder's modem
        transmits it through the channel; an insider's frames leave from its position."""
        if f.kind not in INSIDER_ATTACKS:
            self.net.send(INTRUDER, self.intruder.frame(f.kind, now), "data")
            return
        for frame in self._insider(f.vid).frames(f.kind, now):
            self.net.send(f.vid, frame, "data")

    def _insider(self, vid: str) -> Insider:
        """The insider ``vid``: its leaked seed is the one its own agent was given."""
        if vid not in self.insiders:
            index = self.problem.vehicle_index[vid]
            chains = self.fleet.chains
            assert chains is not None and chains.seeds is not None, "a simulation derives " \
                "every chain, seeds included"
            self.insiders[vid] = Insider(self.problem, self.fleet.codec, chains, self.config,
                                         index, chains.seeds[index], insider_rng(self.seed, index))
        return self.insiders[vid]

    # -- the perfect-information reference ---------------------------------------------------

    def _snapshot_oracle(self, vid: str, now: float) -> None:
        """Centralized replan with perfect information at the moment ``vid`` dies: the true
        positions, batteries and routes of the survivors and the true cleared set. (Not in a
        dynamic mission: there the clairvoyant plan on the truth is the reference.)"""
        if self.reef is not None:
            return
        agents = {v: s.agent for v, s in self.seats.items()}
        survivors = [a for v, a in agents.items() if v != vid and a is not None
                     and not a.own.done and not a.own.aborted]
        n = self.problem.n_tasks  # the map's spots (not the operator's added ones)
        idx = self.problem.task_index
        cleared = frozenset(t for a in agents.values() if a is not None
                            for t, _ in a.know.treated if t < n) | frozenset(
            idx[x] for vid, s in self.seats.items()
            if s.agent is None and vid in self.ledger.statuses
            for x in self.ledger.statuses[vid].treated if x in idx)
        live = []
        for a in survivors:
            v = a.own
            locked = (v.injecting,) if v.injecting is not None and v.injecting < n else ()
            pos = (float(v.pos[0]), float(v.pos[1]), float(v.pos[2]))
            live.append(Live(a.index, pos, v.battery_left_s(now),
                             tuple(t for t in v.route if t < n), locked))
        planner = Planner(self.problem, self.seed, 0, self.oracle_iterations,
                          self.config.battery_reserve_s)
        routes = planner.replan(live, cleared, {}, seed=self.seed) if live else {}
        priority = sum(float(self.problem.priority[t]) for r in routes.values() for t in r)
        self.oracle = {"vid": vid, "t_s": now, "priority": priority,
                       "survivors": [self.problem.vehicles[a.index].id for a in survivors],
                       "cleared_before": sorted(cleared)}

    def _collected_after(self, t0: float, survivors: set[str], before: set[int]) -> float:
        spots = {t for e in self.ledger.events if e.kind == EventKind.CLEARED and e.id in survivors
                 and e.t_s > t0 for t in e.tasks}
        idx = self.problem.task_index
        return sum(float(self.problem.priority[idx[t]]) for t in spots
                   if t in idx and idx[t] not in before)


def mac_of(channel: ChannelConfig, fleet: Fleet, problem: Problem) -> ChannelConfig:
    """The channel with its TDMA MAC, if it has one, set for the fleet's own schedule (the
    spatial schedule every agent computes, `Fleet.schedule`, handed to the `Channel`): the
    roster in order, the agents' slot, the guard cut to what that slot leaves after the
    largest frame; so the water and the agents agree on every slot."""
    if channel.tdma is None or fleet.schedule is None:
        return channel
    slot = fleet.schedule.slot_s
    guard = min(channel.tdma.guard_s, slot - channel.airtime_s(channel.max_frame_bytes))
    tdma = replace(channel.tdma, slot_s=slot, guard_s=max(0.0, guard),
                   order=tuple(v.id for v in problem.vehicles))
    return replace(channel, tdma=tdma)


@dataclass
class SimResult:
    report: MissionReport
    wall_s: float
    backend: InProcessBackend
    ledger: FleetLedger = field(repr=False, default_factory=FleetLedger)

    @property
    def statuses(self) -> dict[str, Status]:
        return self.ledger.statuses

    @property
    def events(self) -> list[Event]:
        return self.ledger.events

    @property
    def agents(self) -> dict[str, Agent | None]:
        return {vid: s.agent for vid, s in self.backend.seats.items()}

    @property
    def oracle(self) -> Oracle | None:
        return self.report.oracle


def simulate(problem: Problem, config: AgentConfig | None = None, *,
             faults: Sequence[Fault] = (), horizon_s: float | None = None,
             progress: Any = None, **kw: Any) -> SimResult:
    """One seeded in-process mission (keyword arguments of `InProcessBackend`)."""
    backend = InProcessBackend(problem, config or AgentConfig(), **kw)
    horizon = horizon_s or horizon_of(problem)
    bind = getattr(progress, "bind", None)
    if bind is not None:  # a progress line that counts the spots cleared (`cotsfleet sim`)
        bind(backend.ledger, horizon)
    # What exists now (the scenario, the plan, every agent's start) lives as long as the
    # mission: out of the collector's sight, a full collection does not walk it again and
    # again (at 100 vehicles it won back 2.6 s of a 50 s mission; docs/membership.md).
    # Thawed at the end, so a sweep's worker collects it after the mission. Collected first:
    # the last mission's cycles, dropped by the caller but not yet collected, would be frozen
    # with the live objects, thawed, frozen again by the next mission and never freed (a
    # worker running hard dynamic reefs grew by 20 MB a mission: 634 MB after 24 missions,
    # 174 MB with this collection). And the mission
    # makes many short-lived objects, nearly all freed by their counts: the young generation
    # is collected every `YOUNG_OBJECTS` allocations, not 700 (at 100 vehicles the collector's
    # 2.4-3.0 s fell to 1.2 s); a cycle left behind waits that much longer, a bounded amount.
    thresholds = gc.get_threshold()
    gc.collect()
    gc.freeze()
    gc.set_threshold(max(thresholds[0], YOUNG_OBJECTS), *thresholds[1:])
    try:
        outcome: Outcome = run_mission(problem, backend, faults, seed=backend.seed,
                                       step_s=STEP_S, horizon_s=horizon,
                                       progress=progress, reef=backend.reef)
    finally:
        gc.set_threshold(*thresholds)
        gc.unfreeze()
    return SimResult(outcome.report, outcome.wall_s, backend, backend.ledger)
