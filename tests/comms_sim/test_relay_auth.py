"""The relay under attack, with the run's credentials: only vehicle X's signed frames enter
X's queue, only the operator's link control is applied, a flood costs the flooder's queue,
and partitions are bounded. Driven by plain calls on a manual clock with real keys."""

from __future__ import annotations

from pathlib import Path

import msgpack
import numpy as np
import pytest

from comms_sim.channel import MAX_QUEUED_FRAMES, Channel, ChannelConfig
from comms_sim.relay import MAX_PARTITIONS, Relay
from fleet_bus import keys
from fleet_bus.clock import ManualClock
from fleet_bus.credentials import load_auth, write_run_credentials
from fleet_bus.link import LinkControl, Partition
from fleet_bus.telemetry import Truth

LOSSLESS = ChannelConfig(range_d50_m=1e7)
VEHICLES = ("auv1", "auv2", "auv3")


@pytest.fixture(scope="module")
def creds(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("relay-auth") / "credentials"
    write_run_credentials(root, VEHICLES)
    return root


def make_relay(creds: Path):
    clock = ManualClock(0.0)
    sent: list[tuple[str, bytes, bytes | None]] = []
    relay = Relay(Channel(LOSSLESS, np.random.default_rng(0)), clock,
                  lambda k, p, a: sent.append((k, p, a)), frozenset(VEHICLES),
                  load_auth(creds / "relay", "relay"))
    signers = {vid: load_auth(creds / vid, vid) for vid in VEHICLES}
    for i, vid in enumerate(VEHICLES):
        relay.on_truth(vid, signers[vid].seal(keys.truth_key(vid),
                                              Truth(0.0, (100.0 * i, 0.0, 0.0)).encode()))
    return clock, relay, sent, signers


def delivered(sent, dst: str) -> list[bytes]:
    return [p for k, p, _ in sent if k == keys.rx_key(dst)]


def run_until_idle(clock: ManualClock, relay: Relay, limit_s: float = 10_000.0) -> None:
    while (due := relay.step()) is not None and due < limit_s:
        clock.advance_to(due)


def test_a_forged_pose_does_not_replace_a_queued_heartbeat(creds: Path) -> None:
    clock, relay, sent, signers = make_relay(creds)
    auv1 = signers["auv1"]
    relay.on_tx("auv1", auv1.seal(keys.tx_key("auv1"), b"first"), "data")  # on the air
    relay.on_tx("auv1", auv1.seal(keys.tx_key("auv1"), b"real-pose"), "pose")  # queued
    auv2 = signers["auv2"]  # another vehicle's key, or none: never auv1's queue
    relay.on_tx("auv1", auv2.seal(keys.tx_key("auv1"), b"forged-pose"), "pose")
    relay.on_tx("auv1", b"forged-pose unsigned", "pose")
    run_until_idle(clock, relay)
    assert delivered(sent, "auv2") == [b"first", b"real-pose"]
    assert relay.counters["auth_not_allowed"] == 1 and relay.counters["auth_malformed"] == 1


def test_garbage_does_not_starve_a_real_sender(creds: Path) -> None:
    clock, relay, sent, signers = make_relay(creds)
    rng = np.random.default_rng(1)
    for _ in range(5000):
        relay.on_tx("auv2", rng.bytes(int(rng.integers(1, 200))), "data")
    relay.on_tx("auv1", signers["auv1"].seal(keys.tx_key("auv1"), b"hello"), "data")
    clock.advance_to(1.0)
    run_until_idle(clock, relay, limit_s=30.0)
    assert delivered(sent, "auv3") == [b"hello"]
    assert clock.now() < 5.0  # within one airtime plus propagation, not 600 s later
    assert relay.counters["auth_malformed"] == 5000


def test_a_flooding_vehicle_fills_only_its_own_bounded_queue(creds: Path) -> None:
    clock, relay, sent, signers = make_relay(creds)
    flooder, honest = signers["auv2"], signers["auv1"]
    for i in range(3 * MAX_QUEUED_FRAMES):
        relay.on_tx("auv2", flooder.seal(keys.tx_key("auv2"), b"flood %d" % i), "data")
    relay.on_tx("auv1", honest.seal(keys.tx_key("auv1"), b"honest"), "data")
    stats = relay.channel.stats()
    assert stats[("auv2", "*")]["queue_full"] == 3 * MAX_QUEUED_FRAMES - MAX_QUEUED_FRAMES
    clock.advance_to(1.0)
    relay.step()
    # auv1's frame went on the air at once, not behind auv2's flood (under ALOHA a vehicle
    # that transmits without pause still jams the water: that is physics, see security.md)
    assert relay.channel.stats()[("auv1", "auv3")]["sent"] == 1


def test_only_the_operator_controls_the_link_and_partitions_are_bounded(creds: Path) -> None:
    clock, relay, _, signers = make_relay(creds)
    operator = load_auth(creds / "operator", "operator")
    cut = LinkControl(partition=Partition(0.0, 1e9, (("auv1",),))).encode()
    relay.on_ctl(signers["auv1"].seal(keys.LINK_CTL, cut))  # a vehicle may not
    relay.on_ctl(msgpack.packb({"extra_loss": 1.0}))  # nobody unsigned may
    assert relay.channel.partitions == () and relay.channel.extra_loss == 0.0
    for _ in range(MAX_PARTITIONS + 10):
        relay.on_ctl(operator.seal(keys.LINK_CTL, cut))
    assert len(relay.channel.partitions) == MAX_PARTITIONS
    assert relay.counters["ctl_too_many_partitions"] == 10
    assert relay.counters["auth_not_allowed"] == 1 and relay.counters["auth_malformed"] == 1
    # what the relay publishes is signed by the relay: a vehicle's verifier accepts it
    payload = relay.stats_payload()
    assert payload and relay.auth is not None
