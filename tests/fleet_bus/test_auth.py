"""Signed envelopes, the key ring and a run's credentials on disk (fleet_bus.auth,
fleet_bus.credentials): who may speak where, replays, other runs, tampering, files."""

from __future__ import annotations

import os
import stat
from pathlib import Path

import pytest

from fleet_bus import keys
from fleet_bus.auth import REPLAY_WINDOW, Refused, allowed
from fleet_bus.credentials import (CredentialsError, load_auth, load_login, load_ring,
                                   load_router_zid, write_run_credentials)

VEHICLES = ("auv1", "auv2", "auv3")


@pytest.fixture(scope="module")
def creds(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("creds") / "credentials"
    write_run_credentials(root, VEHICLES, "run-a")
    return root


def write_run_credentials_zid(root: Path) -> str:
    import shutil

    shutil.rmtree(root, ignore_errors=True)
    write_run_credentials(root, ("auv1",))
    return load_router_zid(root / "router")


def refusal(auth, key: str, envelope: bytes) -> str:
    with pytest.raises(Refused) as exc:
        auth.open(key, envelope)
    return exc.value.reason


def test_only_the_rightful_role_may_speak_on_a_key():
    assert allowed(keys.ctl_key("auv1"), "operator", "operator")
    assert not allowed(keys.ctl_key("auv1"), "auv1", "vehicle")
    assert allowed(keys.status_key("auv2"), "auv2", "vehicle")
    assert not allowed(keys.status_key("auv2"), "auv1", "vehicle")
    assert not allowed(keys.status_key("auv2"), "operator", "operator")
    assert allowed(keys.rx_key("auv1"), "relay", "relay")
    assert not allowed(keys.rx_key("auv1"), "auv1", "vehicle")
    assert allowed(keys.link_event_key("auv1", "auv2"), "relay", "relay")
    assert allowed(keys.busy_key("auv1"), "auv1", "vehicle")  # only its own planner runs
    assert not allowed(keys.busy_key("auv1"), "auv2", "vehicle")
    assert not allowed(keys.busy_key("auv1"), "operator", "operator")
    assert allowed(keys.MISSION, "operator", "operator") and allowed(keys.CLOCK, "operator",
                                                                     "operator")
    assert not allowed(keys.MISSION, "relay", "relay")
    assert not allowed("elsewhere/x", "operator", "operator")
    # order requests (`cotsfleet ctl`): the operator's, or the remote ground station's
    assert allowed(keys.ORDER_REQUEST, "operator", "operator")
    assert allowed(keys.ORDER_REQUEST, "ground", "ground")
    assert not allowed(keys.ORDER_REQUEST, "auv1", "vehicle")
    assert not allowed(keys.ORDER_REQUEST, "relay", "relay")
    for key in (keys.ORDER_ANSWER, keys.ctl_key("auv1"), keys.LINK_CTL, keys.MISSION,
                keys.CLOCK, keys.status_key("ground"), keys.tx_key("ground"),
                keys.rx_key("ground"), "fleet/query/ground"):
        assert not allowed(key, "ground", "ground"), key


def test_an_envelope_opens_once_on_its_key_only(creds):
    auv1 = load_auth(creds / "auv1", "auv1")
    station = load_auth(creds / "station")
    env = auv1.seal(keys.status_key("auv1"), b"payload")
    assert station.open(keys.status_key("auv1"), env) == ("auv1", b"payload")
    assert refusal(station, keys.status_key("auv1"), env) == "replay"
    moved = auv1.seal(keys.status_key("auv1"), b"payload")
    assert refusal(station, keys.event_key("auv1"), moved) == "bad_signature"  # moved key
    assert refusal(station, keys.status_key("auv2"), env) == "not_allowed"
    assert refusal(station, keys.ctl_key("auv2"), auv1.seal(keys.ctl_key("auv2"), b"x")) \
        == "not_allowed"  # a vehicle cannot command, even when it signs
    assert station.verifier.refused == {"replay": 1, "bad_signature": 1, "not_allowed": 2}


def test_tampering_garbage_and_strangers_are_refused(creds):
    op = load_auth(creds / "operator", "operator")
    relay = load_auth(creds / "relay", "relay")
    key = keys.ctl_key("auv1")
    env = bytearray(op.seal(key, b"abort"))
    env[-70] ^= 1  # a payload byte
    assert refusal(relay, key, bytes(env)) == "bad_signature"
    assert refusal(relay, key, b"") == "malformed"
    assert refusal(relay, key, os.urandom(200)) == "malformed"
    stranger = bytearray(op.seal(key, b"abort"))
    stranger[5:5 + len("operator")] = b"operatoR"
    assert refusal(relay, key, bytes(stranger)) == "unknown_signer"


def test_another_runs_envelope_is_refused(tmp_path: Path, creds):
    other = tmp_path / "other"
    write_run_credentials(other, VEHICLES, "run-b")
    op_b = load_auth(other / "operator", "operator")
    auv1 = load_auth(creds / "auv1", "auv1")
    # a different run's key: unknown to this ring's public key for "operator"
    assert refusal(auv1, keys.ctl_key("auv1"), op_b.seal(keys.ctl_key("auv1"), b"x")) \
        == "bad_signature"


def test_reordering_within_the_window_is_accepted_replays_are_not(creds):
    relay = load_auth(creds / "relay", "relay")
    auv2 = load_auth(creds / "auv2", "auv2")
    key = keys.rx_key("auv2")
    envs = [relay.seal(key, b"%d" % i) for i in range(10)]
    for env in reversed(envs):  # Zenoh threads may deliver one sender's puts out of order
        auv2.open(key, env)
    for env in envs:
        assert refusal(auv2, key, env) == "replay"
    old = relay.seal(key, b"old")
    for _ in range(REPLAY_WINDOW + 1):
        relay.seal(key, b"")  # the sender moves on
    auv2.open(key, relay.seal(key, b"new"))
    assert refusal(auv2, key, old) == "replay"  # below the window


def test_a_restarted_sender_continues_above_its_counter(creds):
    key = keys.status_key("auv3")
    station = load_auth(creds / "station")
    first = load_auth(creds / "auv3", "auv3")
    for _ in range(50):
        station.open(key, first.seal(key, b"before"))
    again = load_auth(creds / "auv3", "auv3")  # a new process: the counter restarts from time
    assert station.open(key, again.seal(key, b"after")) == ("auv3", b"after")


def test_credentials_on_disk(creds):
    for pid in (*VEHICLES, "operator", "relay", "ground"):
        mode = stat.S_IMODE((creds / pid / "signing.key").stat().st_mode)
        assert mode == 0o600, (pid, oct(mode))
        assert stat.S_IMODE((creds / pid).stat().st_mode) == 0o700
    assert not (creds / "station" / "signing.key").exists()  # it only listens
    assert not (creds / "router" / "signing.key").exists()
    assert load_ring(creds / "auv2").run_id == "run-a"
    users = (creds / "router" / "users.txt").read_text().split()
    # "world": the listen-only login of the ROS 2 vehicles' clock (`cotsfleet run --helm ros2`)
    # "ground": a ground station elsewhere (`cotsfleet ctl --connect`), order requests only
    assert {u.split(":")[0] for u in users} == {*VEHICLES, "operator", "relay", "ground",
                                                "station", "world", "router"}
    assert load_login(creds / "auv1").user == "auv1"
    for _ in range(64):  # a Zenoh id never starts with 0 (Zenoh refuses it)
        assert not write_run_credentials_zid(creds.parent / "z").startswith("0")
    with pytest.raises(CredentialsError, match="not auv2's key"):
        load_auth(creds / "auv1", "auv2")
    with pytest.raises(CredentialsError, match="cannot read"):
        load_auth(creds / "station", "operator")
    station = load_auth(creds / "station")
    with pytest.raises(PermissionError):
        station.seal(keys.status_key("auv1"), b"x")


def test_one_keys_counters_do_not_refuse_another_keys_messages(creds):
    """An insider's login signing busy flags with counters far ahead (a session started later)
    must not make the operator refuse the vehicle's genuine statuses as replays: one replay
    window per (signer, key expression)."""
    genuine, leaked = load_auth(creds / "auv1", "auv1"), load_auth(creds / "auv1", "auv1")
    assert leaked.signer is not None
    leaked.signer._counter += 10 * REPLAY_WINDOW  # started much later: its counters are ahead
    operator = load_auth(creds / "operator", "operator")
    busy, status = keys.busy_key("auv1"), keys.status_key("auv1")
    assert operator.open(busy, leaked.seal(busy, b"1"))[0] == "auv1"
    assert operator.open(status, genuine.seal(status, b"s"))[0] == "auv1"
    again = genuine.seal(busy, b"0")  # on the busy key itself the window still holds
    with pytest.raises(Refused):
        operator.open(busy, again)
