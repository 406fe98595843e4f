"""NMEA-0183 sentences of the WHOI Micro-Modem subset both sides of the emulated water speak.

A sentence is ``$`` + talker and type (``CC`` host to modem, ``CA`` modem to host, ``P...``
proprietary) + comma-separated fields + ``*`` + two hex digits, the XOR of every byte between
``$`` and ``*`` (NMEA 0183), ended by CR LF. Anything else raises `NmeaError`, whose
``reason`` (one of `REASONS`) names a counter.

Formats, as WHOI's Micro-Modem Software Interface Guide defines them and public drivers quote
it (cited per sentence below as [AC] WHOI's ``acomms`` Python package, 3.1.1:
``messageparser.py``, ``micromodem.py``, ``cyclestats.py``; [Goby] Goby3's MMDriver,
``src/acomms/modemdriver/mm_driver.cpp``, whose sentence list cites the guide v3.04):

- ``$CCCYC,CMD,SRC,DEST,RATE,ACK,NFRAMES`` cycle init, host to modem; ``$CACYC`` the same
  fields: the modem's echo, or a cycle init heard acoustically [AC CACYC, Goby cccyc/cacyc];
  CMD is deprecated and sent as 0.
- ``$CADRQ,HHMMSS,SRC,DEST,ACK,NBYTES,FRAME`` data request: the modem asks for frame FRAME
  (from 1) of at most NBYTES [AC CADRQ, Goby cadrq].
- ``$CCTXD,SRC,DEST,ACK,HEX`` data for the requested frame; empty HEX says "no more data"
  [Goby cadrq]. ``$CATXD,SRC,DEST,ACK,NBYTES`` its echo (fields: ours, see docs/modems.md;
  [AC] and [Goby] ignore them).
- ``$CARXD,SRC,DEST,ACK,FRAME,HEX`` a received frame [AC CARXD, Goby carxd].
- ``$CACST,6,MODE,TOA,...`` receive cycle statistics, version 6 (29 fields after the version;
  version 8 adds four) [AC cyclestats.CycleStats.from_nmea_msg, Goby cacst].
- ``$CATXP,NBYTES`` / ``$CATXF,NBYTES`` start / end of a transmission (field: ours) [Goby
  sentence list]; ``$CAACK,SRC,DEST,FRAME,1`` frame FRAME acknowledged by SRC [AC CAACK,
  Goby caack].
- ``$CCCFG,NAME,VALUE`` / ``$CACFG,NAME,VALUE`` set / echo of a configuration parameter,
  ``$CCCFQ,NAME`` a query [AC CACFG, get_config].
- ``$CCCLK,YYYY,MM,DD,HH,MM,SS`` set the modem's clock, ``$CACLK`` the same fields
  [AC CACLK].
- ``$CAREV,HHMMSS,AUV,VERSION`` the modem's revision (``INIT`` for a reboot) [AC, Goby carev].
- ``$CAERR,HHMMSS,MODULE,NUMBER,MESSAGE`` an error; ``DATA_TIMEOUT`` with the frame number
  [AC CAERR, Goby caerr].
- ``$CCMPC,SRC,DEST`` ping, ``$CAMPC`` its echo, ``$CAMPA,SRC,DEST`` a ping heard,
  ``$CAMPR,SRC,DEST,OWTT`` the reply (SRC the modem that replied, DEST the pinger, OWTT the
  one-way travel time in seconds) [AC CAMPR, wait_for_ping_reply; Goby campr].
- ``$PCFLP,X,Y,Z`` ours (a proprietary sentence, NMEA's ``P`` + maker ``CFL``): where an
  emulated modem is, in the scenario's metres (docs/modems.md).

`RATES` is the Micro-Modem's packet table: frames per packet and bytes per frame [Goby
PACKET_FRAME_COUNT/PACKET_SIZE, AC messageparams.Rates], burst rate where WHOI publishes it.
"""

from __future__ import annotations

import datetime as dt
import math
import re
from dataclasses import dataclass
from typing import Callable, ClassVar, Union

MAX_LINE_CHARS = 1024  # a rate-5 $CARXD (256 bytes as 512 hex digits) is ~540
MAX_FIELDS = 48  # $CACST version 8 has 34
REASONS = ("too_long", "not_ascii", "no_start", "no_checksum", "checksum", "fields",
           "number", "hex", "value")
