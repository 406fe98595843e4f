"""Faults a mission can be given, one type for both backends (in-process and processes).

Kinds and their ``value``:

- ``abort``: the vehicle announces an abort and heads for the rendezvous;
- ``kill``: its agent dies silently (the vehicle is dead in the water where it stopped);
- ``restart``: a killed agent comes back from its journal;
- ``partition``: the vehicle is cut off from everyone for ``value`` seconds;
- ``stall``: the vehicle's host is starved of CPU for ``value`` seconds: its agent is frozen
  for the first half of every `STALL_PERIOD_S`. The vehicle is fine; only its computer runs
  late. In process its steps are deferred (mission time: the worst case, no pacing); with the
  processes it gets SIGSTOP and SIGCONT in wall time at the requested warp, as a busy
  machine would, so a clock the pacing rule slows shortens the stall in mission time;
- ``loss``: extra uniform link loss ``value`` (0..1) from then on;
- ``forge``, ``replay``, ``garbage``: an intruder's modem transmits ``value`` hostile frames
  (forged under a wrong key, replays of overheard frames, random bytes), one every 3.7 s;
- ``all-cleared``, ``claim-own``, ``claim-all``, ``abort-as``, ``phantom``, ``busy-hold``:
  the *insider* ``vid`` (a vehicle whose credentials leaked) attacks ``value`` times, 3.7 s
  apart (`cotsfleet.mission.insider`: what each sends and what stops it).
- ``ctl``: the operator's live order ``words`` (`fleet_bus.orders.parse_words`: ``recall
  auv2``, ``pause all``, ``drop-spot 17``, ...) goes out from the topside modem; with
  ``unsigned`` first, an insider holding the fleet key but not the topside's chain sends it.

`check_schedule` refuses faults that cannot happen (a restart without an earlier kill, a
kill of a vehicle already dead, anything after the mission's end), with the reason.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Iterable, Sequence

from fleet_bus.orders import ALL, Order, OrderError, parse_words
from fleet_bus.states import FaultKind

_F = FaultKind  # the kinds as plain strings (what messages and reports print)
VEHICLE_FAULTS = tuple(k.value for k in (_F.ABORT, _F.KILL, _F.RESTART, _F.PARTITION, _F.STALL))
OUTSIDER_ATTACKS = tuple(k.value for k in (_F.FORGE, _F.REPLAY, _F.GARBAGE))
INSIDER_ATTACKS = tuple(k.value for k in (_F.ALL_CLEARED, _F.CLAIM_OWN, _F.CLAIM_ALL, _F.ABORT_AS,
                                          _F.PHANTOM, _F.BUSY_HOLD))
ATTACKS = (*OUTSIDER_ATTACKS, *INSIDER_ATTACKS)
FAULT_KINDS = tuple(k.value for k in FaultKind)  # `fleet_bus.states.FaultKind`: named once
VEHICLE_FLAGS = ("aborted", "killed", "restarted", "stalled")  # a report's per-vehicle marks
ATTACK_SPACING_S = 3.7  # between two hostile frames of one attack
DEFAULT_PARTITION_S = 300.0
DEFAULT_STALL_S = 300.0
STALL_PERIOD_S = 8.0  # a stalled host: frozen for the first half of each period, then runs
DEFAULT_ATTACK_FRAMES = 10
# An insider's steps by default: the whole lie once, 24 phantom finds (issue 31's attack), a
# busy announcement every 3.7 s for 10 minutes.
INSIDER_STEPS = {"phantom": 24, "busy-hold": 162}


class FaultError(ValueError):
    """A fault that cannot be applied to this mission (the message says why)."""


@dataclass(frozen=True)
class Fault:
    """``kind`` at simulation time ``t_s`` on vehicle ``vid`` (empty for fleet-wide kinds)."""

    kind: str
    t_s: float
    vid: str = ""
    value: float = 0.0
    words: tuple[str, ...] = ()  # a ``ctl``'s order

    def __post_init__(self) -> None:
        if self.kind not in FAULT_KINDS:
            raise FaultError(f"unknown fault {self.kind!r}; choose from {FAULT_KINDS}")
        if not (math.isfinite(self.t_s) and self.t_s >= 0):
            raise FaultError(f"fault time must be a finite number >= 0, got {self.t_s}")
        if not math.isfinite(self.value):
            raise FaultError(f"fault value must be finite, got {self.value}")
        if self.kind in VEHICLE_FAULTS and not self.vid:
            raise FaultError(f"a {self.kind} names a vehicle")
        if self.kind in INSIDER_ATTACKS and not self.vid:
            raise FaultError(f"a {self.kind} attack names its insider (--insider ID)")
        if self.kind == FaultKind.LOSS and not 0.0 <= self.value <= 1.0:
            raise FaultError(f"loss must be in [0, 1], got {self.value}")
        if self.kind in (FaultKind.PARTITION, FaultKind.STALL) and not self.value > 0:
            raise FaultError(f"a {self.kind} lasts > 0 s, got {self.value}")
        if self.kind in ATTACKS and not (self.value >= 1 and float(self.value).is_integer()):
            raise FaultError(f"an attack sends a whole number >= 1 of frames, got {self.value}")
        if self.kind == FaultKind.CTL:
            try:
                parse_words(list(self.order_words))
            except OrderError as exc:
                raise FaultError(f"--ctl: {exc}") from None

    @property
    def unsigned(self) -> bool:
        """A ``ctl`` an insider sends, unsigned by the topside's chain."""
        return bool(self.words) and self.words[0] == "unsigned"

    @property
    def order_words(self) -> tuple[str, ...]:
        return self.words[1:] if self.unsigned else self.words

    def order(self) -> Order:
        """A ``ctl``'s order, unnumbered."""
        return parse_words(list(self.order_words))

    def describe(self) -> str:
        what = {"partition": f" for {self.value:g} s", "stall": f" for {self.value:g} s",
                "loss": f" {self.value:g}",
                **{a: f" x{int(self.value)}" for a in ATTACKS}}.get(self.kind, "")
        who = (f" by insider {self.vid}" if self.kind in INSIDER_ATTACKS else f" {self.vid}") \
            if self.vid else ""
        if self.kind == FaultKind.CTL:
            what = " " + " ".join(self.words)
        return f"{self.kind}{who}{what} at t={self.t_s:g} s"

    def stall_phase(self, t_s: float) -> tuple[bool, float] | None:
        """For a stall under way at ``t_s``: whether the host is frozen then, and when that
        half of the period ends (the stall's end at the latest); None outside it."""
        end = self.t_s + self.value
        if self.kind != FaultKind.STALL or not self.t_s <= t_s < end:
            return None
        start = self.t_s + math.floor((t_s - self.t_s) / STALL_PERIOD_S) * STALL_PERIOD_S
        thaw = start + STALL_PERIOD_S / 2
        if t_s < thaw:
            return True, min(thaw, end)
        return False, min(start + STALL_PERIOD_S, end)

    def thaw_at(self, t_s: float) -> float | None:
        """For a stall: when a host frozen at ``t_s`` runs again, or None if it runs then."""
        phase = self.stall_phase(t_s)
        return phase[1] if phase is not None and phase[0] else None


