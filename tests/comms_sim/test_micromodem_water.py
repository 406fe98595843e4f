"""The emulated Micro-Modems: their protocol on a manual clock (no sockets), and the CI check
of issue 29: WHOI's ``acomms`` drives two emulated modems and gets a packet at the model's
arrival time with the $CACST it expects; the project's driver and acomms share one water;
``cotsfleet water`` refuses bad input and ends cleanly on SIGTERM."""

from __future__ import annotations

import datetime as dt
import os
import queue
import select
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from comms_sim.channel import Channel
from comms_sim.micromodem.fleet import ModemFleet
from comms_sim.micromodem.packet import channel_config
from comms_sim.micromodem.run import run_water
from comms_sim.water import Water
from fleet_bus import nmea
from fleet_bus.clock import ManualClock
from fleet_bus.process import WATER_READY

REPO = Path(__file__).resolve().parents[2]


class Clock(ManualClock):
    def wall_delay(self, sim_dt_s: float) -> float:
        return sim_dt_s


def emulated(rate: int = 1, gap_m: float = 1000.0):
    clock = Clock(0.0)
    water = Water(Channel(channel_config(rate), np.random.default_rng(1)), clock)
    fleet = ModemFleet(water, rate, [("a", (0.0, 0.0, 0.0)), ("b", (gap_m, 0.0, 0.0))],
                       lambda: 1.7e9, lambda: 1.0)
    lines: dict[str, list] = {"a": [], "b": []}
    for m in fleet.modems:
        m.attach(lambda line, n=m.node: lines[n].append(nmea.decode(line)))
    return clock, water, fleet, lines


def run_until_idle(clock: Clock, water: Water, limit_s: float = 100.0) -> None:
    while (due := water.step()) is not None and due <= limit_s:
        clock.advance_to(max(due, clock.now()))


def host(modem, message) -> None:
    modem.on_line(nmea.encode(message).rstrip())


def test_a_cycle_goes_out_and_arrives_with_its_statistics() -> None:
    clock, water, fleet, lines = emulated()
    a, b = fleet.modems
    clock.advance_to(10.0)
    host(a, nmea.CycleInit("CC", 1, 2, 1, False, 2))
    host(a, nmea.TxData(1, 2, False, b"abc"))
    host(a, nmea.TxData(1, 2, False, b""))  # no more data: one frame goes
    run_until_idle(clock, water)
    kinds = [type(m).__name__ for m in lines["a"]]
    assert kinds == ["Revision", "CycleInit", "DataRequest", "TxDataEcho", "DataRequest",
                     "TxDataEcho", "TxEdge", "TxEdge"]
    cyc, rxd, cst = lines["b"][1:]
    assert (cyc.src, cyc.dest, cyc.frames) == (1, 2, 1) and rxd.data == b"abc"
    assert cst.frames == 1 and cst.bad_frames == 0 and cst.rate == 1
    toa_s = cst.toa.timestamp() - 1.7e9
    assert toa_s == pytest.approx(10.0 + 1000.0 / 1500.0, abs=1e-5)


@pytest.mark.parametrize(("message", "module"), [
    (nmea.CycleInit("CC", 2, 1, 1, False, 1), "CYC"),  # an uplink request for modem 2
    (nmea.CycleInit("CC", 1, 2, 5, False, 1), "CYC"),  # another rate than the water's
    (nmea.CycleInit("CC", 1, 2, 1, False, 4), "CYC"),  # rate 1 holds 3 frames
    (nmea.TxData(1, 2, False, b"x"), "TXD"),  # no data request pending
    (nmea.Sentence("CCMSC", ("1", "1", "0")), "NMEA"),  # not emulated
    (b"$CCCYC,0,1,2,1,0,1*00", "NMEA"),  # bad checksum
    (b"\x00\x01garbage", "NMEA"),
])
def test_what_a_modem_cannot_do_gets_caerr(message, module) -> None:
    _, _, fleet, lines = emulated()
    a = fleet.modems[0]
    a.on_line(message if isinstance(message, bytes) else nmea.encode(message).rstrip())
    assert isinstance(lines["a"][-1], nmea.ModemError) and lines["a"][-1].module == module
    assert a.counters["errors"] == 1