BROADCAST = 0  # the Micro-Modem's broadcast address
MAX_ADDRESS = 127  # seven-bit modem addresses [AC: "7-bit/8-bit addressing"]


class NmeaError(ValueError):
    """A line that is not a well-formed sentence of the subset; ``reason`` is in `REASONS`."""

    def __init__(self, reason: str, detail: str) -> None:
        assert reason in REASONS, reason
        super().__init__(f"{reason}: {detail}")
        self.reason = reason


# -- rates ---------------------------------------------------------------------------------


@dataclass(frozen=True)
class Rate:
    """One Micro-Modem packet type: ``frames`` frames of at most ``frame_bytes`` each, at a
    burst rate of ``bit_rate_bps`` (None where no source gives it)."""

    number: int
    name: str
    frames: int
    frame_bytes: int
    bit_rate_bps: float | None
    source: str

    @property
    def packet_bytes(self) -> int:
        return self.frames * self.frame_bytes


# Frames and bytes: [Goby] PACKET_FRAME_COUNT {1,3,3,2,2,8}, PACKET_SIZE {32,64,64,256,256,256}
# for rates 0-5; rate 6 (6 x 32 bytes) and the coding names from [AC] messageparams.Rates.
# Burst rates: [WHOI] acomms.whoi.edu/micro-modem: "80-5400 bps", rate 6 PSK 490 bps, "a
# Rate 5 PSK packet has a Burst Rate of ~5000bps"; rate 0 FH-FSK 80 bps (Freitag et al.,
# OCEANS 2005). Rate 1's ~500 bps is the project's assumption (comms_sim preset
# micromodem_psk1), not a published figure; rates 2-4 have none here.
RATES: dict[int, Rate] = {r.number: r for r in (
    Rate(0, "FH-FSK", 1, 32, 80.0, "WHOI, Freitag 2005; Goby, acomms"),
    Rate(1, "PSK BCH 128:8", 3, 64, 500.0, "Goby, acomms; bit rate assumed"),
    Rate(2, "PSK DSS 1/15", 3, 64, None, "Goby, acomms"),
    Rate(3, "PSK DSS 1/7", 2, 256, None, "Goby, acomms"),
    Rate(4, "PSK BCH 64:10", 2, 256, None, "Goby, acomms"),
    Rate(5, "PSK Hamming 14:9", 8, 256, 5000.0, "WHOI; Goby, acomms"),
    Rate(6, "PSK DSS 1/15 (32-byte frames)", 6, 32, 490.0, "WHOI; acomms"),
)}


# -- framing -------------------------------------------------------------------------------


def checksum(body: str) -> str:
    """NMEA 0183: the XOR of the characters between ``$`` and ``*``, two upper-case hex."""
    value = 0
    for byte in body.encode("ascii"):
        value ^= byte
    return f"{value:02X}"


_BODY_CHARS = re.compile(r"^[\x20-\x7e]*$")
_HEX = re.compile(r"^(?:[0-9A-Fa-f]{2})*$")


@dataclass(frozen=True)
class Sentence:
    """Any sentence: ``kind`` is talker + type (``"CCCYC"``, ``"PCFLP"``), ``fields`` the
    text between the commas."""

    kind: str
    fields: tuple[str, ...]

    def encode(self) -> bytes:
        body = ",".join((self.kind, *self.fields))
        return f"${body}*{checksum(body)}\r\n".encode("ascii")

    @property
    def talker(self) -> str:
        return self.kind[:2]

    @property
    def type(self) -> str:
        return self.kind[2:]


