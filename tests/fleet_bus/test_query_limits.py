"""Queries are signed by their asker and rationed per asker: a flood by one identity is
dropped unanswered and counted, and costs no one else their answers. Real keys, an injected
monotonic clock."""

from __future__ import annotations

from pathlib import Path

import pytest

from fleet_bus import keys
from fleet_bus.auth import Refused, open_query, seal_query
from fleet_bus.credentials import load_auth, write_run_credentials
from fleet_bus.query_limits import (
    BURST,
    RATE_PER_S,
    UNSIGNED,
    UNSIGNED_BURST,
    QueryGate,
    TokenBucket,
    nonce_of,
)


class Mono:
    def __init__(self) -> None:
        self.t = 0.0

    def __call__(self) -> float:
        return self.t


@pytest.fixture(scope="module")
def creds(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("q") / "c"
    write_run_credentials(root, ("auv1", "auv2"))
    return root


def test_a_signed_query_names_its_asker_and_binds_key_and_nonce(creds: Path) -> None:
    operator = load_auth(creds / "operator", "operator")
    auv1 = load_auth(creds / "auv1", "auv1")
    att = seal_query(auv1, keys.CLOCK, "n1")
    assert open_query(operator, keys.CLOCK, "n1", att) == "auv1"
    with pytest.raises(Refused) as exc:  # the same envelope again
        open_query(operator, keys.CLOCK, "n1", att)
    assert exc.value.reason == "replay"
    with pytest.raises(Refused) as exc:  # moved to another key
        open_query(operator, keys.MISSION, "n2", seal_query(auv1, keys.CLOCK, "n2"))
    assert exc.value.reason == "invalid"
    with pytest.raises(Refused):
        open_query(operator, keys.CLOCK, "n3", b"garbage")
    station = load_auth(creds / "station")  # holds no signing key: asks unsigned
    assert seal_query(station, keys.MISSION, "n4") is None and seal_query(None, "k", "n") is None


def test_a_flood_by_one_asker_is_limited_and_counted_and_others_are_answered(
        creds: Path) -> None:
    mono = Mono()
    gate = QueryGate(load_auth(creds / "operator", "operator"), mono=mono)
    auv1, auv2 = load_auth(creds / "auv1", "auv1"), load_auth(creds / "auv2", "auv2")
    answered = 0
    for i in range(1000):  # a thousand queries in one second by auv1
        mono.t = i / 1000.0
        answered += gate.admit(keys.CLOCK, f"n=a{i}", seal_query(auv1, keys.CLOCK, f"a{i}"))\
            is not None
    assert answered == pytest.approx(BURST + RATE_PER_S, abs=1)
    assert gate.admit(keys.CLOCK, "n=b", seal_query(auv2, keys.CLOCK, "b")) == "auv2"
    counts = gate.counts()
    assert counts["answered"]["auv1"] == answered and counts["answered"]["auv2"] == 1
    assert counts["limited"]["auv1"] == 1000 - answered and counts["refused"] == 0
    mono.t += 60.0  # the allowance comes back
    assert gate.admit(keys.CLOCK, "n=c", seal_query(auv1, keys.CLOCK, "c")) == "auv1"


def test_forged_and_unsigned_queries(creds: Path) -> None:
    mono = Mono()
    gate = QueryGate(load_auth(creds / "operator", "operator"), mono=mono)
    auv1 = load_auth(creds / "auv1", "auv1")
    forged = bytearray(seal_query(auv1, keys.MISSION, "x"))
    forged[-1] ^= 1  # auv1's name, not its signature: refused, auv1's allowance untouched
    for _ in range(100):
        assert gate.admit(keys.MISSION, "n=x", bytes(forged)) is None
    assert gate.counts()["refused"] == 100
    assert gate.admit(keys.MISSION, "n=y", seal_query(auv1, keys.MISSION, "y")) == "auv1"
    answered = sum(gate.admit(keys.MISSION, "", None) is not None for _ in range(500))
    assert answered == UNSIGNED_BURST and gate.counts()["limited"][UNSIGNED] == 500 - answered
    open_bus = QueryGate(None, mono=mono)  # no credentials: everyone is unsigned
    assert open_bus.admit(keys.CLOCK, "", b"anything") == UNSIGNED


def test_the_bucket_and_the_nonce() -> None:
    b = TokenBucket(2.0, 3.0, now=0.0)
    assert [b.take(0.0) for _ in range(4)] == [True, True, True, False]
    assert b.ready(0.5) and b.take(0.5) and not b.take(0.5)
    assert not b.take(0.4)  # time going back gives nothing
    assert nonce_of("n=abc") == "abc" and nonce_of("x=1;n=d") == "d" and nonce_of("") == ""
    assert len(nonce_of("n=" + "z" * 500)) == 32