def test_a_second_cycle_while_transmitting_is_busy_and_a_silent_host_times_out() -> None:
    clock, water, fleet, lines = emulated()
    a = fleet.modems[0]
    host(a, nmea.CycleInit("CC", 1, 0, 1, False, 1))
    host(a, nmea.CycleInit("CC", 1, 0, 1, False, 1))
    assert lines["a"][-1] == nmea.ModemError(lines["a"][-1].time, "CYC", 3, "busy")
    clock.advance_to(6.0)  # DTO 5 s without $CCTXD
    water.step()
    assert lines["a"][-1].module == "DATA_TIMEOUT" and lines["a"][-1].number == 1
    assert a.counters["data_timeouts"] == 1 and a.counters["empty_cycles"] == 1


def test_ping_reports_the_one_way_travel_time_and_placement_moves_a_modem() -> None:
    clock, water, fleet, lines = emulated(gap_m=750.0)
    a, b = fleet.modems
    host(b, nmea.Place((0.0, 1500.0, 0.0)))
    assert lines["b"][-1] == nmea.Place((0.0, 1500.0, 0.0))
    host(a, nmea.Ping("CC", 1, 2))
    run_until_idle(clock, water)
    assert any(isinstance(m, nmea.Ping) and m.heard for m in lines["b"])
    [reply] = [m for m in lines["a"] if isinstance(m, nmea.PingReply)]
    assert (reply.src, reply.dest) == (2, 1) and reply.owtt_s == pytest.approx(1.0, abs=1e-3)


def test_configuration_and_clock() -> None:
    clock, water, fleet, lines = emulated()
    a = fleet.modems[0]
    host(a, nmea.ConfigQuery("SRC"))
    assert lines["a"][-1] == nmea.Config("CA", "SRC", "1")
    host(a, nmea.Config("CC", "SRC", "9"))
    assert a.address == 9 and lines["a"][-1] == nmea.Config("CA", "SRC", "9")
    when = dt.datetime(2030, 1, 2, 3, 4, 5, tzinfo=dt.timezone.utc)
    host(a, nmea.Clock("CC", when))
    assert lines["a"][-1] == nmea.Clock("CA", when)


# -- through sockets: acomms, the project's driver -------------------------------------------


def free_base_port(n: int) -> int:
    for _ in range(50):
        with socket.socket() as s:
            s.bind(("127.0.0.1", 0))
            base = s.getsockname()[1]
        ok = True
        for i in range(n):
            with socket.socket() as s:
                try:
                    s.bind(("127.0.0.1", base + i))
                except OSError:
                    ok = False
        if ok and base + n < 65000:
            return base
    raise RuntimeError("no free ports")


@pytest.fixture
def water_thread():
    """Two emulated modems 1000 m apart at warp 1, rate 1, on a thread."""
    stop, box = threading.Event(), {}
    port = free_base_port(2)
    thread = threading.Thread(target=run_water, args=(
        [("a", (0.0, 0.0, -5.0)), ("b", (1000.0, 0.0, -5.0))], "127.0.0.1", port, 1, 1.0, 0,
        stop), kwargs={"on_ready": lambda server, fleet: box.update(fleet=fleet),
                       "heartbeat_s": 0.0})
    thread.start()
    deadline = time.monotonic() + 10
    while "fleet" not in box and time.monotonic() < deadline:
        time.sleep(0.02)
    assert "fleet" in box
    yield port, box["fleet"]
    stop.set()
    thread.join(10)
    assert not thread.is_alive()


