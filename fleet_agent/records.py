"""What the agent journals: typed records, their documents, and their parsing.

Each record knows its journal document (a small msgpack map, key ``k`` names the kind) and
whether it must be durable (fsync'ed: what was cleared, promised or decided by this vehicle).
`parse` turns a document back into a record, or None for one it cannot read (a damaged or
foreign record costs that record, never the journal).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping, Union

JOURNAL_VERSION = 1


@dataclass(frozen=True)
class Start:
    """A fresh agent: which vehicle, which journal format."""

    t_s: float
    index: int
    durable = True

    def doc(self) -> dict[str, Any]:
        return {"k": "start", "t": self.t_s, "v": JOURNAL_VERSION, "i": self.index}


@dataclass(frozen=True)
class Clear:
    """Spots known cleared; ``own``: this vehicle injected them (durable)."""

    t_s: float
    tasks: tuple[int, ...]
    own: bool
    # Where this vehicle's camera measured what it injected (x, y, sigma; map frame), if it
    # said: what later sightings are held against (`policies.discovery.treated_estimates`).
    at: tuple[float, float, float] | None = None

    @property
    def durable(self) -> bool:
        return self.own

    def doc(self) -> dict[str, Any]:
        doc: dict[str, Any] = {"k": "clr", "t": self.t_s, "ids": list(self.tasks),
                               "own": self.own}
        if self.at is not None:
            doc["at"] = [round(c, 2) for c in self.at]
        return doc


@dataclass(frozen=True)
class Hold:
    """A claim (``claim``) or release by vehicle ``v`` at ``t_s`` (own ones are durable)."""

    v: int
    t_s: int
    tasks: tuple[int, ...]
    claim: bool
    durable: bool = False

    def doc(self) -> dict[str, Any]:
        return {"k": "hold", "v": self.v, "t": self.t_s, "ids": list(self.tasks), "c": self.claim}


@dataclass(frozen=True)
class PeerState:
    """What this vehicle concluded about a peer (alive, lost, aborted, home) at ``t_s``."""

    v: int
    status: str
    t_s: float
    durable = False

    def doc(self) -> dict[str, Any]:
        return {"k": "peer", "v": self.v, "s": self.status, "t": self.t_s}


@dataclass(frozen=True)
class Aborted:
    t_s: float
    durable = True

    def doc(self) -> dict[str, Any]:
        return {"k": "abort", "t": self.t_s}


@dataclass(frozen=True)
class Home:
    t_s: float
    durable = True

    def doc(self) -> dict[str, Any]:
        return {"k": "home", "t": self.t_s}


@dataclass(frozen=True)
class Restarted:
    t_s: float
    durable = True

    def doc(self) -> dict[str, Any]:
        return {"k": "restart", "t": self.t_s}


@dataclass(frozen=True)
class Checkpoint:
    """Where the vehicle was and what it was doing: position, distance run, route, last
    sequence number, replay high-water marks, and when it got home (if it did)."""

    t_s: float
    pos: tuple[float, float, float]
    distance_m: float
    route: tuple[int, ...]
    seq: int
    high_water: Mapping[int, int]
    home_at_s: float | None
    durable = False

    def doc(self) -> dict[str, Any]:
        return {"k": "ckpt", "t": self.t_s, "pos": list(self.pos), "dist": self.distance_m,
                "route": list(self.route), "seq": self.seq,
                "hw": {str(s): q for s, q in self.high_water.items()}, "home": self.home_at_s}


@dataclass(frozen=True)
class FoundSpot:
    """A find (own or heard) in a dynamic mission: its slot, position, rho and t. Durable
    when this vehicle named it: the fleet may know it only from this vehicle."""

    t_s: float
    slot: int
    pos: tuple[float, float, float]
    priority: float
    service_s: float
    durable: bool = False
    sigma_m: float = 0.0  # its finder's navigation sigma (`beliefs.Find`)

    def doc(self) -> dict[str, Any]:
        return {"k": "find", "t": self.t_s, "s": self.slot, "pos": list(self.pos),
                "r": self.priority, "d": self.service_s, "sig": self.sigma_m}


@dataclass(frozen=True)
class OrderTaken:
    """The operator's order ``seq`` taken at ``t_s`` (its verb, for a restart's pause):
    read back by `policies.orders`, so a repeat is never acted on twice."""

    t_s: float
    seq: int
    verb: str
    durable: bool = True

    def doc(self) -> dict[str, Any]:
        return {"k": "ord", "t": self.t_s, "n": self.seq, "verb": self.verb}


@dataclass(frozen=True)
class SpotAdded:
    """The operator's add-spot taken at ``t_s``: the spot in operator slot ``slot``, where,
    rho and t (`beliefs.Beliefs.add_spot`). Durable: the order is taken once, so a restarted
    agent rebuilds the spot from this record, never from the order again."""

    t_s: float
    slot: int
    pos: tuple[float, float, float]
    priority: float
    service_s: float
    durable: bool = True

    def doc(self) -> dict[str, Any]:
        return {"k": "add", "t": self.t_s, "s": self.slot, "pos": list(self.pos),
                "r": self.priority, "d": self.service_s}


@dataclass(frozen=True)
class Doubt:
    """Spots this vehicle left out of its plans at ``t_s`` without clearing them
    (`Knowledge.doubtful`: a peer was seen at work there, a look showed another's find, a lost
    peer probably treated them). Durable: forgotten in a restart, the spot would be planned
    again while the peer that works it may be the one whose clear is lost."""

    t_s: float
    tasks: tuple[int, ...]
    durable: bool = True

    def doc(self) -> dict[str, Any]:
        return {"k": "doubt", "t": self.t_s, "ids": list(self.tasks)}


JournalRecord = Union[Start, Clear, Hold, PeerState, Aborted, Home, Restarted, Checkpoint,
                      FoundSpot, OrderTaken, SpotAdded, Doubt]


def _ints(value: Any) -> tuple[int, ...]:
    return tuple(int(x) for x in value)


def _at(value: Any) -> tuple[float, float, float]:
    x, y, sigma = (float(c) for c in value)
    if not all(math.isfinite(c) for c in (x, y, sigma)) or sigma < 0:
        raise ValueError(f"not a position and sigma: {value!r}")
    return x, y, sigma


def parse(doc: Mapping[str, Any]) -> JournalRecord | None:
    """The record a journal document holds, or None if it is not one this agent can read."""
    try:
        k = doc.get("k")
        t = float(doc["t"])
        if k == "clr":
            at = doc.get("at")
            return Clear(t, _ints(doc["ids"]), bool(doc.get("own")),
                         None if at is None else _at(at))
        if k == "doubt":
            return Doubt(t, _ints(doc["ids"]))
        if k == "hold":
            return Hold(int(doc["v"]), int(doc["t"]), _ints(doc["ids"]), bool(doc["c"]))
        if k == "peer":
            return PeerState(int(doc["v"]), str(doc["s"]), t)
        if k == "abort":
            return Aborted(t)
        if k == "home":
            return Home(t)
        if k == "restart":
            return Restarted(t)
        if k == "start":
            return Start(t, int(doc.get("i", -1)))
        if k in ("find", "add"):
            pos = tuple(float(c) for c in doc["pos"])
            if len(pos) != 3:
                return None
            if k == "add":
                return SpotAdded(t, int(doc["s"]), pos, float(doc["r"]), float(doc["d"]))
            return FoundSpot(t, int(doc["s"]), pos, float(doc["r"]),
                             float(doc["d"]), sigma_m=float(doc.get("sig", 0.0)))
        if k == "ckpt":
            pos = tuple(float(c) for c in doc["pos"])
            if len(pos) != 3:
                return None
            home = doc.get("home")
            return Checkpoint(t, pos, float(doc.get("dist", 0.0)),
                              _ints(doc.get("route", [])), int(doc.get("seq", -1)),
                              {int(s): int(q) for s, q in doc.get("hw", {}).items()},
                              None if home is None else float(home))
    except (KeyError, TypeError, ValueError, AttributeError):
        return None
    return None
