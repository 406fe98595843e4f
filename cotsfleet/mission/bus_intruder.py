"""The intruder on the bus: what the security test and benchmark attack a live mission with.

Unlike the modem intruder of the attack faults (`cotsfleet.mission.intruder`, in the water),
this one reaches the Zenoh router. First it tries to get in without an identity of the
mission (a login it does not have, or over TLS the mission's public CA certificate and no
certificate of its own); then, with an identity it was given (e.g. the router's own login
or TLS key, as if they leaked) and no fleet key, it
sends every forgery the bus allows (`attack_round`: abort and stop commands, forged
statuses, events, ready announcements, truths, link control, link records and frames, plain
and in well-formed envelopes with random signatures), serves a rival mission and clock
record, and floods one agent's deliveries and the relay's input with garbage and forged
envelopes at a set rate. It samples the CPU time and memory of the processes it floods, so
the cost of a flood message can be told apart from the mission's own work.
"""

from __future__ import annotations

import json
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

import msgpack
import numpy as np
import zenoh

from fleet_bus import keys, topics
from fleet_bus.auth import MAGIC, SIG_BYTES
from fleet_bus.commands import ABORT, STOP
from fleet_bus.credentials import CA_CERT, ZenohLogin, uses_tls
from fleet_bus.link import LinkControl, LinkRecord, Partition
from fleet_bus.mission import Mission
from fleet_bus.session import client_config
from fleet_bus.states import EventKind, VehicleState
from fleet_bus.telemetry import Event, Ready, Status

CLOCK_TICKS = 100  # os.sysconf("SC_CLK_TCK") on Linux


def forged_envelope(rng: np.random.Generator, signer: str, payload: bytes) -> bytes:
    """Well-formed, claims a real signer, random signature whose scalar is in range (so the
    receiver cannot reject it by its encoding alone: it costs a full Ed25519 verification)."""
    sid = signer.encode()
    sig = bytearray(rng.bytes(SIG_BYTES))
    sig[-1] &= 0x0F  # S < 2^252 < the group order
    return (MAGIC + bytes((len(sid),)) + sid + int(rng.integers(1 << 62)).to_bytes(8, "little")
            + payload + bytes(sig))


def session_as(endpoint: str, login: ZenohLogin | Path | None, timeout_s: float = 3.0
               ) -> zenoh.Session:
    """A session as ``login``: a Zenoh login, or a process's credentials directory (its TLS
    certificate, or its login)."""
    if isinstance(login, Path):
        return zenoh.open(client_config([endpoint], timeout_s=timeout_s, credentials=login))
    conf = client_config([endpoint], timeout_s=timeout_s)
    if login is not None:
        conf.insert_json5("transport/auth/usrpwd", json.dumps(
            {"user": login.user, "password": login.password}))
    return zenoh.open(conf)


def attack_round(s: zenoh.Session, rng: np.random.Generator, vehicles: tuple[str, ...]) -> int:
    """One of every forgery; returns how many messages it put."""
    puts: list[tuple[str, bytes]] = []
    for vid in vehicles:
        ctl = topics.CTL.of(vid)
        for name in (ABORT, STOP):
            puts += [(ctl.key, ctl.encode(name)),
                     (ctl.key, forged_envelope(rng, "operator", ctl.encode(name)))]
        status, event, alive = topics.STATUS.of(vid), topics.EVENT.of(vid), topics.ALIVE.of(vid)
        home = status.encode(Status(1e6, vid, VehicleState.HOME, (0.0, 0.0, 0.0), 0.0, 0.0, [],
                                    [99999], 1, 0.0, 0.0))
        puts += [(status.key, home), (status.key, forged_envelope(rng, vid, home)),
                 (event.key, event.encode(Event(0.0, vid, EventKind.ABORT, [99999]))),
                 (alive.key, alive.encode(Ready(vid, "x"))),
                 (topics.TRUTH.of(vid).key, forged_envelope(rng, vid, b"\x80"))]
    isolated = Partition(0.0, 1e12, (frozenset({vehicles[0]}),))
    cut = topics.LINK_CTL.encode(LinkControl(partition=isolated, extra_loss=1.0))
    a, b = vehicles[0], vehicles[-1]
    link = topics.LINK.of(a, b)
    puts += [(topics.LINK_CTL.key, cut),
             (topics.LINK_CTL.key, forged_envelope(rng, "operator", cut)),
             (link.key, link.encode(LinkRecord(a, b, 0.0, 0.0, 64, False, "partition"))),
             (topics.TX.of(b).key, forged_envelope(rng, b, b"pose"))]
    for key, payload in puts:
        s.put(key, payload)
    return len(puts)


def rival_records(query: zenoh.Query) -> None:
    """A rival operator's answers: another mission, and a clock with a NaN epoch and an absurd
    warp, each plain and in a forged envelope."""
    rng = np.random.default_rng()
    key = str(query.key_expr)
    if key == keys.MISSION:
        payload = Mission({"name": "forged", "vehicles": []}, 1, "forged-run").encode()
    else:
        payload = msgpack.packb({"epoch_unix": float("nan"), "warp": 1e9})
    for body in (payload, forged_envelope(rng, "operator", payload)):
        try:
            query.reply(key, body)
        except Exception:  # the query is already gone
            pass


