"""The agent's decision logic: a pure state machine ``(state, input) -> (state, outbox)``.

Inputs are `Tick`, `Frame` (bytes off the radio) and `Command` (fault injection), each with
the simulation time ``now``; outputs are `Send` (a frame for the radio), `Publish`
(telemetry: status, event, truth) and `Record` (a journal record). No I/O, no clock, no
randomness at all (the TDMA schedule needs no jitter): the same inputs give the same outputs,
under the Zenoh shell (`fleet_agent.node`) and in the simulation (`fleet_agent.sim`).

What it does (paper section II and IV-A):
- executes its route of the shared initial plan (`Planner.initial_routes`) on the vehicle
  model (eq. 3-7) and reaches the rendezvous within its battery;
- gossips pose and cleared spots in its TDMA slot (`fleet_agent.wire`, `fleet_agent.cleared`);
- drops any spot someone else cleared, and never keeps one another vehicle holds
  (`fleet_agent.negotiation`);
- cooperation operator, online: with spare battery it claims free spots (single-vehicle
  replan, inserting free spots into its own route);
- takeover: when a peer aborts or goes silent (`fleet_agent.membership`) it replans the
  survivors (dead-reckoned from their last poses) over the freed spots and claims its share;
- journals what it cleared and knows, and resumes from that journal after a restart.
"""

from __future__ import annotations

from collections import deque
from typing import Any, Iterable, Sequence

from comms_sim.bus import Truth
from fleet_agent import membership as mb
from fleet_agent.cleared import ClearedSet
from fleet_agent.config import AgentConfig
from fleet_agent.cooperation import (cheapest_insertion, cooperation_route, detour_fits,
                                     live_peer, live_self, takeover_share)
from fleet_agent.fleet import Fleet
from fleet_agent.io_types import (Command, Frame, Input, Output, Publish, Record, Send,
                                  Tick)
from fleet_agent.membership import Membership
from fleet_agent.negotiation import Holdings
from fleet_agent.radio import Slots
from fleet_agent.replay import ReplayWindow
from fleet_agent.telemetry import Event, Status
from fleet_agent.vehicle import Arrived, Cleared, Vehicle, fit_route
from fleet_agent.wire import (Abort, Claim, ClearedSegment, Message, Pose, Release, WireError,
                              radio_kind)

__all__ = ["Agent", "Fleet", "step", "Tick", "Frame", "Command", "Input", "Send", "Publish",
           "Record", "Output"]

JOURNAL_VERSION = 1


# -- the agent -------------------------------------------------------------------------------

