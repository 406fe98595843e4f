"""The launcher's desk for `cotsfleet ctl` (cotsfleet.mission.order_desk), driven by plain
calls: a request the operator or the remote ground station signed is numbered, sent from the
topside and answered, and counted by signer; a vehicle's signature, an unknown key, garbage,
a replay, a flood and a non-order are refused and counted; the acknowledgements the topside
hears are answered once each."""

from __future__ import annotations

from pathlib import Path

import msgpack
import pytest
from cryptography.hazmat.primitives.asymmetric.ed25519 import Ed25519PrivateKey

from cotsfleet.mission.order_desk import MAX_QUEUED, OrderDesk
from cotsfleet.mission.topside import Topside
from fleet_bus import keys
from fleet_bus.auth import Signer
from fleet_bus.credentials import (
    load_auth,
    load_frame_chains,
    load_frame_seed,
    load_ring,
    write_run_credentials,
)
from fleet_bus.orders import (
    ACKED,
    REFUSALS,
    KeyFrame,
    OrderCodec,
    OrderFrame,
    TopsideSchedule,
    encode_request,
    parse_words,
)

VEHICLES = ("auv1", "auv2", "auv3")
FLEET_KEY = bytes(range(16))


@pytest.fixture()
def creds(tmp_path: Path) -> Path:
    root = tmp_path / "creds"
    write_run_credentials(root, VEHICLES, "run-desk")
    return root


def _desk(creds: Path) -> OrderDesk:
    op = creds / "operator"
    codec = OrderCodec(FLEET_KEY, "run-desk", VEHICLES)
    top = Topside(codec, TopsideSchedule(), load_frame_seed(op),
                  load_frame_chains(op, VEHICLES).length, (100.0, 200.0), 600.0)
    return OrderDesk(top, load_ring(op))


def _request(creds: Path, signer: str, words: list[str], ref: str = "r1") -> bytes:
    auth = load_auth(creds / signer, signer)
    return auth.seal(keys.ORDER_REQUEST, encode_request(parse_words(words), ref))


def test_an_operators_request_is_numbered_sent_and_answered(creds: Path) -> None:
    desk = _desk(creds)
    desk.request(_request(creds, "operator", ["recall", "auv2"]))
    due = desk.due(1200.0)
    [answer] = due.answers
    assert (answer.ref, answer.seq, answer.order, answer.targets, answer.error) == (
        "r1", 1, "recall auv2", ("auv2",), "")
    read = [desk.topside.codec.read(f) for f in due.frames]  # the order, and a key
    assert [type(r) for r in read] == [OrderFrame, KeyFrame] and read[0].order.seq == 1
    assert desk.due(1201.0).frames == []  # once per interval
    later = desk.due(1230.5)  # the next interval: sent again, not yet acknowledged
    assert any(isinstance(desk.topside.codec.read(f), OrderFrame) for f in later.frames)
    # auv2's ACK through the water: answered once, then the order is closed
    desk.hear(desk.topside.codec.ack(1, 1240, 1, ACKED), 1241.0)
    [acked] = desk.due(1242.0).answers
    assert acked.acked == {"auv2": 1241.0} and acked.ref == "r1"
    assert desk.due(1243.0).answers == []
    frames = desk.due(1290.5).frames  # keys only (the order is closed): it is not resent
    assert frames and all(isinstance(desk.topside.codec.read(f), KeyFrame) for f in frames)
    section = desk.section({"auv2": {"ctl_taken": 1}})
    assert section["sent"][0]["acked"] == {"auv2": 1241.0} and desk.refusals() == {}
    assert section["sent"][0]["by"] == "operator" and desk.takers() == {"operator": 1}


def test_the_ground_stations_request_is_taken_and_counted_by_signer(creds: Path) -> None:
    """``ground`` (`cotsfleet ctl --connect` on another host) orders as the operator does;
    each signer has its own replay window, and a scheduled order names no signer."""
    desk = _desk(creds)
    ground = _request(creds, "ground", ["pause", "auv3"], ref="g1")
    desk.request(ground)
    desk.request(_request(creds, "operator", ["resume", "auv3"], ref="o1"))
    desk.request(ground)  # played again: refused as the operator's would be
    answers = desk.due(300.0).answers
    assert [(a.ref, a.seq, a.order, a.error) for a in answers] == [
        ("g1", 1, "pause auv3", ""), ("o1", 2, "resume auv3", "")]
    desk.submit(parse_words(["drop-spot", "3"]), 310.0)  # `--ctl`, scheduled: no signer
    sent = desk.section({})["sent"]
    assert [row.get("by") for row in sent] == ["ground", "operator", None]
    assert desk.takers() == {"ground": 1, "operator": 1}
    assert desk.refusals() == {"replay": 1}


