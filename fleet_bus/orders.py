"""The operator's live orders: what they say, and the topside modem's frames that carry them.

An order (`Order`) is ``recall``, ``abort``, ``pause`` or ``resume`` of one vehicle or all,
``add-spot X Y PRIORITY`` or ``drop-spot ID``, numbered by the operator (``seq``, one counter
per operator: the vehicles refuse a number they took before) and dated (``issued_s``, mission
time: the vehicles refuse one older than their ``ctl_max_age_s``). An add-spot also carries
its own number among the operator's add-spots (``added``, from 0): every vehicle names the
spot by it (the operator's slot ``added`` of `fleet_agent.beliefs`), so all name it alike
whatever order they hear the orders in, and all refuse it alike once the slots are full.

Under water an order travels from the topside modem (at the boat) as an ORDER frame, and the
vehicles pass it on verbatim. An insider vehicle holds the fleet key, so the fleet MAC cannot
prove an order is the operator's; an Ed25519 signature (64 B) is a whole frame. The topside
therefore has a TESLA key chain of its own (`fleet_bus.tesla`; Perrig et al., IEEE S&P 2000):
its seed is in the operator's credentials only, its commitment in the public ring. An order
sent in topside interval ``i`` (``TopsideSchedule``) carries a 4-byte tag under ``K_i``;
``K_i`` is disclosed by the topside's frames of interval ``i + lag`` on (ORDER frames carry a
key, and KEY frames carry nothing else), and the vehicles pass those on too. A vehicle acts
on an order once a disclosed key proves its tag; a frame heard after its key could be out
proves nothing (``late``). The lag leaves the vehicles room to pass a frame on while its key
is still secret. Costs: 43 B for the largest ORDER frame (8 B of them the disclosed key and
the tag), 18 B a KEY frame; an order is acted on ``lag`` intervals after it was sent at most
(60 s with 30 s intervals), earlier if a key comes sooner.

Frames (big-endian; kinds 15, 14, 13 of wire version 3, which vehicle frames never use):

    ORDER  0x3F | 0xFF | sent_s u32 | seq u32 | issued_s u32 | verb u8 | target u8 |
           args (add-spot: x dm i32, y dm i32, priority tenths u16, added u8;
                 drop-spot: spot u16) |
           disclosed key 8 | tag 4 | MAC 4
    KEY    0x3E | 0xFF | sent_s u32 | disclosed key 8 | MAC 4
    ACK    0x3D | vehicle index | sent_s u32 | seq u32 | result u8 | MAC 4

The MAC is the fleet MAC of the topside (or of the acknowledging vehicle) under a key derived
from the fleet key and the run id: it keeps outsiders' bytes out at once. An ACK says that a
vehicle took an order (``ACKED``) or why it refused it; it is not proven the vehicle's under
water (the vehicle's own signed event on the bus is).
"""

from __future__ import annotations

import hashlib
import hmac
import math
import struct
from dataclasses import dataclass, field

import msgpack

from fleet_bus import values as v
from fleet_bus.tesla import tag as _tesla_tag

VERBS = ("recall", "abort", "pause", "resume", "add-spot", "drop-spot")
VEHICLE_VERBS = VERBS[:4]
ALL = "all"
TOPSIDE = "topside"  # the topside modem's node name in the water
TOPSIDE_INDEX = 0xFF
ALL_INDEX = 0xFF
VERSION = 3
KIND_ORDER, KIND_KEY, KIND_ACK = 15, 14, 13
KEY_BYTES, TAG_BYTES, MAC_BYTES = 8, 4, 4
# Why a vehicle refused an order (counters `ctl_<reason>`, ACK results 1..); ACKED: taken.
ACKED = 0
# ``no_room``: an add-spot beyond the vehicles' operator slots; ``on_land``: one no vehicle
# can reach (appended: the ACK results of the others keep their numbers).
REFUSALS = ("unsigned", "replayed", "stale", "malformed", "unknown_spot", "no_room", "on_land")
MAX_ADDED = 255  # an add-spot's own number is one byte
MAX_SEQ = 2**32 - 1
_HEAD = struct.Struct(">BBI")  # version|kind, sender, sent_s
_ORDER = struct.Struct(">IIBB")  # seq, issued_s, verb, target
_ADD = struct.Struct(">iiHB")  # x, y in decimetres, priority in tenths, added
_DROP = struct.Struct(">H")
_ACK = struct.Struct(">IB")  # seq, result
MAX_ORDER_BYTES = _HEAD.size + _ORDER.size + _ADD.size + KEY_BYTES + TAG_BYTES + MAC_BYTES


class OrderError(ValueError):
    """An order that cannot be made or read (the message says why)."""


