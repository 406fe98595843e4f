"""Application-level authentication of every bus message that is not an acoustic frame's body.

Every payload a fleet process puts on Zenoh (commands, link control, the mission and clock
records, telemetry, link records and stats, the relay's deliveries, the agents' frames to the
relay, readiness) travels in a signed envelope::

    b"CFA1" | u8 signer length | signer id | u64 counter | payload | Ed25519 signature (64)

The signature covers a domain tag, the run id, the key expression, the signer, the counter and
the payload: a message cannot be moved to another key (an ``abort`` for auv1 is not one for
auv2), to another run, or sent twice. Counters start at the sender's wall clock in
microseconds and grow by one per message, so a restarted process continues above what it sent
before; receivers keep a sliding window per signer (Zenoh may reorder messages of one sender
across keys and threads) and refuse what is below it or already seen.

Who may sign what (`allowed`): the operator (the launcher) alone commands, serves the mission
and clock records and controls the link; vehicle X alone speaks on ``fleet/<kind>/X``; the
relay alone delivers (``fleet/rx``), reports link fates and serves link stats; a remote ground
station (role ``ground``: `cotsfleet ctl --connect` on another host) signs only order
requests (``fleet/ctl/order``), as the operator may too. A receiver refuses an envelope whose
signer is not allowed on its key, and counts every refusal by reason.

Queries are signed too (`seal_query`, `open_query`): the envelope rides as the query's
attachment, under the signing key ``fleet/query/<signer>`` (anyone of the ring, for itself
only) over the key asked and a nonce, so a queryable knows who asks and can ration each
asker (`fleet_bus.query_limits`).

The private keys never travel on the bus: the launcher writes a run's credentials
(`fleet_bus.credentials`) and hands each process its own key file.
"""

from __future__ import annotations

import struct
import threading
import time
from collections import Counter
from dataclasses import dataclass, field
from typing import Mapping

from cryptography.exceptions import InvalidSignature
from cryptography.hazmat.primitives.asymmetric.ed25519 import Ed25519PrivateKey, Ed25519PublicKey

from fleet_bus import keys

MAGIC = b"CFA1"
DOMAIN = b"cotsfleet-bus-v1\x00"
SIG_BYTES = 64
_COUNTER = struct.Struct("<Q")
MIN_ENVELOPE = len(MAGIC) + 1 + 1 + _COUNTER.size + SIG_BYTES
REPLAY_WINDOW = 4096  # counters this far below a signer's highest are still accepted once

OPERATOR, VEHICLE, RELAY, GROUND = "operator", "vehicle", "relay", "ground"
ROLES = (OPERATOR, VEHICLE, RELAY, GROUND)
OPERATOR_ID, RELAY_ID, GROUND_ID = "operator", "relay", "ground"
QUERY_KIND = "query"  # the signing key of a query: fleet/query/<signer> (never on the bus)

# Why an envelope was refused (the counters every receiver keeps).
REFUSALS = ("malformed", "unknown_signer", "not_allowed", "bad_signature", "replay", "invalid")

# Which role may sign on which kind of key; vehicles only on keys ending with their own id.
_KIND_ROLE = {"ctl": OPERATOR, "tx": VEHICLE, "truth": VEHICLE, "status": VEHICLE, "event": VEHICLE,
              "alive": VEHICLE, "busy": VEHICLE, "rx": RELAY, "link": RELAY, "stats": RELAY}


class Refused(ValueError):
    """An envelope that is not accepted; ``reason`` is one of `REFUSALS`."""

    def __init__(self, reason: str, detail: str = "") -> None:
        super().__init__(f"{reason}: {detail}" if detail else reason)
        self.reason = reason


def allowed(key: str, signer: str, role: str) -> bool:
    """Whether ``signer`` of ``role`` may sign a message on ``key``."""
    if key == keys.ORDER_REQUEST:  # `cotsfleet ctl`: the operator's, or a remote ground's
        return role in (OPERATOR, GROUND)
    if role == GROUND:  # nothing else: not even its own queries (it never asks)
        return False
    if key in (keys.MISSION, keys.CLOCK):  # the operator's two records
        return role == OPERATOR
    try:
        kind = keys.kind_of(key)
    except ValueError:
        return False
    if kind == QUERY_KIND:  # every member signs its own queries, and only its own
        return keys.vid_of(key) == signer
    need = _KIND_ROLE.get(kind)
    if need is None or need != role:
        return False
    if role == VEHICLE:
        return keys.vid_of(key) == signer
    return True