class PtyBridge:
    """acomms talks to a serial port: a pty whose master end is bridged to a TCP modem."""

    def __init__(self, port: int) -> None:
        self.master, slave = os.openpty()
        self.slave_name = os.ttyname(slave)
        self._slave = slave  # kept open so the pty lives while acomms opens it by name
        self.sock = socket.create_connection(("127.0.0.1", port))
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.is_set():
            readable, _, _ = select.select([self.master, self.sock], [], [], 0.1)
            try:
                if self.master in readable:
                    self.sock.sendall(os.read(self.master, 4096))
                if self.sock in readable:
                    data = self.sock.recv(4096)
                    if not data:
                        return
                    os.write(self.master, data)
            except OSError:
                return

    def close(self) -> None:
        self._stop.set()
        self._thread.join(5)
        self.sock.close()
        os.close(self.master)
        os.close(self._slave)


@pytest.fixture
def acomms_modem():
    pytest.importorskip("acomms", reason="WHOI's acomms package (pip install acomms: the "
                                         "test extra)")
    from acomms.micromodem import Micromodem

    made = []

    def make(port: int, name: str):
        bridge = PtyBridge(port)
        modem = Micromodem(name=name, log_path=None, log_level="WARNING")
        modem.connect_serial(bridge.slave_name, 19200)
        made.append((modem, bridge))
        return modem

    yield make
    for modem, bridge in made:
        end_reader(modem.connection)
        bridge.close()


class _ReaderEnd(Exception):
    """Raised into acomms' reader thread to end it."""


class _EndedPort:
    """Stands in for acomms' serial port at teardown.

    acomms' reader thread loops forever: it catches every SerialException, sleeps a second and
    reopens the port by name (the pty still exists), so closing the port ends it only when the
    close lands inside a read (a TypeError in pyserial). A read that raises anything else is
    the one sure way out (pytest reports it as a warning: filtered on these tests).
    """

    is_open = False

    def readline(self) -> bytes:
        raise _ReaderEnd("test teardown")

    def close(self) -> None:
        pass


def end_reader(connection, timeout_s: float = 10.0) -> None:
    """End acomms' reader thread and prove it is gone.

    The swap is repeated because the thread may be asleep in its reconnect branch, which
    assigns a freshly opened port over ours when it wakes.
    """
    deadline = time.monotonic() + timeout_s
    while connection._thread.is_alive() and time.monotonic() < deadline:
        port, connection._serialport = connection._serialport, _EndedPort()
        connection.connection_active = True
        port.close()
        connection._thread.join(0.5)
    assert not connection._thread.is_alive()
    connection._serialport.close()


ACOMMS_THREAD_END = pytest.mark.filterwarnings(
    "ignore::pytest.PytestUnhandledThreadExceptionWarning")


@pytest.mark.integration
@ACOMMS_THREAD_END
def test_acomms_sends_a_packet_across_the_emulated_water(water_thread, acomms_modem) -> None:
    from acomms.messageparams import Rates

    port, fleet = water_thread
    clock = fleet.water.clock
    events = []
    fleet.water.add_listener(events.extend)
    sender, receiver = acomms_modem(port, "alpha"), acomms_modem(port + 1, "bravo")
    assert (sender.id, receiver.id) == (1, 2)  # learnt from $CACFG,SRC at connect
    packets, csts = queue.Queue(), queue.Queue()
    receiver.packetrx_listeners.append(lambda packet: packets.put((clock.now(), packet)))
    receiver.attach_incoming_cst_queue(csts)
    payload = bytes(range(100))
    sender.send_packet_data(2, bytearray(payload), rate_num=1)
    t_rx, packet = packets.get(timeout=15)
    cst = csts.get(timeout=5)
    data = b"".join(bytes(f.data) for f in packet.frames)
    assert data == payload and len(packet.frames) == 2
    [event] = [e for e in events if e.dst == "b" and e.delivered]
    config = fleet.config
    # the model's arrival for 1000 m at rate 1: 2 frames of 64 bytes on the air
    assert event.t_s == pytest.approx(event.t_sent_s + 1000.0 / 1500.0
                                      + config.airtime_s(2 * Rates[1].framesize))
    assert abs(t_rx - event.t_s) < 0.1
    toa_s = cst["toa"].replace(tzinfo=dt.timezone.utc).timestamp() - clock.epoch_unix
    assert abs(toa_s - (event.t_sent_s + 1000.0 / 1500.0)) < 0.1
    assert (cst["src"], cst["dest"], cst["rate_num"], cst["num_frames"],
            cst["bad_frames_num"], cst["mode"]) == (1, 2, 1, 2, 0, 0)


