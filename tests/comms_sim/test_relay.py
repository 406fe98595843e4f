"""The relay's logic, driven by plain calls on a manual clock (the Zenoh shell is covered by
the integration test)."""

from __future__ import annotations

import msgpack
import numpy as np
import pytest

from comms_sim.channel import Channel, ChannelConfig
from comms_sim.relay import Relay
from fleet_bus.clock import ManualClock
from fleet_bus.link import INTRUDER, LinkControl, LinkRecord, decode_stats
from fleet_bus.orders import TOPSIDE
from fleet_bus.telemetry import Truth

LOSSLESS = ChannelConfig(range_d50_m=1e7)


def make_relay(vehicles: frozenset[str] | None = None):
    clock = ManualClock(0.0)
    sent: list[tuple[str, bytes, bytes | None]] = []
    relay = Relay(Channel(LOSSLESS, np.random.default_rng(0)), clock,
                  lambda k, p, a: sent.append((k, p, a)), vehicles)
    return clock, relay, sent


def truth(x: float) -> bytes:
    return Truth(0.0, (x, 0.0, 0.0)).encode()


def test_frames_are_delivered_at_the_model_time_with_metadata() -> None:
    clock, relay, sent = make_relay()
    relay.on_truth("auv0", truth(0.0))
    relay.on_truth("auv1", truth(1500.0))
    clock.advance_to(3.0)
    relay.on_tx("auv0", b"pose!", "pose")
    due = relay.step()  # the transmission starts now; its reception ends later
    expected = 3.0 + 1.0 + 0.3 + 5 * 8 / 1000.0
    assert due == pytest.approx(expected) and sent == []
    clock.advance_to(due)
    assert relay.step() is None
    [(rx_key, frame, att), (link_key, payload, _)] = sent
    assert (rx_key, frame) == ("fleet/rx/auv1", b"pose!")
    meta = msgpack.unpackb(att)
    assert meta == {"src": "auv0", "t_s": pytest.approx(expected), "t_sent_s": 3.0}
    assert link_key == "fleet/link/auv0/auv1" and LinkRecord.decode(payload).delivered


def test_garbage_and_unknown_ids_are_dropped_and_counted() -> None:
    clock, relay, sent = make_relay(vehicles=frozenset({"auv0", "auv1"}))
    relay.on_truth("auv0", truth(0.0))
    relay.on_truth("auv1", b"\x00garbage")
    relay.on_truth("auv1", msgpack.packb({"t": 0, "p": [1, "nan", 2]}))
    relay.on_truth("auv1", msgpack.packb({"t": 0, "p": [float("inf"), 0, 0]}))
    relay.on_truth("intruder", truth(5.0))
    relay.on_tx("auv1", b"never located")  # on the roster: the channel hears it, out of range
    relay.on_tx("intruder", b"hi")
    relay.on_tx("auv0", b"")
    relay.on_ctl(b"\xff\xfe")
    relay.on_ctl(msgpack.packb({"extra_loss": 7}))
    relay.on_tx("auv0", b"x" * 80)  # oversize: refused by the channel, published at once
    clock.advance_to(100.0)
    relay.step()
    c = relay.counters
    assert (c["malformed_truth"], c["unknown_truth"], c["unknown_tx"], c["malformed_tx"],
            c["malformed_ctl"]) == (3, 1, 1, 1, 2)
    assert [(k, LinkRecord.decode(p).reason) for k, p, _ in sent] == [
        ("fleet/link/auv0/*", "oversize"), ("fleet/link/auv1/auv0", "range")]
    counts, extra = decode_stats(relay.stats_payload())
    assert counts[("auv0", "*")]["oversize"] == 1
    assert extra["relay"]["malformed_ctl"] == 2 and extra["t_s"] == 100.0