def test_a_vehicles_key_and_unknown_keys_are_refused(creds: Path, tmp_path: Path) -> None:
    desk = _desk(creds)
    desk.request(_request(creds, "auv2", ["recall", "auv2"]))  # a vehicle's own key
    other = tmp_path / "other"  # another run's ground station: its key is not this ring's
    write_run_credentials(other, VEHICLES, "run-desk")
    desk.request(_request(other, "ground", ["recall", "auv2"]))
    stranger = Signer("ground-2", Ed25519PrivateKey.generate(), "run-desk")  # not in the ring
    desk.request(stranger.seal(keys.ORDER_REQUEST,
                               encode_request(parse_words(["recall", "auv2"]), "s1")))
    assert desk.due(10.0).answers == [] and not desk.topside.orders
    assert desk.refusals() == {"not_allowed": 1, "bad_signature": 1, "unknown_signer": 1}
    assert desk.takers() == {}


def test_a_refusal_heard_from_a_vehicle_is_answered(creds: Path) -> None:
    desk = _desk(creds)
    desk.request(_request(creds, "operator", ["drop-spot", "7"]))
    desk.due(100.0)
    desk.hear(desk.topside.codec.ack(0, 110, 1, 1 + REFUSALS.index("unknown_spot")), 111.0)
    [answer] = desk.due(112.0).answers
    assert answer.refused == {"auv1": "unknown_spot"} and answer.targets == VEHICLES


def test_what_is_not_the_operators_order_is_refused_and_counted(creds: Path) -> None:
    desk = _desk(creds)
    genuine = _request(creds, "operator", ["pause", "all"])
    desk.request(_request(creds, "auv1", ["recall", "all"]))  # a vehicle's key
    desk.request(b"garbage, not an envelope" * 4)
    desk.request(genuine)
    desk.request(genuine)  # played again
    op = load_auth(creds / "operator", "operator")
    desk.request(op.seal(keys.ORDER_REQUEST, msgpack.packb({"verb": "launch", "ref": "r9"})))
    desk.request(op.seal(keys.LINK_CTL, encode_request(parse_words(["abort", "all"]))))
    answers = desk.due(50.0).answers
    assert [(a.ref, a.seq, bool(a.error)) for a in answers] == [("r1", 1, False),
                                                                 ("r9", 0, True)]
    assert "unknown order 'launch'" in answers[1].error
    assert desk.refusals() == {"not_allowed": 1, "malformed": 1, "replay": 1, "invalid": 1,
                               "bad_signature": 1}  # signed for another key: no good here
    assert len(desk.topside.orders) == 1


def test_a_flood_of_signed_requests_is_bounded(creds: Path) -> None:
    """Per signer: the ground station's flood costs its own requests, not the operator's."""
    desk = _desk(creds)
    for i in range(MAX_QUEUED + 5):
        desk.request(_request(creds, "ground", ["pause", "auv1"], ref=f"r{i}"))
    desk.request(_request(creds, "operator", ["recall", "auv2"], ref="op"))
    assert desk.refusals() == {"flood": 5}
    answers = desk.due(10.0).answers
    assert len(answers) == MAX_QUEUED + 1 and answers[-1].ref == "op"
    assert desk.takers() == {"ground": MAX_QUEUED, "operator": 1}
    desk.request(_request(creds, "ground", ["resume", "auv1"], ref="again"))  # room again
    assert [a.ref for a in desk.due(11.0).answers] == ["again"]


def test_an_unknown_vehicle_is_answered_with_the_reason(creds: Path) -> None:
    desk = _desk(creds)
    desk.request(_request(creds, "operator", ["recall", "auv9"]))
    [answer] = desk.due(10.0).answers
    assert "no vehicle 'auv9'" in answer.error and desk.refusals() == {"invalid": 1}


def test_without_a_topside_chain_every_request_gets_the_reason(creds: Path) -> None:
    desk = OrderDesk(None, load_ring(creds / "operator"), "no topside chain here")
    desk.request(_request(creds, "operator", ["recall", "auv2"]))
    [answer] = desk.due(10.0).answers
    assert answer.error == "no topside chain here" and answer.seq == 0
    assert desk.section({}) is None and desk.refusals() == {"unavailable": 1}
