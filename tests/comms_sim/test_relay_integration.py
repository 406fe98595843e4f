"""The relay as a real process between real Zenoh sessions on loopback."""

from __future__ import annotations

import json
import statistics
import threading
import time
from pathlib import Path

import msgpack
import pytest

from comms_sim.config import ChannelConfig
from fleet_bus import keys as bus
from fleet_bus.clock import WarpClock
from fleet_bus.link import LinkRecord, decode_stats
from fleet_bus.mission import ClockRecord, Mission
from fleet_bus.process import RELAY_READY, ROUTER_READY
from fleet_bus.session import client_config, free_tcp_endpoint, open_session
from fleet_bus.telemetry import Truth

pytestmark = pytest.mark.integration

WARP = 20.0
POSITIONS = {"a": (0.0, 0.0, 0.0), "b": (1500.0, 0.0, 0.0), "c": (0.0, 6000.0, 0.0)}


class Inbox:
    """What a subscriber saw, with the simulation time of arrival."""

    def __init__(self, clock: WarpClock) -> None:
        self.clock = clock
        self.lock = threading.Lock()
        self.rx: dict[str, list[tuple[bytes, dict, float]]] = {v: [] for v in POSITIONS}
        self.links: list[LinkRecord] = []

    def on_rx(self, sample) -> None:
        now = self.clock.now()
        meta = msgpack.unpackb(sample.attachment.to_bytes())
        with self.lock:
            self.rx[bus.vid_of(str(sample.key_expr))].append((sample.payload.to_bytes(), meta,
                                                              now))

    def on_link(self, sample) -> None:
        with self.lock:
            self.links.append(LinkRecord.decode(sample.payload.to_bytes()))


def stats(session) -> tuple[dict, dict]:
    for reply in session.get(bus.LINK_STATS, timeout=5.0):
        return decode_stats(reply.ok.payload.to_bytes())
    raise AssertionError("no stats reply")


def wait_until(predicate, timeout_s: float = 20.0) -> None:
    deadline = time.monotonic() + timeout_s
    while not predicate():
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.05)


def test_relay_applies_delay_and_loss_and_never_delivers_a_drop(tmp_path: Path, spawn) -> None:
    endpoint = free_tcp_endpoint()
    router = spawn(["-m", "comms_sim.router", "--listen", endpoint])
    router.wait_for(ROUTER_READY)
    cfg = tmp_path / "channel.json"
    cfg.write_text(json.dumps({"extra_loss": 0.3}))
    epoch = time.time()
    clock = WarpClock(epoch, WARP)
    relay = spawn(["-m", "comms_sim", "--connect", endpoint, "--epoch-unix", repr(epoch),
                   "--warp", str(WARP), "--seed", "3", "--config", str(cfg)])
    relay.wait_for(RELAY_READY)
    inbox = Inbox(clock)
    n = 40
    with open_session(client_config([endpoint])) as session, \
            session.declare_subscriber("fleet/rx/*", inbox.on_rx), \
            session.declare_subscriber(bus.LINK_ALL, inbox.on_link):
        for vid, pos in POSITIONS.items():
            session.put(bus.truth_key(vid), Truth(clock.now(), pos).encode())
        time.sleep(0.3)
        for i in range(n):  # a frame every 3 simulated seconds: no queueing, no collisions
            session.put(bus.tx_key("a"), b"frame-%03d" % i)
            time.sleep(3.0 / WARP)
        wait_until(lambda: len(inbox.links) >= 2 * n)
        time.sleep(0.3)  # anything extra would show up now
        counts, extra = stats(session)

    with inbox.lock:
        links, rx = list(inbox.links), {k: list(v) for k, v in inbox.rx.items()}
    assert len(links) == 2 * n  # one event per frame per receiver, nothing more
    for dst in ("b", "c"):  # a frame is known by when it was sent (one every 3 s)
        delivered = sorted(e.t_sent_s for e in links if e.dst == dst and e.delivered)
        assert sorted(m["t_sent_s"] for _, m, _ in rx[dst]) == delivered  # the model's only
        dropped = {e.t_sent_s for e in links if e.dst == dst and not e.delivered}
        assert not dropped & {m["t_sent_s"] for _, m, _ in rx[dst]}
    assert rx["a"] == [] and rx["c"] == []  # c is beyond max range
    assert {e.reason for e in links if e.dst == "c"} == {"range"}
    reasons_b = [e.reason for e in links if e.dst == "b"]
    assert 0 < reasons_b.count(None) < n and "random" in reasons_b  # loss applied
    assert counts[("a", "b")]["delivered"] == reasons_b.count(None)
    assert counts[("a", "c")]["range"] == n

    # Delay: the model's own numbers are exact; arrival lateness is wall scheduling jitter.
    config = ChannelConfig()
    model_delay = 1500.0 / 1500.0 + config.airtime_s(len(b"frame-000"))
    lateness = []
    for frame, meta, arrived_s in rx["b"]:
        assert meta["src"] == "a"
        assert meta["t_s"] - meta["t_sent_s"] == pytest.approx(model_delay, abs=1e-9)
        lateness.append(arrived_s - meta["t_s"])
    # Never early (beyond 1 ms of wall clock), and late by under 25 ms of wall time in median
    # (0.5 simulated s at warp 20): generous, the test machine is shared.
    assert min(lateness) > -0.001 * WARP
    assert statistics.median(lateness) < 0.5
    assert extra["relay"]["tx"] == n and extra["relay"]["malformed_tx"] == 0
    assert relay.stop() == 0 and router.stop() == 0