def parse(line: bytes | str) -> Sentence:
    """One line (CR LF optional) as a `Sentence`; raises `NmeaError`. The checksum is
    required: the Micro-Modem always sends one and every driver here does."""
    if len(line) > MAX_LINE_CHARS + 2:
        raise NmeaError("too_long", f"{len(line)} characters")
    if isinstance(line, bytes):
        try:
            line = line.decode("ascii")
        except UnicodeDecodeError:
            raise NmeaError("not_ascii", "a byte above 0x7f") from None
    line = line.rstrip("\r\n")
    if not _BODY_CHARS.match(line):
        raise NmeaError("not_ascii", "a control character")
    if not line.startswith("$"):
        raise NmeaError("no_start", f"does not start with $: {line[:16]!r}")
    star = line.rfind("*")
    if star < 0 or len(line) - star != 3:
        raise NmeaError("no_checksum", f"no *HH at the end: {line[-8:]!r}")
    body, given = line[1:star], line[star + 1:]
    if given.upper() != checksum(body):
        raise NmeaError("checksum", f"says {given}, is {checksum(body)}")
    if "$" in body or "*" in body:
        raise NmeaError("fields", "$ or * inside a sentence")
    parts = body.split(",")
    kind = parts[0]
    if not re.match(r"^(?:[A-Z]{2}[A-Z0-9]{3}|P[A-Z0-9]{3,8})$", kind):
        raise NmeaError("fields", f"bad talker/type {kind[:12]!r}")
    if len(parts) - 1 > MAX_FIELDS:
        raise NmeaError("fields", f"{len(parts) - 1} fields")
    return Sentence(kind, tuple(parts[1:]))


# -- field codecs --------------------------------------------------------------------------


def _int(text: str, what: str, lo: int, hi: int) -> int:
    if not re.match(r"^[+-]?\d{1,10}$", text):
        raise NmeaError("number", f"{what}: not an integer: {text[:16]!r}")
    value = int(text)
    if not lo <= value <= hi:
        raise NmeaError("value", f"{what}: {value} outside {lo}..{hi}")
    return value


def _float(text: str, what: str) -> float:
    if not re.match(r"^[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?$", text):
        raise NmeaError("number", f"{what}: not a number: {text[:16]!r}")
    value = float(text)
    if not math.isfinite(value):
        raise NmeaError("value", f"{what}: not finite")
    return value


def _hex(text: str, what: str) -> bytes:
    if not _HEX.match(text):
        raise NmeaError("hex", f"{what}: not an even number of hex digits")
    return bytes.fromhex(text)


def _text(text: str, what: str) -> str:
    if "," in text or "*" in text or "$" in text or not _BODY_CHARS.match(text):
        raise NmeaError("value", f"{what}: may not hold , * $ or control characters")
    return text


def _hhmmss(text: str, what: str) -> str:
    if not re.match(r"^(?:\d{6}(?:\.\d{1,6})?)?$", text):
        raise NmeaError("value", f"{what}: not HHMMSS: {text[:16]!r}")
    return text


def _num(value: float) -> str:
    """A float field, exact on the way back (Python's shortest round-trip form)."""
    return repr(float(value))


def hhmmss(when: dt.datetime) -> str:
    return when.strftime("%H%M%S")


def _address(text: str, what: str) -> int:
    return _int(text, what, 0, MAX_ADDRESS)


def _flag(text: str, what: str) -> bool:
    return bool(_int(text, what, 0, 1))


def _count(sentence: Sentence, n: int, at_least: bool = False) -> None:
    have = len(sentence.fields)
    if have < n if at_least else have != n:
        raise NmeaError("fields", f"{sentence.kind} has {have} fields, needs "
                                  f"{'at least ' if at_least else ''}{n}")


# -- typed sentences -----------------------------------------------------------------------


@dataclass(frozen=True)
class CycleInit:
    """``$CCCYC`` (``talker="CC"``) or ``$CACYC`` (``"CA"``)."""

    TYPE: ClassVar[str] = "CYC"
    talker: str
    src: int
    dest: int
    rate: int
    ack: bool
    frames: int

    def sentence(self) -> Sentence:
        return Sentence(self.talker + self.TYPE, ("0", str(self.src), str(self.dest),
                                                  str(self.rate), str(int(self.ack)),
                                                  str(self.frames)))

    @classmethod
    def from_sentence(cls, s: Sentence) -> "CycleInit":
        _count(s, 6)
        f = s.fields
        return cls(s.talker, _address(f[1], "src"), _address(f[2], "dest"),
                   _int(f[3], "rate", 0, 15), _flag(f[4], "ack"), _int(f[5], "frames", 0, 64))


