"""The whole fleet in one process, on the deterministic transport and clock.

The same `Agent` logic as the multi-process deployment, driven by `comms_sim.des`: each agent
wakes at its own `next_wakeup`, frames cross the same `Channel` model, and faults are injected
at simulation times: abort (command), kill (the agent stops; its vehicle is dead in the
water), restart (a new agent from the old one's journal), partition (one vehicle cut off for
a while), extra loss, and an intruder transmitting forged, replayed and garbage frames.
Seeded: the same seed gives the same mission, frame for frame.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from typing import Any, Callable, Sequence

import numpy as np

from comms_sim.channel import Channel
from comms_sim.config import ChannelConfig, Partition
from comms_sim.des import EventLoop, Handle, InProcessNetwork
from comms_sim.link_event import LinkEvent
from fleet_agent.config import AgentConfig
from fleet_agent.journal import MemoryJournal
from fleet_agent.logic import Agent, Command, Fleet, Frame, Output, Publish, Record, Send, Tick
from fleet_agent.plans import Live, Planner
from fleet_agent.report import FaultRecord, build_report
from fleet_agent.telemetry import Event, Status
from fleet_agent.wire import Codec, Digest, Pose
from hfc_core.problem import Problem

FAULT_KINDS = ("abort", "kill", "restart", "partition", "loss", "forge", "replay", "garbage")
INTRUDER = "intruder"


@dataclass(frozen=True)
class Fault:
    """``kind`` at ``t_s`` on ``vid``; ``value``: extra loss (loss), duration in seconds
    (partition), number of frames (forge/replay/garbage)."""

    kind: str
    t_s: float
    vid: str = ""
    value: float = 0.0

    def __post_init__(self) -> None:
        if self.kind not in FAULT_KINDS:
            raise ValueError(f"unknown fault {self.kind!r}; choose from {FAULT_KINDS}")
        if not self.t_s >= 0:
            raise ValueError(f"fault time must be >= 0, got {self.t_s}")


def parse_at(spec: str) -> tuple[str, float]:
    """``"auv2@1200"`` -> ("auv2", 1200.0)."""
    vid, sep, t = spec.partition("@")
    if not sep or not vid:
        raise ValueError(f"expected VEHICLE@SECONDS, got {spec!r}")
    try:
        t_s = float(t)
    except ValueError:
        raise ValueError(f"expected VEHICLE@SECONDS, got {spec!r}") from None
    if not t_s >= 0:
        raise ValueError(f"time must be >= 0 in {spec!r}")
    return vid, t_s


@dataclass
class _Slot:
    """One vehicle's seat in the simulation: its agent (None while killed) and journal."""

    agent: Agent | None
    journal: MemoryJournal
    handle: Handle | None = None
    status: Status | None = None


@dataclass
class SimResult:
    report: dict[str, Any]
    statuses: dict[str, Status]
    events: list[Event]
    link: dict
    wall_s: float
    oracle: dict[str, Any] = field(default_factory=dict)
    agents: dict[str, Agent | None] = field(default_factory=dict)