@dataclass(frozen=True)
class Order:
    """``verb`` for ``target`` (a vehicle id or `ALL`; add-spot and drop-spot are the fleet's),
    numbered ``seq`` by the operator and issued at mission time ``issued_s``; ``x, y,
    priority`` and ``added`` (its number among the operator's add-spots, from 0) for
    add-spot, ``spot`` (a scenario spot index) for drop-spot."""

    verb: str
    target: str = ALL
    seq: int = 0
    issued_s: float = 0.0
    x: float = 0.0
    y: float = 0.0
    priority: float = 0.0
    spot: int = -1
    added: int = 0

    def __post_init__(self) -> None:
        if self.verb not in VERBS:
            raise OrderError(f"unknown order {self.verb!r}; choose from {', '.join(VERBS)}")
        if not self.target:
            raise OrderError("an order names a vehicle or 'all'")
        if not 0 <= self.seq <= MAX_SEQ:
            raise OrderError(f"order number {self.seq} out of range")
        if not (math.isfinite(self.issued_s) and 0 <= self.issued_s <= MAX_SEQ):
            raise OrderError(f"order time {self.issued_s} out of range")
        if self.verb == "add-spot":
            if not (all(math.isfinite(c) and abs(c) < 2e8 for c in (self.x, self.y))
                    and 0 < self.priority <= 6553.5):
                raise OrderError("add-spot takes X Y in metres and a priority in (0, 6553.5]")
            if not 0 <= self.added <= MAX_ADDED:
                raise OrderError(f"add-spot number {self.added} out of range")
        if self.verb == "drop-spot" and not 0 <= self.spot < 65536:
            raise OrderError("drop-spot takes a spot id")

    def describe(self) -> str:
        if self.verb == "add-spot":
            return f"add-spot at {self.x:.0f},{self.y:.0f} priority {self.priority:g}"
        if self.verb == "drop-spot":
            return f"drop-spot {self.spot}"
        return f"{self.verb} {self.target}"

    def to_doc(self) -> dict:
        return {"verb": self.verb, "target": self.target, "seq": self.seq,
                "issued_s": self.issued_s, "x": self.x, "y": self.y,
                "priority": self.priority, "spot": self.spot, "added": self.added}

    @staticmethod
    def from_doc(doc: dict) -> "Order":
        try:
            return Order(str(doc["verb"]), str(doc.get("target", ALL)), int(doc.get("seq", 0)),
                         float(doc.get("issued_s", 0.0)), float(doc.get("x", 0.0)),
                         float(doc.get("y", 0.0)), float(doc.get("priority", 0.0)),
                         int(doc.get("spot", -1)), int(doc.get("added", 0)))
        except (KeyError, TypeError, ValueError) as exc:
            raise OrderError(f"not an order: {exc}") from None


def parse_words(words: list[str]) -> Order:
    """``["recall", "auv2"]``, ``["add-spot", "X", "Y", "P"]``, ``["drop-spot", "ID"]``
    (the command line's and the ``--ctl`` specs' words) -> an unnumbered `Order`."""
    if not words:
        raise OrderError(f"an order is one of {', '.join(VERBS)}")
    verb, rest = words[0], words[1:]
    try:
        if verb in VEHICLE_VERBS and len(rest) == 1:
            return Order(verb, rest[0])
        if verb == "add-spot" and len(rest) == 3:
            return Order(verb, ALL, x=float(rest[0]), y=float(rest[1]),
                         priority=float(rest[2]))
        if verb == "drop-spot" and len(rest) == 1:
            return Order(verb, ALL, spot=int(rest[0]))
    except ValueError as exc:
        raise OrderError(f"{' '.join(words)}: {exc}") from None
    if verb not in VERBS:
        raise OrderError(f"unknown order {verb!r}; choose from {', '.join(VERBS)}")
    raise OrderError(f"{verb} takes " + ("VEHICLE|all" if verb in VEHICLE_VERBS else
                                         "X Y PRIORITY" if verb == "add-spot" else "ID"))


# -- the operator's request on the bus (`cotsfleet ctl` -> the launcher) ----------------------

MAX_REF_CHARS = 64


def encode_request(order: Order, ref: str = "") -> bytes:
    """Payload of ``fleet/ctl/order`` (signed by the operator: `fleet_bus.auth`); ``ref``
    names the request in the launcher's answers."""
    return msgpack.packb({**order.to_doc(), "ref": ref[:MAX_REF_CHARS]})


def decode_request(payload: bytes) -> Order:
    return Order.from_doc(v.unpack_map(payload, "order"))