@dataclass(frozen=True)
class DataRequest:
    """``$CADRQ``: frame ``frame`` (from 1) of at most ``nbytes``."""

    TYPE: ClassVar[str] = "DRQ"
    time: str
    src: int
    dest: int
    ack: bool
    nbytes: int
    frame: int
    talker: str = "CA"

    def sentence(self) -> Sentence:
        return Sentence("CADRQ", (self.time, str(self.src), str(self.dest), str(int(self.ack)),
                                  str(self.nbytes), str(self.frame)))

    @classmethod
    def from_sentence(cls, s: Sentence) -> "DataRequest":
        _count(s, 6)
        f = s.fields
        return cls(_hhmmss(f[0], "time"), _address(f[1], "src"), _address(f[2], "dest"),
                   _flag(f[3], "ack"), _int(f[4], "nbytes", 0, 4096), _int(f[5], "frame", 1, 64))


@dataclass(frozen=True)
class TxData:
    """``$CCTXD``: the data of the frame the modem asked for (empty: no more)."""

    TYPE: ClassVar[str] = "TXD"
    src: int
    dest: int
    ack: bool
    data: bytes
    talker: str = "CC"

    def sentence(self) -> Sentence:
        return Sentence("CCTXD", (str(self.src), str(self.dest), str(int(self.ack)),
                                  self.data.hex().upper()))

    @classmethod
    def from_sentence(cls, s: Sentence) -> "TxData":
        _count(s, 4)
        f = s.fields
        return cls(_address(f[0], "src"), _address(f[1], "dest"), _flag(f[2], "ack"),
                   _hex(f[3], "data"))


@dataclass(frozen=True)
class TxDataEcho:
    """``$CATXD``: the modem took ``nbytes`` for the frame."""

    TYPE: ClassVar[str] = "TXD"
    src: int
    dest: int
    ack: bool
    nbytes: int
    talker: str = "CA"

    def sentence(self) -> Sentence:
        return Sentence("CATXD", (str(self.src), str(self.dest), str(int(self.ack)),
                                  str(self.nbytes)))

    @classmethod
    def from_sentence(cls, s: Sentence) -> "TxDataEcho":
        _count(s, 4)
        f = s.fields
        return cls(_address(f[0], "src"), _address(f[1], "dest"), _flag(f[2], "ack"),
                   _int(f[3], "nbytes", 0, 4096))


@dataclass(frozen=True)
class RxData:
    """``$CARXD``: frame ``frame`` (from 1) of a packet the modem decoded."""

    TYPE: ClassVar[str] = "RXD"
    src: int
    dest: int
    ack: bool
    frame: int
    data: bytes
    talker: str = "CA"

    def sentence(self) -> Sentence:
        return Sentence("CARXD", (str(self.src), str(self.dest), str(int(self.ack)),
                                  str(self.frame), self.data.hex().upper()))

    @classmethod
    def from_sentence(cls, s: Sentence) -> "RxData":
        _count(s, 5)
        f = s.fields
        return cls(_address(f[0], "src"), _address(f[1], "dest"), _flag(f[2], "ack"),
                   _int(f[3], "frame", 1, 64), _hex(f[4], "data"))


@dataclass(frozen=True)
class TxEdge:
    """``$CATXP`` (``start=True``: the transmission begins) or ``$CATXF`` (it ended)."""

    start: bool
    nbytes: int
    talker: str = "CA"

    def sentence(self) -> Sentence:
        return Sentence("CATXP" if self.start else "CATXF", (str(self.nbytes),))

    @classmethod
    def from_sentence(cls, s: Sentence) -> "TxEdge":
        nbytes = _int(s.fields[0], "nbytes", 0, 1 << 16) if s.fields and s.fields[0] else 0
        return cls(s.type == "TXP", nbytes)


@dataclass(frozen=True)
class Ack:
    """``$CAACK``: modem ``src`` acknowledged frame ``frame`` (from 1) sent by ``dest``."""

    TYPE: ClassVar[str] = "ACK"
    src: int
    dest: int
    frame: int
    talker: str = "CA"

    def sentence(self) -> Sentence:
        return Sentence("CAACK", (str(self.src), str(self.dest), str(self.frame), "1"))

    @classmethod
    def from_sentence(cls, s: Sentence) -> "Ack":
        _count(s, 3, at_least=True)
        f = s.fields
        return cls(_address(f[0], "src"), _address(f[1], "dest"), _int(f[2], "frame", 1, 64))


