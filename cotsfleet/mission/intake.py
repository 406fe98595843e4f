"""What the operator of a multi-process mission takes from the bus.

Every vehicle signs what it puts (`fleet_bus.auth`): its statuses (``fleet/status/<id>``),
its events (``fleet/event/<id>``), its ready announcement (``fleet/alive/<id>``) and its
planning flag (``fleet/busy/<id>``). A sample is taken only when it is signed by the vehicle
its key names, the vehicle is on this mission's roster, the payload decodes, and it speaks
for that vehicle only (its id, this run, spot ids the mission knows). Anything else is
dropped and counted: the verifier counts what fails the signature, `refused` ("invalid")
what fails the rest. One unknown spot id must not cost the report: a vehicle's bug is no
reason to lose the mission's record.

Bus callbacks run on Zenoh's threads; the ledger, the ready set and the counts are read by
the launcher's loop: one lock guards them.
"""

from __future__ import annotations

import threading
from typing import Any, Callable, Collection, Protocol, Sequence, TypeVar

from fleet_bus import topics
from fleet_bus.auth import BusAuth
from fleet_bus.ledger import FleetLedger
from fleet_bus.telemetry import STATES, Status
from fleet_bus.topics import TopicError, VehicleTopics
from hfc_core.model.problem import Problem

T = TypeVar("T")


class Sample(Protocol):
    """What is read of a `zenoh.Sample` (read-only, as zenoh's own properties are)."""

    @property
    def key_expr(self) -> Any: ...

    @property
    def payload(self) -> Any: ...


class Intake:
    """``status``, ``event``, ``alive``, ``busy`` and ``rx`` are the subscribers' callbacks;
    set ``auth`` (the operator's, with the run's ring) before the first sample."""

    def __init__(self, problem: Problem, ids: Sequence[str], run_id: str,
                 find_ids: Collection[int], on_busy: Callable[[str, bool], None],
                 overhear: Callable[[bytes], None]) -> None:
        self.problem, self.ids, self.run_id = problem, list(ids), run_id
        self._find_ids, self._on_busy, self._overhear = find_ids, on_busy, overhear
        self.auth: BusAuth | None = None
        self.ledger = FleetLedger()
        self.lock = threading.Lock()
        self.ready: set[str] = set()  # vehicles that announced their initial plan
        self.refused: dict[str, int] = {}  # what this intake refused, by reason

    # -- for the launcher's loop --------------------------------------------------------------

    def statuses(self) -> dict[str, Status]:
        """The latest status of each vehicle (a copy)."""
        with self.lock:
            return dict(self.ledger.statuses)

    def missing(self) -> list[str]:
        """Vehicles not ready yet."""
        with self.lock:
            return [vid for vid in self.ids if vid not in self.ready]

    def all_final(self, dead: set[str]) -> bool:
        with self.lock:
            return self.ledger.all_final(self.ids, dead)

    def refused_counts(self) -> dict[str, int]:
        """Refused by reason: the signature's (the verifier's) and the rest."""
        with self.lock:
            out = dict(self.refused)
        for reason, n in self.auth.verifier.refused.items() if self.auth is not None else ():
            out[reason] = out.get(reason, 0) + n
        return out

    # -- the subscribers' callbacks ---------------------------------------------------------

    def status(self, sample: Sample) -> None:
        got = self._from_fleet(sample, topics.STATUS)
        if got is None:
            return
        vid, s = got
        if s.id != vid or s.state not in STATES \
                or not self._known_tasks(s.route, s.treated, s.claims):
            return self._invalid()
        with self.lock:
            self.ledger.add_status(s)

    def event(self, sample: Sample) -> None:
        got = self._from_fleet(sample, topics.EVENT)
        if got is None:
            return
        vid, e = got
        if e.id != vid or not self._known_tasks(e.tasks):
            return self._invalid()
        with self.lock:
            self.ledger.add_event(e)

    def alive(self, sample: Sample) -> None:
        """A vehicle's ready announcement (its initial plan is computed)."""
        got = self._from_fleet(sample, topics.ALIVE)
        if got is None:
            return
        vid, ready = got
        if ready.id != vid or ready.run_id != self.run_id:
            return self._invalid()  # another vehicle's or another run's
        with self.lock:
            self.ready.add(vid)

    def busy(self, sample: Sample) -> None:
        """A vehicle starts or ends a planner run (`ClockControl.busy`)."""
        got = self._from_fleet(sample, topics.BUSY)
        if got is not None:
            self._on_busy(*got)

    def rx(self, sample: Sample) -> None:
        """A delivery overheard: the replay attack's material (`Intruder.overhear`)."""
        opened = self._open(sample)
        if opened is not None:
            self._overhear(opened[1])

    # -- checks -----------------------------------------------------------------------------

    def _open(self, sample: Sample) -> tuple[str, bytes] | None:
        """(key, payload) of a sample signed by its key's rightful sender, else None (the
        refusal is counted by the verifier)."""
        assert self.auth is not None, "Intake.auth is set before any subscriber"
        key = str(sample.key_expr)
        payload = self.auth.open_payload(key, sample.payload.to_bytes())
        return None if payload is None else (key, payload)

    def _from_fleet(self, sample: Sample, topic: VehicleTopics[T]) -> tuple[str, T] | None:
        """(vehicle id, record) of a sample signed by a vehicle of this mission under its
        own key; else None, and a payload that is not the topic's record (`TopicError`), or
        a sender not on the roster, is counted as invalid."""
        opened = self._open(sample)
        if opened is None:
            return None
        try:
            got: tuple[str, T] | None = topic.decode_at(*opened)
        except TopicError:
            got = None
        if got is None or got[0] not in self.ids:
            self._invalid()
            return None
        return got

    def _known_tasks(self, *lists: list[int]) -> bool:
        index, finds = self.problem.task_index, self._find_ids
        return all(t in index or t in finds for ids in lists for t in ids)

    def _invalid(self) -> None:
        with self.lock:
            self.refused["invalid"] = self.refused.get("invalid", 0) + 1