def request_ref(payload: bytes) -> str:
    """The ``ref`` of a request (``""`` if it has none or it is not text)."""
    ref = v.unpack_map(payload, "order").get("ref", "")
    return ref[:MAX_REF_CHARS] if isinstance(ref, str) else ""


@dataclass(frozen=True)
class Answer:
    """The launcher's word on a request (``fleet/ctl/order/answer``): the order as numbered
    (``seq`` 0 and ``error`` when refused), and who acknowledged (vehicle -> mission time the
    topside heard it) or refused it (vehicle -> reason) so far."""

    ref: str
    seq: int = 0
    order: str = ""
    targets: tuple[str, ...] = ()
    issued_s: float = 0.0
    acked: dict[str, float] = field(default_factory=dict)
    refused: dict[str, str] = field(default_factory=dict)
    error: str = ""

    def encode(self) -> bytes:
        return msgpack.packb({"ref": self.ref, "seq": self.seq, "order": self.order,
                              "targets": list(self.targets), "issued_s": self.issued_s,
                              "acked": dict(self.acked), "refused": dict(self.refused),
                              "error": self.error})

    @staticmethod
    def decode(payload: bytes) -> Answer:
        doc = v.unpack_map(payload, "order answer")
        try:
            acked, refused = doc.get("acked", {}), doc.get("refused", {})
            targets = doc.get("targets", [])
            if not (isinstance(acked, dict) and isinstance(refused, dict)
                    and isinstance(targets, list) and len(targets) <= 255):
                raise ValueError("order answer: acked and refused are maps, targets a list")
            return Answer(
                v.text(doc["ref"], "answer.ref", MAX_REF_CHARS),
                v.integer(doc.get("seq", 0), "answer.seq", 0, MAX_SEQ),
                v.text(doc.get("order", ""), "answer.order", 128),
                tuple(v.text(t, "answer.targets", 64) for t in targets),
                v.number(doc.get("issued_s", 0.0), "answer.issued_s"),
                {v.text(k, "answer.acked", 64): v.number(t, "answer.acked")
                 for k, t in acked.items()},
                {v.text(k, "answer.refused", 64): v.text(r, "answer.refused", 32)
                 for k, r in refused.items()},
                v.text(doc.get("error", ""), "answer.error", 256))
        except (KeyError, TypeError) as exc:
            raise ValueError(f"order answer: {exc!r}") from None


# -- the topside's key schedule ------------------------------------------------------------------


