"""The emulated modems' TCP ports: modem i listens on ``base_port + i``.

One selector thread serves every port: it accepts a host (a newer connection replaces the
older, as a serial line has one host: a driver that restarts gets its modem back), splits what
the host sends into lines (CR, LF or both end one), hands each to its modem, and writes what
the modems say. Input lines are bounded (`fleet_bus.nmea.MAX_LINE_CHARS`: longer input is
dropped up to the next end of line and reported to the modem), and so is each host's output
buffer (`MAX_OUT_BYTES`: a host that does not read loses lines, counted, and never holds
the water up). Writes from other threads (the water's scheduler) only append to that buffer
and wake the selector.
"""

from __future__ import annotations

import selectors
import socket
import threading
from collections import Counter
from typing import Sequence

from comms_sim.micromodem.modem import VirtualModem
from fleet_bus.nmea import MAX_LINE_CHARS

MAX_OUT_BYTES = 256 * 1024
_READ = 4096


class _Host:
    """One connected host of one modem."""

    def __init__(self, server: "ModemServer", sock: socket.socket, modem: VirtualModem) -> None:
        self.server = server
        self.sock = sock
        self.modem = modem
        self.inbuf = bytearray()
        self.discarding = False  # inside an over-long line: drop up to its end
        self.out = bytearray()
        self.closed = False

    def send(self, line: bytes) -> None:
        """Queue ``line`` for the host (any thread)."""
        with self.server.lock:
            if self.closed:
                return
            if len(self.out) + len(line) > MAX_OUT_BYTES:
                self.server.counters["out_overflow"] += 1
                return
            self.out += line
        self.server.wake()


class ModemServer:
    """See the module docstring. `start` binds every port (raises OSError if one is taken),
    `serve` runs the selector until ``stop``, `close` closes every socket."""

    def __init__(self, modems: Sequence[VirtualModem], host: str, base_port: int) -> None:
        self.modems = list(modems)
        self.host = host
        self.base_port = base_port
        self.lock = threading.Lock()
        self.counters: Counter[str] = Counter()
        self._selector = selectors.DefaultSelector()
        self._listeners: list[socket.socket] = []
        self._hosts: dict[int, _Host] = {}  # modem index -> its host
        self._wake_r, self._wake_w = socket.socketpair()
        self._wake_r.setblocking(False)
        self._wake_w.setblocking(False)
        self._closed = False

    @property
    def ports(self) -> list[int]:
        return [s.getsockname()[1] for s in self._listeners]

    def start(self) -> None:
        try:
            for i, _ in enumerate(self.modems):
                sock = socket.create_server((self.host, self.base_port + i), backlog=4)
                sock.setblocking(False)
                self._listeners.append(sock)
                self._selector.register(sock, selectors.EVENT_READ, ("listen", i))
        except OSError:
            self.close()
            raise
        self._selector.register(self._wake_r, selectors.EVENT_READ, ("wake", -1))

    def wake(self) -> None:
        try:
            self._wake_w.send(b"\0")
        except (BlockingIOError, OSError):  # already woken, or closing
            pass

    def serve(self, stop: threading.Event, max_wait_s: float = 0.2) -> None:
        while not stop.is_set():
            self._update_interest()
            for key, mask in self._selector.select(max_wait_s):
                what, index = key.data
                if what == "listen" and isinstance(key.fileobj, socket.socket):
                    self._accept(key.fileobj, index)
                elif what == "wake":
                    try:
                        while self._wake_r.recv(512):
                            pass
                    except (BlockingIOError, OSError):
                        pass
                else:
                    host = self._hosts.get(index)
                    if host is None or host.sock is not key.fileobj:
                        continue
                    if mask & selectors.EVENT_READ:
                        self._read(host, index)
                    if mask & selectors.EVENT_WRITE and not host.closed:
                        self._write(host, index)

    def _update_interest(self) -> None:
        with self.lock:
            hosts = [(i, h, bool(h.out)) for i, h in self._hosts.items()]
        for i, host, pending in hosts:
            events = selectors.EVENT_READ | (selectors.EVENT_WRITE if pending else 0)
            try:
                if self._selector.get_key(host.sock).events != events:
                    self._selector.modify(host.sock, events, ("host", i))
            except (KeyError, ValueError):
                pass

    def _accept(self, listener: socket.socket, index: int) -> None:
        try:
            sock, _ = listener.accept()
        except (BlockingIOError, OSError):
            return
        sock.setblocking(False)
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        old = self._hosts.get(index)
        if old is not None:
            self.counters["replaced_hosts"] += 1
            self._drop(old, index, replaced=True)
        host = _Host(self, sock, self.modems[index])
        self._hosts[index] = host
        self._selector.register(sock, selectors.EVENT_READ, ("host", index))
        self.counters["hosts"] += 1
        self.modems[index].attach(host.send)

    def _read(self, host: _Host, index: int) -> None:
        try:
            data = host.sock.recv(_READ)
        except (BlockingIOError, InterruptedError):
            return
        except OSError:
            data = b""
        if not data:
            self._drop(host, index)
            return
        self.counters["bytes_in"] += len(data)
        host.inbuf += data
        while True:
            cut = min((i for i in (host.inbuf.find(b"\r"), host.inbuf.find(b"\n")) if i >= 0),
                      default=-1)
            if cut < 0:
                break
            line = bytes(host.inbuf[:cut])
            del host.inbuf[:cut + 1]
            if host.discarding:
                host.discarding = False
                continue
            if line.strip():
                host.modem.on_line(line.strip())
        if len(host.inbuf) > MAX_LINE_CHARS:
            host.inbuf.clear()
            if not host.discarding:
                host.discarding = True
                host.modem.on_garbage("too_long")

    def _write(self, host: _Host, index: int) -> None:
        with self.lock:
            chunk = bytes(host.out[:65536])
        try:
            sent = host.sock.send(chunk)
        except (BlockingIOError, InterruptedError):
            return
        except OSError:
            self._drop(host, index)
            return
        with self.lock:
            del host.out[:sent]
        self.counters["bytes_out"] += sent

    def _drop(self, host: _Host, index: int, replaced: bool = False) -> None:
        with self.lock:
            host.closed = True
            host.out.clear()
        try:
            self._selector.unregister(host.sock)
        except (KeyError, ValueError):
            pass
        host.sock.close()
        if self._hosts.get(index) is host:
            del self._hosts[index]
            if not replaced:
                host.modem.attach(None)

    def close(self) -> None:
        """Close every socket (idempotent)."""
        if self._closed:
            return
        self._closed = True
        for index, host in list(self._hosts.items()):
            self._drop(host, index)
        for sock in self._listeners:
            try:
                self._selector.unregister(sock)
            except (KeyError, ValueError):
                pass
            sock.close()
        self._listeners.clear()
        for sock in (self._wake_r, self._wake_w):
            try:
                self._selector.unregister(sock)
            except (KeyError, ValueError):
                pass
            sock.close()
        self._selector.close()
