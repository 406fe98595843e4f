"""A small asynchronous MOOS client: one TCP connection to a MOOSDB, mail pushed as it comes.

It speaks the wire protocol of `fleet_agent.helms.moos_wire` as core-moos's
`MOOSAsyncCommClient` does: a handshake asking for asynchronous mail, REGISTER for each
variable, NOTIFY to post, and a TIMING message every second so that the DB (which drops a
client after 5 s of silence) keeps us. One reader thread receives packets and hands each
packet's NOTIFY messages to ``on_mail`` (keep it short: it runs on that thread); `notify`
writes from the caller's thread under a lock, so a post reaches the DB without waiting for a
tick. The connection is re-made (subscriptions replayed) when the DB goes away, until `close`.

Why our own and not `pymoos2` or `pymoos`: see `docs/onboard.md` (MOOS client).
"""

from __future__ import annotations

import logging
import socket
import threading
import time
from typing import Callable

from fleet_agent.helms import moos_wire as wire
from fleet_agent.helms.moos_wire import MoosMsg, WireError

log = logging.getLogger(__name__)

MailHandler = Callable[[list[MoosMsg]], None]
KEEPALIVE_S = 1.0  # TIMING messages, as MOOSAsyncCommClient's TIMING_MESSAGE_PERIOD
IO_TIMEOUT_S = 5.0  # a DB that takes longer to accept a write or a handshake is gone
RETRY_S = (0.2, 2.0)  # reconnect backoff: first wait, longest wait