class Agent:
    """One vehicle's brain. Use `step` (or the module function `step`)."""

    def __init__(self, fleet: Fleet, index: int, config: AgentConfig, now: float = 0.0,
                 journal: Sequence[dict[str, Any]] = ()) -> None:
        p = fleet.problem
        self.fleet, self.problem, self.index, self.config = fleet, p, index, config
        self.id = p.vehicles[index].id
        self.k = p.n_vehicles
        self.slots = Slots(index, self.k, config.slot_s)
        self.cycle_s = self.slots.cycle_s
        self.vehicle = Vehicle(p, index, fleet.paths)
        self.cleared = ClearedSet(p.n_tasks)
        self.holdings = Holdings(p.n_tasks, fleet.base_routes)
        self.members = Membership(self.k, index, config.lost_after_cycles * self.cycle_s,
                                  self.cycle_s)
        self.replay = ReplayWindow()
        self.treated: list[tuple[int, float]] = []
        self.counters: dict[str, int] = {}
        self.largest_frame = 0
        self.peer_pose: dict[int, tuple[tuple[float, float, float], float, str]] = {}
        self.peer_digest: dict[int, Any] = {}
        self.last_seq = -1
        self.t = float(now)
        self.restarted = bool(journal)
        # radio
        self._slot_no = self.slots.first_from(now)
        self._since_pose = 10**6
        self._outgoing: deque[list] = deque()  # [message factory args..., repeats left]
        self._push_cleared = 0  # full-state pushes still owed
        self._mismatch: set[int] = set()
        self._last_refresh_slot = 0
        self._last_claim_refresh_slot = 0
        self._abort_left = 0
        self._home_left = 0
        self._relay_aborts: list[tuple[int, int]] = []  # (vehicle, abort time) to pass on
        # schedules
        self._next_status = now
        self._next_truth = now
        self._next_ckpt = now + config.checkpoint_period_s
        self._next_coop = now + config.coop_period_s * (1.0 + index / self.k)
        self._coop_soon = False
        self._dirty = True  # knowledge changed since the route was last checked against it
        self._boot: list[Output] = []
        if journal:
            self._restore(journal, now)
        else:
            self.vehicle.set_route(fleet.base_routes[index])
            self._boot.append(self._record({"k": "start", "t": now, "v": JOURNAL_VERSION,
                                            "i": index}, durable=True))

    # -- the state machine -----------------------------------------------------------------

    def step(self, inp: Input) -> list[Output]:
        now = max(float(inp.now), self.t)
        out: list[Output] = self._boot
        self._boot = []
        self._advance(now, out)
        if isinstance(inp, Frame):
            self._on_frame(inp.data, now, out)
        elif isinstance(inp, Command):
            self._on_command(inp.name, now, out)
        self._detect(now, out)
        self._cooperate(now, out)
        self._sync_route(now, out)
        self._telemetry(now, out)  # truth first: the relay places a sender before its frames
        self._radio(now, out)
        self.t = now
        return out

    def next_wakeup(self) -> float:
        """The next time `step(Tick(...))` has something to do."""
        times = [self.slots.time(self._slot_no), self._next_status, self._next_truth,
                 self._next_ckpt]
        ev = self.vehicle.next_event_s()
        if ev is not None:
            times.append(ev)
        if not self.vehicle.done and not self.vehicle.aborted:
            times.append(self._next_coop)
            dl = self.members.next_deadline_s()
            if dl is not None:
                times.append(dl)
        return max(self.t, min(times))

    @property
    def state(self) -> str:
        return self.vehicle.state()

    @property
    def quiet(self) -> bool:
        """Home or aborted, and done announcing it."""
        return (self.vehicle.done or self.vehicle.aborted) and self._abort_left == 0 \
            and self._home_left == 0 and self._push_cleared == 0

    # -- vehicle ---------------------------------------------------------------------------

    def _advance(self, now: float, out: list[Output]) -> None:
        for ev in self.vehicle.advance(now):
            self._dirty = True
            if isinstance(ev, Cleared):
                self.treated.append((ev.task, ev.t_s))
                self.cleared.add(ev.task)
                self._push_cleared = 2
                out.append(self._record({"k": "clr", "t": ev.t_s, "ids": [ev.task], "own": True},
                                        durable=True))
                out.append(self._event(ev.t_s, "cleared", [ev.task]))
            elif isinstance(ev, Arrived):
                # An aborted vehicle already said goodbye; others announce their arrival.
                self._home_left = 0 if self.vehicle.aborted else self.config.home_repeats
                out.append(self._record({"k": "home", "t": ev.t_s}, durable=True))
                out.append(self._event(ev.t_s, "replan", [], detail="home"))

    # -- radio in --------------------------------------------------------------------------

    def _count(self, name: str, n: int = 1) -> None:
        self.counters[name] = self.counters.get(name, 0) + n

    def _on_frame(self, data: bytes, now: float, out: list[Output]) -> None:
        self._count("rx_frames")
        try:
            msg = self.fleet.codec.decode(data)
        except WireError as exc:
            self._count(f"drop_{exc.reason}")
            return
        if msg.sender == self.index:
            self._count("drop_self")  # our own frame played back: a replay
            return
        if not self.replay.accept(msg.sender, msg.seq):
            self._count("drop_replay")
            return
        self._count(f"rx_{type(msg).__name__.lower()}")
        v = msg.sender
        revived = [v] if self.members.heard(v, float(msg.seq), now) else []
        revived += self.members.take_heard(v, msg.heard, float(msg.seq), now)
        for u in revived:
            self._dirty = True
            out.append(self._event(now, "revived", [], peer=self._vid(u)))
            out.append(self._record({"k": "peer", "v": u, "s": mb.ALIVE, "t": now}))
        if isinstance(msg, Pose):
            self._on_pose(msg, now, out)
        elif isinstance(msg, ClearedSegment):
            self._on_cleared(msg, now, out)
        elif isinstance(msg, (Claim, Release)):
            self._on_claim(msg, now, out)
        elif isinstance(msg, Abort) and msg.who != self.index:
            if self._peer_gone(msg.who, mb.ABORTED, now, out, msg.t_s) and msg.who != v:
                self._count("abort_relayed_in")

    def _on_pose(self, msg: Pose, now: float, out: list[Output]) -> None:
        v = msg.sender
        self.peer_pose[v] = (msg.pos, float(msg.seq), msg.state)
        self.peer_digest[v] = msg.digest
        mine = self.cleared.digest()
        # Push only if the peer may lack something we have: equal sizes with different
        # hashes, or a smaller set (sizes are mod 128; a larger set will push to us instead).
        behind = (mine.count - msg.digest.count) % 128
        if msg.digest != mine and (behind == 0 or behind < 64):
            self._mismatch.add(v)
        if msg.state == "home":
            self._peer_gone(v, mb.HOME, now, out)
        elif msg.state == "aborted":
            self._peer_gone(v, mb.ABORTED, now, out)

    def _on_cleared(self, msg: ClearedSegment, now: float, out: list[Output]) -> None:
        new = self.cleared.merge_segment(msg.segment, msg.bits)
        if new:
            self._dirty = True
            out.append(self._record({"k": "clr", "t": now, "ids": new, "own": False}))
        if self.cleared.missing_from(msg.segment, msg.bits):
            self._mismatch.add(msg.sender)

    def _on_claim(self, msg: Claim | Release, now: float, out: list[Output]) -> None:
        is_claim = isinstance(msg, Claim)
        mine_before = set(self.vehicle.route)
        changed = self.holdings.apply(msg.sender, msg.t_s, msg.tasks, is_claim)
        if changed:
            self._dirty = True
            out.append(self._record({"k": "hold", "v": msg.sender, "t": msg.t_s, "ids": changed,
                                     "c": is_claim}))
            lost = [t for t in changed if t in mine_before and self._holder(t) != self.index
                    and t != self.vehicle.injecting]
            if lost:
                out.append(self._event(now, "claim_lost", lost, peer=self._vid(msg.sender)))
                self._coop_soon = True

    def _on_command(self, name: str, now: float, out: list[Output]) -> None:
        if name != "abort" or self.vehicle.aborted or self.vehicle.done:
            return
        self.vehicle.abort()
        self._abort_left = self.config.abort_repeats
        self._push_cleared = 1
        out.append(self._record({"k": "abort", "t": now}, durable=True))
        out.append(self._event(now, "abort", []))

    # -- membership, takeover, cooperation -------------------------------------------------

    def _peer_gone(self, v: int, status: str, now: float, out: list[Output],
                   t_event: int | None = None) -> bool:
        """Record an announced abort or arrival home; True if it was news."""
        before = self.members.status(v)
        if not self.members.mark(v, status, now):
            return False
        self._dirty = True
        out.append(self._record({"k": "peer", "v": v, "s": status, "t": now}))
        if status == mb.ABORTED:
            out.append(self._event(now, "lost", [], peer=self._vid(v), detail="aborted"))
            # Pass the news on once: a peer that missed every announcement learns it from us
            # instead of waiting for the silence to be noticed.
            if not (self.vehicle.done or self.vehicle.aborted):
                self._relay_aborts.append((v, int(now) if t_event is None else t_event))
            if before == mb.ALIVE:
                self._takeover(v, now, out)
        return True

    def _detect(self, now: float, out: list[Output]) -> None:
        if self.vehicle.done or self.vehicle.aborted:
            return
        for v in self.members.check(now):
            self._dirty = True
            out.append(self._record({"k": "peer", "v": v, "s": mb.LOST, "t": now}))
            out.append(self._event(now, "lost", [], peer=self._vid(v), detail="silent"))
            self._takeover(v, now, out)

    def _takeover(self, gone: int, now: float, out: list[Output]) -> None:
        """Replan the survivors over the spots freed by ``gone``; claim this vehicle's share."""
        if self.vehicle.done or self.vehicle.aborted:
            return
        free = self._free_spots()
        if not free:
            return
        peers = [live_peer(self.problem, v, self.peer_pose.get(v), self._peer_route(v), now)
                 for v in self._active_peers()]
        # The same seed on every survivor: equal views give equal answers.
        mine = takeover_share(self.fleet.planner, live_self(self.vehicle), peers,
                              frozenset(self.cleared), self._held_map(),
                              seed=self.fleet.seed * 1000 + gone)
        gained = [t for t in mine if t in free]
        if gained:
            self._hold(gained, True, now, out)
            out.append(self._event(now, "takeover", gained, peer=self._vid(gone)))
        self._set_route(mine, now, out, why=f"takeover of {self._vid(gone)}")

    def _cooperate(self, now: float, out: list[Output]) -> None:
        """The paper's cooperation operator, online: spend spare battery on free spots."""
        if self.vehicle.done or self.vehicle.aborted:
            return
        if now < self._next_coop and not self._coop_soon:
            return
        self._coop_soon = False
        self._next_coop = now + self.config.coop_period_s
        slack = self.vehicle.slack_s(self.config.battery_reserve_s)
        if slack < self.config.coop_min_slack_s:
            return
        free = self._free_spots()
        if not free or not detour_fits(self.vehicle, free, slack):
            return
        mine = cooperation_route(self.fleet.planner, live_self(self.vehicle),
                                 frozenset(self.cleared), self._held_map(),
                                 seed=self.fleet.seed * 1000 + 100 + self.index)
        gained = [t for t in mine if t in free]
        if gained:
            self._hold(gained, True, now, out)
            self._set_route(mine, now, out, why="cooperation")

    def _hold(self, tasks: list[int], claim: bool, now: float, out: list[Output]) -> None:
        """Claim (or release) ``tasks``: journal it first, then tell the fleet."""
        t = int(now)
        changed = self.holdings.apply(self.index, t, tasks, claim)
        if changed:
            self._dirty = True
            out.append(self._record({"k": "hold", "v": self.index, "t": t, "ids": changed,
                                     "c": claim}, durable=True))
            self._queue(Claim if claim else Release, t, changed)
            if claim:
                out.append(self._event(now, "claim", changed))

    def _queue(self, cls: type, t: int, tasks: list[int]) -> None:
        step = self.fleet.codec.max_ids
        for i in range(0, len(tasks), step):
            self._outgoing.append([cls, t, tuple(tasks[i:i + step]), self.config.claim_repeats])

    # -- route -----------------------------------------------------------------------------

    def _sync_route(self, now: float, out: list[Output]) -> None:
        """Keep the route to spots this vehicle holds and nobody cleared, within battery;
        fold in held spots missing from it, release what cannot fit."""
        if self.vehicle.done or self.vehicle.aborted or not self._dirty:
            return
        self._dirty = False
        injecting = self.vehicle.injecting
        route = [t for t in self.vehicle.route
                 if t not in self.cleared and (t == injecting or self._holder(t) == self.index)]
        orphans = [t for t in self._held_by_me() if t not in route and t not in self.cleared]
        for t in orphans:
            route = cheapest_insertion(self.vehicle, route, t)
        self._set_route(route, now, out, why="sync")

    def _set_route(self, route: list[int], now: float, out: list[Output], why: str) -> None:
        fitted = fit_route(self.vehicle, route, self.config.battery_reserve_s)
        # Whatever this vehicle holds but will not treat is released for the others.
        dropped = [t for t in self._held_by_me() if t not in fitted]
        if dropped:
            self._hold(dropped, False, now, out)
        if fitted != self.vehicle.route:
            self.vehicle.set_route(fitted)
            if why != "sync":
                out.append(self._event(now, "replan", [], detail=why))

    # -- knowledge helpers -----------------------------------------------------------------

    def _holder(self, task: int) -> int | None:
        return self.holdings.holder(task, self.members.alive)

    def _held_map(self) -> dict[int, int]:
        return {t: h for t, h in self.holdings.holders(self.members.alive).items()
                if t not in self.cleared}

    def _held_by_me(self) -> list[int]:
        return [t for t, h in self._held_map().items() if h == self.index]

    def _free_spots(self) -> set[int]:
        held = self._held_map()
        return {t for t in range(self.problem.n_tasks) if t not in self.cleared and t not in held}

    def _active_peers(self) -> list[int]:
        return [v for v in range(self.k) if v != self.index and self.members.status(v) == mb.ALIVE]

    def _peer_route(self, v: int) -> list[int]:
        held = self._held_map()
        base = [t for t in self.fleet.base_routes[v] if held.get(t) == v]
        extra = sorted((t for t, h in held.items() if h == v and t not in base),
                       key=lambda t: (self.holdings.claim_time(t, v) or 0, t))
        return base + extra

    def _vid(self, v: int) -> str:
        return self.problem.vehicles[v].id

    def _tids(self, tasks: Iterable[int]) -> list[int]:
        return [self.problem.tasks[t].id for t in tasks]

    # -- radio out -------------------------------------------------------------------------

    def _radio(self, now: float, out: list[Output]) -> None:
        if now < self.slots.time(self._slot_no):
            return
        late = self.slots.missed(self._slot_no, now)
        self._slot_no = self.slots.first_from(now + 1e-9)
        if late:
            self._count("slots_missed")
            return
        msg = self._choose(now)
        if msg is None:
            return
        frame = self.fleet.codec.encode(msg)
        name = type(msg).__name__.lower()
        self._count(f"tx_{name}")
        self._count("tx_bytes", len(frame))
        self.largest_frame = max(self.largest_frame, len(frame))
        out.append(Send(frame, radio_kind(msg), name))
        out.append(self._checkpoint(now))

    def _next_seq(self, now: float) -> int:
        self.last_seq = max(self.last_seq + 1, int(now))
        return self.last_seq

    def _choose(self, now: float) -> Message | None:
        """One frame per own slot, most urgent first."""
        cfg = self.config
        slot = self._slot_no
        if self.vehicle.aborted:
            if self._abort_left > 0:
                self._abort_left -= 1
                return Abort(self.index, self._next_seq(now), int(now), self._heard(now))
            if self._push_cleared > 0:
                self._push_cleared -= 1
                return self._cleared_msg(now)
            return None
        if self.vehicle.done:
            if self._home_left > 0:
                self._home_left -= 1
                return self._pose(now)
            return None
        self._since_pose += 1
        if self._relay_aborts:
            who, t = self._relay_aborts.pop(0)
            return Abort(self.index, self._next_seq(now), t, self._heard(now), who)
        if self._since_pose >= cfg.pose_every_cycles:
            return self._pose(now)
        if self._outgoing:
            entry = self._outgoing[0]
            cls, t, tasks, left = entry
            tasks = tuple(x for x in tasks if x not in self.cleared)
            entry[3] = left - 1
            if entry[3] <= 0 or not tasks:
                self._outgoing.popleft()
            if tasks:
                return cls(self.index, self._next_seq(now), t, tasks, self._heard(now))
        if self._push_cleared > 0 or self._mismatch or \
                slot - self._last_refresh_slot >= cfg.cleared_refresh_cycles:
            self._push_cleared = max(0, self._push_cleared - 1)
            self._mismatch.clear()
            self._last_refresh_slot = slot
            if len(self.cleared):
                return self._cleared_msg(now)
        if slot - self._last_claim_refresh_slot >= cfg.claim_refresh_cycles:
            self._last_claim_refresh_slot = slot
            standing = {t: c for t, c in self.holdings.explicit_claims(self.index).items()
                        if t not in self.cleared and self._holder(t) == self.index}
            if standing:
                by_time: dict[int, list[int]] = {}
                for t, c in sorted(standing.items()):
                    by_time.setdefault(c, []).append(t)
                for c, tasks in by_time.items():
                    self._queue(Claim, c, tasks)
                entry = self._outgoing.popleft()
                return entry[0](self.index, self._next_seq(now), entry[1], entry[2],
                                self._heard(now))
        return self._pose(now)

    def _pose(self, now: float) -> Pose:
        self._since_pose = 0
        v = self.vehicle
        return Pose(self.index, self._next_seq(now), v.pos, int(round(v.yaw_deg)), v.state(),
                    self.cleared.digest(), self._heard(now))

    def _heard(self, now: float) -> int:
        return self.members.heard_field(now)

    def _cleared_msg(self, now: float) -> ClearedSegment:
        # Rotate over segments; the one holding our latest clear goes first.
        n = self.cleared.n_segments
        seg = self.cleared.segment_of(self.treated[-1][0]) if self.treated and \
            self._push_cleared else int(self._slot_no % n)
        return ClearedSegment(self.index, self._next_seq(now), self.cleared.digest(), seg,
                              self.cleared.segment(seg), self._heard(now))

    # -- telemetry and journal -------------------------------------------------------------

    def _event(self, t: float, kind: str, tasks: list[int], peer: str = "",
               detail: str = "") -> Publish:
        return Publish("event", Event(float(t), self.id, kind, self._tids(tasks), peer, detail))

    def _record(self, doc: dict[str, Any], durable: bool = False) -> Record:
        return Record(doc, durable)

    def status(self, now: float | None = None) -> Status:
        now = self.t if now is None else now
        v = self.vehicle
        finish = v.time_to_finish_s()
        return Status(
            t_s=float(now), id=self.id, state=v.state(), pos=tuple(v.pos),
            battery_s=float(v.battery_left_s(now)),
            t_diff_s=float(v.battery_left_s(now) - finish),
            route=self._tids(v.route), treated=self._tids(t for t, _ in self.treated),
            cleared_known=len(self.cleared),
            priority_collected=float(sum(self.problem.priority[t] for t, _ in self.treated)),
            distance_m=float(v.distance_m),
            peers={self._vid(u): s for u, (s, _) in self.members.snapshot().items()},
            claims=self._tids(sorted(t for t in self.holdings.explicit_claims(self.index)
                                     if t not in self.cleared and self._holder(t) == self.index)),
            counters={**self.counters, "largest_frame": self.largest_frame,
                      "replans": self.fleet.planner.calls},
        )

    def truth(self, now: float) -> Truth:
        v = self.vehicle
        return Truth(float(now), tuple(v.pos), float(v.yaw_deg), float(v.pitch_deg), v.state())

    def _telemetry(self, now: float, out: list[Output]) -> None:
        if now >= self._next_truth:
            self._next_truth = now + self.config.truth_period_s
            out.append(Publish("truth", self.truth(now)))
        if now >= self._next_status:
            self._next_status = now + self.config.status_period_s
            out.append(Publish("status", self.status(now)))
        if now >= self._next_ckpt:
            self._next_ckpt = now + self.config.checkpoint_period_s
            out.append(self._checkpoint(now))

    def _checkpoint(self, now: float) -> Record:
        v = self.vehicle
        return self._record({
            "k": "ckpt", "t": now, "pos": list(v.pos), "dist": v.distance_m,
            "route": list(v.route), "seq": self.last_seq,
            "hw": {str(s): q for s, q in self.replay.high_water().items()},
            "home": v.home_at_s})

    # -- restart ---------------------------------------------------------------------------

    def _restore(self, journal: Sequence[dict[str, Any]], now: float) -> None:
        """Rebuild from the journal: cleared spots, treatments, claims, peers' fates, the
        last checkpoint of the vehicle; time lost while down is lost battery too."""
        ckpt: dict[str, Any] | None = None
        aborted = False
        home_at: float | None = None
        for rec in journal:
            try:
                k = rec.get("k")
                if k == "clr":
                    for t in rec["ids"]:
                        if 0 <= int(t) < self.problem.n_tasks:
                            self.cleared.add(int(t))
                            if rec.get("own") and all(int(t) != x for x, _ in self.treated):
                                self.treated.append((int(t), float(rec["t"])))
                elif k == "hold":
                    self.holdings.apply(int(rec["v"]), int(rec["t"]),
                                        [int(t) for t in rec["ids"]], bool(rec["c"]))
                elif k == "peer" and rec["s"] in (mb.ABORTED, mb.HOME):
                    self.members.mark(int(rec["v"]), rec["s"], float(rec["t"]))
                elif k == "abort":
                    aborted = True
                elif k == "home":
                    home_at = float(rec["t"])
                elif k == "ckpt":
                    ckpt = rec
            except (KeyError, TypeError, ValueError, AttributeError):
                self._count("journal_bad_records")
        # Silence is counted from the restart: we could not listen while down.
        for peer in self.members.peers.values():
            peer.evidence_s = max(peer.evidence_s, now)
            peer.since_s = max(peer.since_s, now)
        if ckpt is not None:
            self.last_seq = int(ckpt.get("seq", -1))
            self.replay.restore({int(s): int(q) for s, q in ckpt.get("hw", {}).items()})
            route = [int(t) for t in ckpt.get("route", [])]
            self.vehicle.restore(now, tuple(ckpt["pos"]), float(ckpt.get("dist", 0.0)), route,
                                 aborted, home_at)
        else:
            self.vehicle.restore(now, self.vehicle.pos, 0.0, self.fleet.base_routes[self.index],
                                 aborted, home_at)
        if aborted:
            self._abort_left = self.config.abort_repeats
        self._push_cleared = 1  # tell the fleet what we know as soon as we can
        self._boot.append(self._record({"k": "restart", "t": now}, durable=True))
        self._boot.append(self._event(now, "restart", [], detail=f"{len(self.cleared)} cleared"))


def step(agent: Agent, inp: Input) -> tuple[Agent, list[Output]]:
    """The state machine as a function: the agent (mutated in place) and its outbox."""
    return agent, agent.step(inp)
