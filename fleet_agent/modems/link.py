"""The byte stream to a modem, cut into NMEA sentences (`fleet_bus.nmea`).

``tcp:HOST:PORT`` is a socket; anything else a serial device (pyserial, an optional
dependency imported only then). Lines end at CR or LF; a line longer than
`fleet_bus.nmea.MAX_LINE_CHARS` is dropped up to its end; malformed sentences are counted per
reason (``nmea_<reason>``) and skipped.
"""

from __future__ import annotations

import socket
from collections import Counter
from typing import Protocol

from fleet_bus import nmea
from fleet_bus.nmea import MAX_LINE_CHARS, NmeaError

REPLY_TIMEOUT_S = 3.0  # wall seconds a modem may take to answer a sentence
DEFAULT_BAUD = 19200  # the Micro-Modem's default serial rate [Goby MMDriver DEFAULT_BAUD]


class _Stream(Protocol):
    def fileno(self) -> int: ...
    def read_available(self) -> bytes: ...
    def write(self, data: bytes) -> None: ...
    def close(self) -> None: ...


class _TcpStream:
    def __init__(self, host: str, port: int) -> None:
        self.sock = socket.create_connection((host, port), timeout=REPLY_TIMEOUT_S)
        self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)

    def fileno(self) -> int:
        return self.sock.fileno()

    def read_available(self) -> bytes:
        data = self.sock.recv(4096)
        if not data:
            raise ConnectionError("the modem closed the link")
        return data

    def write(self, data: bytes) -> None:
        self.sock.sendall(data)

    def close(self) -> None:
        self.sock.close()


class _SerialStream:
    def __init__(self, device: str, baud: int) -> None:
        try:
            import serial  # optional dependency: only a serial modem needs it
        except ImportError:
            raise OSError("a serial Micro-Modem needs pyserial (pip install pyserial)") from None
        self.port = serial.Serial(device, baud, timeout=0, write_timeout=REPLY_TIMEOUT_S)

    def fileno(self) -> int:
        return self.port.fileno()

    def read_available(self) -> bytes:
        return self.port.read(4096)

    def write(self, data: bytes) -> None:
        self.port.write(data)

    def close(self) -> None:
        self.port.close()


def parse_link(link: str) -> tuple[str, str, int]:
    """``tcp:HOST:PORT`` -> ("tcp", host, port); a device path -> ("serial", path, 0).
    Raises ValueError."""
    if link.startswith("tcp:"):
        host, _, port = link[4:].rpartition(":")
        if not host or not port.isdigit() or not 1 <= int(port) <= 65535:
            raise ValueError(f"modem link {link!r}: expected tcp:HOST:PORT")
        return "tcp", host, int(port)
    if not link or ":" in link:
        raise ValueError(f"modem link {link!r}: expected tcp:HOST:PORT or a device path")
    return "serial", link, 0


class NmeaLink:
    """A connected modem: `read` what it said, `send` to it; ``address_known`` and
    ``config_deadline`` are the driver's handshake state on this connection."""

    def __init__(self, stream: _Stream, counters: Counter[str]) -> None:
        self.stream = stream
        self.counters = counters
        self.inbuf = bytearray()
        self.discarding = False  # inside an over-long line: dropped up to its end
        self.address_known = False
        self.config_deadline = 0.0

    @staticmethod
    def open(kind: str, where: str, port: int, baud: int, counters: Counter[str]) -> "NmeaLink":
        """Raises OSError if the modem cannot be reached."""
        stream: _Stream = _TcpStream(where, port) if kind == "tcp" else \
            _SerialStream(where, baud)
        return NmeaLink(stream, counters)

    def fileno(self) -> int:
        return self.stream.fileno()

    def read(self) -> list[nmea.Typed | nmea.Sentence]:
        """The sentences completed by what is available now. Raises OSError or
        ConnectionError if the link is gone."""
        self.inbuf += self.stream.read_available()
        out: list[nmea.Typed | nmea.Sentence] = []
        while True:
            cut = min((i for i in (self.inbuf.find(b"\r"), self.inbuf.find(b"\n")) if i >= 0),
                      default=-1)
            if cut < 0:
                break
            line = bytes(self.inbuf[:cut]).strip()
            del self.inbuf[:cut + 1]
            if self.discarding:
                self.discarding = False
            elif line:
                try:
                    out.append(nmea.decode(line))
                except NmeaError as exc:
                    self.counters[f"nmea_{exc.reason}"] += 1
        if len(self.inbuf) > MAX_LINE_CHARS:
            self.inbuf.clear()
            if not self.discarding:
                self.discarding = True
                self.counters["nmea_too_long"] += 1
        return out

    def send(self, message: nmea.Typed) -> None:
        """Raises OSError if the link is gone."""
        self.stream.write(nmea.encode(message))

    def close(self) -> None:
        try:
            self.stream.close()
        except OSError:
            pass
