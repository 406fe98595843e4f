"""The mission record (``fleet/mission``) and the mission clock record (``fleet/clock``),
both served by the operator (the launcher) as queryables.

The mission record is what every process needs before it can do anything: the scenario
document, the mission seed and the run id. The agents plan from it (one place, one copy: no
scenario file or seed to keep in step). The clock record (epoch and warp of the shared
`MissionClock`) is served only once every agent is ready, so the mission starts when the
slowest planner is done. Neither ever carries a key.

The clock record is the operator's latest state, held for whoever asks (a queryable, not a
put of the latest value: an answer is signed fresh from the operator's state when asked, so
there is no cache to go stale, and the same exchange times the answer for `ClockSync`);
changes are also put as they happen. A process that missed a put reads the newest record at
its next exchange, a second later.
"""

from __future__ import annotations

import secrets
import threading
import time
from dataclasses import dataclass
from typing import Any, Callable, Mapping, TypeVar

import msgpack
import zenoh

from fleet_bus import keys
from fleet_bus import values as v
from fleet_bus.auth import BusAuth, seal_query, unseal
from fleet_bus.clock import (
    MissionClock,
    OffsetFilter,
    TimeSample,
    WallWatch,
    WarpClock,
    time_sample,
)
from fleet_bus.query_limits import nonce_of

T = TypeVar("T")


@dataclass(frozen=True)
class Mission:
    scenario: dict[str, Any]
    seed: int
    run_id: str

    def encode(self) -> bytes:
        return msgpack.packb({"scenario": self.scenario, "seed": self.seed,
                              "run_id": self.run_id})

    @staticmethod
    def decode(payload: bytes) -> "Mission":
        return Mission.from_doc(v.unpack_map(payload, "mission record"))

    @staticmethod
    def from_doc(doc: Mapping[str, Any]) -> "Mission":
        """The record's fields from a map (the bus record's, a mission file's), checked."""
        scenario = doc.get("scenario")
        if not isinstance(scenario, dict):
            raise ValueError("mission record: scenario must be a map")
        return Mission(scenario, v.integer(doc.get("seed"), "mission.seed", 0, 2**63 - 1),
                       v.text(doc.get("run_id"), "mission.run_id", 64))

    def roster(self) -> tuple[str, ...]:
        """Vehicle ids of the scenario, in scenario order (empty if it lists none)."""
        vehicles = self.scenario.get("vehicles")
        if not isinstance(vehicles, list):
            return ()
        return tuple(str(x["id"]) for x in vehicles if isinstance(x, dict) and "id" in x)