def _signed_bytes(run_id: str, key: str, signer: bytes, counter: bytes, payload: bytes) -> bytes:
    return b"".join((DOMAIN, run_id.encode(), b"\x00", key.encode(), b"\x00", signer, counter,
                     payload))


class Signer:
    """One process's private key: seals payloads for the keys it may speak on."""

    def __init__(self, signer_id: str, private: Ed25519PrivateKey, run_id: str) -> None:
        if not 0 < len(signer_id.encode()) < 256:
            raise ValueError(f"signer id must be 1..255 bytes: {signer_id!r}")
        self.id, self.run_id = signer_id, run_id
        self._id = signer_id.encode()
        self._private = private
        self._lock = threading.Lock()
        self._counter = time.time_ns() // 1000  # above anything an earlier incarnation sent

    def seal(self, key: str, payload: bytes) -> bytes:
        """The envelope of ``payload`` for ``key`` (thread-safe)."""
        with self._lock:
            self._counter += 1
            counter = _COUNTER.pack(self._counter)
        sig = self._private.sign(_signed_bytes(self.run_id, key, self._id, counter, payload))
        return b"".join((MAGIC, bytes((len(self._id),)), self._id, counter, payload, sig))


@dataclass(frozen=True)
class Member:
    """A public key of the ring and the role it speaks with."""

    role: str
    public: Ed25519PublicKey


@dataclass
class _Window:
    highest: int = -1
    seen: set[int] = field(default_factory=set)

    def fresh(self, counter: int) -> bool:
        return counter > self.highest - REPLAY_WINDOW and counter not in self.seen

    def accept(self, counter: int) -> bool:
        if not self.fresh(counter):
            return False
        self.seen.add(counter)
        if counter > self.highest:
            self.highest = counter
            floor = counter - REPLAY_WINDOW
            if len(self.seen) > 2 * REPLAY_WINDOW:  # bounded: forget what the window left
                self.seen = {c for c in self.seen if c > floor}
        return True


class Verifier:
    """The public key ring of a run: opens envelopes, refuses and counts the rest.

    ``unknown ids`` cost nothing but a dictionary look-up; a forged signature costs one
    Ed25519 verification (tens of microseconds), which bounds what a flood can make us spend.
    """

    def __init__(self, ring: Mapping[str, Member], run_id: str) -> None:
        self.ring, self.run_id = dict(ring), run_id
        self.refused: Counter[str] = Counter()
        self.accepted = 0
        # One replay window per (signer, key expression): the signature covers the key, so a
        # message cannot be replayed on another key anyway, and one login's messages on one
        # key (an insider's busy flags) cannot push the window past its genuine messages on
        # another (the vehicle's statuses). Created only for a valid signature of a ring
        # member on a key it may use: a finite set per mission.
        self._windows: dict[tuple[str, str], _Window] = {}
        self._lock = threading.Lock()

    def open(self, key: str, envelope: bytes) -> tuple[str, bytes]:
        """``(signer id, payload)``; raises `Refused` (counted) otherwise."""
        try:
            return self._open(key, envelope)
        except Refused as exc:
            with self._lock:
                self.refused[exc.reason] += 1
            raise

    def refuse(self, reason: str) -> None:
        """Count a refusal found after opening (e.g. a value a decoder rejected)."""
        with self._lock:
            self.refused[reason] += 1

    def take_refused(self) -> Counter[str]:
        """The refusals since the last call (for counters kept elsewhere)."""
        with self._lock:
            out, self.refused = self.refused, Counter()
        return out

    def _open(self, key: str, envelope: bytes) -> tuple[str, bytes]:
        if len(envelope) < MIN_ENVELOPE or not envelope.startswith(MAGIC):
            raise Refused("malformed", "not an envelope")
        n = envelope[len(MAGIC)]
        start = len(MAGIC) + 1
        signer_raw = envelope[start:start + n]
        pos = start + n
        if n == 0 or len(envelope) < pos + _COUNTER.size + SIG_BYTES:
            raise Refused("malformed", "truncated")
        try:
            signer = signer_raw.decode()
        except UnicodeDecodeError:
            raise Refused("malformed", "signer id") from None
        member = self.ring.get(signer)
        if member is None:
            raise Refused("unknown_signer", signer[:64])
        if not allowed(key, signer, member.role):
            raise Refused("not_allowed", f"{signer} on {key}")
        counter_raw = envelope[pos:pos + _COUNTER.size]
        payload = envelope[pos + _COUNTER.size:-SIG_BYTES]
        (counter,) = _COUNTER.unpack(counter_raw)
        with self._lock:  # a replay is refused before paying for a signature check
            window = self._windows.get((signer, key))
            if window is not None and not window.fresh(counter):
                raise Refused("replay", f"{signer} #{counter}")
        try:
            member.public.verify(envelope[-SIG_BYTES:], _signed_bytes(
                self.run_id, key, signer_raw, counter_raw, payload))
        except InvalidSignature:
            raise Refused("bad_signature", signer) from None
        with self._lock:
            window = self._windows.setdefault((signer, key), _Window())
            if not window.accept(counter):
                raise Refused("replay", f"{signer} #{counter}")
            self.accepted += 1
        return signer, payload


