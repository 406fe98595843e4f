"""The launcher's desk for the operator's live orders in a multi-process mission.

`cotsfleet ctl` (the operator's terminal) signs an order request with the operator's key, or
on another host with a remote ground station's (``ground``: `cotsfleet ctl --connect`), and
puts it on ``fleet/ctl/order`` (`fleet_bus.orders.encode_request`). The desk opens it with a
verifier of its own over the run's ring (so its refusals are counted apart, as the report's
``security.orders``; the orders taken, by signer, as ``security.orders_taken``; one replay
window per signer), takes it only from those two signers, hands the order to the topside
(`cotsfleet.mission.topside`: numbered, dated, sent until acknowledged, its key chain
disclosed) and answers on ``fleet/ctl/order/answer`` (`fleet_bus.orders.Answer`): accepted
as number N, then each acknowledgement or refusal the topside hears through the water.

Zenoh's threads call `request` and `hear`; the launcher's loop calls `due` (what to transmit
now, and the answers to publish). One lock guards the topside. Requests wait in a queue
bounded per signer (`MAX_QUEUED` each): a flood of signed requests costs the flooder its own
requests, never the other signer's.
"""

from __future__ import annotations

import threading
from collections import deque
from dataclasses import dataclass
from typing import Any

from cotsfleet.mission.topside import Topside
from fleet_bus import keys
from fleet_bus.auth import Refused, Verifier
from fleet_bus.credentials import GROUND_ID, OPERATOR_ID
from fleet_bus.orders import ALL, Answer, Order, OrderError, decode_request, request_ref

MAX_QUEUED = 64  # requests of one signer taken but not yet handed to the topside
# Who may order: the launcher's operator and a ground station elsewhere (`fleet_bus.auth`).
ORDER_SIGNERS = (OPERATOR_ID, GROUND_ID)


@dataclass
class Due:
    """What the launcher's loop does now: transmit ``frames`` from the topside, publish
    ``answers``."""

    frames: list[bytes]
    answers: list[Answer]


class OrderDesk:
    """``topside`` None: the run's credentials hold no topside chain (every request is
    answered with ``unavailable``, the reason)."""

    def __init__(self, topside: Topside | None, verifier: Verifier, unavailable: str = "",
                 ) -> None:
        self.topside, self.verifier, self.unavailable = topside, verifier, unavailable
        self.refused: dict[str, int] = {}  # requests refused, by reason
        self.taken: dict[str, int] = {}  # requests numbered, by signer
        self._lock = threading.Lock()
        # order, ref, error, signer
        self._queue: deque[tuple[Order | None, str, str, str]] = deque()
        self._waiting: dict[str, int] = {}  # requests queued, by signer
        self._refs: dict[int, str] = {}  # order number -> the request's ref
        self._by: dict[int, str] = {}  # order number -> who signed its request
        self._told: dict[int, tuple[int, int]] = {}  # seq -> (acks, refusals) answered
        self._next_s: float | None = None

    def _count(self, reason: str) -> None:
        with self._lock:
            self.refused[reason] = self.refused.get(reason, 0) + 1

    # -- Zenoh's threads ----------------------------------------------------------------------

    def request(self, envelope: bytes) -> None:
        """A sample of ``fleet/ctl/order``: queued if the operator or the ground station
        signed it and it is an order; refused and counted otherwise (no answer: whoever sent
        it is not one of their terminals)."""
        try:
            signer, payload = self.verifier.open(keys.ORDER_REQUEST, envelope)
        except Refused as exc:
            return self._count(exc.reason)
        if signer not in ORDER_SIGNERS:  # another signer of their roles (none in a run's ring)
            return self._count("not_allowed")
        try:
            ref = request_ref(payload)
        except ValueError:
            return self._count("malformed")
        try:
            order, error = decode_request(payload), ""
        except (OrderError, ValueError) as exc:
            order, error = None, str(exc)
        with self._lock:
            if self._waiting.get(signer, 0) >= MAX_QUEUED:
                self.refused["flood"] = self.refused.get("flood", 0) + 1
                return
            self._waiting[signer] = self._waiting.get(signer, 0) + 1
            self._queue.append((order, ref, error, signer))

    def hear(self, frame: bytes, now: float) -> None:
        """A frame the water delivered to the topside (``fleet/rx/topside``, the relay's)."""
        if self.topside is None:
            return
        with self._lock:  # an ack only ever closes an order: the schedule stands
            self.topside.hear(frame, now)

    # -- the launcher's loop ------------------------------------------------------------------

    def submit(self, order: Order, now: float, ref: str = "", by: str = "") -> Answer:
        """Hand ``order`` to the topside now (a request signed by ``by``, or a scheduled
        ``--ctl``: ``by`` empty)."""
        with self._lock:
            return self._submit(order, now, ref, by)

    def _submit(self, order: Order, now: float, ref: str, by: str) -> Answer:
        if self.topside is None:
            self.refused["unavailable"] = self.refused.get("unavailable", 0) + 1
            return Answer(ref, order=order.describe(), error=self.unavailable)
        try:
            numbered = self.topside.submit(order, now)
        except OrderError as exc:
            self.refused["invalid"] = self.refused.get("invalid", 0) + 1
            return Answer(ref, order=order.describe(), error=str(exc))
        self._refs[numbered.seq] = ref
        if by:
            self._by[numbered.seq] = by
            self.taken[by] = self.taken.get(by, 0) + 1
        self._told[numbered.seq] = (0, 0)
        self._next_s = now  # out at once
        return self._answer(numbered.seq)

    def _answer(self, seq: int) -> Answer:
        assert self.topside is not None
        s = self.topside.orders[seq]
        targets = self.topside.codec.vehicles if s.order.target == ALL else (s.order.target,)
        return Answer(self._refs.get(seq, ""), seq, s.order.describe(), tuple(targets),
                      s.order.issued_s, dict(s.acked), dict(s.refused))

    def due(self, now: float) -> Due:
        """The queued requests handed over, the topside's frames due by ``now``, and the
        answers owed (each new request, each order with news since it was last answered)."""
        out = Due([], [])
        with self._lock:
            while self._queue:
                order, ref, error, signer = self._queue.popleft()
                self._waiting[signer] -= 1
                if order is None:
                    self.refused["invalid"] = self.refused.get("invalid", 0) + 1
                    out.answers.append(Answer(ref, error=error))
                else:
                    out.answers.append(self._submit(order, now, ref, signer))
            if self.topside is None:
                return out
            for seq, told in self._told.items():
                s = self.topside.orders[seq]
                if (len(s.acked), len(s.refused)) != told:
                    self._told[seq] = (len(s.acked), len(s.refused))
                    out.answers.append(self._answer(seq))
            if self._next_s is not None and now >= self._next_s:
                out.frames = self.topside.frames(now)
                self._next_s = self.topside.next_s(now)
        return out

    def section(self, counters: dict[str, dict[str, int]]) -> dict[str, Any] | None:
        """The report's ``commands`` section (None: no order was ever given)."""
        with self._lock:
            if self.topside is None or not self.topside.orders:
                return None
            section = self.topside.section(counters)
            for row in section["sent"]:  # who signed each request (none: scheduled)
                if row["seq"] in self._by:
                    row["by"] = self._by[row["seq"]]
            return section

    def refusals(self) -> dict[str, int]:
        with self._lock:
            return {k: n for k, n in self.refused.items() if n}

    def takers(self) -> dict[str, int]:
        """The requests numbered, by signer (the report's ``security.orders_taken``)."""
        with self._lock:
            return dict(self.taken)
