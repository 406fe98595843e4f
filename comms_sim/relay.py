"""The relay: moves every vehicle-to-vehicle frame through the channel model, over Zenoh.

Subscribes to ``fleet/tx/*`` (frames), ``fleet/truth/*`` (where vehicles really are) and
``fleet/ctl/link`` (fault injection, see `comms_sim.control`); puts each delivered frame on
``fleet/rx/<dst>`` when the model says its reception ends, and every delivery or drop as a
`LinkEvent` on ``fleet/link/<src>/<dst>``; answers ``fleet/stats/link`` queries.

With the run's credentials (`fleet_bus.auth`) it takes ``fleet/tx/X`` and ``fleet/truth/X``
only signed by vehicle X and link control only signed by the operator, and signs what it
publishes; what is refused is counted per reason (``auth_<reason>``) before it reaches the
channel, so a forged pose can never replace a vehicle's queued heartbeat. Each sender's queue
is bounded (`comms_sim.channel.MAX_QUEUED_FRAMES`) and so is the number of partitions: a
flood costs the flooder's own queue, never another sender's.

`Relay` holds the logic and is driven by plain calls (tests drive it without Zenoh); `serve`
wires it to a session. It stands on a `comms_sim.water.Water` (the channel behind one lock,
the scheduler): Zenoh callbacks run on Zenoh's threads, the scheduler on the caller's, and
nothing is published while holding the lock. The emulated Micro-Modems stand on the same
water (`comms_sim.micromodem`), with a relay that publishes link events but no deliveries.
"""

from __future__ import annotations

import contextlib
import sys
import threading
from typing import Callable, Sequence

import msgpack
import zenoh

from comms_sim.channel import Channel
from comms_sim.config import ChannelConfig, with_tdma
from comms_sim.control import apply_control
from comms_sim.link_event import LinkEvent
from comms_sim.seeds import channel_rng
from comms_sim.water import SimClock, Water
from fleet_bus import keys, topics
from fleet_bus.auth import BusAuth, Refused, seal
from fleet_bus.clock import MissionClock
from fleet_bus.link import LinkRecord, TxTag
from fleet_bus.mission import ClockRecord, ClockSync, fetch_mission
from fleet_bus.process import RELAY_READY, ready
from fleet_bus.query_limits import QueryGate, gate_queryable

Put = Callable[[str, bytes, "bytes | None"], None]  # key, payload, attachment
READY = RELAY_READY
# What the relay drops before the channel: garbage on its keys, or ids it cannot place.
RELAY_COUNTERS = ("tx", "truth", "ctl", "malformed_tx", "malformed_truth", "malformed_ctl",
                  "unknown_tx", "unknown_truth", "late_tx", "misdated_tx",
                  "ctl_too_many_partitions")
MAX_PARTITIONS = 64  # scheduled partitions the channel holds; more link control is refused
# How far back a late frame may be dated (TxTag.sent_s), in mission seconds: an agent dates
# a late frame at most one TDMA cycle back (24 vehicles x 2.5 s slots = 60 s).
MAX_LATE_S = 60.0


def delivery_attachment(event: LinkEvent) -> bytes:
    """Metadata put beside a delivered frame on ``fleet/rx/<dst>`` (the frame stays raw)."""
    return msgpack.packb({"src": event.src, "t_s": event.t_s, "t_sent_s": event.t_sent_s})


