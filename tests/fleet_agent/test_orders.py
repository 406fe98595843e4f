"""The operator's orders at one agent, in-process with an injected clock: proven by the
topside's chain, refused when unsigned, replayed or stale, never acted on twice (journal)."""

from __future__ import annotations

import pytest

from cotsfleet.mission.topside import forged_order, topside_of
from fleet_agent.agent import Agent, Frame, Tick
from fleet_agent.config import AgentConfig
from fleet_agent.fleet import Fleet
from fleet_bus.orders import (MAX_ORDER_BYTES, AckFrame, KeyFrame, Order, OrderCodec,
                              OrderError, OrderFrame, parse_words)
from hfc_core.formats.scenario import problem_from_dict
from reef_sim.scenarios.field import paper_preset_doc

CONFIG = AgentConfig(plan_iterations=60, replan_iterations=30)


@pytest.fixture(scope="module")
def fleet() -> Fleet:
    p = problem_from_dict(paper_preset_doc(5))
    return Fleet.build(p, b"k" * 16, 0, CONFIG, run_id="t-orders")


def _feed(agent: Agent, frames: list[bytes], now: float) -> list:
    out = []
    for f in frames:
        out += agent.step(Frame(f, now))
    return out


def _counters(agent: Agent) -> dict[str, int]:
    return agent.counters


def test_codec_round_trip_and_sizes() -> None:
    codec = OrderCodec(b"x" * 16, "run", ("auv1", "auv2"))
    for words in (["recall", "auv2"], ["pause", "all"], ["add-spot", "512.3", "-40", "80.5"],
                  ["drop-spot", "17"]):
        o = parse_words(words)
        o = Order(o.verb, o.target, 7, 100, o.x, o.y, o.priority, o.spot,
                  3 if o.verb == "add-spot" else 0)
        f = codec.read(codec.order(o, 130, b"a" * 8, b"b" * 8))
        assert isinstance(f, OrderFrame) and f.order == o and f.disclosed == b"b" * 8
        assert len(codec.order(o, 130, b"a" * 8, b"b" * 8)) <= MAX_ORDER_BYTES <= 43
    assert isinstance(codec.read(codec.key(90, b"c" * 8)), KeyFrame)
    assert codec.read(codec.ack(1, 90, 7, 0)) == AckFrame(1, 90, 7, 0)
    other = OrderCodec(b"y" * 16, "run", ("auv1", "auv2"))
    with pytest.raises(OrderError, match="mac"):
        other.read(codec.key(90, b"c" * 8))


def test_an_order_is_acted_on_once_its_key_is_out_and_never_twice(fleet) -> None:
    top = topside_of(fleet.problem, fleet, CONFIG)
    agent = Agent(fleet, 1, CONFIG, 0.0)
    agent.step(Tick(500.0))
    top.submit(parse_words(["recall", "auv2"]), 500.0)
    first = top.frames(500.0)
    _feed(agent, first, 501.0)
    assert agent.active  # held: its interval's key is still secret
    t = top.next_s(500.0)
    while agent.active and t is not None and t < 700:
        _feed(agent, top.frames(t), t + 1.0)
        t = top.next_s(t)
    assert not agent.active and agent.own.aborted
    assert _counters(agent)["ctl_taken"] == 1
    # Played back later: its key is out, it proves nothing.
    _feed(agent, first, 800.0)
    assert _counters(agent)["ctl_replayed"] == 1
    # A restarted agent keeps what it took (the journal), so a repeat is only acknowledged.
    journal = [{"k": "ord", "t": 560.0, "n": 1, "verb": "recall"}]
    again = Agent(fleet, 1, CONFIG, 600.0, journal)
    assert 1 in again.orders.taken


def test_an_insiders_order_is_refused_as_unsigned(fleet) -> None:
    top = topside_of(fleet.problem, fleet, CONFIG)
    agent = Agent(fleet, 0, CONFIG, 0.0)
    agent.step(Tick(300.0))
    _feed(agent, [forged_order(fleet, Order("recall", "auv1"), 300.0)], 301.0)
    top.submit(parse_words(["pause", "auv3"]), 310.0)  # the genuine topside's keys
    t: float | None = 310.0
    while t is not None and t < 500:
        _feed(agent, top.frames(t), t + 1.0)
        t = top.next_s(t)
    assert agent.active and _counters(agent)["ctl_unsigned"] == 1


def test_garbage_with_a_topside_kind_is_counted_not_raised(fleet) -> None:
    agent = Agent(fleet, 0, CONFIG, 0.0)
    for junk in (b"\x3f\xff" + b"\x00" * 40, b"\x3e\xff" + b"\x01" * 16,
                 b"\x3d\x00" + b"\x02" * 13):
        agent.step(Frame(junk, 10.0))
    assert sum(n for k, n in agent.counters.items() if k.startswith("drop_ctl_")) == 3