def test_embedded_tdma_relay_survives_garbage_and_takes_the_mission_from_the_bus(spawn) -> None:
    endpoint = free_tcp_endpoint()
    relay = spawn(["-m", "comms_sim", "--listen", endpoint, "--mission-from-bus",
                   "--tdma", "--mission-timeout", "30"])
    epoch = time.time()
    mission = Mission({"vehicles": [{"id": "a"}, {"id": "b"}]}, 5, "run-1")
    record = ClockRecord(epoch, WARP)
    clock = WarpClock(epoch, WARP)
    inbox = Inbox(clock)
    deadline = time.monotonic() + 30
    while True:  # the relay is the router: connect once it listens
        try:
            session_cm = open_session(client_config([endpoint], timeout_s=2.0))
            break
        except Exception:
            assert time.monotonic() < deadline and relay.popen.poll() is None
            time.sleep(0.2)
    with session_cm as session, \
            session.declare_queryable(bus.MISSION, lambda q: q.reply(bus.MISSION,
                                                                     mission.encode())), \
            session.declare_queryable(bus.CLOCK, lambda q: q.reply(bus.CLOCK, record.encode())), \
            session.declare_subscriber("fleet/rx/*", inbox.on_rx):
        line = relay.wait_for(RELAY_READY)
        assert f"warp={WARP}" in line and "roster=a,b" in line and "mac=tdma" in line
        session.put(bus.truth_key("a"), Truth(0.0, POSITIONS["a"]).encode())
        session.put(bus.truth_key("b"), b"\x00\x01garbage")
        session.put(bus.truth_key("b"), Truth(0.0, (100.0, 0.0, 0.0)).encode())
        session.put(bus.truth_key("zz"), Truth(0.0, (0.0, 0.0, 0.0)).encode())
        time.sleep(0.3)  # samples on different keys may be handled concurrently
        session.put(bus.tx_key("zz"), b"unknown id")
        session.put(bus.tx_key("a"), b"")
        session.put(bus.tx_key("a"), b"\xff" * 200)  # oversize
        session.put(bus.LINK_CTL, b"\xc1 not msgpack")
        session.put(bus.LINK_CTL, msgpack.packb({"extra_loss": 0.0}))
        time.sleep(0.3)
        session.put(bus.tx_key("a"), b"still alive")
        wait_until(lambda: len(inbox.rx["b"]) == 1)
        _, extra = stats(session)
    c = extra["relay"]
    assert (c["malformed_truth"], c["unknown_truth"], c["unknown_tx"], c["malformed_tx"],
            c["malformed_ctl"], c["ctl"]) == (1, 1, 1, 1, 1, 2)
    assert inbox.rx["b"][0][0] == b"still alive"
    assert relay.popen.poll() is None  # still running
    assert relay.stop() == 0