class Relay:
    """The bus face of a `Water`: bus samples in, deliveries and link events out through
    ``put``.

    ``vehicles`` is the roster: frames and truths of other ids are dropped as unknown. A
    roster vehicle whose truth has not come yet is still heard by the channel (which counts
    its frames as out of range until it is located: its first truth may race its first
    frame). Without a roster a vehicle is known once its truth has been seen, so that garbage
    ids do not become phantom receivers. ``deliver=False`` publishes link events only: another
    face (the emulated Micro-Modems) delivers the frames; ``water`` shares an existing one."""

    def __init__(self, channel: Channel, clock: SimClock, put: Put,
                 vehicles: frozenset[str] | None = None, auth: BusAuth | None = None, *,
                 deliver: bool = True, water: Water | None = None) -> None:
        self.water = Water(channel, clock) if water is None else water
        if self.water.channel is not channel or self.water.clock is not clock:
            raise ValueError("a shared water must hold the relay's channel and clock")
        self.channel = channel
        self.auth = auth
        self.clock = clock
        self._put = put
        self._deliver = deliver
        self._vehicles = vehicles
        self._located: set[str] = set()
        self._lock = self.water.lock
        self.counters = dict.fromkeys(RELAY_COUNTERS, 0)
        self.max_late_s = 0.0  # the most a frame was placed back from its arrival (late_tx)
        self.queries: QueryGate | None = None  # who asked for the stats (`serve`)
        self.clock_sync: ClockSync | None = None  # the relay's clock exchanges (`main`)
        self.water.add_listener(self._publish)

    # -- inputs (any thread) ---------------------------------------------------------------

    def _open(self, key: str, payload: bytes) -> bytes | None:
        """The payload if ``key``'s rightful signer sealed it (always, on an open bus); a
        refusal is counted as ``auth_<reason>``."""
        if self.auth is None:
            return payload
        try:
            return self.auth.open(key, payload)[1]
        except Refused as exc:
            with self._lock:
                name = f"auth_{exc.reason}"
                self.counters[name] = self.counters.get(name, 0) + 1
            return None

    def on_tx(self, vid: str, envelope: bytes, kind: str = "data",
              sent_s: float | None = None) -> None:
        """A frame from ``vid``, sent at ``sent_s`` on its sender's clock (`TxTag`): placed
        there in the channel if the relay's clock has passed it (bus latency, a host that ran
        late: counted ``late_tx``), at the relay's time if not yet or if undated; dated more
        than `MAX_LATE_S` back, it is sent now and counted ``misdated_tx``."""
        frame = self._open(topics.TX.of(vid).key, envelope) if vid else envelope

        def submit(channel: Channel, now: float) -> list[LinkEvent]:
            self.counters["tx"] += 1
            if frame is None:
                return []
            if not vid or not frame:
                self.counters["malformed_tx"] += 1
                return []
            known = self._located if self._vehicles is None else self._vehicles
            if vid not in known:
                self.counters["unknown_tx"] += 1
                return []
            t_s, keep = now, False
            if sent_s is not None and sent_s < now:
                if sent_s >= now - MAX_LATE_S:
                    t_s, keep = sent_s, True
                    self.counters["late_tx"] += 1
                    self.max_late_s = max(self.max_late_s, now - sent_s)
                else:
                    self.counters["misdated_tx"] += 1
            return channel.submit(vid, frame, t_s, kind, keep_time=keep)

        self.water.act(submit)

    def on_truth(self, vid: str, envelope: bytes) -> None:
        topic = topics.TRUTH.of(vid)
        payload = self._open(topic.key, envelope) if vid else envelope
        with self._lock:
            self.counters["truth"] += 1
            if payload is None:
                return
            if self._vehicles is not None and vid not in self._vehicles:
                self.counters["unknown_truth"] += 1
                return
            try:
                truth = topic.decode(payload)
                self.channel.set_position(vid, truth.pos, self.clock.now())
            except ValueError:
                self.counters["malformed_truth"] += 1
                return
            self._located.add(vid)

    def on_ctl(self, envelope: bytes) -> None:
        payload = self._open(topics.LINK_CTL.key, envelope)

        def control(channel: Channel, now: float) -> list[LinkEvent]:
            self.counters["ctl"] += 1
            if payload is None:
                return []
            try:
                control = topics.LINK_CTL.decode(payload, now)
                if control.partition is not None and not control.clear_partitions and \
                        len(channel.partitions) >= MAX_PARTITIONS:
                    self.counters["ctl_too_many_partitions"] += 1
                    return []
                apply_control(control, channel, now)
                if control.inject is not None and control.inject_at is not None:
                    # from the intruder's modem, or the operator's topside (whose node then
                    # hears the water: its deliveries go out on fleet/rx/topside)
                    channel.set_position(control.inject_from, control.inject_at, now)
                    return channel.submit(control.inject_from, control.inject, now, "data")
            except ValueError:
                self.counters["malformed_ctl"] += 1
            return []

        self.water.act(control)

    def stats_payload(self) -> bytes:
        with self._lock:
            return topics.LINK_STATS.encode((self.channel.stats(), {
                "relay": dict(self.counters), "t_s": self.clock.now(),
                "max_late_s": round(self.max_late_s, 3),
                "refused": dict(self.auth.verifier.refused) if self.auth else {},
                "extra_loss": self.channel.extra_loss,
                "partitions": [p.to_dict() for p in self.channel.partitions],
                "queries": self.queries.counts() if self.queries is not None else {},
                "clock": self._clock_counts()}))

    def _clock_counts(self) -> dict[str, float]:
        sync = self.clock_sync
        if sync is None:
            return {}
        return {"wall_steps": sync.watch.steps, "exchanges": sync.exchanges,
                "failed": sync.failed, "offset_s": getattr(self.clock, "offset_s", 0.0)}

    # -- scheduler (one thread): the water's --------------------------------------------

    def step(self) -> float | None:
        """Settle everything due now and publish it; return the next due simulation time."""
        return self.water.step()

    def run(self, stop: threading.Event, max_wait_s: float = 0.5) -> None:
        self.water.run(stop, max_wait_s)

    def wake(self) -> None:
        self.water.wake()

    def _publish(self, events: list[LinkEvent]) -> None:
        for event in events:
            if event.delivered and self._deliver:
                rx = topics.RX.of(event.dst)
                self._put(rx.key, rx.encode(event.frame), delivery_attachment(event))
            link = topics.LINK.of(event.src, event.dst)
            self._put(link.key, link.encode(link_record(event)), None)