@dataclass(frozen=True)
class Config:
    """``$CCCFG`` / ``$CACFG``: configuration parameter ``name`` is ``value``."""

    TYPE: ClassVar[str] = "CFG"
    talker: str
    name: str
    value: str

    def sentence(self) -> Sentence:
        return Sentence(self.talker + self.TYPE, (self.name, self.value))

    @classmethod
    def from_sentence(cls, s: Sentence) -> "Config":
        _count(s, 2)
        name = _text(s.fields[0], "name")
        if not re.match(r"^[A-Za-z][A-Za-z0-9_.]{0,31}$", name):
            raise NmeaError("value", f"bad parameter name {name[:16]!r}")
        return cls(s.talker, name, _text(s.fields[1], "value"))


@dataclass(frozen=True)
class ConfigQuery:
    """``$CCCFQ``: what is parameter ``name`` (``ALL``: every one)."""

    TYPE: ClassVar[str] = "CFQ"
    name: str
    talker: str = "CC"

    def sentence(self) -> Sentence:
        return Sentence("CCCFQ", (self.name,))

    @classmethod
    def from_sentence(cls, s: Sentence) -> "ConfigQuery":
        _count(s, 1)
        return cls(_text(s.fields[0], "name"))


@dataclass(frozen=True)
class Clock:
    """``$CCCLK`` (set) / ``$CACLK`` (the modem's clock), to the second, UTC."""

    TYPE: ClassVar[str] = "CLK"
    talker: str
    when: dt.datetime

    def sentence(self) -> Sentence:
        w = self.when
        return Sentence(self.talker + self.TYPE, (f"{w.year:04d}", f"{w.month:02d}",
                                                  f"{w.day:02d}", f"{w.hour:02d}",
                                                  f"{w.minute:02d}", f"{w.second:02d}"))

    @classmethod
    def from_sentence(cls, s: Sentence) -> "Clock":
        _count(s, 6)
        f = s.fields
        parts = [_int(f[0], "year", 1970, 9999), _int(f[1], "month", 1, 12),
                 _int(f[2], "day", 1, 31), _int(f[3], "hour", 0, 23),
                 _int(f[4], "minute", 0, 59), _int(f[5], "second", 0, 60)]
        try:
            when = dt.datetime(parts[0], parts[1], parts[2], parts[3], parts[4], min(parts[5], 59),
                               tzinfo=dt.timezone.utc)
        except ValueError as exc:
            raise NmeaError("value", f"bad date: {exc}") from None
        return cls(s.talker, when)


@dataclass(frozen=True)
class Revision:
    """``$CAREV``: ``kind`` ``AUV`` with the firmware ``version``, or ``INIT`` at a boot."""

    TYPE: ClassVar[str] = "REV"
    time: str
    kind: str
    version: str
    talker: str = "CA"

    def sentence(self) -> Sentence:
        return Sentence("CAREV", (self.time, self.kind, self.version))

    @classmethod
    def from_sentence(cls, s: Sentence) -> "Revision":
        _count(s, 3)
        f = s.fields
        return cls(_hhmmss(f[0], "time"), _text(f[1], "kind"), _text(f[2], "version"))


@dataclass(frozen=True)
class ModemError:
    """``$CAERR``: ``module`` reports error ``number`` (for ``DATA_TIMEOUT``: the frame)."""

    TYPE: ClassVar[str] = "ERR"
    time: str
    module: str
    number: int
    message: str
    talker: str = "CA"

    def sentence(self) -> Sentence:
        return Sentence("CAERR", (self.time, self.module, str(self.number),
                                  clean_text(self.message)))

    @classmethod
    def from_sentence(cls, s: Sentence) -> "ModemError":
        _count(s, 3, at_least=True)
        f = s.fields
        return cls(_hhmmss(f[0], "time"), _text(f[1], "module"),
                   _int(f[2], "number", -(1 << 31), 1 << 31),
                   _text(",".join(f[3:]).replace(",", ";"), "message"))


@dataclass(frozen=True)
class Ping:
    """``$CCMPC`` (``talker="CC"``), its echo ``$CAMPC``, or ``$CAMPA`` (``heard=True``: a
    ping from ``src`` to ``dest`` was heard)."""

    talker: str
    src: int
    dest: int
    heard: bool = False

    def sentence(self) -> Sentence:
        return Sentence(self.talker + ("MPA" if self.heard else "MPC"),
                        (str(self.src), str(self.dest)))

    @classmethod
    def from_sentence(cls, s: Sentence) -> "Ping":
        _count(s, 2)
        return cls(s.talker, _address(s.fields[0], "src"), _address(s.fields[1], "dest"),
                   s.type == "MPA")


