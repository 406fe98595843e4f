"""A run's credentials on disk: one directory per process, holding only what it needs.

``write_run_credentials(root, vehicles)`` makes, for a fresh run id, one of two kinds.

With ``tls=True`` (across machines; what ``cotsfleet credentials`` makes), identity is a
certificate of the mission's CA (`fleet_bus.certificates`) and there is no password at all::

    root/ring.json                  the public ring: run id, every signer's role and public key
    root/ca.pem                     the mission's CA certificate (its key is never written)
    root/<id>/ring.json, ca.pem     the same, in every process's directory
    root/<id>/tls.key, tls.pem      its own TLS key and certificate (common name: its id)
    root/<id>/signing.key           its own Ed25519 private key (operator, relay, ground,
                                    vehicles)
    root/<vehicle>/frames.key       its own key chain's seed for the acoustic frames
                                    (`fleet_bus.tesla`; the ring holds every commitment)
    root/operator/frames.key        the topside modem's key chain seed: the operator's live
                                    orders (`fleet_bus.orders`; the ring holds its commitment)

for ``operator``, ``relay``, ``ground`` (a ground station elsewhere that orders the fleet:
`cotsfleet ctl --connect`; its key signs order requests only, and the router lets it put
those and hear their answers, nothing else), ``station`` and ``world`` (no signing key:
they only listen;
``world`` is the simulated world's processes, e.g. the ROS 2 vehicles that follow the mission
clock), ``router`` (the operator's host's router; its certificate also names ``hosts``) and
every vehicle; and, for each vehicle of ``linked_routers``, ``router-<id>``: the router of
that vehicle's own host, linked to the operator's, which may forward only what that vehicle
may say.

Without it (one host, loopback only: `fleet_bus.session` refuses these across machines),
identity is a Zenoh user/password login::

    root/ring.json, root/<id>/ring.json, root/<id>/signing.key   as above
    root/<id>/zenoh.login           its own Zenoh user and password ("user:password")
    root/router/users.txt           the router's dictionary of every Zenoh login
    root/router/zid                 the Zenoh id of the mission's main router

Directories are mode 0700 and secret files 0600. A process is started with
``--credentials root/<id>``; a vehicle on another machine gets a copy of its own directory
and of its host's router's, and nothing else (`docs/security.md`).
"""

from __future__ import annotations

import json
import os
import secrets
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

from cryptography.hazmat.primitives import serialization
from cryptography.hazmat.primitives.asymmetric.ed25519 import Ed25519PrivateKey, Ed25519PublicKey

from fleet_bus.auth import (GROUND, GROUND_ID, OPERATOR, OPERATOR_ID, RELAY, RELAY_ID, ROLES,
                            VEHICLE, BusAuth, Member, Signer, Verifier)
from fleet_bus.certificates import (Authority, CertificateError, CertificateInfo, check_identity,
                                   host_name)
from fleet_bus.tesla import KEY_BYTES, FleetChains, KeyChain

RING = "ring.json"
SIGNING_KEY = "signing.key"
FRAMES_KEY = "frames.key"  # a vehicle's key chain seed (`fleet_bus.tesla`)
# Cycles a vehicle's key chain covers: 8.5 h of 3 vehicles' 7.5 s cycles, 2.8 h of one
# vehicle's 2.5 s slots; a mission longer than its chain is refused when its fleet is built.
FRAME_CHAIN_LENGTH = 4096
ZENOH_LOGIN = "zenoh.login"
ROUTER_ID, STATION_ID, WORLD_ID = "router", "station", "world"
ROUTER_USERS = "users.txt"
ROUTER_ZID = "zid"
CA_CERT, TLS_CERT, TLS_KEY = "ca.pem", "tls.pem", "tls.key"
LINKED_PREFIX = "router-"  # + a vehicle id: the router of that vehicle's host
DEFAULT_VALID_DAYS = 7.0


class CredentialsError(ValueError):
    """Credentials missing, unreadable or inconsistent (said in one line)."""


@dataclass(frozen=True)
class ZenohLogin:
    user: str
    password: str


@dataclass(frozen=True)
class TlsIdentity:
    """A process's TLS files (paths, as Zenoh's configuration takes them) and its
    certificate, checked (`load_tls`)."""

    ca: Path
    cert: Path
    key: Path
    info: CertificateInfo


def linked_router_id(vid: str) -> str:
    return LINKED_PREFIX + vid


def new_run_id() -> str:
    return time.strftime("%Y%m%d-%H%M%S") + f"-{secrets.token_hex(4)}"


def _raw_public(key: Ed25519PrivateKey) -> str:
    return key.public_key().public_bytes(serialization.Encoding.Raw,
                                         serialization.PublicFormat.Raw).hex()


def _raw_private(key: Ed25519PrivateKey) -> str:
    return key.private_bytes(serialization.Encoding.Raw, serialization.PrivateFormat.Raw,
                             serialization.NoEncryption()).hex()