def link_record(event: LinkEvent) -> LinkRecord:
    """What the bus is told about a frame's fate: everything but the frame itself."""
    return LinkRecord(event.src, event.dst, event.t_sent_s, event.t_s, event.nbytes,
                      event.delivered, event.reason, getattr(event, "snr_db", None))


def bus_put(session: zenoh.Session, auth: BusAuth | None) -> tuple[Put, Callable[[], None]]:
    """A `Put` on ``session`` (one publisher per key, declared once: half the cost of
    ``session.put``; sealed with ``auth``), and the function that undeclares them."""
    publishers: dict[str, zenoh.Publisher] = {}

    def put(key: str, payload: bytes, attachment: bytes | None) -> None:
        publisher = publishers.get(key)
        if publisher is None:
            publisher = publishers[key] = session.declare_publisher(key)
        publisher.put(seal(auth, key, payload), attachment=attachment)

    def undeclare() -> None:
        for publisher in list(publishers.values()):
            publisher.undeclare()

    return put, undeclare


def serve(session: zenoh.Session, channel: Channel, clock: SimClock, stop: threading.Event,
          vehicles: frozenset[str] | None = None,
          on_ready: Callable[[Relay], None] | None = None,
          auth: BusAuth | None = None, *, take_tx: bool = True,
          water: Water | None = None) -> Relay:
    """Relay ``channel`` on ``session`` until ``stop`` is set; returns the relay (counters).
    With ``auth`` what it takes must be signed by its rightful sender and what it publishes
    is signed by the relay. ``take_tx=False`` (another face takes the frames, on ``water``)
    serves truths, link control, link events and stats only."""
    put, undeclare = bus_put(session, auth)
    relay = Relay(channel, clock, put, vehicles, auth, deliver=take_tx, water=water)

    def on_tx(sample: zenoh.Sample) -> None:
        if sample.kind == zenoh.SampleKind.PUT:
            att = sample.attachment
            tag = TxTag.decode(None if att is None else att.to_bytes())
            relay.on_tx(keys.vid_of(str(sample.key_expr)), sample.payload.to_bytes(), tag.kind,
                        tag.sent_s)

    def on_truth(sample: zenoh.Sample) -> None:
        if sample.kind == zenoh.SampleKind.PUT:
            relay.on_truth(keys.vid_of(str(sample.key_expr)), sample.payload.to_bytes())

    def on_ctl(sample: zenoh.Sample) -> None:
        if sample.kind == zenoh.SampleKind.PUT:
            relay.on_ctl(sample.payload.to_bytes())

    relay.queries = QueryGate(auth)  # each asker rationed and counted
    stats = topics.LINK_STATS.key
    on_stats = gate_queryable(relay.queries, stats, lambda query: query.reply(
        stats, seal(auth, stats, relay.stats_payload())))

    try:
        with contextlib.ExitStack() as stack:
            if take_tx:
                stack.enter_context(session.declare_subscriber(topics.TX.all.key, on_tx))
            stack.enter_context(session.declare_subscriber(topics.TRUTH.all.key, on_truth))
            stack.enter_context(session.declare_subscriber(topics.LINK_CTL.key, on_ctl))
            stack.enter_context(session.declare_queryable(stats, on_stats))
            if on_ready is not None:
                on_ready(relay)
            relay.run(stop)
    finally:  # after the subscribers, whose callbacks may publish too
        undeclare()
    return relay