def cpu_s(pid: int) -> float:
    """User + system CPU seconds of process ``pid`` so far (0 once it is gone)."""
    try:
        with open(f"/proc/{pid}/stat") as fh:
            fields = fh.read().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / CLOCK_TICKS
    except (OSError, IndexError, ValueError):
        return 0.0


def rss_mb(pid: int) -> float:
    try:
        with open(f"/proc/{pid}/status") as fh:
            for line in fh:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    return 0.0


@dataclass
class BusIntruder:
    """Attacks the mission whose router is at ``endpoint``; ``agent`` and ``relay`` are the
    pids of the flooded agent (its deliveries, ``fleet/rx/<target>``) and of the relay."""

    endpoint: str
    login: ZenohLogin | Path  # the identity it holds (a credentials directory: TLS or login)
    vehicles: tuple[str, ...]
    agent: int
    relay: int
    flood_s: float = 20.0
    rate_hz: float = 2000.0  # over both targets
    calm_s: float = 5.0  # measured before the flood: what the processes spend anyway
    refused_login: bool = False
    sent: dict[str, int] = field(default_factory=lambda: {
        "attacks": 0, "flood_agent": 0, "flood_relay": 0})
    flood_wall_s: float = 0.0
    rss_mb: list[float] = field(default_factory=list)
    cpu: dict[str, tuple[float, float]] = field(default_factory=dict)  # calm, flood CPU s
    error: str = ""

    def run(self, stop: threading.Event) -> None:
        try:
            self._run(stop)
        except Exception as exc:  # the caller says what went wrong
            self.error = repr(exc)

    def _run(self, stop: threading.Event) -> None:
        try:  # only the address: the router does not let it in
            self._stranger().close()
        except Exception:
            self.refused_login = True
        rng = np.random.default_rng(7)
        with session_as(self.endpoint, self.login) as s, \
                s.declare_queryable(keys.MISSION, rival_records), \
                s.declare_queryable(keys.CLOCK, rival_records):
            pids = {"agent": self.agent, "relay": self.relay}
            before = {k: cpu_s(p) for k, p in pids.items()}
            stop.wait(self.calm_s)
            calm = {k: cpu_s(p) - before[k] for k, p in pids.items()}
            for _ in range(3):
                self.sent["attacks"] += attack_round(s, rng, self.vehicles)
            self._flood(s, rng, stop)
            time.sleep(2.0)  # what was queued is processed
            self.rss_mb.append(rss_mb(self.agent))
            spent = {k: cpu_s(p) - before[k] - calm[k] for k, p in pids.items()}
            self.cpu = {k: (calm[k], spent[k]) for k in pids}

    def _stranger(self) -> zenoh.Session:
        """A session with no identity of the mission: a guessed login, or over TLS the
        mission's CA certificate (public) and no certificate of its own."""
        if isinstance(self.login, Path) and uses_tls(self.login):
            conf = client_config([self.endpoint], timeout_s=3.0)
            conf.insert_json5("transport/link/tls", json.dumps(
                {"root_ca_certificate": str(self.login / CA_CERT)}))
            return zenoh.open(conf)
        return session_as(self.endpoint, ZenohLogin("intruder", "guess"))

    def _flood(self, s: zenoh.Session, rng: np.random.Generator, stop: threading.Event) -> None:
        rx, tx = keys.rx_key(self.vehicles[0]), keys.tx_key(self.vehicles[-1])
        t0 = time.monotonic()
        self.rss_mb.append(rss_mb(self.agent))
        n = 0
        while not stop.is_set() and time.monotonic() - t0 < self.flood_s:
            ahead = t0 + n / self.rate_hz - time.monotonic()
            if ahead > 0:
                time.sleep(ahead)
            garbage = rng.bytes(int(rng.integers(1, 120)))
            if n % 2:  # half plain garbage, half forged envelopes (a signature check each)
                s.put(rx, garbage if n % 4 == 1 else forged_envelope(rng, "relay", garbage))
                self.sent["flood_agent"] += 1
            else:
                s.put(tx, garbage if n % 4 == 0 else forged_envelope(
                    rng, self.vehicles[-1], garbage))
                self.sent["flood_relay"] += 1
            n += 1
            if n % 2000 == 0:
                self.sent["attacks"] += attack_round(s, rng, self.vehicles)
                self.rss_mb.append(rss_mb(self.agent))
        self.flood_wall_s = time.monotonic() - t0

    def cost_us(self, who: str) -> float | None:
        """CPU microseconds ``who`` ("agent" or "relay") spent per flood message sent to it,
        beyond what it spent at the calm rate over the same wall time."""
        calm, spent = self.cpu.get(who, (0.0, 0.0))
        n = self.sent["flood_agent" if who == "agent" else "flood_relay"]
        if not n or not self.flood_wall_s:
            return None
        extra = spent - calm / max(self.calm_s, 1e-9) * (self.flood_wall_s + 2.0)
        return max(0.0, extra) / n * 1e6


def run_dir_pids(run_dir: Path) -> dict[str, list[int]]:
    return json.loads((run_dir / "pids.json").read_text())
