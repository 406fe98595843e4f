"""The Micro-Modem driver: the happy path through emulated modems, and a scripted peer on a
socket for a modem that errs, garbles, or falls silent. Sockets and threads only (no
process); every thread and socket is closed by the end of each test."""

from __future__ import annotations

import socket
import threading
import time
from typing import Callable

import pytest

from comms_sim.micromodem.run import run_water
from fleet_agent.modems import micromodem as mm
from fleet_agent.modems.micromodem import MicroModem, parse_link
from fleet_bus import nmea
from fleet_bus.clock import WarpClock
from fleet_bus.modem_port import Acked, Dropped, Received, Sent

pytestmark = pytest.mark.integration


def free_port(n: int = 1) -> int:
    """A base port with ``n`` free ports after it (best effort, loopback)."""
    for _ in range(50):
        with socket.socket() as s:
            s.bind(("127.0.0.1", 0))
            base = s.getsockname()[1]
        if base + n < 65000 and all(_free(base + i) for i in range(n)):
            return base
    raise RuntimeError("no free ports")


def _free(port: int) -> bool:
    with socket.socket() as s:
        try:
            s.bind(("127.0.0.1", port))
            return True
        except OSError:
            return False


def wait_until(cond: Callable[[], bool], timeout_s: float = 10.0) -> bool:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if cond():
            return True
        time.sleep(0.02)
    return cond()


@pytest.fixture
def water():
    """Two emulated modems 750 m apart at warp 10 on a thread: (base port, fleet)."""
    stop, box = threading.Event(), {}
    port = free_port(2)
    thread = threading.Thread(target=run_water, args=(
        [("a", (0.0, 0.0, -5.0)), ("b", (750.0, 0.0, -5.0))], "127.0.0.1", port, 1, 10.0, 3,
        stop), kwargs={"on_ready": lambda server, fleet: box.update(fleet=fleet),
                       "heartbeat_s": 0.0})
    thread.start()
    assert wait_until(lambda: "fleet" in box)
    yield port, box["fleet"]
    stop.set()
    thread.join(10)
    assert not thread.is_alive()


def test_frames_cross_the_emulated_water_at_the_model_time(water) -> None:
    port, fleet = water
    clock = fleet.water.clock
    got_a, got_b = [], []
    a = MicroModem(f"tcp:127.0.0.1:{port}", got_a.append, clock, rate=1)
    b = MicroModem(f"tcp:127.0.0.1:{port + 1}", got_b.append, clock, rate=1)
    events = []
    fleet.water.add_listener(events.extend)
    try:
        assert wait_until(lambda: a.connected and b.connected)
        assert (a.address, b.address) == (1, 2)
        assert (a.spec.max_frame_bytes, a.spec.frames_per_packet) == (64, 3)
        a.transmit([b"p" * 64, b"q" * 20], "pose")
        assert wait_until(lambda: len(got_b) == 2 and got_a)
        [sent] = got_a
        assert isinstance(sent, Sent) and (sent.n_frames, sent.n_bytes) == (2, 84)
        [event] = [e for e in events if e.dst == "b"]
        config = fleet.config
        # the model: start + 750 m / 1500 m/s + airtime of two padded 64-byte frames
        assert event.t_s == pytest.approx(event.t_sent_s + 0.5 + config.airtime_s(128))
        assert [r.frame for r in got_b] == [b"p" * 64, b"q" * 20]
        assert all(isinstance(r, Received) and abs(r.t_s - event.t_s) < 0.1 for r in got_b)
    finally:
        a.close()
        b.close()


def test_acknowledged_unicast_reports_acks(water) -> None:
    port, fleet = water
    clock = fleet.water.clock
    got_a, got_b = [], []
    a = MicroModem(f"tcp:127.0.0.1:{port}", got_a.append, clock, dest=2, ack=True)
    b = MicroModem(f"tcp:127.0.0.1:{port + 1}", got_b.append, clock)
    try:
        assert a.spec.acknowledged
        assert wait_until(lambda: a.connected and b.connected)
        a.transmit([b"one", b"two"], "data")
        assert wait_until(lambda: sum(isinstance(r, Acked) for r in got_a) == 2)
        assert sorted(r.frame_no for r in got_a if isinstance(r, Acked)) == [0, 1]
        assert [r.frame for r in got_b] == [b"one", b"two"]
    finally:
        a.close()
        b.close()


def test_what_the_modem_cannot_carry_is_dropped_not_sent(water) -> None:
    port, fleet = water
    got = []
    a = MicroModem(f"tcp:127.0.0.1:{port}", got.append, fleet.water.clock)
    try:
        assert wait_until(lambda: a.connected)
        a.transmit([b"x" * 65], "data")
        a.transmit([b"x"] * 4, "data")
        assert [(r.reason, r.n_frames) for r in got] == [("oversize", 1), ("oversize", 4)]
    finally:
        a.close()


class Peer:
    """A scripted modem on a socket: ``script(message, send)`` answers each host sentence
    (``message`` typed, or the raw line if it does not parse)."""

    def __init__(self, script: Callable[[object, Callable[[bytes], None]], None]) -> None:
        self.listener = socket.create_server(("127.0.0.1", 0))
        self.port = self.listener.getsockname()[1]
        self.script = script
        self.heard: list[object] = []
        self.accepts = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        self.listener.settimeout(0.1)
        while not self._stop.is_set():
            try:
                conn, _ = self.listener.accept()
            except (TimeoutError, OSError):
                continue
            self.accepts += 1
            with conn:
                conn.settimeout(0.1)
                buf = b""
                while not self._stop.is_set():
                    try:
                        data = conn.recv(4096)
                    except TimeoutError:
                        continue
                    except OSError:
                        break
                    if not data:
                        break
                    buf += data
                    while b"\n" in buf:
                        line, buf = buf.split(b"\n", 1)
                        try:
                            message: object = nmea.decode(line)
                        except nmea.NmeaError:
                            message = line
                        self.heard.append(message)
                        self.script(message, conn.sendall)

    def close(self) -> None:
        self._stop.set()
        self._thread.join(5)
        self.listener.close()