@dataclass(frozen=True)
class ClockRecord:
    """The shared mission clock: mission time ``(ref - epoch_ref) * warp`` on the operator's
    reference clock (its monotonic clock), which every process measures its own against
    (`ClockSync`). ``epoch_unix`` dates mission time 0 on the operator's wall clock (for
    dates only, and for the tools that still run a wall-clock `WarpClock`); ``held_by``: the
    vehicles whose planning holds the clock now (`cotsfleet.mission.pacing.Holds`).

    The operator may slow the clock down during a mission (a process lagging behind it, a
    planning hold) and speed it up again: it then puts a record with a higher ``seq``, whose
    epoch is chosen so that mission time runs on without a jump (`MissionClock.at_warp`).
    Every process follows the newest record. A record without ``epoch_ref`` (an operator of
    an older release, a test) is read on the wall clock."""

    epoch_unix: float
    warp: float
    seq: int = 0
    epoch_ref: float | None = None
    held_by: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        v.number(self.epoch_unix, "clock.epoch_unix")
        if self.epoch_ref is not None:
            v.number(self.epoch_ref, "clock.epoch_ref")
        if not v.number(self.warp, "clock.warp") > 0:
            raise ValueError(f"clock.warp must be positive, got {self.warp}")
        v.integer(self.seq, "clock.seq", 0)
        if len(self.held_by) > MAX_HOLDERS:
            raise ValueError(f"clock.held_by: more than {MAX_HOLDERS}")

    def to_dict(self) -> dict[str, Any]:
        doc: dict[str, Any] = {"epoch_unix": self.epoch_unix, "warp": self.warp, "seq": self.seq}
        if self.epoch_ref is not None:
            doc["epoch_ref"] = self.epoch_ref
        if self.held_by:
            doc["held_by"] = list(self.held_by)
        return doc

    def encode(self) -> bytes:
        return msgpack.packb(self.to_dict())

    @staticmethod
    def from_dict(doc: dict[str, Any]) -> "ClockRecord":
        ref = doc.get("epoch_ref")
        held = doc.get("held_by", [])
        if not isinstance(held, list) or len(held) > MAX_HOLDERS:
            raise ValueError("clock.held_by: expected a short list")
        return ClockRecord(v.number(doc.get("epoch_unix"), "clock.epoch_unix"),
                           v.number(doc.get("warp"), "clock.warp"),
                           v.integer(doc.get("seq", 0), "clock.seq", 0),
                           None if ref is None else v.number(ref, "clock.epoch_ref"),
                           tuple(v.text(h, "clock.held_by", 64) for h in held))

    @staticmethod
    def decode(payload: bytes) -> "ClockRecord":
        return ClockRecord.from_dict(v.unpack_map(payload, "clock record"))

    def timing(self, mono: Callable[[], float] = time.monotonic,
               wall: Callable[[], float] = time.time) -> tuple[float, float, int]:
        """(epoch_ref, warp, seq) for a `MissionClock`; a record without ``epoch_ref`` is
        placed on the reference clock through this host's wall clock, read now."""
        ref = self.epoch_ref if self.epoch_ref is not None else \
            self.epoch_unix - (wall() - mono())
        return ref, self.warp, self.seq


MAX_HOLDERS = 64


@dataclass(frozen=True)
class ClockAnswer:
    """The operator's answer on ``fleet/clock``: the newest record, and, for a query that
    carried a nonce, the reference times it received the query and answered it (the two
    middle timestamps of an NTP exchange, `fleet_bus.clock.time_sample`)."""

    record: ClockRecord
    nonce: str = ""
    ref_received: float | None = None
    ref_answered: float | None = None

    def encode(self) -> bytes:
        doc = self.record.to_dict()
        if self.nonce:
            doc.update(nonce=self.nonce, ref_received=self.ref_received,
                       ref_answered=self.ref_answered)
        return msgpack.packb(doc)

    @staticmethod
    def decode(payload: bytes) -> "ClockAnswer":
        doc = v.unpack_map(payload, "clock answer")
        record = ClockRecord.from_dict(doc)
        nonce = doc.get("nonce")
        if nonce is None:
            return ClockAnswer(record)
        return ClockAnswer(record, v.text(nonce, "clock.nonce", 64),
                           v.number(doc.get("ref_received"), "clock.ref_received"),
                           v.number(doc.get("ref_answered"), "clock.ref_answered"))


def answer_clock(record: bytes, parameters: str, received_ref: float,
                 ref: Callable[[], float]) -> bytes:
    """The operator's answer (unsigned payload) to a query of ``fleet/clock`` received at
    ``received_ref``: ``record`` (an encoded `ClockRecord`) with the exchange's times."""
    nonce = nonce_of(parameters)
    if not nonce:
        return record
    return ClockAnswer(ClockRecord.decode(record), nonce, received_ref, ref()).encode()


def _ask(session: zenoh.Session, key: str, timeout_s: float, auth: BusAuth | None,
         nonce: str) -> Any:
    """``session.get`` of ``key`` with ``nonce`` in its parameters, signed if we can."""
    attachment = seal_query(auth, key, nonce)
    return session.get(f"{key}?n={nonce}", timeout=timeout_s, attachment=attachment)


