"""One emulated Micro-Modem: the host's sentences in, the modem's sentences out.

Host side (`on_line`, from the server's thread), after WHOI's Software Interface Guide as
drivers use it (`fleet_bus.nmea` cites each format):

- ``$CCCYC`` from this modem's own address at the water's rate: echo ``$CACYC``, then one
  ``$CADRQ`` per frame; each ``$CCTXD`` is echoed ``$CATXD`` and the next frame requested.
  An empty ``$CCTXD``, the last frame, or a data request unanswered for ``DTO`` seconds (then
  ``$CAERR,...,DATA_TIMEOUT,<frame>``) ends the cycle: the frames given so far go on the
  water (``$CATXP`` now, ``$CATXF`` when the packet's airtime ends). The packet is placed on
  the water at the time of the ``$CCCYC`` (within `MAX_SERIAL_S`): the serial exchange takes
  no mission time, so a fast-warped mission sees the same water as at warp 1.
- ``$CCMPC``: a ping minipacket; the pinged modem answers at once (``$CAMPA`` at its host)
  and the pinger's host gets ``$CAMPR`` with the one-way travel time.
- ``$CCCFG`` / ``$CCCFQ``: configuration (``SRC`` is the modem's address), ``$CCCLK`` the
  modem's clock, ``$PCFLP`` (ours) where the modem is.
- anything malformed, unknown, or impossible now (busy, another rate, an uplink request for
  another modem) gets ``$CAERR`` and is counted.

Water side (`on_event`, from the water's scheduler): a data packet decoded here comes out as
``$CACYC`` (heard), one ``$CARXD`` per frame and ``$CACST``, at the mission time the channel
settles it; one heard but lost to a collision or the extra loss as ``$CACST`` with every
frame bad; one addressed here with ACK set is acknowledged by a minipacket that becomes
``$CAACK`` at the sender. A modem transmits one thing at a time; acknowledgements and ping
replies wait for none (a real modem answers at once too).

The modem's clock reads the mission clock as a date: ``epoch_unix + mission seconds`` (plus
what ``$CCCLK`` moved it by), so at warp 1 it is UTC.
"""

from __future__ import annotations

import datetime as dt
import threading
from collections import Counter
from dataclasses import dataclass, field
from typing import Callable, Protocol

from comms_sim.config import ChannelConfig
from comms_sim.link_event import LinkEvent
from comms_sim.micromodem.packet import ACK, DATA, PING, PONG, OnAir
from comms_sim.water import Timer
from fleet_bus import nmea
from fleet_bus.nmea import BROADCAST, NmeaError



class Medium(Protocol):
    """What a virtual modem needs of the water it is in (`comms_sim.micromodem.fleet`)."""

    rate: nmea.Rate
    config: ChannelConfig

    def now(self) -> float: ...
    def date_of(self, t_s: float) -> dt.datetime: ...
    def airtime_s(self, nbytes: int) -> float: ...
    def submit(self, node: str, on_air: bytes, t_s: float, tag: OnAir) -> None: ...
    def place(self, node: str, pos: tuple[float, float, float]) -> None: ...
    def at(self, t_s: float, fn: Callable[[], None]) -> "Timer": ...
    def after_wall(self, wall_s: float, fn: Callable[[], None]) -> "Timer": ...

REVISION = "0.1.0-cotsfleet"  # what $CAREV reports: an emulator, not a WHOI firmware
MAX_SERIAL_S = 10.0  # mission seconds a packet may be placed back to its $CCCYC
MAX_CONFIG = 64  # parameters one modem stores (the known ones plus what hosts set)
# $CAERR numbers, ours (the guide's own are not public): module, number
ERR_NMEA, ERR_UNSUPPORTED, ERR_BUSY, ERR_CYCLE, ERR_NO_REQUEST = 1, 2, 3, 4, 5
DEFAULT_CONFIG = {"SRC": "1", "CST": "1", "XST": "0", "TXF": "1", "TXP": "1", "DTO": "5",
                  "CTO": "10", "ASD": "0", "BND": "0", "AGN": "250", "REV": "1"}
HEARD_LOST = ("collision", "random")  # detected but not decoded: $CACST with bad frames

Send = Callable[[bytes], None]


@dataclass
class _Cycle:
    """A cycle this modem's host started: the frames given so far."""

    dest: int
    ack: bool
    frames_wanted: int
    t_cycle_s: float
    frames: list[bytes] = field(default_factory=list)
    timer: Timer | None = None


