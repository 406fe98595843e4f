"""The agent state machine alone: hostile input changes nothing, restarts forget nothing.

A tiny lockstep harness stands in for the water here (every frame reaches every other agent
one second later): these tests are about the decision logic, the channel has its own.
"""

from __future__ import annotations

import functools
import heapq
import itertools

import numpy as np
import pytest

from fleet_agent.config import AgentConfig
from fleet_agent.logic import Agent, Command, Fleet, Frame, Publish, Record, Send, Tick, step
from fleet_agent.wire import Abort, Codec, Pose, WireError
from hfc_core.generate import paper_preset_doc
from hfc_core.scenario import problem_from_dict

KEY = bytes(range(16))
CONFIG = AgentConfig().with_key(KEY)


@functools.lru_cache(maxsize=None)
def fleet() -> Fleet:
    return Fleet.build(problem_from_dict(paper_preset_doc(5)), KEY, 5, CONFIG)


def agent(index: int, now: float = 0.0, journal=()) -> Agent:
    return Agent(fleet(), index, CONFIG, now, journal)


class Lockstep:
    """Agents stepped at their wake-up times; each frame sent reaches the others 1 s later."""

    def __init__(self, agents: dict[int, Agent]) -> None:
        self.agents = agents
        self.outputs: dict[int, list] = {i: [] for i in agents}
        self.frames: list[tuple[float, int, bytes]] = []  # (sent at, sender, frame)
        self._queue: list[tuple[float, int, int, bytes]] = []
        self._n = itertools.count()

    def run_until(self, t_end: float, extra: dict[int, list[tuple[float, bytes]]] | None = None
                  ) -> None:
        inject = {i: sorted(v) for i, v in (extra or {}).items()}
        while True:
            wake = min((a.next_wakeup(), i) for i, a in self.agents.items())
            due_frame = self._queue[0][0] if self._queue else float("inf")
            due_extra = min(((v[0][0], i) for i, v in inject.items() if v),
                            default=(float("inf"), -1))
            t = min(wake[0], due_frame, due_extra[0])
            if t > t_end:
                return
            if due_extra[0] == t:
                _, data = inject[due_extra[1]].pop(0)
                self._step(due_extra[1], Frame(data, t))
            elif due_frame == t:
                _, _, dst, data = heapq.heappop(self._queue)
                self._step(dst, Frame(data, t))
            else:
                self._step(wake[1], Tick(t))

    def _step(self, i: int, inp) -> None:
        _, out = step(self.agents[i], inp)
        self.outputs[i] += out
        for o in out:
            if isinstance(o, Send):
                self.frames.append((inp.now, i, o.frame))
                for j in self.agents:
                    if j != i:
                        heapq.heappush(self._queue, (inp.now + 1.0, next(self._n), j, o.frame))


def comparable(outputs: list) -> list:
    """What an agent did, minus its own bookkeeping of what it refused."""
    keep = []
    for o in outputs:
        if isinstance(o, Send):
            keep.append(("send", o.frame))
        elif isinstance(o, Publish) and o.topic == "event":
            keep.append(("event", o.payload))
        elif isinstance(o, Publish) and o.topic == "truth":
            keep.append(("truth", o.payload))
    return keep