def fetch(session: zenoh.Session, key: str, decode: Callable[[bytes], T],
          stop: threading.Event, timeout_s: float, query_timeout_s: float = 2.0,
          retry_s: float = 0.2, auth: BusAuth | None = None) -> T | None:
    """Ask the queryable ``key`` until a well-formed answer comes (the operator may not be up
    yet, or not ready to answer); None if ``stop`` is set or ``timeout_s`` passes first.
    Malformed answers, and with ``auth`` answers not signed by the operator, are skipped
    (and counted by ``auth``): the first reply no longer wins, the first genuine one does.
    Queries are signed when this process holds a key (`fleet_bus.query_limits`)."""
    deadline = time.monotonic() + timeout_s
    while not stop.is_set() and time.monotonic() < deadline:
        left = deadline - time.monotonic()
        for reply in _ask(session, key, max(0.1, min(query_timeout_s, left)), auth,
                          secrets.token_hex(8)):
            if reply.ok is None:
                continue
            payload = unseal(auth, key, reply.ok.payload.to_bytes())
            if payload is None:
                continue
            try:
                return decode(payload)
            except ValueError:
                if auth is not None:
                    auth.verifier.refuse("invalid")
                continue
        stop.wait(retry_s)
    return None


def fetch_mission(session: zenoh.Session, stop: threading.Event,
                  timeout_s: float, auth: BusAuth | None = None) -> Mission | None:
    """The operator's mission record; with ``auth``, only one of this run (its run id)."""
    def decode(payload: bytes) -> Mission:
        mission = Mission.decode(payload)
        if auth is not None and mission.run_id != auth.run_id:
            raise ValueError(f"mission record of run {mission.run_id!r}, not {auth.run_id!r}")
        return mission

    return fetch(session, keys.MISSION, decode, stop, timeout_s, auth=auth)


def fetch_clock(session: zenoh.Session, stop: threading.Event,
                timeout_s: float, auth: BusAuth | None = None) -> ClockRecord | None:
    return fetch(session, keys.CLOCK, ClockRecord.decode, stop, timeout_s, auth=auth)


def ask_clock(session: zenoh.Session, auth: BusAuth | None, timeout_s: float,
              mono: Callable[[], float] = time.monotonic
              ) -> tuple[ClockRecord, TimeSample | None] | None:
    """One exchange on ``fleet/clock``: the newest record and, if the operator timed its
    answer, a time sample; None if no genuine answer came within ``timeout_s``."""
    nonce = secrets.token_hex(8)
    sent = mono()
    for reply in _ask(session, keys.CLOCK, timeout_s, auth, nonce):
        got = mono()
        if reply.ok is None:
            continue
        payload = unseal(auth, keys.CLOCK, reply.ok.payload.to_bytes())
        if payload is None:
            continue
        try:
            answer = ClockAnswer.decode(payload)
        except ValueError:
            if auth is not None:
                auth.verifier.refuse("invalid")
            continue
        sample = None
        if answer.nonce == nonce and answer.ref_received is not None \
                and answer.ref_answered is not None:
            sample = time_sample(sent, answer.ref_received, answer.ref_answered, got)
        return answer.record, sample
    return None


SYNC_EVERY_S = 1.0  # seconds between two clock exchanges of a process
FIRST_SAMPLES = 4  # exchanges in quick succession when a process joins (before mission 0)
EXCHANGE_TIMEOUT_S = 1.0