@dataclass(frozen=True)
class PingReply:
    """``$CAMPR``: ``src`` (the pinged modem) answered ``dest`` (the pinger) after a one-way
    travel time of ``owtt_s``."""

    TYPE: ClassVar[str] = "MPR"
    src: int
    dest: int
    owtt_s: float
    talker: str = "CA"

    def sentence(self) -> Sentence:
        return Sentence("CAMPR", (str(self.src), str(self.dest), f"{self.owtt_s:.4f}"))

    @classmethod
    def from_sentence(cls, s: Sentence) -> "PingReply":
        _count(s, 3)
        f = s.fields
        owtt = _float(f[2], "owtt")
        if owtt < 0:
            raise NmeaError("value", "owtt < 0")
        return cls(_address(f[0], "src"), _address(f[1], "dest"), owtt)


@dataclass(frozen=True)
class Place:
    """``$PCFLP,X,Y,Z``: ours. The emulated modem is at (X, Y, Z), scenario metres."""

    pos: tuple[float, float, float]
    talker: str = "P"

    def sentence(self) -> Sentence:
        return Sentence("PCFLP", tuple(_num(c) for c in self.pos))

    @classmethod
    def from_sentence(cls, s: Sentence) -> "Place":
        _count(s, 3)
        x, y, z = (_float(t, "position") for t in s.fields)
        return cls((x, y, z))


CST_FIELDS = ("mode", "toa", "toa_mode", "mfd_peak", "mfd_pow", "mfd_ratio", "mfd_spl", "agn",
              "shift_ain", "shift_ainp", "shift_mfd", "shift_p2b", "rate", "src", "dest",
              "psk_error", "packet_type", "frames", "bad_frames", "snr_rss", "snr_in",
              "snr_out", "snr_sym", "mse", "dqf", "dop", "noise", "carrier", "bandwidth")
_CST_FLOATS = {"snr_in", "snr_out", "snr_sym", "mse", "dop"}
TOA_FORMAT = "%Y%m%d%H%M%S"


@dataclass(frozen=True)
class CycleStats:
    """``$CACST`` version 6 (the fields of `CST_FIELDS`, in that order [AC, Goby]). ``toa``
    is the time of arrival, ``YYYYMMDDHHMMSS.ffffff``; ``mode`` 0 good, 1 bad CRC, 2 packet
    timeout. Versions 7 and 8 parse too (8's four extra fields are dropped)."""

    TYPE: ClassVar[str] = "CST"
    toa: dt.datetime
    rate: int
    src: int
    dest: int
    frames: int
    bad_frames: int = 0
    mode: int = 0
    snr_in: float = 0.0
    snr_out: float = 0.0
    snr_sym: float = 0.0
    mse: float = 0.0
    dop: float = 0.0
    toa_mode: int = 0
    mfd_peak: int = 0
    mfd_pow: int = 0
    mfd_ratio: int = 0
    mfd_spl: int = 0
    agn: int = 250
    shift_ain: int = 0
    shift_ainp: int = 0
    shift_mfd: int = 0
    shift_p2b: int = 0
    psk_error: int = 0
    packet_type: int = 5
    snr_rss: int = 0
    dqf: int = 0
    noise: int = 0
    carrier: int = 25000
    bandwidth: int = 5000
    version: int = 6
    talker: str = "CA"

    def sentence(self) -> Sentence:
        out = [str(self.version)]
        for name in CST_FIELDS:
            value = getattr(self, name)
            if name == "toa":
                out.append(value.strftime(TOA_FORMAT) + f".{value.microsecond:06d}")
            elif name in _CST_FLOATS:
                out.append(f"{value:.2f}")
            else:
                out.append(str(int(value)))
        return Sentence("CACST", tuple(out))

    @classmethod
    def from_sentence(cls, s: Sentence) -> "CycleStats":
        _count(s, 1 + len(CST_FIELDS), at_least=True)
        version = _int(s.fields[0], "version", 6, 8)
        toa = dt.datetime.min
        n: dict[str, int] = {}  # the integer fields, and the real ones (`_CST_FLOATS`)
        x: dict[str, float] = {}
        for name, text in zip(CST_FIELDS, s.fields[1:]):
            if name == "toa":
                m = re.match(r"^(\d{14})\.(\d{1,6})$", text)
                if m is None:
                    raise NmeaError("value", f"toa: not YYYYMMDDHHMMSS.f: {text[:24]!r}")
                try:
                    whole = dt.datetime.strptime(m.group(1), TOA_FORMAT)
                except ValueError:
                    raise NmeaError("value", f"toa: bad date {text[:24]!r}") from None
                toa = whole.replace(microsecond=int(m.group(2).ljust(6, "0")),
                                    tzinfo=dt.timezone.utc)
            elif name in _CST_FLOATS:
                x[name] = _float(text, name)
            else:
                n[name] = _int(text, name, -(1 << 31), 1 << 31)
        for name in ("src", "dest"):
            _address(str(n[name]), name)
        # Each field by name, so that the type checker sees every one of them.
        return cls(toa=toa, rate=n["rate"], src=n["src"], dest=n["dest"], frames=n["frames"],
                   bad_frames=n["bad_frames"], mode=n["mode"], snr_in=x["snr_in"],
                   snr_out=x["snr_out"], snr_sym=x["snr_sym"], mse=x["mse"], dop=x["dop"],
                   toa_mode=n["toa_mode"], mfd_peak=n["mfd_peak"], mfd_pow=n["mfd_pow"],
                   mfd_ratio=n["mfd_ratio"], mfd_spl=n["mfd_spl"], agn=n["agn"],
                   shift_ain=n["shift_ain"], shift_ainp=n["shift_ainp"], shift_mfd=n["shift_mfd"],
                   shift_p2b=n["shift_p2b"], psk_error=n["psk_error"], packet_type=n["packet_type"],
                   snr_rss=n["snr_rss"], dqf=n["dqf"], noise=n["noise"], carrier=n["carrier"],
                   bandwidth=n["bandwidth"], version=version)


