"""The acoustic channel model: pure, seeded, no I/O and no clock (time is passed in).

One broadcast medium: a frame a node transmits reaches every other known node after
``range / sound_speed`` seconds and occupies it for the frame's airtime. Its fate at each
receiver settles when that reception ends, because it depends on later transmissions:

- partition: a scheduled link-down window overlaps the reception;
- range: beyond the hearing range (`ChannelConfig.horizon_m`) or a position is unknown; with
  the empirical model also a failed range-curve draw;
- sinr (physical model): the frame would not have decoded even alone: too weak over the noise
  at its range, in its fade;
- half_duplex: the receiver transmitted during the reception;
- collision: lost to interference. Physical model: the frame would have decoded alone but not
  at its SINR, the signal over noise plus the strongest sum of overlapping receptions' powers
  at any instant of it (a near frame survives a far interferer: capture). Empirical model:
  any audible overlap, both lost;
- random: the extra uniform loss of fault injection.

When several apply the first listed is reported. Everything within the hearing range and not
partitioned is audible: it interferes and deafens even when it cannot be decoded.

A reception whose fate is partition, range or sinr is lost whatever happens next (those reasons
come first), so it asks for no wake-up of its own (`next_due_s`): it is settled, in its place
in time order, when `advance` next runs past its end (at the latest when nothing else is due).
In a large fleet most pairs are far apart: at 100 vehicles 56 % of all receptions are such, and
their wake-ups cost the simulator more than the frames delivered.

Physical decisions (see `comms_sim.acoustics`): a reception's mean level is SL - TL(d) and its
SNR that over the band noise; the frame fades by a power gain x drawn for it (Rician, one per
frame and link); the decoder works at x S / (L N + I) with L the modem's implementation loss
and I the peak interference; one uniform u decides: delivered if u < P(success at that SINR),
a collision if only the interference made it fail, sinr if it would have failed alone.
Events report the mean SNR (``snr_db``: S/N, no fading) and mean SINR (``sinr_db``: S/(N+I)).

Randomness: each link (src, dst) draws from its own stream, derived from one root seed and the
two node names (`numpy.random.SeedSequence` spawn keys): a fixed number of uniforms per frame
(two for the empirical model, four for the physical: decode, extra loss, fade). So a link's
draws do not depend on which other nodes exist or in which order they appeared.
"""

from __future__ import annotations

import hashlib
import heapq
import itertools
import math
from dataclasses import dataclass, field
from typing import Callable, Sequence

import numpy as np

from comms_sim.acoustics.fading import power_gain
from comms_sim.config import PRESETS, ChannelConfig, Partition, TdmaConfig
from comms_sim.link_event import BROADCAST, DROP_REASONS, LinkEvent
from comms_sim.stats import LinkCounts, LinkStats
from comms_sim.tdma import SUPERSEDABLE, QueuedFrame, SenderQueue, slot_start
from fleet_bus.tdma import SpatialSchedule

__all__ = ["Channel", "ChannelConfig", "LinkEvent", "Partition", "TdmaConfig", "PRESETS",
           "DROP_REASONS", "BROADCAST"]

_WAKE, _RX = 0, 1  # heap entry kinds: a sender may start its next frame; a reception ends
_LOST_ANYWAY = ("partition", "range", "sinr")  # fates decided at transmission, never changed


@dataclass(eq=False, slots=True)
class _Reception:
    src: str
    dst: str
    t_sent_s: float
    start_s: float
    end_s: float
    frame: bytes
    fate: str | None  # decided at transmission: "partition", "range", "sinr", "random", None
    audible: bool
    collided: bool = False
    deaf: bool = False  # the receiver transmitted meanwhile
    tag: object = None  # the submitter's annotation, handed back in the LinkEvent
    # physical model
    power: float = 0.0  # mean received power, uPa^2: what it adds to others' interference
    gain: float = 1.0  # this frame's fading power gain on this link
    u_decode: float = 0.0
    interferers: list["_Reception"] | None = None  # audible overlaps at the same receiver


MAX_QUEUED_FRAMES = 64  # one sender's frames waiting for its modem (about 3 minutes of slots)


