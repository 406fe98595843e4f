"""`MicroModem`: the agent's modem port on a WHOI Micro-Modem, over its NMEA interface.

The link is ``tcp:HOST:PORT`` (an emulated modem, `cotsfleet water --face micromodem`, or a
real one behind a serial-to-TCP bridge) or a serial device path (``/dev/ttyUSB0``; needs
pyserial, imported only then). One thread owns the link: it reads and parses what the modem
says (`fleet_bus.nmea`), runs the transmit cycle, checks deadlines and reconnects.

A transmission (`transmit`) is one Micro-Modem packet at the configured rate: ``$CCCYC``
from this modem's address to ``dest`` with as many frames as given; the modem echoes
``$CACYC`` and asks for each frame (``$CADRQ``), answered with ``$CCTXD``; ``$CATXF`` ends it
(reported `Sent`). Frames come back as `Received` from ``$CARXD`` (addressed to this modem or
broadcast), acknowledgements as `Acked` from ``$CAACK`` (``frame_no`` counts from 0, in the
order the frames were given). What goes wrong is reported `Dropped` and counted, never
raised: ``$CAERR`` during a cycle (``error``), a modem that does not answer in time
(``timeout``; `SILENT_CYCLES` of those in a row and the link is reopened), no link
(``no_modem``), a full queue (``busy``), frames too many or too large (``oversize``). Lines
that are not well-formed NMEA are counted per reason (``nmea_<reason>``) and skipped.

Mission time: every report is dated by the ``clock`` given (mission seconds); deadlines on
the serial exchange are wall seconds (a host and its modem answer in wall time whatever the
warp), the wait for the end of a transmission is its airtime on the mission clock.
"""

from __future__ import annotations

import os
import select
import threading
import time
from collections import Counter, deque
from dataclasses import dataclass
from typing import Sequence

from fleet_agent.modems.link import DEFAULT_BAUD, REPLY_TIMEOUT_S, NmeaLink, parse_link
from fleet_bus import nmea
from fleet_bus.clock import Clock
from fleet_bus.modem_port import (Acked, Dropped, ModemReport, ModemSpec, Received,
                                  ReportSink, Sent)
from fleet_bus.nmea import BROADCAST, RATES

TXF_MARGIN_S = 5.0  # wall seconds past a packet's airtime before its $CATXF is given up
SILENT_CYCLES = 3  # cycles in a row without an answer: the link is reopened
RECONNECT_S = 1.0
MAX_QUEUED = 8  # transmissions waiting for the modem
SUPERSEDABLE = "pose"


@dataclass
class _Packet:
    frames: tuple[bytes, ...]
    kind: str
    queued_s: float


@dataclass
class _Cycle:
    packet: _Packet
    state: str  # "cyc" (awaiting $CACYC), "drq" (frames), "txf" (on the air)
    deadline: float  # wall (monotonic)
    given: int = 0
    started_s: float | None = None
    t_s: float = 0.0


def micromodem_spec(rate: int, bit_rate_bps: float | None = None,
                    acknowledged: bool = False) -> ModemSpec:
    """What a Micro-Modem at ``rate`` carries (`fleet_bus.nmea.RATES`); ValueError for an
    unknown rate, or one with no published bit rate and none given."""
    if rate not in RATES:
        raise ValueError(f"unknown Micro-Modem rate {rate}; known: {sorted(RATES)}")
    spec_rate = RATES[rate]
    bps = bit_rate_bps if bit_rate_bps is not None else spec_rate.bit_rate_bps
    if bps is None:
        raise ValueError(f"rate {rate} has no published bit rate: give bit_rate_bps")
    return ModemSpec(f"micromodem-rate{rate}", spec_rate.frame_bytes, float(bps),
                     spec_rate.frames, half_duplex=True, acknowledged=acknowledged)


