"""The agent's decision logic: a pure state machine ``(state, input) -> (state, outputs)``.

Inputs are `Tick`, `Frame` (bytes off the modem) and `Command` (the operator's), each with
the mission time ``now``, and with them what the vehicle reported since the last step
(`fleet_bus.vehicle_port`: navigation fixes, arrivals, ends of looks and injections, what its
camera saw); outputs are `Send` (a frame for the modem), `Publish` (telemetry: status,
event), `Record` (a journal record) and `Helm` (a command for the vehicle). No I/O, no clock,
no randomness: the same inputs give the same outputs, under every driver
(`fleet_agent.driver`).

One step (paper section II and IV-A): take the vehicle's reports, take the input, look for
silent peers, run the cooperation operator when due, keep the route true to what is known,
command the vehicle if what it should do changed, publish telemetry, and transmit if this is
the vehicle's slot. The parts, one idea each:

- `knowledge.Knowledge`  what it knows, versioned (its vehicle as `motion.OwnVehicle`, the
                         cleared set, holdings, members, peers, beliefs of the reef);
- `policies`             what it decides: each reads the knowledge and returns intents
                         (`intents`), which `_apply` carries out in order;
- `radio.Radio`          its slots and sequence numbers; `outbox.Outbox` what it owes the
                         fleet and which message goes in its slot;
- `records`              what it journals, and `restore` the fold that brings it back.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from fleet_agent import records as rec
from fleet_agent.beliefs import Beliefs
from fleet_agent.config import AgentConfig
from fleet_agent.fleet import Fleet
from fleet_agent.intents import (Count, Hold, Intent, LastWords, Note, Owe, SeekWork, Steer,
                                 Tell)
from fleet_agent.io_types import (Command, Frame, Helm, Input, Output, Outputs, Publish,
                                  Record, Send, Tick)
from fleet_agent.knowledge import Knowledge, settled_by_s
from fleet_agent.motion import Activity, Conduct, OwnVehicle
from fleet_agent.outbox import Holding, Owed
from fleet_agent.policies import discovery, hearing, searching, unproven
from fleet_agent.policies import reports as reports_policy
from fleet_agent.policies.cooperate import CoopClock, cooperate
from fleet_agent.policies.navigation import Navigation
from fleet_agent.policies.rejoin import Rejoin
from fleet_agent.policies.orders import Orders
from fleet_agent.policies.route import sync
from fleet_agent.provenance import Provenance
from fleet_agent.radio import Radio, Slots
from fleet_agent.restore import fold, restore
from fleet_agent.routing import fit_route
from fleet_agent.wire import Message, radio_kind
from fleet_bus.commands import Command as OperatorCommand
from fleet_bus.orders import is_topside_frame
from fleet_bus.states import EventKind
from fleet_bus.telemetry import Status
from fleet_bus.vehicle_port import VehicleReport
from hfc_core.model.problem import Problem

__all__ = ["Agent", "Fleet", "Tick", "Frame", "Command", "Input", "Send", "Publish", "Record",
           "Helm", "Output"]


class Agent:
    """One vehicle's brain: call `step` with each input; `next_wakeup` says when to tick."""

    def __init__(self, fleet: Fleet, index: int, config: AgentConfig, now: float = 0.0,
                 journal: Sequence[dict[str, Any]] = (), chain_seed: bytes | None = None,
                 journal_damaged: bool = False) -> None:
        """``chain_seed``: this vehicle's key chain (`fleet_bus.tesla`) from its
        credentials; None where the fleet's chains are derived (a simulation).
        ``journal_damaged``: the journal's reader found bytes it could not read."""
        p = fleet.problem
        self.fleet, self.index, self.config = fleet, index, config
        self.id = p.vehicles[index].id
        slots = Slots(index, p.n_vehicles, config.slot_s, fleet.schedule)
        dyn = fleet.dynamic
        beliefs = Beliefs(fleet.given, None if dyn is None else dyn.camera, config, index,
                          fleet.seed, slots.cycle_s, fleet.planner, p)
        self.own = OwnVehicle(p, index, fleet.paths, Conduct(
            self._settled_s, lambda task: discovery.needs_look(self.know, task),
            0.0 if dyn is None else dyn.camera.inspect_s,
            config.battery_reserve_s, self._held_back, lambda: settled_by_s(self.know)), now)
        self.own.frame.enabled = dyn is not None and config.map_relative_nav
        self.know = Knowledge(fleet, index, config, slots.cycle_s, beliefs, self.own)
        self.know.search = searching.belief_of(self.know, config)
        self.radio = Radio(slots, config, fleet.codec.max_ids, now)
        self.provenance = Provenance.of(fleet, index, chain_seed, config.slot_s)
        self.coop = CoopClock(now + config.coop_period_s * (1.0 + index / p.n_vehicles))
        self.nav = Navigation(config)  # fixes that stop, a vehicle that lags (`policies`)
        assert fleet.orders is not None and fleet.chains is not None
        chains = fleet.chains
        self.orders = Orders(fleet.orders, fleet.topside, chains.topside, chains.length, index,
                             config, journal)  # the operator's live orders
        self.nav.paused = self.orders.paused
        self.counters: dict[str, int] = {}
        self.largest_frame = 0
        self.lag_s = 0.0  # worst lateness of the host since the last status (`note_lag`)
        self.t = float(now)
        self.restarted = bool(journal)
        self._next_status = now
        self._next_ckpt = now + config.checkpoint_period_s
        self._peers: dict[str, str] = {}
        self._peers_at = -1  # the membership version `_peers` was built at
        self._synced = -1  # the knowledge's version the route was last checked against
        self._commanded: object = None  # what the vehicle was last told (its command's key)
        self._held_at: set[int] = set()  # spots waited at on an unproven frame (`_held_back`)
        self._boot = self._outputs()
        lost = "damaged" if journal_damaged else None
        if journal:
            snap = fold(journal, p.n_tasks)
            if snap.bad_records:
                self.count("journal_bad_records", snap.bad_records)
                lost = "damaged"
            restore(snap, self.know, self.radio, fleet.base_routes[index], now, self._boot)
            # The fleet went on while this agent was down: its peers took over its spots and
            # may have treated some (a fault fuzz, hard reef, 49 % loss: auv3 killed at
            # 988 s, its spot 23 taken over and treated by auv2 at 1168 s, auv3 restarted at
            # 1316 s and treated 23 again at 1445 s). It rejoins, as after a lost journal.
            lost = lost or "restart"
        else:
            self.own.set_route(fleet.base_routes[index])
            self._boot.record(rec.Start(now, index))
            if now > 2 * slots.cycle_s:  # the mission is under way: a journal lost, or late
                lost = "empty"
        self.rejoin = Rejoin(lost, now, slots.cycle_s)  # learn the fleet's set before acting
        self.nav.rejoining = self.rejoin.waiting
        if lost is not None:
            if lost != "restart":
                self.count(f"journal_{lost}")
            what = "restarted" if lost == "restart" else f"journal {lost}"
            self._boot.event(now, EventKind.RESTART, detail=f"{what}: keeping station until "
                             "the fleet's cleared set is learned")
        self.know.rebind()

    def _settled_s(self, task: int) -> float:
        return self.know.settled_s(task)

    def _held_back(self, task: int, settled_s: float) -> float:
        """Until when the vehicle at ``task`` waits past its claim's settle: a frame not yet
        proven may hold an earlier claim of it (`policies.unproven`); 0 if none does."""
        held = self.provenance.unproven()
        if not unproven.rival(self.know, held, task, self.own.t_s):
            return 0.0
        if task not in self._held_at:  # counted once a spot (judged again at every wake)
            self._held_at.add(task)
            self.count("waits_unproven")
        return settled_s + self.config.unproven_wait_cycles * self.radio.slots.cycle_s

    # -- the state machine -----------------------------------------------------------------

    def step(self, inp: Input, reports: Sequence[VehicleReport] = (),
             nav_age_s: float | None = None) -> list[Output]:
        """Take the vehicle's ``reports`` (in time order, none after ``inp.now``) and its last
        fix's age (None: fresh), then ``inp``; return what to journal, send, publish, command."""
        now = max(float(inp.now), self.t)
        out, self._boot = self._boot, self._outputs()
        for r in reports:
            self._apply(reports_policy.take(self.know, self.config, self.fleet.codec, r,
                                            self.active), now, out)
        if self.own.wake(now):
            self.know.touch()
        if isinstance(inp, Frame):
            self._on_frame(inp.data, now, out)
        elif isinstance(inp, Command):
            self._on_command(inp.name, now, out)
        self._settle(now)
        self._apply(self.nav.check(self.know, now, nav_age_s), now, out)
        if self.rejoin.waiting:
            self._apply(self.rejoin.check(self.know, now), now, out)
            self.nav.rejoining = self.rejoin.waiting
        if self.config.discovery:  # never treat a spot twice (`policies.discovery`)
            self._apply(discovery.fold_treated(self.know, now), now, out)
        self.know.rebind()
        for v in self.know.members.check(now):  # silence makes a suspect, nothing more
            out.event(now, EventKind.SUSPECT, peer=self.know.vid(v))
        if self.active and not self.rejoin.waiting and self.coop.due(now,
                                                                     self.config.coop_period_s):
            self._apply(cooperate(self.know, self.config, now), now, out)
        if self.active and self.know.version != self._synced:
            self._synced = self.know.version
            self._apply(sync(self.know), now, out)
        self._helm(out)
        self._telemetry(now, out)
        self._transmit(now, out)
        self.t = now
        return list(out)

    def next_wakeup(self) -> float:
        """The next time `step(Tick(...))` has something to do."""
        times = [self.radio.next_slot_s(), self._next_status, self._next_ckpt]
        if self.own.activity is Activity.WAITING and self.own.busy_until_s is not None:
            times.append(self.own.busy_until_s)  # the claim has settled: the work begins
        if self.active:
            times.append(self.coop.next_s)
            settle = self.know.beliefs.next_settle_s(self.t)
            if settle is not None:
                times.append(settle)
            dl = self.know.members.next_deadline_s()
            if dl is not None:
                times.append(dl)
        return max(self.t, min(times))

    @property
    def problem(self) -> Problem:
        """The working problem (the scenario; in a dynamic mission, with the finds)."""
        return self.know.problem

    @property
    def active(self) -> bool:
        """Still working: neither home nor aborted."""
        return not (self.own.done or self.own.aborted)

    @property
    def state(self) -> str:
        return self.own.state()

    @property
    def quiet(self) -> bool:
        """Home or aborted, and done announcing it (it may still keep watch)."""
        return not self.active and self.radio.outbox.idle

    def note_lag(self, late_s: float) -> None:
        """The host ran a step ``late_s`` mission seconds after it was due (a busy machine):
        reported in the next status, for the operator's clock (not a decision input)."""
        self.lag_s = max(self.lag_s, late_s)

    def count(self, name: str, n: int = 1) -> None:
        self.counters[name] = self.counters.get(name, 0) + n

    def _outputs(self) -> Outputs:
        return Outputs(self.id, self.know.tids)

    # -- intents ---------------------------------------------------------------------------

    def _apply(self, intents: Sequence[Intent], now: float, out: Outputs) -> None:
        """Carry out what a policy decided, in its order."""
        for i in intents:
            if isinstance(i, Hold):
                self._hold(i, now, out)
            elif isinstance(i, Steer):
                self._steer(i, now, out)
            elif isinstance(i, Owe):
                self.radio.outbox.owe(i.kind, i.item)
            elif isinstance(i, Tell):
                out.event(i.t_s, i.kind, i.tasks, peer=i.peer, detail=i.detail)
            elif isinstance(i, Note):
                out.record(i.record)
            elif isinstance(i, Count):
                self.count(i.name, i.n)
            elif isinstance(i, SeekWork):
                self.coop.soon = True
            elif isinstance(i, LastWords):
                words = self.provenance.last_words(i.v)
                self._apply(hearing.last_words(self.know, i.v, words, now), now, out)

    def _hold(self, h: Hold, now: float, out: Outputs) -> None:
        """Claim (or release): journal it first, then tell the fleet."""
        t = int(now)
        changed = self.know.hold(self.index, t, h.tasks, h.claim)
        if changed:
            out.record(rec.Hold(self.index, t, tuple(changed), h.claim, durable=True))
            self.radio.outbox.owe(Owed.CLAIM, Holding(h.claim, t, tuple(changed)))
            if h.claim:
                out.event(now, EventKind.CLAIM, changed)

    def _steer(self, s: Steer, now: float, out: Outputs) -> None:
        """Fit the route to the battery; release what this vehicle holds and will not treat."""
        fitted = fit_route(self.own, s.route, self.config.battery_reserve_s, s.protect)
        dropped = [t for t in self.know.held_by(self.index) if t not in fitted]
        if dropped:
            self._hold(Hold(tuple(dropped), False), now, out)
        if fitted != self.own.route:
            self.own.set_route(fitted)
            if s.why != "sync":
                out.event(now, EventKind.REPLAN, detail=s.why)

    # -- the vehicle -----------------------------------------------------------------------

    def _helm(self, out: Outputs) -> None:
        """Tell the vehicle what to do when that changed (an arrival, the end of work, a new
        head of the route, an abort)."""
        key = self.nav.command_key(self.own)  # the route's, or a hold for want of navigation
        if key != self._commanded:
            self._commanded, cmd = key, self.nav.command(self.own)
            if cmd is not None:
                out.append(Helm(cmd))

    def _settle(self, now: float) -> None:
        """A find that finished settling may now be planned: look for work."""
        due = self.know.beliefs.next_settle_s(self.t)
        if due is not None and due <= now and self.config.discovery:
            self.coop.soon = True
            self.know.touch()

    # -- the modem in ----------------------------------------------------------------------

    def _on_frame(self, data: bytes, now: float, out: Outputs) -> None:
        """Bytes off the modem (`provenance`): evidence of life counts at once; the rest once
        proven its sender's, then through the replay window and `policies.hearing`."""
        self.count("rx_frames")
        if is_topside_frame(data):  # the operator's orders, keys, acknowledgements
            self._apply(self.orders.hear(data, now, self.know, self.nav), now, out)
            return
        taken = self.provenance.hear(data, now)
        for reason, n in self.provenance.take_drops().items():
            self.count(f"drop_{reason}", n)
        if taken.alive is not None:
            self._apply(hearing.alive(self.know, taken.alive, now), now, out)
        for msg in taken.proven:
            self._take(msg, now, out)

    def _take(self, msg: Message, now: float, out: Outputs) -> None:
        """A frame proven its sender's: once only, then what it says."""
        if not self.know.replay.accept(msg.sender, msg.seq):
            self.count("drop_replay")
            return
        self.count(f"rx_{type(msg).__name__.lower()}")
        self._apply(hearing.confirmed(self.know, self.config, msg, now, self.active), now, out)
        self._apply(hearing.content(self.know, self.config, msg, now, self.active), now, out)

    def _on_command(self, name: OperatorCommand, now: float, out: Outputs) -> None:
        if name == OperatorCommand.ABORT and self.active:
            self.own.abort()
            self._apply([Owe(Owed.OWN_ABORT), Note(rec.Aborted(now)),
                         Tell(now, EventKind.ABORT)], now, out)

    # -- the modem out ---------------------------------------------------------------------

    def _transmit(self, now: float, out: Outputs) -> None:
        if now < self.radio.next_slot_s():
            return
        sent_s, skipped = self.radio.take_slot(now)
        if skipped:
            self.count("slots_missed", skipped)
        if sent_s < now:
            self.count("slots_late")
        room = self.fleet.modem.frames_per_packet
        msgs = self.radio.messages(now, self.know, room)
        if self.orders.owes and (len(msgs) < room or radio_kind(msgs[-1]) == "pose"):
            passed = self.orders.take_frame(now, self.config.slot_s)  # in place of a pose
            msgs = msgs[:room - 1] if passed is not None else msgs
        else:
            passed = None
        sealed = [(m, self.provenance.seal(m)) for m in msgs]
        for reason, n in self.provenance.take_drops().items():
            self.count(f"tx_{reason}", n)
        msgs = [m for m, f in sealed if f is not None]
        frames = tuple(f for _, f in sealed if f is not None) + (
            (passed,) if passed is not None else ())
        if not frames:
            return
        names = tuple(type(m).__name__.lower() for m in msgs) + (
            ("order",) if passed is not None else ())
        for name, frame in zip(names, frames):
            self.count(f"tx_{name}")
            self.count("tx_bytes", len(frame))
            self.largest_frame = max(self.largest_frame, len(frame))
        kind = "pose" if passed is None and all(radio_kind(m) == "pose" for m in msgs) \
            else "data"
        out.append(Send(frames, kind, names, sent_s))
        out.record(self.checkpoint(now))

    # -- telemetry and checkpoints ---------------------------------------------------------

    def _telemetry(self, now: float, out: Outputs) -> None:
        if now >= self._next_status:
            self._next_status = now + self.config.status_period_s
            out.append(Publish("status", self.status(now)))
        if now >= self._next_ckpt:
            self._next_ckpt = now + self.config.checkpoint_period_s
            out.record(self.checkpoint(now))

    def status(self, now: float | None = None) -> Status:
        now = self.t if now is None else now
        v, know = self.own, self.know
        finish = v.time_to_finish_s()
        treated = [t for t, _ in know.treated]
        return Status(
            t_s=float(now), id=self.id, state=v.state(),
            pos=(float(v.pos[0]), float(v.pos[1]), float(v.pos[2])),
            battery_s=float(v.battery_left_s(now)),
            t_diff_s=float(v.battery_left_s(now) - finish),
            route=know.tids(v.route), treated=know.tids(treated),
            cleared_known=len(know.cleared), priority_collected=know.priority_of(treated),
            distance_m=float(v.distance_m),
            peers=self._peer_statuses(),
            claims=know.tids(sorted(know.standing_claims())),
            counters={**self.counters, "largest_frame": self.largest_frame},
            lag_s=self._take_lag(),
            suspects={know.vid(u): n for u, n in sorted(know.suspicion.items())})

    def _peer_statuses(self) -> dict[str, str]:
        """Each peer's status by id: rebuilt only when a status changed (a status is sent
        every few seconds by every vehicle; rebuilding it each time made the fleet's cost
        grow with the square of its size)."""
        members = self.know.members
        if self._peers_at != members.version:
            self._peers = {self.know.vid(u): p.status for u, p in members.peers.items()}
            self._peers_at = members.version
        return dict(self._peers)

    def _take_lag(self) -> float:
        lag, self.lag_s = self.lag_s, 0.0
        return float(lag)

    def checkpoint(self, now: float) -> rec.Checkpoint:
        v = self.own
        return rec.Checkpoint(now, v.pos, v.distance_m, tuple(v.route), self.radio.last_seq,
                              self.know.replay.high_water(), v.home_at_s)