def test_hostile_frames_are_counted_and_change_nothing() -> None:
    base = Lockstep({i: agent(i) for i in range(3)})
    base.run_until(1500.0)
    genuine = [(t + 1.0, f) for t, i, f in base.frames if i != 0]
    own = [(t + 2.0, f) for t, i, f in base.frames if i == 0][:20]
    rng = np.random.default_rng(0)
    forger = Codec.for_problem(fleet().problem, b"not the fleet key")
    hostile: list[tuple[float, bytes]] = []
    for k in range(60):
        t = 20.0 + 23.7 * k
        hostile.append((t, rng.bytes(int(rng.integers(0, 70)))))  # garbage
        hostile.append((t + 0.3, forger.encode(Abort(1, int(t) + 5, int(t)))))  # forged abort
        hostile.append((t + 0.6, forger.encode(Pose(2, int(t) + 5, (0.0, 0.0, 0.0), 0, "home",
                                                    fleet().codec.largest(1).digest))))
    replays = [(t + 37.0, f) for t, f in genuine[::5] if t + 37.0 < 1499.0]  # heard again
    attacked = Lockstep({i: agent(i) for i in range(3)})
    attacked.run_until(1500.0, {0: hostile + replays + own})
    assert comparable(attacked.outputs[0]) == comparable(base.outputs[0])
    assert attacked.agents[0].status().route == base.agents[0].status().route
    c = attacked.agents[0].counters
    assert c.get("drop_mac", 0) >= 120  # forged frames (and garbage that got that far)
    assert c.get("drop_replay", 0) == len(replays)
    assert c.get("drop_self", 0) == len(own)
    refused = sum(n for k, n in c.items() if k.startswith("drop_"))
    assert refused == len(hostile) + len(replays) + len(own)


def test_restart_from_the_journal_forgets_nothing() -> None:
    world = Lockstep({i: agent(i) for i in range(3)})
    world.run_until(1300.0)
    before = world.agents[1]
    journal = [o.doc for o in world.outputs[1] if isinstance(o, Record)]
    reborn = agent(1, now=1400.0, journal=journal)
    assert set(reborn.cleared) >= set(before.cleared)
    assert reborn.treated == before.treated
    assert reborn.vehicle.distance_m == pytest.approx(before.vehicle.distance_m, abs=20.0)
    assert reborn.vehicle.battery_left_s(1400.0) == pytest.approx(3600.0 - 1400.0)
    # its replay window came back: frames it took before the restart are refused
    old = [f for t, i, f in world.frames if i != 1][-5:]
    out = []
    for f in old:
        out += reborn.step(Frame(f, 1401.0))
    assert reborn.counters.get("drop_replay", 0) == len(old)
    # and its own sequence numbers go on increasing
    while not any(isinstance(o, Send) for o in out):
        out += reborn.step(Tick(reborn.next_wakeup()))
    frame = next(o.frame for o in out if isinstance(o, Send))
    assert fleet().codec.decode(frame).seq > before.last_seq
    events = [o.payload.kind for o in out if isinstance(o, Publish) and o.topic == "event"]
    assert "restart" in events


def test_abort_announces_then_goes_quiet_and_home() -> None:
    world = Lockstep({i: agent(i) for i in range(3)})
    world.run_until(600.0)
    world._step(2, Command("abort", 600.5))
    world.run_until(4000.0)
    sent = [fleet().codec.decode(f) for t, i, f in world.frames if i == 2 and t > 600.5]
    kinds = [type(m).__name__ for m in sent]
    assert kinds[:CONFIG.abort_repeats] == ["Abort"] * CONFIG.abort_repeats
    assert "Pose" not in kinds  # an aborted vehicle is out of the conversation
    assert world.agents[2].vehicle.done and world.agents[2].quiet
    for i in (0, 1):
        assert world.agents[i].members.status(2) == "aborted"
        assert world.agents[i].status().peers["auv3"] == "aborted"


def test_truth_goes_out_before_the_first_frame() -> None:
    a = agent(0)
    out = a.step(Tick(0.0))
    topics = [o.topic if isinstance(o, Publish) else type(o).__name__ for o in out]
    assert "truth" in topics
    if "Send" in topics:
        assert topics.index("truth") < topics.index("Send")


def test_every_frame_an_agent_sends_decodes_within_the_limits() -> None:
    world = Lockstep({i: agent(i) for i in range(3)})
    world.run_until(3700.0)
    kinds = set()
    for _, _, f in world.frames:
        assert len(f) <= 64
        try:
            m = fleet().codec.decode(f)
        except WireError as exc:  # pragma: no cover - would be a codec bug
            pytest.fail(f"own frame refused: {exc.reason}")
        kinds.add(type(m).__name__)
        if isinstance(m, Pose):
            assert len(f) <= 32
    assert {"Pose", "ClearedSegment"} <= kinds