class ClockSync:
    """Keeps this process's `MissionClock` on the operator's: follows every record the
    operator puts on ``fleet/clock``, and every `SYNC_EVERY_S` asks ``fleet/clock`` for the
    time (an NTP-like exchange: the offset of the best of the last samples steers the clock,
    `OffsetFilter`) and for the newest record, so a process that missed a put is put right
    within a second (slewed, never stepped back: `MissionClock`). It also watches this
    host's wall clock (`WallWatch`): a step is counted and changes nothing else.

    ``join`` waits for the first answer (the operator serves the clock once every agent is
    ready) and returns the clock; ``start`` runs the exchanges on a thread until ``stop``."""

    def __init__(self, session: zenoh.Session, auth: BusAuth | None, stop: threading.Event,
                 every_s: float = SYNC_EVERY_S) -> None:
        self.session, self.auth, self.stop, self.every_s = session, auth, stop, every_s
        self.filter = OffsetFilter()
        self.watch = WallWatch()
        self.clock: MissionClock | None = None
        self.exchanges = 0
        self.failed = 0  # exchanges that got no genuine answer
        self._reported_steps = 0
        self._subscriber: Any = None
        self._thread: threading.Thread | None = None

    def join(self, timeout_s: float, retry_s: float = 0.2) -> MissionClock | None:
        """The mission clock from the operator's first answer (and `FIRST_SAMPLES` more
        exchanges to settle the offset); None if ``stop`` or ``timeout_s`` came first."""
        deadline = time.monotonic() + timeout_s
        while self.clock is None:
            if self.stop.is_set() or time.monotonic() >= deadline:
                return None
            got = ask_clock(self.session, self.auth,
                            max(0.1, min(2.0, deadline - time.monotonic())))
            if got is None:
                self.stop.wait(retry_s)
                continue
            record, sample = got
            if sample is not None:
                self.filter.add(sample)
            best = self.filter.best()
            ref, warp, seq = record.timing()
            self.clock = MissionClock(ref, warp, seq, epoch_unix=record.epoch_unix,
                                      offset_s=best.offset_s if best else 0.0)
        self._subscriber = follow_clock(self.session, self.clock, self.auth)
        for _ in range(FIRST_SAMPLES):
            self.exchange()
        return self.clock

    def start(self) -> None:
        self._thread = threading.Thread(target=self._run, name="clock-sync", daemon=True)
        self._thread.start()

    def exchange(self) -> bool:
        """One exchange: steer by the best sample, follow a newer record; False if none."""
        assert self.clock is not None
        self.watch.check()
        got = ask_clock(self.session, self.auth, EXCHANGE_TIMEOUT_S)
        self.exchanges += 1
        if got is None:
            self.failed += 1
            return False
        record, sample = got
        if sample is not None:
            self.filter.add(sample)
            best = self.filter.best()
            if best is not None and best.offset_s != self.clock.offset_s:
                self.clock.steer(best.offset_s)
        follow_record(self.clock, record)
        return True

    def take_wall_steps(self) -> int:
        """Steps of this host's wall clock seen since the last call."""
        n = self.watch.steps - self._reported_steps
        self._reported_steps = self.watch.steps
        return n

    def close(self) -> None:
        if self._thread is not None:
            self._thread.join(EXCHANGE_TIMEOUT_S + 1.0)
        if self._subscriber is not None:
            try:
                self._subscriber.undeclare()
            except Exception:  # already gone with the session
                pass

    def _run(self) -> None:
        while not self.stop.wait(self.every_s):
            try:
                self.exchange()
            except Exception:  # the session closing under us: the process is ending
                if not self.stop.is_set():
                    self.failed += 1


def follow_record(clock: MissionClock | WarpClock, record: ClockRecord) -> bool:
    """``clock`` follows ``record`` if it is newer; True if taken."""
    if isinstance(clock, MissionClock):
        ref, warp, seq = record.timing()
        return clock.follow(ref, warp, seq, record.epoch_unix)
    return clock.follow(record.epoch_unix, record.warp, record.seq)


def clock_of(session: zenoh.Session, record: ClockRecord,
             auth: BusAuth | None = None) -> tuple[MissionClock, Any]:
    """The mission clock from ``record`` (offset 0: this host's monotonic clock taken for
    the operator's, true on one machine), following the operator's later records; returns it
    and the subscriber, to be kept alive. `ClockSync` measures the offset as well."""
    ref, warp, seq = record.timing()
    clock = MissionClock(ref, warp, seq, epoch_unix=record.epoch_unix)
    return clock, follow_clock(session, clock, auth)


def follow_clock(session: zenoh.Session, clock: MissionClock | WarpClock,
                 auth: BusAuth | None = None) -> Any:
    """Keep ``clock`` on the newest clock record the operator puts (a change of pace);
    returns the subscriber, to be kept alive. Records not signed by the operator, malformed
    ones and older ones change nothing."""
    def on_sample(sample: zenoh.Sample) -> None:
        payload = unseal(auth, keys.CLOCK, sample.payload.to_bytes())
        if payload is None:
            return
        try:
            follow_record(clock, ClockRecord.decode(payload))
        except ValueError:
            return
    return session.declare_subscriber(keys.CLOCK, on_sample)