class FleetSim:
    def __init__(self, problem: Problem, config: AgentConfig, *, seed: int = 0,
                 loss: float = 0.0, faults: Sequence[Fault] = (),
                 channel: ChannelConfig | None = None, horizon_s: float | None = None,
                 planner: Planner | None = None, key: bytes | None = None,
                 oracle_iterations: int = 300) -> None:
        self.problem = problem
        self.seed = seed
        root = np.random.SeedSequence(seed)
        channel_seed, attack_seed, key_seed = root.spawn(3)
        key = key or np.random.default_rng(key_seed).bytes(16)
        self.config = config.with_key(key)
        self.fleet = Fleet.build(problem, key, seed, self.config, planner)
        self.faults = sorted(faults, key=lambda f: f.t_s)
        ids = {v.id for v in problem.vehicles}
        for f in self.faults:
            if f.kind in ("abort", "kill", "restart", "partition") and f.vid not in ids:
                raise ValueError(f"fault {f.kind} names unknown vehicle {f.vid!r}")
        cfg = replace(channel or ChannelConfig(), extra_loss=loss)
        self.loop = EventLoop()
        self.channel = Channel(cfg, np.random.default_rng(channel_seed))
        self.net = InProcessNetwork(self.channel, self.loop, self._positions)
        self._attack_rng = np.random.default_rng(attack_seed)
        self.horizon_s = horizon_s or max(v.battery_s for v in problem.vehicles) + 120.0
        self.oracle_iterations = oracle_iterations
        self.slots: dict[str, _Slot] = {}
        self.events: list[Event] = []
        self.records: list[FaultRecord] = []
        self.oracle: dict[str, Any] = {}
        self._captured: list[bytes] = []  # frames the intruder overheard, for replay
        self.at_kill: dict[str, tuple[Status, frozenset[int]]] = {}  # status, cleared set
        self._stuck = 0
        self._pending_restarts = {f.vid for f in self.faults if f.kind == "restart"}
        self.net.add_listener(self._overhear)

    # -- wiring ----------------------------------------------------------------------------

    def _positions(self, t_s: float) -> dict[str, tuple[float, float, float]]:
        out = {vid: s.agent.vehicle.pos for vid, s in self.slots.items() if s.agent is not None}
        for vid, s in self.slots.items():
            if s.agent is None and s.status is not None:
                out[vid] = s.status.pos  # dead in the water where it stopped
        return out

    def _start(self, vid: str, now: float, journal: MemoryJournal) -> None:
        idx = self.problem.vehicle_index[vid]
        agent = Agent(self.fleet, idx, self.config, now, journal.records)
        slot = self.slots.get(vid)
        if slot is None:
            slot = self.slots[vid] = _Slot(agent, journal)
            self.net.attach(vid, lambda data, t, vid=vid: self._deliver(vid, data, t))
        else:
            slot.agent, slot.journal = agent, journal
        self._step(vid, Tick(now))

    def _deliver(self, vid: str, data: bytes, t_s: float) -> None:
        if self.slots[vid].agent is not None:
            self._step(vid, Frame(data, t_s))

    def _wake(self, vid: str) -> None:
        slot = self.slots[vid]
        slot.handle = None
        if slot.agent is not None:
            self._step(vid, Tick(self.loop.now()))

    def _step(self, vid: str, inp: Tick | Frame | Command) -> None:
        slot = self.slots[vid]
        agent = slot.agent
        assert agent is not None
        self._handle(vid, slot, agent.step(inp))
        due = agent.next_wakeup()
        if due <= self.loop.now() and isinstance(inp, Tick):
            self._stuck += 1
            if self._stuck > 10_000:  # a logic bug must fail loudly, never hang a test
                raise RuntimeError(f"agent {vid} makes no progress at t={self.loop.now()}")
        else:
            self._stuck = 0
        if slot.handle is not None:
            if slot.handle.t_s <= due and not slot.handle.cancelled:
                return
            slot.handle.cancel()
        slot.handle = self.loop.call_at(due, lambda: self._wake(vid))

    def _handle(self, vid: str, slot: _Slot, outputs: list[Output]) -> None:
        for o in outputs:
            if isinstance(o, Send):
                self.net.send(vid, o.frame, o.kind)
            elif isinstance(o, Record):
                slot.journal.append(o.doc, o.durable)
            elif isinstance(o, Publish):
                if o.topic == "status":
                    slot.status = o.payload  # type: ignore[assignment]
                elif o.topic == "event":
                    self.events.append(o.payload)  # type: ignore[arg-type]

    # -- faults ----------------------------------------------------------------------------

    def _apply(self, f: Fault) -> None:
        now = self.loop.now()
        self.records.append(FaultRecord(f.kind, f.vid, now, f.value))
        slot = self.slots.get(f.vid)
        if f.kind == "abort" and slot is not None and slot.agent is not None:
            self._step(f.vid, Command("abort", now))
        elif f.kind == "kill" and slot is not None and slot.agent is not None:
            self._snapshot_oracle(f.vid, now)
            slot.status = slot.agent.status(now)
            self.at_kill[f.vid] = (slot.status, frozenset(slot.agent.cleared))
            slot.agent = None
            if slot.handle is not None:
                slot.handle.cancel()
                slot.handle = None
        elif f.kind == "restart" and slot is not None and slot.agent is None:
            self._start(f.vid, now, slot.journal.reopen())
        elif f.kind == "partition":
            self.channel.add_partition(Partition(now, now + max(f.value, 1.0), ((f.vid,),)))
        elif f.kind == "loss":
            self.channel.set_extra_loss(f.value)
        elif f.kind in ("forge", "replay", "garbage"):
            for i in range(int(f.value) or 10):
                self.loop.call_later(1.0 + 3.7 * i, lambda kind=f.kind: self._attack(kind))

    def _overhear(self, event: LinkEvent) -> None:
        if event.delivered and event.src != INTRUDER and len(self._captured) < 256:
            self._captured.append(event.frame)

    def _attack(self, kind: str) -> None:
        """The intruder transmits one hostile frame through the channel."""
        rng = self._attack_rng
        if kind == "garbage":
            frame = rng.bytes(int(rng.integers(1, 65)))
        elif kind == "replay" and self._captured:
            frame = self._captured[int(rng.integers(len(self._captured)))]
        else:  # forged: well-formed, plausible, under the wrong key
            codec = Codec.for_problem(self.problem, rng.bytes(16))
            sender = int(rng.integers(self.problem.n_vehicles))
            frame = codec.encode(Pose(sender, int(self.loop.now()) + 10**6, (0.0, 0.0, 0.0), 0,
                                      "home", Digest(0, 0)))
        self.net.send(INTRUDER, frame, "data")

    def _snapshot_oracle(self, vid: str, now: float) -> None:
        """Centralized replan with perfect information at the moment ``vid`` dies: the true
        positions, batteries and routes of the survivors and the true cleared set."""
        survivors = [s.agent for v, s in self.slots.items()
                     if v != vid and s.agent is not None and not s.agent.vehicle.done
                     and not s.agent.vehicle.aborted]
        cleared = frozenset(t for s in self.slots.values() if s.agent is not None
                            for t, _ in s.agent.treated) | frozenset(
            t for s in self.slots.values() if s.agent is None and s.status is not None
            for t in (self.problem.task_index[x] for x in s.status.treated))
        for a in [self.slots[vid].agent]:
            if a is not None:
                cleared |= frozenset(t for t, _ in a.treated)
        live = []
        for a in survivors:
            v = a.vehicle
            locked = (v.injecting,) if v.injecting is not None else ()
            live.append(Live(a.index, tuple(v.pos), v.battery_left_s(now), tuple(v.route), locked))
        planner = Planner(self.problem, self.seed, 0, self.oracle_iterations)
        routes = planner.replan(live, cleared, {}, seed=self.seed) if live else {}
        priority = sum(float(self.problem.priority[t]) for r in routes.values() for t in r)
        self.oracle = {"vid": vid, "t_s": now, "priority": priority,
                       "survivors": [self.problem.vehicles[a.index].id for a in survivors],
                       "cleared_before": sorted(cleared)}

    # -- running ---------------------------------------------------------------------------

    def run(self, progress: Callable[[float], None] | None = None) -> SimResult:
        wall = time.perf_counter()
        for v in self.problem.vehicles:
            self._start(v.id, 0.0, MemoryJournal())
        if any(f.kind in ("forge", "replay", "garbage") for f in self.faults):
            self.channel.set_position(INTRUDER, self._centroid(), 0.0)
        for f in self.faults:
            self.loop.call_at(f.t_s, lambda f=f: self._apply(f))
        t = 0.0
        while t < self.horizon_s:
            t = min(self.horizon_s, t + 60.0)
            self.loop.run_until(t)
            if progress is not None:
                progress(t)
            if self._finished(t):
                break
        end = self.loop.now()
        statuses = {}
        for vid, s in self.slots.items():
            if s.agent is not None:
                s.status = s.agent.status(end)
            if s.status is not None:
                statuses[vid] = s.status
        link = self.channel.stats()
        extra: dict[str, Any] = {}
        if self.oracle:
            after = self._collected_after(self.oracle["t_s"], set(self.oracle["survivors"]),
                                          set(self.oracle["cleared_before"]))
            ratio = after / self.oracle["priority"] if self.oracle["priority"] > 0 else 1.0
            extra["oracle"] = {**{k: v for k, v in self.oracle.items() if k != "cleared_before"},
                               "collected": round(after, 2), "ratio": round(ratio, 4)}
        report = build_report(self.problem, statuses, self.events, link, self.records,
                              mode="sim", seed=self.seed, end_s=end, extra=extra)
        return SimResult(report, statuses, self.events, link, time.perf_counter() - wall,
                         extra.get("oracle", {}),
                         {vid: s.agent for vid, s in self.slots.items()})

    def _finished(self, now: float) -> bool:
        if any(f.t_s > now for f in self.faults if f.kind in ("restart", "abort")):
            return False
        return all(s.agent is None or s.agent.quiet for s in self.slots.values())

    def _collected_after(self, t0: float, survivors: set[str], before: set[int]) -> float:
        spots = {t for e in self.events if e.kind == "cleared" and e.id in survivors
                 and e.t_s > t0 for t in e.tasks}
        idx = self.problem.task_index
        return sum(float(self.problem.priority[idx[t]]) for t in spots if idx[t] not in before)

    def _centroid(self) -> tuple[float, float, float]:
        c = self.problem.xyz[: self.problem.n_tasks].mean(axis=0)
        return (float(c[0]), float(c[1]), 0.0)


def simulate(problem: Problem, config: AgentConfig | None = None, **kw: Any) -> SimResult:
    """One seeded in-process mission (keyword arguments of `FleetSim`)."""
    return FleetSim(problem, config or AgentConfig(), **kw).run()
