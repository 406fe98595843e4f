"""The agent's decision logic: a pure state machine ``(state, input) -> (state, outputs)``.

Inputs are `Tick`, `Frame` (bytes off the radio) and `Command` (fault injection), each with
the simulation time ``now``, and with them what the vehicle reported since the last step
(`fleet_bus.vehicle_port`: navigation fixes, arrivals, ends of looks and injections, what its
camera saw); outputs are `Send` (a frame for the radio), `Publish` (telemetry: status,
event), `Record` (a journal record) and `Helm` (a command for the vehicle). No I/O, no clock,
no randomness: the same inputs give the same outputs, under every driver
(`fleet_agent.driver`).

One step (paper section II and IV-A): take the vehicle's reports, take the input, look for
silent peers, run the cooperation operator when due, keep the route true to what is known,
command the vehicle if what it should do changed, publish telemetry, and transmit if this is
the vehicle's slot. The parts, one idea each:

- `motion.OwnVehicle`    where the vehicle is and what it is doing (the agent's model);
- `knowledge.Knowledge`  what it knows about the fleet (cleared, holdings, members, peers);
- `decisions.Decisions`  takeover, cooperation, the route;
- `radio.Radio`          what it owes the fleet and which frame goes in its slot;
- `records`              what it journals, and `restore` how it comes back from that.
"""

from __future__ import annotations

from typing import Any, Sequence

from fleet_agent import membership as mb
from fleet_agent.beliefs import Beliefs
from fleet_agent.config import AgentConfig
from fleet_agent.decisions import Decisions
from fleet_agent.discovery import Discovery
from fleet_agent.fleet import Fleet
from fleet_agent.io_types import (Command, Frame, Helm, Input, Output, Outputs, Publish,
                                  Record, Send, Tick)
from fleet_agent.knowledge import Knowledge, PeerPose
from fleet_agent.motion import Activity, Conduct, OwnVehicle
from fleet_agent.radio import PendingAbort, Radio, Slots
from fleet_agent.records import Aborted, Checkpoint, Clear, Hold, Home, PeerState, Start
from fleet_agent.restore import restore
from fleet_agent.wire import (MAX_LEAD_S, Abort, Claim, ClearedSegment, Found, Pose, Release,
                              WireError, radio_kind)
from fleet_bus.telemetry import Status
from fleet_bus.vehicle_port import (Arrived, Injected, Looked, NavFix, Refused, Sighted,
                                    VehicleReport)

__all__ = ["Agent", "Fleet", "Tick", "Frame", "Command", "Input", "Send", "Publish", "Record",
           "Helm", "Output"]