class MicroModem:
    """A `fleet_bus.modem_port.ModemPort` on a Micro-Modem (see the module docstring).

    ``rate``: the packet type of every transmission (its frames and bytes are the spec's);
    ``address``: set the modem's ``SRC`` (None: ask it); ``dest``: where packets go
    (0 broadcast); ``ack``: ask for acknowledgements (unicast only); ``bit_rate_bps``: for a
    rate with no published burst rate (`fleet_bus.nmea.RATES`)."""

    def __init__(self, link: str, sink: ReportSink, clock: Clock, *, rate: int = 1,
                 address: int | None = None, dest: int = BROADCAST, ack: bool = False,
                 baud: int = DEFAULT_BAUD, bit_rate_bps: float | None = None,
                 reply_timeout_s: float = REPLY_TIMEOUT_S, start: bool = True) -> None:
        self._kind, self._where, self._port = parse_link(link)
        if address is not None and not 1 <= address <= nmea.MAX_ADDRESS:
            raise ValueError(f"address must be 1-{nmea.MAX_ADDRESS}, got {address}")
        if not 0 <= dest <= nmea.MAX_ADDRESS:
            raise ValueError(f"dest must be 0-{nmea.MAX_ADDRESS}, got {dest}")
        self.spec = micromodem_spec(rate, bit_rate_bps, ack and dest != BROADCAST)
        self.rate = rate
        self.address = address
        self.dest = dest
        self.ack = ack and dest != BROADCAST
        self.baud = baud
        self.reply_timeout_s = reply_timeout_s
        self.counters: Counter[str] = Counter()
        self.revision: str | None = None
        self._sink = sink
        self._clock = clock
        self._lock = threading.Lock()
        self._queue: deque[_Packet] = deque()
        self._link: NmeaLink | None = None
        self._cycle: _Cycle | None = None
        self._last_sent_s = 0.0
        self._silent = 0
        self.last_error = ""
        self._stop = threading.Event()
        self._wake_r, self._wake_w = os.pipe()
        os.set_blocking(self._wake_w, False)
        self._thread = threading.Thread(target=self._run, name=f"micromodem-{link}",
                                        daemon=True)
        if start:
            self._thread.start()

    # -- the port --------------------------------------------------------------------------

    def transmit(self, frames: Sequence[bytes], kind: str, sent_s: float | None = None) -> None:
        now = self._clock.now()
        frames = tuple(bytes(f) for f in frames if f)
        if not frames or len(frames) > self.spec.frames_per_packet or \
                any(len(f) > self.spec.max_frame_bytes for f in frames):
            self._report(Dropped(now, "oversize", max(1, len(frames))))
            return
        with self._lock:
            if self._link is None:
                dropped: ModemReport | None = Dropped(now, "no_modem", len(frames))
            else:
                dropped = None
                if kind == SUPERSEDABLE:
                    kept = deque(p for p in self._queue if p.kind != SUPERSEDABLE)
                    self.counters["superseded"] += len(self._queue) - len(kept)
                    self._queue = kept
                if len(self._queue) >= MAX_QUEUED:
                    dropped = Dropped(now, "busy", len(frames))
                else:
                    self._queue.append(_Packet(frames, kind, now))
        if dropped is not None:
            self._report(dropped)
        else:
            self._wake()

    def close(self) -> None:
        """Stop the thread and close the link (idempotent)."""
        if self._stop.is_set():
            return
        self._stop.set()
        self._wake()
        if self._thread.is_alive():
            self._thread.join(5.0)
        self._close_link()
        for fd in (self._wake_r, self._wake_w):
            try:
                os.close(fd)
            except OSError:
                pass

    @property
    def connected(self) -> bool:
        return self._link is not None and self._link.address_known

    # -- the link thread -------------------------------------------------------------------

    def _run(self) -> None:
        next_try = 0.0
        while not self._stop.is_set():
            if self._link is None and time.monotonic() >= next_try:
                next_try = time.monotonic() + RECONNECT_S
                self._open_link()
            fds = [self._wake_r] + ([self._link.fileno()] if self._link else [])
            try:
                readable, _, _ = select.select(fds, [], [], self._wait_s(next_try))
            except (OSError, ValueError):
                self._lost("select")
                continue
            if self._wake_r in readable:
                try:
                    os.read(self._wake_r, 512)
                except OSError:
                    pass
            if self._link is not None and self._link.fileno() in readable:
                self._read()
            self._check_deadlines()
            self._next_cycle()

    def _wait_s(self, next_try: float) -> float:
        now = time.monotonic()
        deadlines = [next_try] if self._link is None else []
        if self._cycle is not None:
            deadlines.append(self._cycle.deadline)
        if self._link is not None and not self._link.address_known:
            deadlines.append(self._link.config_deadline)
        return max(0.0, min([now + 0.5, *deadlines]) - now)

    def _open_link(self) -> None:
        try:
            link = NmeaLink.open(self._kind, self._where, self._port, self.baud, self.counters)
        except OSError as exc:
            self.counters["connect_failed"] += 1
            self._drop_queue("no_modem")
            self.last_error = str(exc)
            return
        with self._lock:
            self._link = link
        self.counters["connects"] += 1
        self._configure()

    def _configure(self) -> None:
        link = self._link
        if link is None:
            return
        link.config_deadline = time.monotonic() + self.reply_timeout_s
        if self.address is None:
            self._write(nmea.ConfigQuery("SRC"))
        else:
            self._write(nmea.Config("CC", "SRC", str(self.address)))

    def _close_link(self) -> None:
        with self._lock:
            link, self._link = self._link, None
        if link is not None:
            link.close()

    def _lost(self, why: str) -> None:
        self.counters[f"link_lost_{why}"] += 1
        self._close_link()
        self._fail_cycle("no_modem")
        self._drop_queue("no_modem")

    def _read(self) -> None:
        link = self._link
        assert link is not None
        try:
            messages = link.read()
        except (OSError, ConnectionError):
            self._lost("read")
            return
        for message in messages:
            self.counters["lines"] += 1
            self._silent = 0
            handler = getattr(self, "_on_" + type(message).__name__, None)
            if handler is None:
                self.counters["ignored"] += 1
            else:
                handler(message)
            if self._link is not link:
                return

    # -- what the modem says ---------------------------------------------------------------

    def _on_Config(self, m: nmea.Config) -> None:
        link = self._link
        if m.name == "SRC" and m.value.isdigit() and link is not None:
            if self.address is None or int(m.value) == self.address:
                self.address = int(m.value)
                link.address_known = True

    def _on_Revision(self, m: nmea.Revision) -> None:
        self.counters["revisions"] += 1
        if m.kind == "AUV":
            self.revision = m.version
        elif m.kind == "INIT":  # the modem rebooted: whatever it was doing is lost
            self.counters["modem_reboots"] += 1
            self._fail_cycle("error")
            if self._link is not None:
                self._link.address_known = False
                self._configure()

    def _on_ModemError(self, m: nmea.ModemError) -> None:
        self.counters[f"caerr_{m.module.lower()}"[:40]] += 1
        if self._cycle is not None:
            self._fail_cycle("timeout" if m.module == "DATA_TIMEOUT" else "error")

    def _on_CycleInit(self, m: nmea.CycleInit) -> None:
        cycle = self._cycle
        if m.src == self.address and cycle is not None and cycle.state == "cyc":
            cycle.state = "drq"
            cycle.deadline = time.monotonic() + self.reply_timeout_s
        elif m.src != self.address:
            self.counters["rx_cycles"] += 1

    def _on_DataRequest(self, m: nmea.DataRequest) -> None:
        cycle = self._cycle
        if cycle is None or cycle.state != "drq" or m.src != self.address:
            self.counters["drq_unexpected"] += 1
            self._write(nmea.TxData(m.src, m.dest, m.ack, b""))  # nothing to send
            return
        frames = cycle.packet.frames
        data = frames[m.frame - 1] if m.frame <= len(frames) else b""
        if len(data) > m.nbytes:
            self.counters["drq_too_small"] += 1
            data = b""
        self._write(nmea.TxData(self.address, self.dest, self.ack, data))
        if data:
            cycle.given = max(cycle.given, m.frame)
        if not data or m.frame >= len(frames):
            cycle.state = "txf"
            airtime = self.spec.airtime_s(sum(len(f) for f in frames[:cycle.given]))
            cycle.deadline = time.monotonic() + self._wall(airtime) + TXF_MARGIN_S
        else:
            cycle.deadline = time.monotonic() + self.reply_timeout_s

    def _on_TxEdge(self, m: nmea.TxEdge) -> None:
        cycle = self._cycle
        if cycle is None or cycle.state != "txf":
            return
        if m.start:
            cycle.started_s = self._clock.now()
            return
        self._cycle = None
        self._silent = 0
        frames = cycle.packet.frames[:cycle.given]
        now = self._clock.now()
        t_s = cycle.started_s if cycle.started_s is not None else \
            now - self.spec.airtime_s(sum(len(f) for f in frames))
        self._last_sent_s = t_s
        self.counters["sent"] += 1
        self._report(Sent(t_s, len(frames), sum(len(f) for f in frames)))

    def _on_RxData(self, m: nmea.RxData) -> None:
        if m.dest not in (BROADCAST, self.address):
            self.counters["rx_not_for_us"] += 1
        elif m.data:
            self.counters["received"] += 1
            self._report(Received(m.data, self._clock.now()))

    def _on_CycleStats(self, m: nmea.CycleStats) -> None:
        self.counters["cycle_stats"] += 1
        if m.bad_frames:
            self.counters["rx_bad_frames"] += m.bad_frames

    def _on_Ack(self, m: nmea.Ack) -> None:
        if m.dest == self.address:
            self.counters["acked"] += 1
            self._report(Acked(self._last_sent_s, m.frame - 1))

    # -- the transmit cycle ----------------------------------------------------------------

    def _next_cycle(self) -> None:
        if self._cycle is not None or not self.connected:
            return
        with self._lock:
            if not self._queue:
                return
            packet = self._queue.popleft()
        self._cycle = _Cycle(packet, "cyc", time.monotonic() + self.reply_timeout_s)
        self._write(nmea.CycleInit("CC", self.address or 0, self.dest, self.rate, self.ack,
                                   len(packet.frames)))

    def _check_deadlines(self) -> None:
        now = time.monotonic()
        link = self._link
        if link is not None and not link.address_known and now > link.config_deadline:
            self.counters["config_timeouts"] += 1
            self._silent += 1
            if self._silent >= SILENT_CYCLES:
                self._lost("silent")
            else:
                self._configure()
            return
        cycle = self._cycle
        if cycle is not None and now > cycle.deadline:
            self.counters[f"timeout_{cycle.state}"] += 1
            self._silent += 1
            self._fail_cycle("timeout")
            if self._silent >= SILENT_CYCLES:
                self._lost("silent")

    def _fail_cycle(self, reason: str) -> None:
        cycle, self._cycle = self._cycle, None
        if cycle is not None:
            self.counters[f"dropped_{reason}"] += 1
            self._report(Dropped(self._clock.now(), reason, len(cycle.packet.frames)))

    def _drop_queue(self, reason: str) -> None:
        with self._lock:
            packets, self._queue = list(self._queue), deque()
        for packet in packets:
            self.counters[f"dropped_{reason}"] += 1
            self._report(Dropped(self._clock.now(), reason, len(packet.frames)))

    # -- plumbing --------------------------------------------------------------------------

    def _write(self, message: nmea.Typed) -> None:
        link = self._link
        if link is None:
            return
        try:
            link.send(message)
        except OSError:
            self._lost("write")

    def _report(self, report: ModemReport) -> None:
        try:
            self._sink(report)
        except Exception:  # the agent's sink must never stop the modem
            self.counters["sink_errors"] += 1

    def _wake(self) -> None:
        try:
            os.write(self._wake_w, b"\0")
        except OSError:  # full (already woken) or closed
            pass

    def _wall(self, mission_s: float) -> float:
        wall_delay = getattr(self._clock, "wall_delay", None)
        return wall_delay(mission_s) if callable(wall_delay) else mission_s