Typed = Union[CycleInit, DataRequest, TxData, TxDataEcho, RxData, TxEdge, Ack, Config,
              ConfigQuery, Clock, Revision, ModemError, Ping, PingReply, Place, CycleStats]

# Each kind's decoder (the class's `from_sentence`, typed as what `typed` returns).
_DECODERS: dict[str, Callable[[Sentence], Typed]] = {
    "CCCYC": CycleInit.from_sentence, "CACYC": CycleInit.from_sentence,
    "CADRQ": DataRequest.from_sentence, "CCTXD": TxData.from_sentence,
    "CATXD": TxDataEcho.from_sentence, "CARXD": RxData.from_sentence,
    "CATXP": TxEdge.from_sentence, "CATXF": TxEdge.from_sentence,
    "CAACK": Ack.from_sentence, "CCCFG": Config.from_sentence,
    "CACFG": Config.from_sentence, "CCCFQ": ConfigQuery.from_sentence,
    "CCCLK": Clock.from_sentence, "CACLK": Clock.from_sentence,
    "CAREV": Revision.from_sentence, "CAERR": ModemError.from_sentence,
    "CCMPC": Ping.from_sentence, "CAMPC": Ping.from_sentence,
    "CAMPA": Ping.from_sentence, "CAMPR": PingReply.from_sentence,
    "PCFLP": Place.from_sentence, "CACST": CycleStats.from_sentence,
}
KINDS = frozenset(_DECODERS)


def typed(sentence: Sentence) -> Typed | Sentence:
    """The typed form of ``sentence`` if it is of the subset (else the sentence itself);
    raises `NmeaError` if its fields are wrong."""
    decoder = _DECODERS.get(sentence.kind)
    return sentence if decoder is None else decoder(sentence)


def decode(line: bytes | str) -> Typed | Sentence:
    """`parse` then `typed`: one line in, one typed sentence (or an unknown one) out."""
    return typed(parse(line))


def encode(message: Typed | Sentence) -> bytes:
    """The line (with checksum and CR LF) of a typed or plain sentence."""
    return (message if isinstance(message, Sentence) else message.sentence()).encode()


def clean_text(text: str, max_len: int = 80) -> str:
    """``text`` made safe for a free-text field (no , * $, printable ASCII, bounded)."""
    out = "".join(c if 0x20 <= ord(c) < 0x7f and c not in ",*$" else "_" for c in text)
    return out[:max_len]