class Agent:
    """One vehicle's brain: call `step` with each input; `next_wakeup` says when to tick."""

    def __init__(self, fleet: Fleet, index: int, config: AgentConfig, now: float = 0.0,
                 journal: Sequence[dict[str, Any]] = ()) -> None:
        p = fleet.problem
        self.fleet, self.problem, self.index, self.config = fleet, p, index, config
        self.id = p.vehicles[index].id
        slots = Slots(index, p.n_vehicles, config.slot_s)
        beliefs = None
        if fleet.dynamic is not None:  # the map is a prior: look before injecting
            beliefs = Beliefs(fleet.dynamic.scenario, fleet.dynamic.camera, config, index,
                              fleet.seed, slots.cycle_s)
        self.know = Knowledge(fleet, index, config, slots.cycle_s, beliefs)
        conduct = Conduct(self.know.settled_s,
                          beliefs.unknown if beliefs is not None else lambda task: False,
                          fleet.dynamic.camera.inspect_s if fleet.dynamic is not None else 0.0,
                          config.battery_reserve_s)
        self.own = OwnVehicle(p, index, fleet.paths, conduct, now)
        self.discovery = Discovery(self)  # the reef as the camera shows it
        self.radio = Radio(slots, config, fleet.codec.max_ids, now)
        self.counters: dict[str, int] = {}
        self.decide = Decisions(fleet, config, self.own, self.know, self.radio, now,
                                self.count)
        self.largest_frame = 0
        self.lag_s = 0.0  # worst lateness of the host since the last status (`note_lag`)
        self.t = float(now)
        self.restarted = bool(journal)
        self._next_status = now
        self._next_ckpt = now + config.checkpoint_period_s
        self._commanded: tuple[Any, ...] | None = None  # what the vehicle was last told
        self._boot = self._outputs()
        if journal:
            restore(self, journal, now, self._boot)
        else:
            self.own.set_route(fleet.base_routes[index])
            self._boot.record(Start(now, index))
        self.discovery.rebind()

    # -- the state machine -----------------------------------------------------------------

    def step(self, inp: Input, reports: Sequence[VehicleReport] = ()) -> list[Output]:
        """Take the vehicle's ``reports`` (in time order, none after ``inp.now``), then
        ``inp``; return what to journal, send, publish and command."""
        now = max(float(inp.now), self.t)
        out, self._boot = self._boot, self._outputs()
        self._from_vehicle(reports, out)
        if self.own.wake(now):
            self.decide.dirty = True
        if isinstance(inp, Frame):
            self._on_frame(inp.data, now, out)
        elif isinstance(inp, Command):
            self._on_command(inp.name, now, out)
        self.discovery.settled(now)
        self.discovery.rebind()
        self._detect(now, out)
        self.decide.cooperate(now, out)
        self.decide.sync_route(now, out)
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
        if self.decide.active:
            times.append(self.decide.next_coop_s)
            b = self.know.beliefs
            settle = None if b is None else b.next_settle_s(self.t)
            if settle is not None:
                times.append(settle)
            dl = self.know.members.next_deadline_s()
            if dl is not None:
                times.append(dl)
        return max(self.t, min(times))

    @property
    def state(self) -> str:
        return self.own.state()

    @property
    def quiet(self) -> bool:
        """Home or aborted, and done announcing it (it may still keep watch)."""
        return not self.decide.active and self.radio.idle

    def note_lag(self, late_s: float) -> None:
        """The host ran a step ``late_s`` mission seconds after it was due (a busy machine):
        reported in the next status, for the operator's clock (not a decision input)."""
        self.lag_s = max(self.lag_s, late_s)

    def count(self, name: str, n: int = 1) -> None:
        self.counters[name] = self.counters.get(name, 0) + n

    def _outputs(self) -> Outputs:
        return Outputs(self.id, self.know.tids)

    # -- the vehicle -----------------------------------------------------------------------

    def _from_vehicle(self, reports: Sequence[VehicleReport], out: Outputs) -> None:
        """What the vehicle reported, in time order: fixes move the model, arrivals and ends
        of work change what it does, sightings and looks go to `discovery`."""
        own = self.own
        for r in reports:
            if isinstance(r, NavFix):
                own.fix(r)
            elif isinstance(r, Arrived):
                home = own.arrived(r.target, r.t_s)
                if home is not None:
                    self.decide.dirty = True
                    # An aborted vehicle already said goodbye; others announce their arrival.
                    self.radio.home_left = 0 if own.aborted else self.config.home_repeats
                    out.record(Home(home.t_s))
                    out.event(home.t_s, "replan", detail="home")
            elif isinstance(r, Injected):
                done = own.injected(r.task, r.t_s)
                if done is None:
                    self.count("injection_stale")
                    continue
                self.decide.dirty = True
                self.know.treated.append((done.task, done.t_s))
                self.know.cleared.add(done.task)
                self.radio.push_cleared = 2
                out.record(Clear(done.t_s, (done.task,), own=True))
                out.event(done.t_s, "cleared", [done.task],
                          detail=self.discovery.where(done.task))
            elif isinstance(r, Looked):
                self.discovery.on_looked(r, out)
            elif isinstance(r, Sighted):
                self.discovery.on_sighted(r, r.t_s, out)
            elif isinstance(r, Refused):
                self.count("helm_refused")
                out.event(r.t_s, "refused", detail=f"{r.command}: {r.reason}")

    def _helm(self, out: Outputs) -> None:
        """Tell the vehicle what to do when that changed (an arrival, the end of work, a new
        head of the route, an abort)."""
        key = self.own.command_key()
        if key == self._commanded:
            return
        self._commanded = key
        cmd = self.own.command()
        if cmd is not None:
            out.append(Helm(cmd))

    # -- radio in --------------------------------------------------------------------------

    def _on_frame(self, data: bytes, now: float, out: Outputs) -> None:
        self.count("rx_frames")
        try:
            msg = self.fleet.codec.decode(data)
        except WireError as exc:
            self.count(f"drop_{exc.reason}")
            return
        know = self.know
        if msg.sender == self.index:
            self.count("drop_self")  # our own frame played back: a replay
            return
        if msg.seq > now + MAX_LEAD_S:  # from the future: forged (see wire.MAX_LEAD_S)
            self.count("drop_future")
            return
        if not know.replay.accept(msg.sender, msg.seq):
            self.count("drop_replay")
            return
        self.count(f"rx_{type(msg).__name__.lower()}")
        v = msg.sender
        revived = [v] if know.members.heard(v, float(msg.seq), now) else []
        revived += know.members.take_heard(v, msg.heard, float(msg.seq), now)
        for u in revived:
            # Its claims live again: the overlap is settled now (spots taken from it leave
            # the route), and whatever of ours a takeover released is looked at again at once.
            self.decide.dirty = self.decide.coop_soon = True
            out.event(now, "revived", peer=know.vid(u))
            out.record(PeerState(u, mb.ALIVE, now))
        for u in know.members.confirm(v, msg.heard, float(msg.seq), now):
            self._declare_lost(u, now, out)
        if isinstance(msg, Pose):
            self._on_pose(msg, now, out)
        elif isinstance(msg, ClearedSegment):
            new = know.cleared.merge_segment(msg.segment, msg.bits)
            if new:
                self.decide.dirty = True
                out.record(Clear(now, tuple(new), own=False))
                self.discovery.fold_aliases(now, out)
            if know.cleared.missing_from(msg.segment, msg.bits):
                self.radio.mismatch.add(v)
        elif isinstance(msg, (Claim, Release)):
            self._on_holding(msg, now, out)
        elif isinstance(msg, Found):
            self.discovery.on_found(msg, now, out)
        elif isinstance(msg, Abort) and msg.who != self.index:
            if self._peer_gone(msg.who, mb.ABORTED, now, out, msg.t_s) and msg.who != v:
                self.count("abort_relayed_in")

    def _on_pose(self, msg: Pose, now: float, out: Outputs) -> None:
        v, know = msg.sender, self.know
        know.peer_pose[v] = PeerPose(msg.pos, float(msg.seq), msg.state)
        know.peer_digest[v] = msg.digest
        mine = know.cleared.digest()
        # Push only if the peer may lack something we have: equal sizes with different
        # hashes, or a smaller set (sizes are mod 128; a larger set will push to us instead).
        behind = (mine.count - msg.digest.count) % 128
        working = msg.state not in ("home", "aborted")  # a watcher needs no cleared set
        if working and msg.digest != mine and (behind == 0 or behind < 64):
            self.radio.mismatch.add(v)
        if msg.state == "home":
            self._peer_gone(v, mb.HOME, now, out)
        elif msg.state == "aborted":
            self._peer_gone(v, mb.ABORTED, now, out)

    def _on_holding(self, msg: Claim | Release, now: float, out: Outputs) -> None:
        is_claim, know = isinstance(msg, Claim), self.know
        mine_before = set(self.own.route)
        changed = know.holdings.apply(msg.sender, msg.t_s, msg.tasks, is_claim)
        if is_claim:
            self._contest(msg.tasks)
        if changed:
            self.decide.dirty = True
            out.record(Hold(msg.sender, msg.t_s, tuple(changed), is_claim))
            lost = [t for t in changed if t in mine_before and know.holder(t) != self.index
                    and t != self.own.injecting]
            if lost:
                out.event(now, "claim_lost", lost, peer=know.vid(msg.sender))
                self.decide.coop_soon = True

    def _contest(self, tasks: tuple[int, ...]) -> None:
        """A peer claims spots it cannot have: answer at once, not at the next refresh. A
        claim on a spot we hold by an earlier claim means the peer missed ours (we re-send
        it); on a spot we know is cleared, that it missed the clear (we push that segment).
        Unanswered, it would fly there and treat the spot again (a claim race under loss)."""
        know = self.know
        by_time: dict[int, list[int]] = {}
        for t in tasks:
            since = know.holdings.claim_time(t, self.index)
            if since and t not in know.cleared and know.holder(t) == self.index:
                by_time.setdefault(since, []).append(t)
        for c, group in sorted(by_time.items()):
            self.radio.answer_claim(c, group)
        done = [t for t in tasks if t in know.cleared]
        if done:
            self.radio.answer_cleared({know.cleared.segment_of(t) for t in done})

    def _on_command(self, name: str, now: float, out: Outputs) -> None:
        if name != "abort" or not self.decide.active:
            return
        self.own.abort()
        self.radio.own_abort_left = self.config.abort_repeats
        self.radio.push_cleared = 1
        out.record(Aborted(now))
        out.event(now, "abort")

    # -- membership ------------------------------------------------------------------------

    def _peer_gone(self, v: int, status: str, now: float, out: Outputs,
                   t_event: int | None = None) -> bool:
        """Record an announced abort or arrival home; True if it was news."""
        members = self.know.members
        before = members.status(v)
        if not members.mark(v, status, now):
            return False
        self.decide.dirty = True
        out.record(PeerState(v, status, now))
        if status == mb.ABORTED:
            out.event(now, "lost", peer=self.know.vid(v), detail="aborted")
            # Pass the news on once: a peer that missed every announcement learns it from us
            # instead of waiting for the silence to be noticed.
            if self.decide.active:
                self.radio.aborts.append(
                    PendingAbort(v, int(now) if t_event is None else t_event))
            if before in mb.WORKING:
                self.decide.takeover(v, now, out)
        return True

    def _detect(self, now: float, out: Outputs) -> None:
        """Silence past the deadline makes a suspect, nothing more (`membership`)."""
        for v in self.know.members.check(now):
            out.event(now, "suspect", peer=self.know.vid(v))

    def _declare_lost(self, v: int, now: float, out: Outputs) -> None:
        """Another vehicle confirmed ``v``'s silence: its work is taken over."""
        self.decide.dirty = True
        out.record(PeerState(v, mb.LOST, now))
        out.event(now, "lost", peer=self.know.vid(v), detail="silent")
        self.decide.takeover(v, now, out, doubt=self.know.members.doubt(now))

    # -- radio out -------------------------------------------------------------------------

    def _transmit(self, now: float, out: Outputs) -> None:
        if now < self.radio.next_slot_s():
            return
        sent_s, skipped = self.radio.take_slot(now)
        if skipped:
            self.count("slots_missed", skipped)
        if sent_s < now:
            self.count("slots_late")
        msg = self.radio.choose(now, self.own, self.know)
        if msg is None:
            return
        frame = self.fleet.codec.encode(msg)
        name = type(msg).__name__.lower()
        self.count(f"tx_{name}")
        self.count("tx_bytes", len(frame))
        self.largest_frame = max(self.largest_frame, len(frame))
        out.append(Send(frame, radio_kind(msg), name, sent_s))
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
            t_s=float(now), id=self.id, state=v.state(), pos=tuple(v.pos),
            battery_s=float(v.battery_left_s(now)),
            t_diff_s=float(v.battery_left_s(now) - finish),
            route=know.tids(v.route), treated=know.tids(treated),
            cleared_known=len(know.cleared), priority_collected=know.priority_of(treated),
            distance_m=float(v.distance_m),
            peers={know.vid(u): s for u, (s, _) in know.members.snapshot().items()},
            claims=know.tids(sorted(know.standing_claims())),
            counters={**self.counters, "largest_frame": self.largest_frame},
            lag_s=self._take_lag(),
        )

    def _take_lag(self) -> float:
        lag, self.lag_s = self.lag_s, 0.0
        return float(lag)

    def checkpoint(self, now: float) -> Checkpoint:
        v = self.own
        return Checkpoint(now, v.pos, v.distance_m, tuple(v.route), self.radio.last_seq,
                          self.know.replay.high_water(), v.home_at_s)