def main(conf: zenoh.Config, config: ChannelConfig, stop: threading.Event,
         epoch_unix: float | None = None, warp: float | None = None, seed: int | None = None,
         vehicles: Sequence[str] | None = None, mission_timeout_s: float = 30.0,
         tdma: bool = False, auth: BusAuth | None = None) -> Relay | None:
    """Open a session on ``conf`` and relay until ``stop``. Without ``epoch_unix`` the seed
    and roster come from the ``fleet/mission`` record and the clock from ``fleet/clock``.
    ``tdma`` gives each vehicle of the roster a slot, in roster (scenario) order, as the
    agents count them. Returns the relay (counters), or None if stopped or no mission came
    (the reason is printed)."""
    with zenoh.open(conf) as session:
        sync = None
        if epoch_unix is None:
            mission = fetch_mission(session, stop, mission_timeout_s, auth)
            if mission is None:
                _gave_up(stop, keys.MISSION, mission_timeout_s)
                return None
            seed = mission.seed if seed is None else seed
            vehicles = vehicles or mission.roster() or None
            sync = ClockSync(session, auth, stop)  # the operator's clock, measured
            clock = sync.join(mission_timeout_s)
            if clock is None:
                _gave_up(stop, keys.CLOCK, mission_timeout_s)
                return None
            sync.start()
        else:  # a clock of its own, from a wall-clock epoch given by hand
            ref, w, _ = ClockRecord(epoch_unix, warp if warp is not None else 1.0).timing()
            clock = MissionClock(ref, w, epoch_unix=epoch_unix)
        if tdma:
            if not vehicles:
                raise ValueError("TDMA needs the roster (--vehicles or the mission's)")
            config = with_tdma(config, list(vehicles))
        channel = Channel(config, channel_rng(0 if seed is None else seed))
        roster = frozenset(vehicles) if vehicles else None

        def on_ready(relay: Relay) -> None:
            relay.clock_sync = sync
            ready(READY, f"epoch_unix={clock.epoch_unix} warp={clock.warp} "
                         f"mac={'tdma' if config.tdma else 'aloha'} "
                         f"roster={','.join(vehicles) if vehicles else 'open'} "
                         f"auth={'signed' if auth else 'open'}")
        try:
            return serve(session, channel, clock, stop, roster, on_ready=on_ready, auth=auth)
        finally:
            if sync is not None:
                sync.close()


def _gave_up(stop: threading.Event, key: str, timeout_s: float) -> None:
    if not stop.is_set():
        print(f"comms_sim relay: no well-formed answer on {key} within {timeout_s:g} s",
              file=sys.stderr, flush=True)