def parse_at(spec: str) -> tuple[str, float]:
    """``"auv2@1200"`` -> ("auv2", 1200.0)."""
    head, sep, t = spec.partition("@")
    if not sep or not head:
        raise FaultError(f"expected NAME@SECONDS, got {spec!r}")
    try:
        t_s = float(t)
    except ValueError:
        raise FaultError(f"expected NAME@SECONDS, got {spec!r}") from None
    if not (math.isfinite(t_s) and t_s >= 0):
        raise FaultError(f"time must be a finite number >= 0 in {spec!r}")
    return head, t_s


def parse_faults(*, aborts: Iterable[str] = (), kills: Iterable[str] = (),
                 restarts: Iterable[str] = (), partitions: Iterable[str] = (),
                 losses: Iterable[str] = (), attacks: Iterable[str] = (),
                 stalls: Iterable[str] = (), insider: str | None = None,
                 ctls: Iterable[str] = ()) -> list[Fault]:
    """Faults from command-line specs: ``ID@S`` (abort, kill, restart), ``ID@S+D``
    (partition or stall for D seconds), ``P@S`` (loss P from S), ``KIND@S`` or
    ``KIND@S*N`` (attack: N frames, default 10; an insider attack's steps, by ``insider``),
    ``WORD:WORD...@S`` (an order: ``recall:auv2@1200``, ``add-spot:500:300:80@900``,
    ``unsigned:recall:auv2@1200``)."""
    faults = []
    for spec in ctls:
        head, t = parse_at(spec)
        faults.append(Fault("ctl", t, "", 0.0, tuple(head.split(":"))))
    for kind, specs in (("abort", aborts), ("kill", kills), ("restart", restarts)):
        for spec in specs:
            vid, t = parse_at(spec)
            faults.append(Fault(kind, t, vid))
    for kind, specs, default_s in (("partition", partitions, DEFAULT_PARTITION_S),
                                   ("stall", stalls, DEFAULT_STALL_S)):
        for spec in specs:
            head, _, dur = spec.partition("+")
            vid, t = parse_at(head)
            faults.append(Fault(kind, t, vid, _number(dur, spec) if dur else default_s))
    for spec in losses:
        p, t = parse_at(spec)
        faults.append(Fault("loss", t, "", _number(p, spec)))
    for spec in attacks:
        head, _, n = spec.partition("*")
        kind, t = parse_at(head)
        if kind not in ATTACKS:
            raise FaultError(f"attack kind must be one of {ATTACKS}, got {kind!r}")
        if kind in INSIDER_ATTACKS and not insider:
            raise FaultError(f"--attack {spec}: an insider attack needs --insider ID (the "
                             "vehicle whose credentials leaked)")
        who = insider if kind in INSIDER_ATTACKS else ""
        default = INSIDER_STEPS.get(kind, 1) if who else DEFAULT_ATTACK_FRAMES
        faults.append(Fault(kind, t, who or "", _number(n, spec) if n else default))
    if insider and not any(f.kind in INSIDER_ATTACKS for f in faults):
        raise FaultError(f"--insider {insider}: no insider attack to make (--attack KIND@S "
                         f"with KIND one of {INSIDER_ATTACKS})")
    return faults


