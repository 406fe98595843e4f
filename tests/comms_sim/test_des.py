"""The in-process discrete-event transport."""

from __future__ import annotations

import numpy as np
import pytest

from comms_sim.channel import Channel, ChannelConfig, LinkEvent
from fleet_bus.clock import ManualClock
from comms_sim.des import EventLoop, InProcessNetwork

LOSSLESS = ChannelConfig(range_d50_m=1e7)


def test_event_loop_runs_in_time_then_scheduling_order() -> None:
    loop = EventLoop(ManualClock(0.0))
    seen: list[tuple[str, float]] = []
    note = lambda tag: (lambda: seen.append((tag, loop.now())))  # noqa: E731
    loop.call_at(2.0, note("b1"))
    loop.call_at(1.0, note("a"))
    loop.call_at(2.0, note("b2"))
    cancelled = loop.call_at(1.5, note("never"))
    cancelled.cancel()
    loop.call_at(1.0, lambda: loop.call_later(0.5, note("chained")))
    loop.run_until(1.9)
    assert seen == [("a", 1.0), ("chained", 1.5)] and loop.now() == 1.9
    loop.run_until(5.0)
    assert seen[2:] == [("b1", 2.0), ("b2", 2.0)] and loop.now() == 5.0
    loop.call_at(3.0, note("past"))  # already past: runs at once, at the current time
    loop.run_until(5.0)
    assert seen[-1] == ("past", 5.0)


def make_net(seed: int = 1, config: ChannelConfig = LOSSLESS):
    loop = EventLoop()
    net = InProcessNetwork(Channel(config, np.random.default_rng(seed)), loop)
    inbox: dict[str, list[tuple[bytes, float]]] = {}
    for node, x in (("a", 0.0), ("b", 750.0), ("c", 1500.0)):
        inbox[node] = []
        net.attach(node, lambda f, t, node=node: inbox[node].append((f, t)))
        net.set_position(node, (x, 0.0, 0.0))
    return loop, net, inbox


def test_frames_arrive_at_the_end_of_reception() -> None:
    loop, net, inbox = make_net()
    events: list[LinkEvent] = []
    net.add_listener(events.append)
    loop.call_at(10.0, lambda: net.send("a", b"hello"))
    loop.run_until(100.0)
    airtime = 0.3 + 5 * 8 / 1000.0
    assert inbox["b"] == [(b"hello", pytest.approx(10.0 + 0.5 + airtime))]
    assert inbox["c"] == [(b"hello", pytest.approx(10.0 + 1.0 + airtime))]
    assert inbox["a"] == []
    assert sorted(e.dst for e in events) == ["b", "c"]


def test_replies_from_handlers_and_refusals() -> None:
    loop, net, inbox = make_net()
    # b answers every frame it hears; the answer crosses the channel too
    net.attach("b", lambda f, t: net.send("b", b"re:" + f) if not f.startswith(b"re:") else None)
    loop.call_at(0.0, lambda: net.send("a", b"ping"))
    refusals: list[LinkEvent] = []
    loop.call_at(50.0, lambda: refusals.extend(net.send("a", b"x" * 65)))
    loop.run_until(60.0)
    assert [f for f, _ in inbox["a"]] == [b"re:ping"]
    assert [f for f, _ in inbox["c"]] == [b"ping", b"re:ping"]
    assert [(e.reason, e.dst) for e in refusals] == [("oversize", "*")]


def test_positions_callback_is_read_when_frames_go_on_air() -> None:
    loop = EventLoop()
    moving = lambda t: {"a": (0.0, 0.0, 0.0), "b": (100.0 * t, 0.0, 0.0)}  # noqa: E731
    net = InProcessNetwork(Channel(LOSSLESS, np.random.default_rng(0)), loop, positions=moving)
    got: list[float] = []
    net.attach("a", lambda f, t: None)
    net.attach("b", lambda f, t: got.append(t))
    loop.call_at(15.0, lambda: net.send("a", b"p"))  # b is 1500 m away then
    loop.run_until(30.0)
    assert got == [pytest.approx(15.0 + 1.0 + 0.308)]


def test_drops_are_never_delivered_and_runs_are_reproducible() -> None:
    def once() -> tuple[list, dict]:
        loop, net, inbox = make_net(seed=5, config=ChannelConfig(extra_loss=0.3))
        events: list[LinkEvent] = []
        net.add_listener(events.append)
        rng = np.random.default_rng(2)
        for i in range(300):
            src = "abc"[int(rng.integers(3))]
            loop.call_at(i * 0.8 + float(rng.random()), lambda s=src, i=i: net.send(s, b"%d" % i))
        loop.run()
        for node, frames in inbox.items():
            delivered = [(e.frame, e.t_s) for e in events if e.dst == node and e.delivered]
            assert frames == delivered  # exactly the model's deliveries, in order
        return events, inbox

    (ev1, in1), (ev2, in2) = once(), once()
    assert ev1 == ev2 and in1 == in2
    assert {e.reason for e in ev1} >= {None, "random", "collision"}