def _secret_file(path: Path, text: str) -> None:
    """Create ``path`` readable by its owner only, before anything is written to it."""
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(fd, "w", encoding="utf-8") as fh:
        fh.write(text)
    os.chmod(path, 0o600)


def _private_dir(path: Path) -> Path:
    path.mkdir(parents=True, exist_ok=True, mode=0o700)
    os.chmod(path, 0o700)
    return path


def write_run_credentials(root: Path, vehicles: Sequence[str], run_id: str | None = None, *,
                          tls: bool = False, hosts: Sequence[str] = (),
                          linked_routers: Sequence[str] = (),
                          valid_days: float = DEFAULT_VALID_DAYS) -> str:
    """Generate a run's keys and identities under ``root`` (see the module docstring);
    returns the run id. ``hosts``, ``linked_routers`` and ``valid_days`` are for ``tls``."""
    run_id = run_id or new_run_id()
    for vid in vehicles:
        if (vid in (OPERATOR_ID, RELAY_ID, GROUND_ID, ROUTER_ID, STATION_ID, WORLD_ID)
                or "/" in vid or not vid or vid.startswith(LINKED_PREFIX)):
            raise CredentialsError(f"vehicle id {vid!r} cannot have credentials of its own")
    if not tls and (hosts or linked_routers):
        raise CredentialsError("hosts and linked routers are for TLS credentials")
    for vid in linked_routers:
        if vid not in vehicles:
            raise CredentialsError(f"a linked router for {vid!r}, not a vehicle of the run")
    try:  # a bad host name or validity is said before anything is written
        for host in hosts:
            host_name(host)
        authority = Authority(valid_days) if tls else None
    except CertificateError as exc:
        raise CredentialsError(str(exc)) from None
    _private_dir(root)
    signers = {OPERATOR_ID: OPERATOR, RELAY_ID: RELAY, GROUND_ID: GROUND,
               **{v: VEHICLE for v in vehicles}}
    private = {sid: Ed25519PrivateKey.generate() for sid in signers}
    # Every chain's seed is random (never derived from the fleet key, which every vehicle
    # holds): only its holder can disclose its keys. The operator's is the topside modem's.
    seeds = {vid: secrets.token_bytes(16) for vid in (*vehicles, OPERATOR_ID)}
    ring = {"run_id": run_id,
            "members": {sid: {"role": role, "public": _raw_public(private[sid])}
                        for sid, role in signers.items()},
            "frames": {"length": FRAME_CHAIN_LENGTH,
                       "commitments": {vid: KeyChain(seeds[vid], FRAME_CHAIN_LENGTH)
                                       .commitment.hex() for vid in vehicles},
                       "topside": KeyChain(seeds[OPERATOR_ID], FRAME_CHAIN_LENGTH)
                       .commitment.hex()}}
    ring_text = json.dumps(ring, indent=1)
    (root / RING).write_text(ring_text, encoding="utf-8")
    processes = (*signers, STATION_ID, WORLD_ID, ROUTER_ID,
                 *(linked_router_id(v) for v in linked_routers))
    if authority is not None:
        (root / CA_CERT).write_bytes(authority.cert_pem)
    logins = {}
    for pid in processes:
        d = _private_dir(root / pid)
        (d / RING).write_text(ring_text, encoding="utf-8")
        if pid in private:
            _secret_file(d / SIGNING_KEY, _raw_private(private[pid]) + "\n")
        if pid in seeds:
            _secret_file(d / FRAMES_KEY, seeds[pid].hex() + "\n")
        if authority is not None:
            issued = authority.issue(pid, hosts if pid == ROUTER_ID else ())
            (d / CA_CERT).write_bytes(authority.cert_pem)
            (d / TLS_CERT).write_bytes(issued.cert_pem)
            _secret_file(d / TLS_KEY, issued.key_pem.decode("ascii"))
        else:
            logins[pid] = secrets.token_hex(16)
            _secret_file(d / ZENOH_LOGIN, f"{pid}:{logins[pid]}\n")
    if authority is None:
        _secret_file(root / ROUTER_ID / ROUTER_USERS,
                     "".join(f"{user}:{pw}\n" for user, pw in logins.items()))
        # The main router's Zenoh id, so that a linked router (which logged in to it, but to
        # which it did not log in) can still tell it apart from a client. Loopback only: with
        # TLS the main router is known by its certificate instead.
        zid = secrets.choice("123456789abcdef") + secrets.token_hex(16)[1:]  # no leading 0
        (root / ROUTER_ID / ROUTER_ZID).write_text(zid + "\n", encoding="utf-8")
    return run_id


def _read(path: Path) -> str:
    try:
        return path.read_text(encoding="utf-8")
    except OSError as exc:
        raise CredentialsError(f"cannot read {path}: {exc.strerror or exc}") from None