def _number(text: str, spec: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise FaultError(f"not a number in {spec!r}: {text!r}") from None


def check_schedule(faults: Sequence[Fault], vehicles: Sequence[str], horizon_s: float) -> None:
    """Raise `FaultError` for a fault that cannot happen in a mission of ``vehicles`` ending
    at ``horizon_s``; the schedule is taken in time order."""
    known = set(vehicles)
    dead: set[str] = set()
    for f in sorted(faults, key=lambda f: f.t_s):
        if f.kind == FaultKind.CTL and f.order().target not in (ALL, *known):
            raise FaultError(f"{f.describe()}: unknown vehicle; the mission has {sorted(known)}")
        if f.vid and f.vid not in known:
            raise FaultError(f"{f.describe()}: unknown vehicle; the mission has {sorted(known)}")
        if f.t_s >= horizon_s:
            raise FaultError(f"{f.describe()}: after the mission's end (t={horizon_s:g} s)")
        if f.kind == FaultKind.KILL:
            if f.vid in dead:
                raise FaultError(f"{f.describe()}: {f.vid} is already dead")
            dead.add(f.vid)
        elif f.kind == FaultKind.RESTART:
            if f.vid not in dead:
                raise FaultError(f"{f.describe()}: {f.vid} is not dead then (a restart needs "
                                 "an earlier --kill)")
            dead.discard(f.vid)
        elif f.kind in (FaultKind.ABORT, FaultKind.PARTITION, FaultKind.STALL) and f.vid in dead:
            raise FaultError(f"{f.describe()}: {f.vid} is dead then")