@dataclass(eq=False, slots=True)
class _Node:
    pos: tuple[float, float, float] | None = None
    queue: SenderQueue = field(default_factory=SenderQueue)
    tx_start_s: float = -math.inf  # the last transmission started
    tx_end_s: float = -math.inf
    pending: list[_Reception] = field(default_factory=list)  # audible, not yet settled
    wake_seq: int | None = None  # the valid heap entry for this sender's next start


def _name_key(name: str) -> int:
    """A stable 64-bit key of a node name (Python's hash() is salted per process)."""
    return int.from_bytes(hashlib.blake2b(name.encode(), digest_size=8).digest(), "little")


class Channel:
    """See the module docstring. Calls must come in non-decreasing time; an earlier time is
    taken as the latest time already seen (a late packet on a real bus, not an error)."""

    def __init__(self, config: ChannelConfig, rng: np.random.Generator,
                 schedule: SpatialSchedule | None = None) -> None:
        """``schedule``: with a TDMA MAC, the fleet's spatial schedule (the one its agents
        compute from the fleet plan: `fleet_bus.tdma.SpatialSchedule`), vehicle
        ``config.tdma.order[i]`` being its vehicle ``i``; a node not listed is not held to it."""
        if schedule is not None and (config.tdma is None or schedule.n != len(config.tdma.order)
                                     or schedule.slot_s != config.tdma.slot_s):
            raise ValueError("a spatial TDMA schedule needs the TDMA MAC with the whole roster "
                             "in order and the schedule's slot length")
        self._schedule = schedule
        self.config = config
        self._root_seed = int(rng.integers(0, 2**63))
        self._link_rngs: dict[tuple[str, str], np.random.Generator] = {}
        self._nodes: dict[str, _Node] = {}
        # (time, sequence, kind, what): a node's name to wake, or a reception to settle
        self._heap: list[tuple[float, int, int, str | _Reception]] = []
        self._seq = itertools.count()
        self._now_s = -math.inf
        self._extra_loss = config.extra_loss
        self._partitions = list(config.partitions)
        self._slots: dict[str, int] = {}
        if config.tdma is not None:
            self._slots = {n: i for i, n in enumerate(config.tdma.order)}
        self._stats = LinkStats()
        self._settled: list[LinkEvent] = []  # settled by a catch-up, returned by `advance`
        # Receptions lost from the start, by (end, seq): merged with the heap in (time, seq)
        # order when settled, but never a reason to wake up (see the module's docstring).
        self._lost: list[tuple[float, int, _Reception]] = []
        self._physical = config.model == "physical"
        self._horizon_m = config.horizon_m
        if self._physical:  # per-frame work below is a logarithm and an error function
            budget = config.budget
            self._budget = budget
            # received power = SL r^-k 10^(-alpha r / 10), in linear units
            self._source = 10.0 ** (config.modem.source_level_db / 10.0)
            self._neg_k = -config.spreading_k
            self._absorb = -budget.alpha_db_per_km / 1000.0 * math.log(10.0) / 10.0  # per m
            self._noise = 10.0 ** (budget.noise_db / 10.0)
            self._decoder_noise = 10.0 ** (budget.decoder_noise_db / 10.0)

    # -- nodes and faults ------------------------------------------------------------------

    def add_node(self, node: str) -> None:
        """Make ``node`` a potential receiver (position unknown until `set_position`)."""
        self._node(node)

    def nodes(self) -> list[str]:
        return list(self._nodes)

    def set_position(self, node: str, pos_xyz: Sequence[float], t_s: float) -> None:
        """Where ``node`` is from ``t_s`` on. Raises ValueError on a non-finite 3-vector."""
        pos = tuple(float(c) for c in pos_xyz)
        if len(pos) != 3 or not all(math.isfinite(c) for c in pos):
            raise ValueError(f"position must be 3 finite numbers, got {pos_xyz!r}")
        self._catch_up(t_s)
        self._now_s = max(self._now_s, t_s)
        self._node(node).pos = pos

    def position(self, node: str) -> tuple[float, float, float] | None:
        n = self._nodes.get(node)
        return None if n is None else n.pos

    @property
    def now_s(self) -> float:
        """The latest time any call has told the channel about."""
        return self._now_s

    def set_extra_loss(self, p: float, t_s: float | None = None) -> None:
        """Uniform loss for frames transmitted from now (or from ``t_s``) on."""
        if not 0.0 <= p <= 1.0:
            raise ValueError(f"extra loss must be in [0, 1], got {p}")
        if t_s is not None:
            self._catch_up(t_s)
        self._extra_loss = float(p)

    @property
    def extra_loss(self) -> float:
        return self._extra_loss

    def add_partition(self, partition: Partition, t_s: float | None = None) -> None:
        """Applies to frames transmitted from now (or from ``t_s``) on."""
        if t_s is not None:
            self._catch_up(t_s)
        self._partitions.append(partition)

    def clear_partitions(self, t_s: float | None = None) -> None:
        if t_s is not None:
            self._catch_up(t_s)
        self._partitions.clear()

    @property
    def partitions(self) -> tuple[Partition, ...]:
        return tuple(self._partitions)

    # -- traffic ---------------------------------------------------------------------------

    def submit(self, src: str, frame: bytes, t_s: float, kind: str = "data", *,
               keep_time: bool = False, tag: object = None) -> list[LinkEvent]:
        """Queue ``frame`` for transmission by ``src`` from ``t_s`` on. Returns the immediate
        refusal (oversize) if any; everything else settles in later `advance` calls. ``tag``
        comes back untouched in every `LinkEvent` of the frame (a face's own header: the
        frame's bytes are what occupies the water, the tag what the face must know of them).

        A ``t_s`` the channel has already moved past is clamped to its time, unless
        ``keep_time``: a frame an emulated sender handed over late (its host lagged behind the
        mission clock) keeps its place. Receptions still pending interfere with it as ever;
        those already settled are history: they neither hurt it nor are hurt by it."""
        if keep_time and t_s < self._now_s:
            return self._queue(src, frame, t_s, kind, tag)
        self._catch_up(t_s)
        t_s = max(t_s, self._now_s)
        self._now_s = t_s
        return self._queue(src, frame, t_s, kind, tag)

    def _queue(self, src: str, frame: bytes, t_s: float, kind: str,
               tag: object = None) -> list[LinkEvent]:
        node = self._node(src)
        frame = bytes(frame)
        if len(frame) > self.config.max_frame_bytes:
            event = LinkEvent(src, BROADCAST, t_s, t_s, len(frame), False, "oversize", frame,
                              tag=tag)
            self._stats.record(event)
            return [event]
        if self.config.tdma is not None and src not in self._slots:
            self._slots[src] = len(self._slots)
        if len(node.queue) >= MAX_QUEUED_FRAMES and kind != SUPERSEDABLE:
            # A sender that submits faster than its modem can send loses its own newest
            # frames; memory stays bounded and no other sender waits longer for it.
            self._stats.add(src, BROADCAST, "queue_full")
            return []
        superseded = node.queue.push(QueuedFrame(frame, kind, t_s, tag))
        if superseded:
            self._stats.add(src, BROADCAST, "superseded", superseded)
        self._schedule_next(src, node, t_s)
        return []

    def next_due_s(self) -> float | None:
        """Earliest time at which `advance` has a reception to settle or a frame to start."""
        if self._settled:
            return self._settled[0].t_s
        while self._heap:
            t, seq, kind, obj = self._heap[0]
            if isinstance(obj, str) and self._nodes[obj].wake_seq != seq:
                heapq.heappop(self._heap)  # superseded wake-up
                continue
            return t
        return self._lost[0][0] if self._lost else None

    def advance(self, t_s: float) -> list[LinkEvent]:
        """Start due transmissions and settle receptions ending by ``t_s``, in time order."""
        self._run_heap(lambda t: t <= t_s)
        self._now_s = max(self._now_s, t_s)
        events, self._settled = self._settled, []
        return events

    def stats(self) -> LinkCounts:
        """Counters per ``(src, dst)``; see `comms_sim.stats`."""
        return self._stats.snapshot()

    def queued(self, node: str) -> int:
        """Frames of ``node`` waiting for the transmitter."""
        n = self._nodes.get(node)
        return 0 if n is None else len(n.queue)

    def airtime_s(self, nbytes: int) -> float:
        return self.config.airtime_s(nbytes)

    # -- internals -------------------------------------------------------------------------

    def _catch_up(self, t_s: float) -> None:
        """Act out everything due strictly before ``t_s`` (kept for the next `advance`), so a
        call made at ``t_s`` without a prior ``advance`` cannot rewrite the past."""
        self._run_heap(lambda t: t < t_s)

    def _run_heap(self, due: Callable[[float], bool]) -> None:
        heap, lost = self._heap, self._lost
        while True:
            if lost and (not heap or lost[0][:2] < heap[0][:2]):
                if not due(lost[0][0]):
                    return
                t, _, r = heapq.heappop(lost)
                self._now_s = max(self._now_s, t)
                self._settled.append(self._settle(r))
                continue
            if not heap or not due(heap[0][0]):
                return
            t, seq, kind, obj = heapq.heappop(heap)
            self._now_s = max(self._now_s, t)
            if isinstance(obj, _Reception):  # kind _RX
                self._settled.append(self._settle(obj))
            else:  # kind _WAKE: a node's name
                node = self._nodes[obj]
                if node.wake_seq == seq:
                    node.wake_seq = None
                    self._try_start(obj, node, t)

    def _node(self, name: str) -> _Node:
        node = self._nodes.get(name)
        if node is None:
            node = self._nodes[name] = _Node()
        return node

    def _link_rng(self, src: str, dst: str) -> np.random.Generator:
        rng = self._link_rngs.get((src, dst))
        if rng is None:
            seq = np.random.SeedSequence(self._root_seed,
                                         spawn_key=(_name_key(src), _name_key(dst)))
            rng = self._link_rngs[(src, dst)] = np.random.Generator(np.random.PCG64(seq))
        return rng

    def _earliest_start(self, src: str, node: _Node, nbytes: int, t_s: float) -> float:
        t = max(t_s, node.tx_end_s)  # the modem sends one frame at a time
        tdma = self.config.tdma
        if tdma is None:
            return t
        return slot_start(t, self.config.airtime_s(nbytes), self._slots[src], len(self._slots),
                          tdma.slot_s, tdma.guard_s, self._schedule)

    def _schedule_next(self, src: str, node: _Node, t_s: float) -> None:
        head = node.queue.head()
        if head is None:
            node.wake_seq = None
            return
        start = self._earliest_start(src, node, len(head.frame), t_s)
        seq = next(self._seq)
        node.wake_seq = seq
        heapq.heappush(self._heap, (start, seq, _WAKE, src))

    def _try_start(self, src: str, node: _Node, t_s: float) -> None:
        head = node.queue.head()
        if head is None:
            return
        if self._earliest_start(src, node, len(head.frame), t_s) > t_s:
            self._schedule_next(src, node, t_s)  # e.g. the TDMA cycle grew meanwhile
            return
        node.queue.pop()
        end = t_s + self.config.airtime_s(len(head.frame))
        node.tx_start_s, node.tx_end_s = t_s, end
        if self.config.half_duplex:
            for r in node.pending:
                if r.start_s < end and t_s < r.end_s:
                    r.deaf = True
        for dst, dst_node in self._nodes.items():
            if dst != src:
                self._receive(src, node, dst, dst_node, head.frame, t_s, head.tag)
        self._schedule_next(src, node, end)

    def _receive(self, src: str, node: _Node, dst: str, dst_node: _Node, frame: bytes,
                 t_s: float, tag: object = None) -> None:
        cfg = self.config
        # a fixed number of draws per frame and link, used or not: stable streams
        draws = self._link_rng(src, dst).random(4 if self._physical else 2).tolist()
        airtime = cfg.airtime_s(len(frame))
        if node.pos is None or dst_node.pos is None:
            r = _Reception(src, dst, t_s, t_s, t_s + airtime, frame, "range", False)
        else:
            range_m = math.dist(node.pos, dst_node.pos)
            start = t_s + cfg.delay_s(range_m)
            r = _Reception(src, dst, t_s, start, start + airtime, frame, None, True)
            if self._partitions and any(p.cuts(src, dst, start, r.end_s)
                                        for p in self._partitions):
                r.fate, r.audible = "partition", False
            elif range_m > self._horizon_m:
                r.fate, r.audible = "range", False
            elif self._physical:
                self._decide_alone(r, range_m, draws)
            elif draws[0] >= cfg.delivery_probability(range_m):
                r.fate = "range"
            elif draws[1] < self._extra_loss:
                r.fate = "random"
        r.tag = tag
        if r.audible:
            if cfg.half_duplex and dst_node.tx_end_s > r.start_s and dst_node.tx_start_s < r.end_s:
                r.deaf = True
            if cfg.collisions and self._physical:  # the SINR decides at settlement
                for q in dst_node.pending:
                    if q.start_s < r.end_s and r.start_s < q.end_s:
                        if q.interferers is None:
                            q.interferers = [r]
                        else:
                            q.interferers.append(r)
                        if r.interferers is None:
                            r.interferers = [q]
                        else:
                            r.interferers.append(q)
            elif cfg.collisions:
                for q in dst_node.pending:
                    if q.start_s < r.end_s and r.start_s < q.end_s:
                        q.collided = r.collided = True
            dst_node.pending.append(r)
        if r.fate in _LOST_ANYWAY:
            heapq.heappush(self._lost, (r.end_s, next(self._seq), r))
        else:
            heapq.heappush(self._heap, (r.end_s, next(self._seq), _RX, r))

    def _decide_alone(self, r: _Reception, range_m: float, draws: list[float]) -> None:
        """Physical model, at transmission: the frame's level, its fade, and whether it would
        decode with no interference at all (if not: "sinr")."""
        rm = range_m if range_m > 1.0 else 1.0  # source levels are defined at 1 m
        r.power = self._source * rm ** self._neg_k * math.exp(self._absorb * rm)
        r.u_decode = draws[0]
        r.gain = power_gain(draws[2], draws[3], self.config.rician_k)
        if r.u_decode >= self._budget.success_ratio(r.power * r.gain / self._decoder_noise,
                                                     len(r.frame)):
            r.fate = "sinr"
        elif draws[1] < self._extra_loss:
            r.fate = "random"

    def _settle(self, r: _Reception) -> LinkEvent:
        snr_db = sinr_db = None
        if r.audible:
            self._nodes[r.dst].pending.remove(r)
            if self._physical:
                snr_db, sinr_db = self._settle_physical(r)
        reason = r.fate
        if reason not in ("partition", "range", "sinr"):
            reason = "half_duplex" if r.deaf else "collision" if r.collided else reason
        event = LinkEvent(r.src, r.dst, r.t_sent_s, r.end_s, len(r.frame), reason is None,
                          reason, r.frame, snr_db, sinr_db, r.tag)
        self._stats.record(event)
        return event

    def _settle_physical(self, r: _Reception) -> tuple[float, float]:
        """The mean SNR and SINR of ``r``; marks it collided if the frame that would have
        decoded alone does not at its SINR."""
        snr_db = 10.0 * math.log10(r.power / self._noise)
        if not r.interferers:
            return snr_db, snr_db
        peak = _peak_interference(r)
        if r.fate is None or r.fate == "random":
            decoder_snr = r.power * r.gain / (self._decoder_noise + peak)
            if r.u_decode >= self._budget.success_ratio(decoder_snr, len(r.frame)):
                r.collided = True
        return snr_db, 10.0 * math.log10(r.power / (self._noise + peak))


def _peak_interference(r: _Reception) -> float:
    """The largest total power of receptions overlapping ``r`` at any instant of it (the worst
    SINR over the reception decides: a burst of interference corrupts the bits it covers, and
    one bad bit loses an uncoded frame)."""
    others = r.interferers or ()
    if len(others) == 1:
        return others[0].power
    start, end = r.start_s, r.end_s
    edges = []
    for q in others:  # clipped to r; half-open: at equal times, ends sort before starts
        edges.append((q.start_s if q.start_s > start else start, 1, q.power))
        edges.append((q.end_s if q.end_s < end else end, 0, -q.power))
    edges.sort()
    level = peak = 0.0
    for _, _, delta in edges:
        level += delta
        if level > peak:
            peak = level
    return peak