def load_ring(directory: Path) -> Verifier:
    """The verifier of the ring in ``directory``."""
    try:
        doc = json.loads(_read(Path(directory) / RING))
        run_id = str(doc["run_id"])
        members = {}
        for sid, m in doc["members"].items():
            if m["role"] not in ROLES:
                raise ValueError(f"unknown role {m['role']!r}")
            members[str(sid)] = Member(m["role"], Ed25519PublicKey.from_public_bytes(
                bytes.fromhex(m["public"])))
    except (ValueError, KeyError, TypeError, AttributeError) as exc:
        raise CredentialsError(f"{directory}/{RING}: not a key ring ({exc})") from None
    return Verifier(members, run_id)


def load_frame_chains(directory: Path, vehicles: Sequence[str]) -> FleetChains:
    """Every vehicle's key chain commitment, from the ring in ``directory``, in roster order,
    and the topside modem's (None in a ring made before it had one: no live orders)."""
    path = Path(directory) / RING
    try:
        frames = json.loads(_read(path))["frames"]
        length = int(frames["length"])
        commitments = tuple(bytes.fromhex(frames["commitments"][vid]) for vid in vehicles)
        topside = frames.get("topside")
        topside = None if topside is None else bytes.fromhex(topside)
    except KeyError as exc:
        raise CredentialsError(f"{path}: no key chain for {exc} (credentials made for "
                               "another scenario?)") from None
    except (ValueError, TypeError, AttributeError) as exc:
        raise CredentialsError(f"{path}: not a key ring ({exc})") from None
    if length < 1 or any(len(c) != KEY_BYTES for c in commitments) or (
            topside is not None and len(topside) != KEY_BYTES):
        raise CredentialsError(f"{path}: malformed key chains")
    return FleetChains(commitments, length, topside=topside)


def load_frame_seed(directory: Path) -> bytes:
    """A vehicle's own key chain seed, or the topside modem's in the operator's directory."""
    text = _read(Path(directory) / FRAMES_KEY).strip()
    try:
        seed = bytes.fromhex(text)
    except ValueError:
        seed = b""
    if len(seed) < 16:
        raise CredentialsError(f"{directory}/{FRAMES_KEY}: not a key chain seed")
    return seed


def load_auth(directory: Path, signer_id: str | None = None) -> BusAuth:
    """What a process started with ``--credentials directory`` holds. With ``signer_id`` its
    private key must be there and match the ring's public key for that id."""
    directory = Path(directory)
    verifier = load_ring(directory)
    if signer_id is None:
        return BusAuth(verifier)
    if signer_id not in verifier.ring:
        raise CredentialsError(f"{directory}: {signer_id!r} is not in the key ring")
    text = _read(directory / SIGNING_KEY).strip()
    try:
        private = Ed25519PrivateKey.from_private_bytes(bytes.fromhex(text))
    except ValueError:
        raise CredentialsError(f"{directory}/{SIGNING_KEY}: not an Ed25519 key") from None
    mine = verifier.ring[signer_id].public.public_bytes(serialization.Encoding.Raw,
                                                        serialization.PublicFormat.Raw)
    if _raw_public(private) != mine.hex():
        raise CredentialsError(f"{directory}/{SIGNING_KEY} is not {signer_id}'s key")
    return BusAuth(verifier, Signer(signer_id, private, verifier.run_id))


def load_router_zid(directory: Path) -> str:
    """The main router's Zenoh id, from a router's credentials directory."""
    zid = _read(Path(directory) / ROUTER_ZID).strip()
    try:
        int(zid, 16)
    except ValueError:
        zid = "0"
    if zid.startswith("0") or not 0 < len(zid) <= 32:  # Zenoh's rule for ids
        raise CredentialsError(f"{directory}/{ROUTER_ZID}: not a Zenoh id")
    return zid


def load_login(directory: Path) -> ZenohLogin:
    """The Zenoh user and password in ``directory``."""
    text = _read(Path(directory) / ZENOH_LOGIN).strip()
    user, sep, password = text.partition(":")
    if not sep or not user or not password:
        raise CredentialsError(f"{directory}/{ZENOH_LOGIN}: expected user:password")
    return ZenohLogin(user, password)


def uses_tls(directory: Path) -> bool:
    """Whether ``directory`` (a run's root or a process's) holds TLS credentials."""
    return (Path(directory) / CA_CERT).is_file()


def load_tls(directory: Path) -> TlsIdentity:
    """The TLS files of a process's directory, checked: its key matches its certificate,
    which the directory's CA signed and which is valid now (`certificates.check_identity`)."""
    directory = Path(directory)
    ca, cert, key = (directory / name for name in (CA_CERT, TLS_CERT, TLS_KEY))
    try:
        info = check_identity(ca.read_bytes(), cert.read_bytes(), key.read_bytes())
    except OSError as exc:
        raise CredentialsError(f"cannot read {exc.filename}: {exc.strerror or exc}") from None
    except CertificateError as exc:
        raise CredentialsError(f"{directory}/{TLS_CERT}: {exc}") from None
    return TlsIdentity(ca, cert, key, info)