class VirtualModem:
    """See the module docstring. ``node`` is the vehicle id the channel knows it by."""

    def __init__(self, fleet: Medium, node: str, address: int) -> None:
        self.fleet = fleet
        self.node = node
        self.config = dict(DEFAULT_CONFIG, SRC=str(address))
        self.counters: Counter[str] = Counter()
        self._lock = threading.RLock()
        self._host: Send | None = None
        self._cycle: _Cycle | None = None
        self._busy_until_s = float("-inf")  # this modem's own transmission ends
        self._clock_offset_s = 0.0

    @property
    def address(self) -> int:
        return int(self.config["SRC"])

    # -- the host --------------------------------------------------------------------------

    def attach(self, send: Send | None) -> None:
        """The host's line (None: none connected). A new host gets ``$CAREV`` at once, as
        when a modem boots."""
        with self._lock:
            self._host = send
            if send is not None:
                self._say(nmea.Revision(self._hhmmss(), "AUV", REVISION))

    def heartbeat(self) -> None:
        """``$CAREV`` if idle (drivers take it as a sign of life; acomms resets its state on
        one, so never mid-cycle)."""
        with self._lock:
            if self._host is not None and self._cycle is None and not self._transmitting():
                self._say(nmea.Revision(self._hhmmss(), "AUV", REVISION))

    def on_line(self, line: bytes) -> None:
        """One line from the host (without its end of line)."""
        with self._lock:
            self.counters["host_lines"] += 1
            try:
                message = nmea.decode(line)
            except NmeaError as exc:
                self.counters[f"host_{exc.reason}"] += 1
                self._error("NMEA", ERR_NMEA, exc.reason)
                return
            if not self._handle(message):
                self.counters["host_unsupported"] += 1
                kind = getattr(message, "kind", type(message).__name__)
                self._error("NMEA", ERR_UNSUPPORTED, f"{kind} not emulated")

    def _handle(self, m: object) -> bool:
        """Carry out a host's command (the $CC sentences a host sends, and our $P place
        extension); False for anything this emulator does not do."""
        talker = getattr(m, "talker", "")
        if talker == "P" and isinstance(m, nmea.Place):
            self._place(m)
        elif talker != "CC":
            return False
        elif isinstance(m, nmea.CycleInit):
            self._cycle_init(m)
        elif isinstance(m, nmea.TxData):
            self._tx_data(m)
        elif isinstance(m, nmea.Ping):
            self._ping(m)
        elif isinstance(m, nmea.Config):
            self._config(m)
        elif isinstance(m, nmea.ConfigQuery):
            self._config_query(m)
        elif isinstance(m, nmea.Clock):
            self._clock(m)
        else:
            return False
        return True

    def on_garbage(self, reason: str) -> None:
        """The server dropped input that is not a line (too long)."""
        with self._lock:
            self.counters[f"host_{reason}"] += 1
            self._error("NMEA", ERR_NMEA, reason)

    def _cycle_init(self, m: nmea.CycleInit) -> None:
        rate = self.fleet.rate
        if m.src != self.address:
            return self._refuse_cycle("uplink requests (polling another modem) are not emulated")
        if m.rate != rate.number:
            return self._refuse_cycle(f"rate {m.rate}: this water runs rate {rate.number}")
        if not 1 <= m.frames <= rate.frames:
            return self._refuse_cycle(f"{m.frames} frames: rate {rate.number} takes 1-"
                                      f"{rate.frames}")
        if self._cycle is not None or self._transmitting():
            self.counters["busy"] += 1
            return self._error("CYC", ERR_BUSY, "busy")
        self.counters["cycles"] += 1
        self._cycle = _Cycle(m.dest, m.ack, m.frames, self.fleet.now())
        self._say(nmea.CycleInit("CA", m.src, m.dest, m.rate, m.ack, m.frames))
        self._request(1)

    def _refuse_cycle(self, why: str) -> None:
        self.counters["bad_cycles"] += 1
        self._error("CYC", ERR_CYCLE, why)

    def _request(self, frame: int) -> None:
        cycle = self._cycle
        assert cycle is not None
        self._say(nmea.DataRequest(self._hhmmss(), self.address, cycle.dest, cycle.ack,
                                   self.fleet.rate.frame_bytes, frame))
        cycle.timer = self.fleet.after_wall(float(self.config.get("DTO", "5")),
                                            lambda: self._data_timeout(cycle, frame))

    def _data_timeout(self, cycle: _Cycle, frame: int) -> None:
        with self._lock:
            if self._cycle is not cycle or len(cycle.frames) != frame - 1:
                return
            self.counters["data_timeouts"] += 1
            self._error("DATA_TIMEOUT", frame, f"no data for frame {frame}")
            self._end_cycle()

    def _tx_data(self, m: nmea.TxData) -> None:
        cycle = self._cycle
        if cycle is None:
            self.counters["txd_unrequested"] += 1
            return self._error("TXD", ERR_NO_REQUEST, "no data request pending")
        if len(m.data) > self.fleet.rate.frame_bytes:
            self.counters["txd_oversize"] += 1
            return self._error("TXD", ERR_CYCLE, f"{len(m.data)} bytes: frames hold "
                                                 f"{self.fleet.rate.frame_bytes}")
        self._say(nmea.TxDataEcho(m.src, m.dest, m.ack, len(m.data)))
        if cycle.timer is not None:
            cycle.timer.cancel()
        if m.data:
            cycle.frames.append(m.data)
        if m.data and len(cycle.frames) < cycle.frames_wanted:
            self._request(len(cycle.frames) + 1)
        else:
            self._end_cycle()

    def _end_cycle(self) -> None:
        cycle, self._cycle = self._cycle, None
        if cycle is None or not cycle.frames:
            self.counters["empty_cycles"] += 1
            return
        tag = OnAir(DATA, self.address, cycle.dest, self.fleet.rate.number, cycle.ack,
                    tuple(cycle.frames))
        self._transmit(tag, cycle.t_cycle_s)

    def _ping(self, m: nmea.Ping) -> None:
        if m.src != self.address:
            return self._refuse_cycle("a ping must come from this modem's address")
        if self._cycle is not None or self._transmitting():
            self.counters["busy"] += 1
            return self._error("MPC", ERR_BUSY, "busy")
        self._say(nmea.Ping("CA", m.src, m.dest))
        self.counters["pings"] += 1
        self._transmit(OnAir(PING, self.address, m.dest, self.fleet.rate.number),
                       self.fleet.now())

    def _config(self, m: nmea.Config) -> None:
        name, value = m.name.upper(), m.value
        if name == "ALL" and value == "0":  # restore the defaults, keeping the address
            self.config = dict(DEFAULT_CONFIG, SRC=self.config["SRC"])
        elif name == "SRC":
            if not (value.isdigit() and 1 <= int(value) <= nmea.MAX_ADDRESS):
                return self._error("CFG", ERR_CYCLE, f"SRC must be 1-{nmea.MAX_ADDRESS}")
            self.config["SRC"] = str(int(value))
        elif name in self.config or len(self.config) < MAX_CONFIG:
            self.config[name] = value
        else:
            return self._error("CFG", ERR_UNSUPPORTED, "too many parameters")
        self._say(nmea.Config("CA", name, self.config.get(name, value)))

    def _config_query(self, m: nmea.ConfigQuery) -> None:
        name = m.name.upper()
        if name == "ALL":
            for key, value in self.config.items():
                self._say(nmea.Config("CA", key, value))
        elif name in self.config:
            self._say(nmea.Config("CA", name, self.config[name]))
        else:
            self._error("CFQ", ERR_UNSUPPORTED, f"unknown parameter {name}")

    def _clock(self, m: nmea.Clock) -> None:
        self._clock_offset_s += (m.when - self._now_date()).total_seconds()
        self._say(nmea.Clock("CA", self._now_date().replace(microsecond=0)))

    def _place(self, m: nmea.Place) -> None:
        try:
            self.fleet.place(self.node, m.pos)
        except ValueError as exc:
            return self._error("CFL", ERR_CYCLE, str(exc))
        self._say(m)

    # -- the water -------------------------------------------------------------------------

    def _transmitting(self) -> bool:
        return self.fleet.now() < self._busy_until_s

    def _transmit(self, tag: OnAir, t_s: float) -> None:
        """Put ``tag`` on the water from ``t_s`` (placed back at most `MAX_SERIAL_S`, never
        before this modem's previous transmission ends)."""
        now = self.fleet.now()
        t_s = max(min(t_s, now), now - MAX_SERIAL_S, self._busy_until_s)
        on_air = tag.on_air(self.fleet.rate)
        end = t_s + self.fleet.airtime_s(len(on_air))
        self._busy_until_s = end
        self.counters[f"tx_{tag.kind}"] += 1
        if tag.kind in (DATA, PING):
            self._say(nmea.TxEdge(True, len(on_air)))
        self.fleet.submit(self.node, on_air, t_s, tag)
        self.fleet.at(end, lambda: self._transmitted(len(on_air)))

    def _transmitted(self, nbytes: int) -> None:
        with self._lock:
            self._say(nmea.TxEdge(False, nbytes))

    def on_event(self, event: LinkEvent) -> None:
        """A transmission's fate here (``event.dst`` is this modem's node)."""
        tag = event.tag
        if not isinstance(tag, OnAir):
            return
        with self._lock:
            if event.delivered:
                self.counters[f"rx_{tag.kind}"] += 1
                self._received(event, tag)
            elif tag.kind == DATA and event.reason in HEARD_LOST:
                self.counters["rx_bad"] += 1
                self._say(self._stats(event, tag, bad=len(tag.frames), mode=1))

    def _received(self, event: LinkEvent, tag: OnAir) -> None:
        me = self.address
        if tag.kind == DATA:
            self._say(nmea.CycleInit("CA", tag.src, tag.dest, tag.rate, tag.ack,
                                     len(tag.frames)))
            for i, frame in enumerate(tag.frames, 1):
                self._say(nmea.RxData(tag.src, tag.dest, tag.ack, i, frame))
            self._say(self._stats(event, tag))
            if tag.ack and tag.dest == me:
                self._transmit(OnAir(ACK, me, tag.src, tag.rate, frames=tag.frames), event.t_s)
        elif tag.kind == ACK and tag.dest == me:
            for i in range(1, len(tag.frames) + 1):
                self._say(nmea.Ack(tag.src, me, i))
        elif tag.kind == PING and tag.dest in (me, BROADCAST):
            self._say(nmea.Ping("CA", tag.src, tag.dest, heard=True))
            airtime = self.fleet.airtime_s(len(tag.on_air(self.fleet.rate)))
            self._transmit(OnAir(PONG, me, tag.src, tag.rate, ping_sent_s=event.t_sent_s,
                                 ping_airtime_s=airtime), event.t_s)
        elif tag.kind == PONG and tag.dest == me:
            # reply arrival start - ping start - ping airtime = two travel times
            start = event.t_s - self.fleet.airtime_s(len(tag.on_air(self.fleet.rate)))
            owtt = max(0.0, (start - tag.ping_sent_s - tag.ping_airtime_s) / 2.0)
            self._say(nmea.PingReply(tag.src, me, owtt))

    def _stats(self, event: LinkEvent, tag: OnAir, bad: int = 0, mode: int = 0
               ) -> nmea.CycleStats:
        """``$CACST`` of a reception: time of arrival (its start, on the modem's clock),
        rate, addresses, frames, and the channel's mean SNR (in) and SINR (out)."""
        airtime = self.fleet.airtime_s(len(tag.on_air(self.fleet.rate)))
        snr = -99.0 if event.snr_db is None else event.snr_db
        sinr = snr if event.sinr_db is None else event.sinr_db
        modem = self.fleet.config.modem
        return nmea.CycleStats(
            self._date_of(event.t_s - airtime), tag.rate, tag.src, tag.dest, len(tag.frames),
            bad_frames=bad, mode=mode, snr_in=round(snr, 2), snr_out=round(sinr, 2),
            packet_type=1 if tag.rate == 0 else 3,
            carrier=int(modem.frequency_khz * 1000), bandwidth=int(modem.bandwidth_khz * 1000))

    # -- output ----------------------------------------------------------------------------

    def _say(self, message: nmea.Typed) -> None:
        if self._host is None:
            self.counters["unheard_lines"] += 1
            return
        self._host(nmea.encode(message))

    def _error(self, module: str, number: int, message: str) -> None:
        self.counters["errors"] += 1
        self._say(nmea.ModemError(self._hhmmss(), module, number, message))

    def _now_date(self) -> dt.datetime:
        return self._date_of(self.fleet.now())

    def _date_of(self, t_s: float) -> dt.datetime:
        return self.fleet.date_of(t_s + self._clock_offset_s)

    def _hhmmss(self) -> str:
        return nmea.hhmmss(self._now_date())