class MoosClient:
    """A client of the MOOSDB at ``host:port`` named ``name`` (unique on that DB), posting
    with MOOS time ``unix * warp`` (the community's ``MOOSTimeWarp``)."""

    def __init__(self, host: str, port: int, name: str, warp: float = 1.0,
                 on_mail: MailHandler | None = None,
                 wall: Callable[[], float] = time.time) -> None:
        if not name or any(c.isspace() for c in name):
            raise ValueError(f"MOOS client name must be one word, got {name!r}")
        wire.moos_time(0.0, warp)  # validates the warp
        self.host, self.port, self.name, self.warp = host, int(port), name, float(warp)
        self._on_mail = on_mail
        self._wall = wall
        self._subs: dict[str, float] = {}
        self._lock = threading.Lock()  # subscriptions, socket swaps, writes
        self._sock: socket.socket | None = None
        self._connected = threading.Event()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.community = ""
        self.asynchronous = False
        self.refused_reason = ""  # the DB's POISON reason, if it turned us away
        self.counters = {"connects": 0, "packets": 0, "messages": 0, "malformed": 0,
                         "posts": 0, "posts_unsent": 0, "handler_errors": 0}

    # -- public --------------------------------------------------------------------------------

    def start(self) -> "MoosClient":
        if self._thread is None:
            self._thread = threading.Thread(target=self._run, name=f"moos-{self.name}",
                                            daemon=True)
            self._thread.start()
        return self

    def wait_connected(self, timeout_s: float) -> bool:
        return self._connected.wait(timeout_s)

    @property
    def connected(self) -> bool:
        return self._connected.is_set()

    def moos_now(self) -> float:
        return wire.moos_time(self._wall(), self.warp)

    def register(self, *names: str, interval_s: float = 0.0) -> None:
        """Ask for every post of each variable (at most one per ``interval_s``; 0: all)."""
        msgs = []
        with self._lock:
            for n in names:
                self._subs[n] = float(interval_s)
                msgs.append(self._register_msg(n, interval_s))
        self._send(msgs)

    def notify(self, key: str, value: float | str) -> bool:
        """Post ``key = value``; False if the DB is not connected (nothing is queued: a
        helm command posted late is worse than a refused one)."""
        ok = self._send([MoosMsg(wire.NOTIFY, key, value, self.moos_now(), self.name)])
        self.counters["posts" if ok else "posts_unsent"] += 1
        return ok

    def notify_many(self, pairs: list[tuple[str, float | str]]) -> bool:
        """Post several variables in one packet, in order (the DB applies them in order)."""
        now = self.moos_now()
        ok = self._send([MoosMsg(wire.NOTIFY, k, v, now, self.name) for k, v in pairs])
        self.counters["posts" if ok else "posts_unsent"] += len(pairs)
        return ok

    def close(self) -> None:
        """Disconnect and stop the reader (idempotent)."""
        self._stop.set()
        with self._lock:
            sock, self._sock = self._sock, None
        if sock is not None:
            try:
                sock.sendall(wire.encode_packet(
                    [MoosMsg(wire.TERMINATE, "-quit-", 0.0, self.moos_now(), self.name)]))
            except OSError:
                pass
            _shut(sock)
        self._connected.clear()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout=IO_TIMEOUT_S + 1.0)

    # -- connection ----------------------------------------------------------------------------

    def _register_msg(self, key: str, interval_s: float) -> MoosMsg:
        return MoosMsg(wire.REGISTER, key, float(interval_s), self.moos_now(), self.name)

    def _send(self, msgs: list[MoosMsg]) -> bool:
        with self._lock:
            sock = self._sock
            if sock is None or not self._connected.is_set():
                return False
            try:
                sock.sendall(wire.encode_packet(msgs))
                return True
            except OSError as err:
                log.warning("MOOS %s: write failed (%s); reconnecting", self.name, err)
                _shut(sock)  # the reader sees the close and reconnects
                return False

    def _run(self) -> None:
        backoff = RETRY_S[0]
        while not self._stop.is_set():
            sock = self._connect()
            if sock is None:
                self._stop.wait(backoff)
                backoff = min(RETRY_S[1], backoff * 2)
                continue
            backoff = RETRY_S[0]
            try:
                self._serve(sock)
            except (OSError, WireError) as err:
                if isinstance(err, WireError):
                    self.counters["malformed"] += 1
                if not self._stop.is_set():
                    log.warning("MOOS %s: connection lost (%s)", self.name, err)
            finally:
                self._connected.clear()
                with self._lock:
                    if self._sock is sock:
                        self._sock = None
                _shut(sock)

    def _connect(self) -> socket.socket | None:
        try:
            sock = socket.create_connection((self.host, self.port), timeout=IO_TIMEOUT_S)
        except OSError:
            return None
        try:
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            sock.sendall(wire.handshake_bytes(self.name, self.moos_now()))
            reply = _read_packet(sock)
        except (OSError, WireError):
            _shut(sock)
            return None
        welcome = reply[0] if reply else None
        if welcome is None or welcome.kind != wire.WELCOME:
            self.refused_reason = welcome.text if welcome is not None else "no reply"
            log.error("MOOS %s: DB refused us: %s", self.name, self.refused_reason)
            _shut(sock)
            return None
        self.community = welcome.community
        self.asynchronous = welcome.text == wire.ASYNC_KEY
        sock.settimeout(None)
        with self._lock:
            if self._stop.is_set():
                _shut(sock)
                return None
            self._sock = sock
            subs = [self._register_msg(k, v) for k, v in self._subs.items()]
            self.counters["connects"] += 1
            self._connected.set()
        if subs:
            self._send(subs)
        return sock

    def _serve(self, sock: socket.socket) -> None:
        next_keepalive = 0.0
        sock.settimeout(KEEPALIVE_S / 2)
        while not self._stop.is_set():
            now = time.monotonic()
            if now >= next_keepalive:
                # Not warped: the DB's silence timeout runs on wall time.
                timing = MoosMsg(wire.TIMING, "_async_timing", 0.0, self._wall(), self.name)
                if not self._send([timing]):
                    raise OSError("keepalive not sent")
                next_keepalive = now + KEEPALIVE_S
            try:
                msgs = _read_packet(sock)
            except socket.timeout:
                continue
            self.counters["packets"] += 1
            mail = [m for m in msgs if m.kind == wire.NOTIFY]
            if any(m.kind == wire.POISON for m in msgs):
                raise OSError("the DB sent POISON")
            self.counters["messages"] += len(mail)
            if mail and self._on_mail is not None:
                try:
                    self._on_mail(mail)
                except Exception:  # a handler bug must not take the link down
                    self.counters["handler_errors"] += 1
                    log.exception("MOOS %s: mail handler failed", self.name)


def _read_exact(sock: socket.socket, n: int) -> bytes:
    chunks, got = [], 0
    while got < n:
        chunk = sock.recv(min(n - got, 1 << 16))
        if not chunk:
            raise OSError("MOOSDB closed the connection")
        chunks.append(chunk)
        got += len(chunk)
    return b"".join(chunks)


def _read_packet(sock: socket.socket) -> list[MoosMsg]:
    head = sock.recv(4, socket.MSG_PEEK)
    if not head:
        raise OSError("MOOSDB closed the connection")
    # Once a packet has begun, read it whole however long it takes (a timeout mid-packet
    # would lose our place in the stream).
    timeout = sock.gettimeout()
    sock.settimeout(IO_TIMEOUT_S)
    try:
        first = _read_exact(sock, 4)
        return wire.decode_packet(first + _read_exact(sock, wire.packet_length(first) - 4))
    except socket.timeout as err:
        raise OSError("MOOSDB stalled mid-packet") from err
    finally:
        sock.settimeout(timeout)


def _shut(sock: socket.socket) -> None:
    try:
        sock.shutdown(socket.SHUT_RDWR)
    except OSError:
        pass
    sock.close()