def answer_config(message: object, send: Callable[[bytes], None]) -> bool:
    if isinstance(message, nmea.Config):
        send(nmea.encode(nmea.Config("CA", message.name, message.value)))
        return True
    if isinstance(message, nmea.ConfigQuery):
        send(nmea.encode(nmea.Config("CA", "SRC", "4")))
        return True
    return False


def test_caerr_during_a_cycle_drops_the_packet_and_counts(monkeypatch) -> None:
    def script(message, send) -> None:
        if not answer_config(message, send) and isinstance(message, nmea.CycleInit):
            send(nmea.encode(nmea.ModemError("120000", "CYC", 3, "busy")))

    peer = Peer(script)
    got = []
    modem = MicroModem(f"tcp:127.0.0.1:{peer.port}", got.append, WarpClock(time.time(), 1.0))
    try:
        assert wait_until(lambda: modem.connected) and modem.address == 4
        modem.transmit([b"hello"], "data")
        assert wait_until(lambda: got)
        assert isinstance(got[0], Dropped) and got[0].reason == "error"
        assert modem.counters["caerr_cyc"] == 1 and modem.counters["dropped_error"] == 1
    finally:
        modem.close()
        peer.close()


def test_bad_checksums_and_garbage_are_counted_and_skipped() -> None:
    good_cfg = nmea.encode(nmea.Config("CA", "SRC", "5"))
    bad_cfg = good_cfg.replace(b"*", b"*0")[:-3] + b"\r\n"

    def script(message, send) -> None:
        if isinstance(message, nmea.ConfigQuery):
            send(b"\x00\xff\xfe garbage\r\n")
            send(b"$CACFG,SRC,5*00\r\n")  # wrong checksum
            send(bad_cfg)
            send(b"CACFG,SRC,5\r\n")  # no $
            send(b"$" + b"A" * 3000 + b"\r\n")  # too long
            send(nmea.Sentence("CARXD", ("1", "5", "0", "1", "XYZ")).encode())  # not hex
            send(good_cfg)

    peer = Peer(script)
    modem = MicroModem(f"tcp:127.0.0.1:{peer.port}", lambda r: None,
                       WarpClock(time.time(), 1.0))
    try:
        assert wait_until(lambda: modem.connected) and modem.address == 5
        c = modem.counters
        assert c["nmea_not_ascii"] == 1 and c["nmea_checksum"] == 2
        assert c["nmea_no_start"] == 1 and c["nmea_hex"] == 1
        assert c["nmea_too_long"] == 1
    finally:
        modem.close()
        peer.close()


def test_a_silent_modem_times_out_and_the_link_is_reopened(monkeypatch) -> None:
    monkeypatch.setattr(mm, "RECONNECT_S", 0.05)

    def script(message, send) -> None:
        answer_config(message, send)  # configures, then never answers a cycle

    peer = Peer(script)
    got = []
    modem = MicroModem(f"tcp:127.0.0.1:{peer.port}", got.append, WarpClock(time.time(), 1.0),
                       reply_timeout_s=0.2)
    try:
        assert wait_until(lambda: modem.connected)
        for _ in range(mm.SILENT_CYCLES):
            n = len(got)
            modem.transmit([b"anyone?"], "data")
            assert wait_until(lambda: len(got) > n)
        assert [r.reason for r in got] == ["timeout"] * mm.SILENT_CYCLES
        assert modem.counters["timeout_cyc"] == mm.SILENT_CYCLES
        assert wait_until(lambda: peer.accepts >= 2 and modem.connected)
        assert modem.counters["link_lost_silent"] == 1
    finally:
        modem.close()
        peer.close()


def test_no_modem_drops_with_no_modem() -> None:
    port = free_port()
    got = []
    modem = MicroModem(f"tcp:127.0.0.1:{port}", got.append, WarpClock(time.time(), 1.0))
    try:
        assert wait_until(lambda: modem.counters["connect_failed"] >= 1)
        modem.transmit([b"x"], "data")
        assert got == [Dropped(got[0].t_s, "no_modem", 1)]
    finally:
        modem.close()


def test_a_missing_serial_device_is_no_modem_not_a_crash() -> None:
    got = []
    modem = MicroModem("/dev/cotsfleet-no-such-modem", got.append, WarpClock(time.time(), 1.0))
    try:
        assert wait_until(lambda: modem.counters["connect_failed"] >= 1)
        modem.transmit([b"x"], "data")
        assert [r.reason for r in got] == ["no_modem"]
    finally:
        modem.close()


@pytest.mark.parametrize("link", ["tcp:host", "tcp::1", "tcp:h:0", "tcp:h:99999", "", "a:b"])
def test_bad_links_are_refused(link) -> None:
    with pytest.raises(ValueError):
        parse_link(link)


def test_rates_without_a_bit_rate_need_one() -> None:
    with pytest.raises(ValueError):
        MicroModem("tcp:h:1", lambda r: None, WarpClock(0, 1.0), rate=3, start=False)
    modem = MicroModem("tcp:h:1", lambda r: None, WarpClock(0, 1.0), rate=3,
                       bit_rate_bps=1200.0, start=False)
    assert (modem.spec.max_frame_bytes, modem.spec.frames_per_packet) == (256, 2)
    modem.close()
