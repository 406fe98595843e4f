"""What the capture tests share: tcpdump on an interface, the TCP streams of its file, TLS
records, and the plaintext a mission would show if its bus were not encrypted.

The pcap format (libpcap's, as tcpdump writes it) is a 24-byte file header and a 16-byte
header per packet; frames are Ethernet (LINKTYPE_ETHERNET, 1: veth and Linux's loopback)
or Linux cooked capture (LINKTYPE_LINUX_SLL, 113: ``-i any``); TLS records are RFC 8446
section 5.1 (type, legacy version, 16-bit length).
"""

from __future__ import annotations

import selectors
import signal
import struct
import subprocess
import time
from dataclasses import fields
from pathlib import Path
from typing import Sequence

import msgpack

from fleet_bus import keys
from fleet_bus.auth import MAGIC
from fleet_bus.mission import ClockRecord, Mission
from fleet_bus.telemetry import Event, Status

Stream = tuple[str, int, str, int]  # source address, port, destination address, port


class Tcpdump:
    """``tcpdump -i iface -w path filter`` (started with ``prefix``, e.g. in a network
    namespace), ready once it says it listens; `stop` ends it and flushes the file."""

    def __init__(self, prefix: Sequence[str], iface: str, path: Path, bpf: str) -> None:
        self.path = path
        # -Z root: tcpdump would otherwise drop to its own user, who cannot write in the
        # test's directory; --immediate-mode and -U: each packet handed over and written as
        # it comes (else the kernel's buffer holds them, and SIGINT loses what it holds).
        self.proc = subprocess.Popen([*prefix, "tcpdump", "-i", iface, "-w", str(path), "-U",
                                      "--immediate-mode", "-Z", "root", "-n", bpf],
                                     stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                     text=True, start_new_session=True)
        assert self.proc.stderr is not None
        sel = selectors.DefaultSelector()
        sel.register(self.proc.stderr, selectors.EVENT_READ)
        deadline = time.monotonic() + 20
        while time.monotonic() < deadline:
            if sel.select(timeout=0.5):
                line = self.proc.stderr.readline()
                if "listening on" in line:
                    return
                if not line:
                    break
        self.stop()
        raise AssertionError(f"tcpdump did not start on {iface}")

    def stop(self) -> None:
        if self.proc.poll() is None:
            time.sleep(0.5)  # the last packets reach it
            self.proc.send_signal(signal.SIGINT)
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()


def _packets(data: bytes) -> tuple[int, list[bytes]]:
    magic = struct.unpack_from("<I", data)[0]
    order = {0xA1B2C3D4: "<", 0xA1B23C4D: "<", 0xD4C3B2A1: ">", 0x4D3CB2A1: ">"}[magic]
    linktype = struct.unpack_from(order + "I", data, 20)[0]
    out, at = [], 24
    while at + 16 <= len(data):
        caplen = struct.unpack_from(order + "I", data, at + 8)[0]
        out.append(data[at + 16:at + 16 + caplen])
        at += 16 + caplen
    return linktype, out


def tcp_streams(path: Path) -> dict[Stream, bytes]:
    """The TCP payload of each direction of each connection in the capture, in order (a
    virtual link neither loses nor reorders, so no reassembly beyond concatenation)."""
    linktype, packets = _packets(path.read_bytes())
    skip = {1: 14, 113: 16}[linktype]
    streams: dict[Stream, bytearray] = {}
    for frame in packets:
        ethertype = struct.unpack_from(">H", frame, skip - 2)[0]
        ip = frame[skip:]
        if ethertype == 0x0800 and ip[9] == 6:  # IPv4, TCP
            header, total = (ip[0] & 0x0F) * 4, struct.unpack_from(">H", ip, 2)[0]
            src, dst = ".".join(map(str, ip[12:16])), ".".join(map(str, ip[16:20]))
        elif ethertype == 0x86DD and ip[6] == 6:  # IPv6 without extension headers, TCP
            header, total = 40, 40 + struct.unpack_from(">H", ip, 4)[0]
            src, dst = ip[8:24].hex(), ip[24:40].hex()
        else:
            continue
        tcp = ip[header:total]
        sport, dport = struct.unpack_from(">HH", tcp)
        payload = tcp[(tcp[12] >> 4) * 4:]
        if payload:
            streams.setdefault((src, sport, dst, dport), bytearray()).extend(payload)
    return {k: bytes(v) for k, v in streams.items()}


def tls_records(stream: bytes) -> list[int]:
    """The content type of each TLS record the stream is made of; AssertionError at the
    first byte that is not inside a well-formed record (a cut last record is fine: the
    capture ended)."""
    kinds, at = [], 0
    while at + 5 <= len(stream):
        kind, version, length = struct.unpack_from(">BHH", stream, at)
        assert kind in (20, 21, 22, 23) and version in (0x0301, 0x0303) \
            and length <= 2**14 + 256, f"not a TLS record at byte {at}: {stream[at:at + 16]!r}"
        kinds.append(kind)
        at += 5 + length
    return kinds


def plaintext_markers(run_id: str, vehicles: Sequence[str]) -> dict[str, bytes]:
    """Byte strings that would be on the wire if the bus were in clear: the run id; the key
    expressions, as Zenoh sends them (a subscriber's declaration names ``fleet/**``, a put
    then the rest of its key after a declared prefix: ``/status/auv3``); each vehicle's id
    as msgpack puts it and as a signed envelope names its signer; the msgpack field names of
    the mission, clock, status and event records. Only strings of 5 bytes or more: a shorter
    one turns up in a megabyte of ciphertext by chance."""
    marks = {"run id": run_id.encode(), "key expressions' root": keys.PREFIX.encode(),
             "key mission": b"/mission", "key clock": b"/clock"}
    for vid in vehicles:
        for kind in ("tx", "rx", "truth", "status", "event", "alive", "busy", "ctl"):
            marks[f"key {kind}/{vid}"] = f"{kind}/{vid}".encode()
        marks[f"{vid} in msgpack"] = msgpack.packb(vid)
        marks[f"{vid} signing an envelope"] = MAGIC + bytes((len(vid),)) + vid.encode()
    names = {"scenario", "run_id", "epoch_unix"} | {f.name for f in fields(Status)} | {
        f.name for f in fields(Event)} | {f.name for f in fields(ClockRecord)} | {
        f.name for f in fields(Mission)}
    for name in sorted(names):
        packed = msgpack.packb(name)
        if len(packed) >= 5:
            marks[f"field {name}"] = packed
    return marks


def found(data: bytes, marks: dict[str, bytes]) -> list[str]:
    return [name for name, mark in marks.items() if mark in data]