@dataclass
class BusAuth:
    """What one process holds: the run's public ring and, if it speaks, its own key.

    ``signer`` is None for a process that only listens (the ground station)."""

    verifier: Verifier
    signer: Signer | None = None

    @property
    def run_id(self) -> str:
        return self.verifier.run_id

    def seal(self, key: str, payload: bytes) -> bytes:
        if self.signer is None:
            raise PermissionError("this process holds no signing key")
        return self.signer.seal(key, payload)

    def open(self, key: str, envelope: bytes) -> tuple[str, bytes]:
        return self.verifier.open(key, envelope)

    def open_payload(self, key: str, envelope: bytes) -> bytes | None:
        """The payload, or None if refused (and counted)."""
        try:
            return self.verifier.open(key, envelope)[1]
        except Refused:
            return None


def query_key(signer: str) -> str:
    """The key a query by ``signer`` is signed under (a signing domain, not a bus key)."""
    return f"{keys.PREFIX}/{QUERY_KIND}/{signer}"


def _query_payload(key: str, nonce: str) -> bytes:
    return key.encode() + b"?" + nonce.encode()


def signer_of(envelope: bytes) -> str | None:
    """The signer an envelope names, unchecked (to choose whose allowance to look at before
    paying for its signature); None for anything that is not an envelope."""
    if len(envelope) < MIN_ENVELOPE or not envelope.startswith(MAGIC):
        return None
    n = envelope[len(MAGIC)]
    try:
        return envelope[len(MAGIC) + 1:len(MAGIC) + 1 + n].decode() or None
    except UnicodeDecodeError:
        return None


def seal_query(auth: BusAuth | None, key: str, nonce: str) -> bytes | None:
    """The attachment of a signed query of ``key`` (``nonce`` in its parameters), or None for
    a process that holds no signing key (its queries go unsigned)."""
    if auth is None or auth.signer is None:
        return None
    return auth.signer.seal(query_key(auth.signer.id), _query_payload(key, nonce))


def open_query(auth: BusAuth, key: str, nonce: str, attachment: bytes) -> str:
    """Who signed this query of ``key``; raises `Refused` (counted) if no one did."""
    signer = signer_of(attachment)
    if signer is None:
        auth.verifier.refuse("malformed")
        raise Refused("malformed", "query attachment")
    who, payload = auth.open(query_key(signer), attachment)
    if payload != _query_payload(key, nonce):
        auth.verifier.refuse("invalid")
        raise Refused("invalid", "query signed for another key or nonce")
    return who


def seal(auth: BusAuth | None, key: str, payload: bytes) -> bytes:
    """``payload`` sealed for ``key``, or as is on an open bus (``auth`` None: a process
    started by hand without ``--credentials``, for experiments only)."""
    return payload if auth is None else auth.seal(key, payload)


def unseal(auth: BusAuth | None, key: str, envelope: bytes) -> bytes | None:
    """The payload of an accepted envelope (as is on an open bus), or None (counted)."""
    return envelope if auth is None else auth.open_payload(key, envelope)