def test_without_roster_only_located_vehicles_transmit() -> None:
    clock, relay, sent = make_relay()
    relay.on_tx("ghost", b"boo")
    relay.on_truth("a", truth(0.0))
    relay.on_truth("b", truth(100.0))
    relay.on_tx("a", b"hi")
    clock.advance_to(10.0)
    relay.step()
    assert relay.counters["unknown_tx"] == 1
    assert [k for k, _, _ in sent] == ["fleet/rx/b", "fleet/link/a/b"]  # no phantom "ghost"


def test_link_control_applies_from_now() -> None:
    clock, relay, sent = make_relay()
    relay.on_truth("a", truth(0.0))
    relay.on_truth("b", truth(150.0))
    clock.advance_to(10.0)
    relay.on_ctl(msgpack.packb({"partition": {"duration_s": 50, "groups": [["a"]]}}))
    relay.on_tx("a", b"cut")
    clock.advance_to(70.0)
    relay.on_tx("a", b"healed")
    while (due := relay.step()) is not None:
        clock.advance_to(max(due, clock.now()))
    reasons = [LinkRecord.decode(p).reason for k, p, _ in sent if k.startswith("fleet/link")]
    assert reasons == ["partition", None]
    assert [p for k, p, _ in sent if k == "fleet/rx/b"] == [b"healed"]
    _, extra = decode_stats(relay.stats_payload())
    assert extra["partitions"] == [{"start_s": 10.0, "end_s": 60.0, "groups": [["a"]]}]


def test_a_late_frame_keeps_its_slot_and_a_misdated_one_is_sent_now() -> None:
    # A lagging agent hands its frame over after the channel moved on: the frame is placed
    # at the time it is dated (within MAX_LATE_S), so the water never sees the host's lag.
    clock, relay, sent = make_relay()
    relay.on_truth("auv0", truth(0.0))
    relay.on_truth("auv1", truth(1500.0))
    clock.advance_to(20.0)
    relay.step()
    relay.on_tx("auv0", b"late", "data", sent_s=16.5)
    relay.on_tx("auv0", b"ancient", "data", sent_s=20.0 - 61.0)  # beyond MAX_LATE_S: now
    relay.on_tx("auv0", b"future", "data", sent_s=25.0)  # not yet on the relay's clock: now
    clock.advance_to(40.0)
    relay.step()
    delivered = {msgpack.unpackb(a)["t_sent_s"]: f for k, f, a in sent if k == "fleet/rx/auv1"}
    assert delivered[16.5] == b"late"
    assert sorted(f for t, f in delivered.items() if t >= 20.0) == [b"ancient", b"future"]
    assert relay.counters["late_tx"] == 1 and relay.counters["misdated_tx"] == 1
    assert relay.max_late_s == pytest.approx(3.5)


def test_the_topside_transmits_from_its_place_and_then_hears_the_water() -> None:
    """The operator's modem (link control ``inject_from: topside``) sends from where it is,
    and once placed it is a node: the vehicles' frames (their ACKs) reach fleet/rx/topside."""
    clock, relay, sent = make_relay(vehicles=frozenset({"auv0"}))
    relay.on_truth("auv0", truth(0.0))
    relay.on_tx("auv0", b"before")  # the topside is nowhere yet: nobody hears this
    clock.advance_to(10.0)
    relay.on_ctl(LinkControl(inject=b"order", inject_at=(500.0, 0.0, 0.0),
                             inject_from=TOPSIDE).encode())
    clock.advance_to(20.0)
    relay.on_tx("auv0", b"ack")
    while (due := relay.step()) is not None:
        clock.advance_to(max(due, clock.now()))
    rx = [(k, p, msgpack.unpackb(a)["src"]) for k, p, a in sent if k.startswith("fleet/rx/")]
    assert rx == [("fleet/rx/auv0", b"order", "topside"), ("fleet/rx/topside", b"ack", "auv0")]
    assert relay.channel.position(TOPSIDE) == (500.0, 0.0, 0.0)
    assert relay.channel.position(INTRUDER) is None  # not the intruder's modem