@pytest.mark.integration
@ACOMMS_THREAD_END
def test_the_project_driver_and_acomms_share_one_water(water_thread, acomms_modem) -> None:
    from fleet_agent.modems.micromodem import MicroModem
    from fleet_bus.modem_port import Received, Sent

    port, fleet = water_thread
    clock = fleet.water.clock
    reports = []
    driver = MicroModem(f"tcp:127.0.0.1:{port}", reports.append, clock, rate=1)
    peer = acomms_modem(port + 1, "bravo")
    frames = queue.Queue()
    peer.rxframe_listeners.append(frames.put)
    try:
        deadline = time.monotonic() + 10
        while not driver.connected and time.monotonic() < deadline:
            time.sleep(0.02)
        driver.transmit([b"from the project's driver"], "data")
        frame = frames.get(timeout=15)
        assert bytes(frame.data) == b"from the project's driver" and frame.src == 1
        peer.send_packet_data(0, bytearray(b"from acomms"), rate_num=1)
        deadline = time.monotonic() + 15
        while not any(isinstance(r, Received) for r in reports) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert [r.frame for r in reports if isinstance(r, Received)] == [b"from acomms"]
        assert sum(isinstance(r, Sent) for r in reports) == 1
    finally:
        driver.close()


# -- the command -----------------------------------------------------------------------------


def cotsfleet(*args: str) -> subprocess.Popen:
    env = {**os.environ, "PYTHONUNBUFFERED": "1",
           "PYTHONPATH": str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    return subprocess.Popen([sys.executable, "-m", "cotsfleet", "water", *args], cwd=REPO,
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)


@pytest.mark.integration
@pytest.mark.parametrize("args", [
    ["--scenario", "examples/green_island.json", "--port", "70000"],
    ["--scenario", "examples/green_island.json", "--port", "47000", "--rate", "3"],
    ["--scenario", "examples/green_island.json", "--port", "47000", "--warp", "0"],
    ["--scenario", "no/such/file.json", "--port", "47000"],
])
def test_bad_input_is_one_line_and_exit_2(args) -> None:
    proc = cotsfleet(*args)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 2, (out, err)
    assert len(err.strip().splitlines()) == 1 and "error" in err


@pytest.mark.integration
def test_the_command_serves_and_ends_cleanly_on_sigterm() -> None:
    port = free_base_port(3)
    proc = cotsfleet("--scenario", "examples/green_island.json", "--port", str(port),
                     "--warp", "5", "--heartbeat", "0")
    try:
        line = proc.stdout.readline()
        assert line.startswith(WATER_READY), (line, proc.stderr.read())
        with socket.create_connection(("127.0.0.1", port + 2)) as sock:
            sock.sendall(nmea.encode(nmea.ConfigQuery("SRC")))
            sock.settimeout(5)
            got = b""
            while b"CACFG" not in got:
                got += sock.recv(4096)
            assert nmea.encode(nmea.Config("CA", "SRC", "3")) in got
            proc.send_signal(signal.SIGTERM)
            assert proc.wait(15) == 0
        for i in range(3):  # every port can be listened on again
            socket.create_server(("127.0.0.1", port + i)).close()
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        proc.stdout.close()
        proc.stderr.close()
