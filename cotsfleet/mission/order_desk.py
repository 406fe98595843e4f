"""The launcher's desk for the operator's live orders in a multi-process mission.

`cotsfleet ctl` (the operator's terminal) signs an order request with the operator's key and
puts it on ``fleet/ctl/order`` (`fleet_bus.orders.encode_request`). The desk opens it with a
verifier of its own over the run's ring (so its refusals are counted apart, as the report's
``security.orders``), hands the order to the topside (`cotsfleet.mission.topside`: numbered,
dated, sent until acknowledged, its key chain disclosed) and answers on
``fleet/ctl/order/answer`` (`fleet_bus.orders.Answer`): accepted as number N, then each
acknowledgement or refusal the topside hears through the water.

Zenoh's threads call `request` and `hear`; the launcher's loop calls `due` (what to transmit
now, and the answers to publish). One lock guards the topside. Requests wait in a bounded
queue (`MAX_QUEUED`): a flood of signed requests costs the flooder its own requests.
"""

from __future__ import annotations

import threading
from collections import deque
from dataclasses import dataclass
from typing import Any

from cotsfleet.mission.topside import Topside
from fleet_bus import keys
from fleet_bus.auth import Refused, Verifier
from fleet_bus.credentials import OPERATOR_ID
from fleet_bus.orders import ALL, Answer, Order, OrderError, decode_request, request_ref

MAX_QUEUED = 64  # requests taken but not yet handed to the topside


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
        self._lock = threading.Lock()
        self._queue: deque[tuple[Order | None, str, str]] = deque()  # order, ref, error
        self._refs: dict[int, str] = {}  # order number -> the request's ref
        self._told: dict[int, tuple[int, int]] = {}  # seq -> (acks, refusals) answered
        self._next_s: float | None = None

    def _count(self, reason: str) -> None:
        with self._lock:
            self.refused[reason] = self.refused.get(reason, 0) + 1

    # -- Zenoh's threads ----------------------------------------------------------------------

    def request(self, envelope: bytes) -> None:
        """A sample of ``fleet/ctl/order``: queued if the operator signed it and it is an
        order; refused and counted otherwise (no answer: whoever sent it is not the
        operator's terminal)."""
        try:
            signer, payload = self.verifier.open(keys.ORDER_REQUEST, envelope)
        except Refused as exc:
            return self._count(exc.reason)
        if signer != OPERATOR_ID:  # another operator-role signer (none in a run's ring)
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
            if len(self._queue) >= MAX_QUEUED:
                self.refused["flood"] = self.refused.get("flood", 0) + 1
                return
            self._queue.append((order, ref, error))

    def hear(self, frame: bytes, now: float) -> None:
        """A frame the water delivered to the topside (``fleet/rx/topside``, the relay's)."""
        if self.topside is None:
            return
        with self._lock:  # an ack only ever closes an order: the schedule stands
            self.topside.hear(frame, now)

    # -- the launcher's loop ------------------------------------------------------------------

    def submit(self, order: Order, now: float, ref: str = "") -> Answer:
        """Hand ``order`` to the topside now (a request, or a scheduled ``--ctl``)."""
        with self._lock:
            return self._submit(order, now, ref)

    def _submit(self, order: Order, now: float, ref: str) -> Answer:
        if self.topside is None:
            self.refused["unavailable"] = self.refused.get("unavailable", 0) + 1
            return Answer(ref, order=order.describe(), error=self.unavailable)
        try:
            numbered = self.topside.submit(order, now)
        except OrderError as exc:
            self.refused["invalid"] = self.refused.get("invalid", 0) + 1
            return Answer(ref, order=order.describe(), error=str(exc))
        self._refs[numbered.seq] = ref
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
                order, ref, error = self._queue.popleft()
                if order is None:
                    self.refused["invalid"] = self.refused.get("invalid", 0) + 1
                    out.answers.append(Answer(ref, error=error))
                else:
                    out.answers.append(self._submit(order, now, ref))
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
            return self.topside.section(counters)

    def refusals(self) -> dict[str, int]:
        with self._lock:
            return {k: n for k, n in self.refused.items() if n}