@dataclass(frozen=True)
class TopsideSchedule:
    """The topside's TESLA intervals: interval ``i`` (chain index, from 1) is
    ``[(i - 1) * interval_s, i * interval_s)``; its key is disclosed from interval ``i + lag``."""

    interval_s: float = 30.0
    lag: int = 2

    @staticmethod
    def for_fleet(cycle_s: float) -> "TopsideSchedule":
        """Intervals of at least two TDMA cycles, so that every vehicle has a slot to pass a
        frame on before its key is out (30 s up to 12 vehicles of 2.5 s slots)."""
        return TopsideSchedule(max(30.0, 2.0 * cycle_s), 2)

    def interval(self, sent_s: float) -> int:
        return int(sent_s // self.interval_s) + 1

    def disclosure_s(self, interval: int) -> float:
        """The earliest time the key of ``interval`` may be out."""
        return (interval - 1 + self.lag) * self.interval_s

    def disclosed_in(self, sent_s: float) -> int:
        """The interval whose key a frame sent at ``sent_s`` discloses (0: none yet)."""
        return max(0, self.interval(sent_s) - self.lag)


def _mac_key(fleet_key: bytes, run_id: str, who: int) -> bytes:
    return hmac.new(fleet_key, b"cotsfleet orders v1\x00" + run_id.encode() + bytes([who]),
                    hashlib.sha256).digest()


@dataclass(frozen=True)
class OrderFrame:
    """An ORDER frame, read: the order, when the topside sent it, the key it discloses, and
    what its tag covers."""

    order: Order
    sent_s: int
    disclosed: bytes
    data: bytes
    tag: bytes


@dataclass(frozen=True)
class KeyFrame:
    sent_s: int
    disclosed: bytes


@dataclass(frozen=True)
class AckFrame:
    vehicle: int
    sent_s: int
    seq: int
    result: int  # ACKED or 1 + the index of the refusal in REFUSALS


TopsideFrame = OrderFrame | KeyFrame | AckFrame


def is_topside_frame(data: bytes) -> bool:
    """Whether ``data`` is one of this module's frames (the agent reads it here, not with its
    own codec)."""
    return len(data) > 1 and data[0] >> 4 == VERSION and data[0] & 0x0F in (
        KIND_ORDER, KIND_KEY, KIND_ACK)


class OrderCodec:
    """The orders' frames of one run: the fleet key, the run id, the roster's vehicle ids."""

    def __init__(self, fleet_key: bytes, run_id: str, vehicles: tuple[str, ...]) -> None:
        if len(vehicles) > 254:
            raise ValueError("orders address at most 254 vehicles (255 is 'all')")
        self.vehicles = tuple(vehicles)
        self._keys = {w: _mac_key(fleet_key, run_id, w)
                      for w in (TOPSIDE_INDEX, *range(len(vehicles)))}

    def _mac(self, who: int, data: bytes) -> bytes:
        return hmac.new(self._keys[who], data, hashlib.sha256).digest()[:MAC_BYTES]

    def order(self, order: Order, sent_s: float, chain_key: bytes, disclosed: bytes) -> bytes:
        target = ALL_INDEX if order.target == ALL else self.vehicles.index(order.target)
        head = _HEAD.pack(VERSION << 4 | KIND_ORDER, TOPSIDE_INDEX, int(sent_s))
        body = _ORDER.pack(order.seq, int(order.issued_s), VERBS.index(order.verb), target)
        if order.verb == "add-spot":
            body += _ADD.pack(round(order.x * 10), round(order.y * 10),
                              round(order.priority * 10), order.added)
        elif order.verb == "drop-spot":
            body += _DROP.pack(order.spot)
        data = head + body + bytes(disclosed)
        data += _tesla_tag(chain_key, data)
        return data + self._mac(TOPSIDE_INDEX, data)

    def key(self, sent_s: float, disclosed: bytes) -> bytes:
        data = _HEAD.pack(VERSION << 4 | KIND_KEY, TOPSIDE_INDEX, int(sent_s)) + disclosed
        return data + self._mac(TOPSIDE_INDEX, data)

    def ack(self, vehicle: int, sent_s: float, seq: int, result: int) -> bytes:
        data = _HEAD.pack(VERSION << 4 | KIND_ACK, vehicle, int(sent_s)) + _ACK.pack(seq, result)
        return data + self._mac(vehicle, data)

    def read(self, frame: bytes) -> TopsideFrame:
        """The frame, its MAC checked; `OrderError` (``str`` = the reason) otherwise."""
        if not is_topside_frame(frame) or len(frame) < _HEAD.size + MAC_BYTES:
            raise OrderError("malformed")
        kind, who, sent_s = _HEAD.unpack_from(frame)
        kind &= 0x0F
        if who not in self._keys or (kind == KIND_ACK) == (who == TOPSIDE_INDEX):
            raise OrderError("malformed")
        data, mac = frame[:-MAC_BYTES], frame[-MAC_BYTES:]
        if not hmac.compare_digest(self._mac(who, data), mac):
            raise OrderError("mac")
        body = data[_HEAD.size:]
        if kind == KIND_KEY:
            if len(body) != KEY_BYTES:
                raise OrderError("malformed")
            return KeyFrame(sent_s, bytes(body))
        if kind == KIND_ACK:
            if len(body) != _ACK.size:
                raise OrderError("malformed")
            seq, result = _ACK.unpack(body)
            return AckFrame(who, sent_s, seq, result)
        return self._order(sent_s, data, body)

    def _order(self, sent_s: int, data: bytes, body: bytes) -> OrderFrame:
        if len(body) < _ORDER.size + KEY_BYTES + TAG_BYTES:
            raise OrderError("malformed")
        seq, issued, verb_no, target = _ORDER.unpack_from(body)
        args = body[_ORDER.size:-(KEY_BYTES + TAG_BYTES)]
        if verb_no >= len(VERBS) or issued > sent_s:
            raise OrderError("malformed")
        verb = VERBS[verb_no]
        try:
            who = ALL if target == ALL_INDEX else self.vehicles[target]
        except IndexError:
            raise OrderError("malformed") from None
        try:
            if verb == "add-spot" and len(args) == _ADD.size:
                x, y, p, added = _ADD.unpack(args)
                order = Order(verb, who, seq, issued, x / 10, y / 10, p / 10, added=added)
            elif verb == "drop-spot" and len(args) == _DROP.size:
                order = Order(verb, who, seq, issued, spot=_DROP.unpack(args)[0])
            elif verb in VEHICLE_VERBS and not args:
                order = Order(verb, who, seq, issued)
            else:
                raise OrderError("malformed")
        except OrderError:
            raise OrderError("malformed") from None
        tail = body[-(KEY_BYTES + TAG_BYTES):]
        return OrderFrame(order, sent_s, bytes(tail[:KEY_BYTES]),
                          bytes(data[:-TAG_BYTES]), bytes(tail[KEY_BYTES:]))
