"""The agent state machine on the real in-process transport: hostile input changes nothing,
restarts forget nothing, an abort is announced then the vehicle goes quiet.

The fleet runs on `cotsfleet.mission.inprocess` (the same discrete-event loop and channel as
every simulation) over a channel without loss, so what these tests see is the decision
logic; the channel has its own tests.
"""

from __future__ import annotations

from dataclasses import replace

import functools
from collections import defaultdict

import numpy as np
import pytest

from comms_sim.config import ChannelConfig
from cotsfleet.mission.faults import Fault
from cotsfleet.mission.inprocess import InProcessBackend
from fleet_agent.agent import Agent
from fleet_agent.config import AgentConfig
from fleet_agent.driver import AgentDriver
from fleet_bus.modem_port import WATER_SPEC
from fleet_agent.fleet import Fleet
from fleet_agent.io_types import Frame, Publish, Record, Send, Tick
from fleet_agent.journal import MemoryJournal
from fleet_agent.wire import Abort, Codec, Pose, WireError
from reef_sim.scenarios.field import paper_preset_doc
from hfc_core.model.problem import Problem
from hfc_core.formats.scenario import problem_from_dict
from reef_sim.vehicle import SimVehicle

KEY = bytes(range(16))
CONFIG = AgentConfig().with_key(KEY)
LOSSLESS = ChannelConfig(range_d50_m=1e9, max_range_m=1e9)


@functools.lru_cache(maxsize=None)
def problem() -> Problem:
    return problem_from_dict(paper_preset_doc(5))


@functools.lru_cache(maxsize=None)
def fleet() -> Fleet:
    # run_id as InProcessBackend names seed 5
    return Fleet.build(problem(), KEY, 5, CONFIG, run_id="sim-5")


class World:
    """The three agents in process, every step's outputs kept per vehicle."""

    def __init__(self, faults: tuple[Fault, ...] = (), config: AgentConfig = CONFIG) -> None:
        self.outputs: dict[str, list] = defaultdict(list)
        self.backend = InProcessBackend(problem(), config, seed=5, key=KEY, channel=LOSSLESS,
                                        tap=lambda vid, out: self.outputs[vid].extend(out))
        self.backend.start(faults)

    def run_until(self, t_s: float) -> None:
        self.backend.advance(t_s)

    def agent(self, vid: str) -> Agent:
        agent = self.backend.seats[vid].agent
        assert agent is not None
        return agent

    def sent(self, vid: str) -> list[bytes]:
        return [f for o in self.outputs[vid] if isinstance(o, Send) for f in o.frames]


def comparable(outputs: list) -> list:
    """What an agent did, minus its own bookkeeping of what it refused."""
    keep = []
    for o in outputs:
        if isinstance(o, Send):
            keep.append(("send", o.frames))
        elif isinstance(o, Publish) and o.topic in ("event", "truth"):
            keep.append((o.topic, o.payload))
    return keep


def test_hostile_frames_are_counted_and_change_nothing() -> None:
    base = World()
    base.run_until(1500.0)
    rng = np.random.default_rng(0)
    forger = Codec.for_problem(problem(), b"not the fleet key", "sim-5")
    attacked = World()
    hostile: list[tuple[float, bytes]] = []
    for k in range(60):
        t = 20.0 + 23.7 * k
        hostile.append((t, rng.bytes(int(rng.integers(0, 70)))))  # garbage
        hostile.append((t + 0.3, forger.encode(Abort(1, int(t) + 5, int(t)))))  # forged abort
        hostile.append((t + 0.6, forger.encode(Pose(2, int(t) + 5, (0.0, 0.0, 0.0), 0, "home",
                                                    fleet().codec.largest(1).digest))))
    genuine = base.sent("auv2")[::5]  # auv1 heard these already: replays
    replays = [(30.0 + 37.0 * i, f) for i, f in enumerate(genuine) if 30.0 + 37.0 * i < 1499.0]
    own = [(25.0 + 41.0 * i, f) for i, f in enumerate(base.sent("auv1")[:20])]
    for t, f in hostile + replays + own:
        attacked.backend.inject("auv1", t, f)
    attacked.run_until(1500.0)
    assert comparable(attacked.outputs["auv1"]) == comparable(base.outputs["auv1"])
    assert attacked.agent("auv1").status().route == base.agent("auv1").status().route
    c = attacked.agent("auv1").counters
    assert c.get("drop_mac", 0) >= 120  # forged frames (and garbage that got that far)
    # A replay comes after its cycle's key was out (`fleet_bus.tesla`): it proves nothing.
    assert c.get("drop_replay", 0) + c.get("drop_late_key", 0) == len(replays)
    assert c.get("drop_self", 0) == len(own)
    refused = sum(n for k, n in c.items() if k.startswith("drop_"))
    assert refused == len(hostile) + len(replays) + len(own)


def test_restart_from_the_journal_forgets_nothing() -> None:
    world = World()
    world.run_until(1300.0)
    before = world.agent("auv2")
    journal = world.backend.seats["auv2"].journal.reopen().records
    assert journal == [o.doc for o in world.outputs["auv2"] if isinstance(o, Record)]
    reborn = Agent(fleet(), 1, CONFIG, 1400.0, journal)
    assert set(reborn.know.cleared) >= set(before.know.cleared)
    assert reborn.know.treated == before.know.treated
    assert reborn.own.distance_m == pytest.approx(before.own.distance_m, abs=20.0)
    assert reborn.own.battery_left_s(1400.0) == pytest.approx(3600.0 - 1400.0)
    # its replay window came back: frames it took before the restart are refused
    old = [f for vid in ("auv1", "auv3") for f in world.sent(vid)[-3:]]
    out = []
    for f in old:
        out += reborn.step(Frame(f, 1401.0))
    c = reborn.counters  # refused as replays, or as heard after their keys were out
    assert c.get("drop_replay", 0) + c.get("drop_late_key", 0) == len(old)
    # and its own sequence numbers go on increasing
    while not any(isinstance(o, Send) for o in out):
        out += reborn.step(Tick(reborn.next_wakeup()))
    frame = next(o.frames[0] for o in out if isinstance(o, Send))
    assert fleet().codec.decode(frame).seq > before.radio.last_seq
    events = [o.payload.kind for o in out if isinstance(o, Publish) and o.topic == "event"]
    assert "restart" in events


def test_abort_announces_then_keeps_watch_and_goes_home() -> None:
    world = World((Fault("abort", 600.5, "auv3"),))
    world.run_until(600.0)
    n_before = len(world.sent("auv3"))
    world.run_until(4000.0)
    sent = [fleet().codec.decode(f) for f in world.sent("auv3")[n_before:]]
    kinds = [type(m).__name__ for m in sent]
    # its ABORTs, its cleared set right after the first and after the last (`outbox.ABORTED`)
    said = ["Abort", "ClearedSegment"] + ["Abort"] * (CONFIG.abort_repeats - 1)
    assert kinds[:CONFIG.abort_repeats + 2] == said + ["ClearedSegment"]
    # then only poses saying "aborted", one every `watch_every_cycles` slots: keeping watch,
    # and after each the key it could not disclose (`fleet_bus.tesla`)
    watch = sent[CONFIG.abort_repeats + 2:]
    assert watch and all((type(m).__name__ == "Pose" and m.state in ("aborted", "home"))
                         or type(m).__name__ == "Key" for m in watch)
    slots = (4000.0 - 600.0) / (3 * CONFIG.slot_s)
    assert len(watch) <= slots / CONFIG.watch_every_cycles + 2
    assert world.agent("auv3").own.done and world.agent("auv3").quiet
    for vid in ("auv1", "auv2"):
        assert world.agent(vid).know.members.status(2) == "aborted"
        assert world.agent(vid).status().peers["auv3"] == "aborted"


def test_a_vehicle_off_watch_falls_silent_after_its_announcements() -> None:
    world = World((Fault("abort", 600.5, "auv3"),), replace(CONFIG, watch_every_cycles=0))
    world.run_until(600.0)
    n_before = len(world.sent("auv3"))
    world.run_until(4000.0)
    kinds = [type(fleet().codec.decode(f)).__name__ for f in world.sent("auv3")[n_before:]]
    assert kinds.count("Abort") == CONFIG.abort_repeats and kinds[0] == "Abort"
    assert "Pose" not in kinds


def test_the_last_working_vehicle_confirms_a_dead_peer_through_a_watcher() -> None:
    """auv3 aborts early and keeps watch; auv2 is killed; auv1, the last one working, can
    only confirm auv2's silence through auv3's heard codes, and does, and takes its spots."""
    world = World((Fault("abort", 300.5, "auv3"), Fault("kill", 900.0, "auv2")))
    world.run_until(1200.0)
    a1 = world.agent("auv1")
    assert a1.know.members.status(1) == "lost"
    events = [o.payload for o in world.outputs["auv1"]
              if isinstance(o, Publish) and o.topic == "event"]
    assert any(e.kind == "takeover" and e.peer == "auv2" for e in events)


def test_without_a_watcher_the_last_working_vehicle_only_suspects() -> None:
    world = World((Fault("abort", 300.5, "auv3"), Fault("kill", 900.0, "auv2")),
                  replace(CONFIG, watch_every_cycles=0))
    world.run_until(1200.0)
    a1 = world.agent("auv1")
    assert a1.know.members.status(1) == "suspect"  # silence alone is not death
    events = [o.payload for o in world.outputs["auv1"]
              if isinstance(o, Publish) and o.topic == "event"]
    assert any(e.kind == "suspect" and e.peer == "auv2" for e in events)
    assert not any(e.kind == "takeover" and e.peer == "auv2" for e in events)


class Recorder:
    """A driver's modem and telemetry that keep what went out, in order."""

    spec = WATER_SPEC

    def __init__(self) -> None:
        self.sent: list[str] = []

    def transmit(self, frames: tuple[bytes, ...], kind: str, sent_s: float | None = None) -> None:
        self.sent.append("frame")

    def close(self) -> None:
        pass

    def publish(self, topic: str, payload: object) -> None:
        self.sent.append(topic)


def test_the_simulated_vehicles_truth_goes_out_before_the_first_frame() -> None:
    a = Agent(fleet(), 0, CONFIG, 0.0, MemoryJournal().records)
    vehicle = SimVehicle(problem(), 0)
    out = Recorder()
    driver = AgentDriver(a, vehicle, out, out, MemoryJournal(), truth=vehicle.true_pose)
    while "frame" not in out.sent:
        driver.tick(driver.next_wakeup())
    assert "truth" in out.sent and out.sent.index("truth") < out.sent.index("frame")


def test_every_frame_an_agent_sends_decodes_within_the_limits() -> None:
    world = World()
    world.run_until(3700.0)
    kinds = set()
    for vid in ("auv1", "auv2", "auv3"):
        for f in world.sent(vid):
            assert len(f) <= 64
            try:
                m = fleet().codec.decode(f)
            except WireError as exc:  # pragma: no cover - would be a codec bug
                pytest.fail(f"own frame refused: {exc.reason}")
            kinds.add(type(m).__name__)
            if isinstance(m, Pose):
                assert len(f) <= 32
    assert {"Pose", "ClearedSegment"} <= kinds


def test_a_restart_on_its_journal_rejoins_before_it_treats_anything() -> None:
    """The fleet went on while the agent was down: its peers took over its spots and treated
    some (a fault fuzz, hard reef, 49 % loss: auv3 killed at 988 s, its spot 23 taken over
    and treated by auv2 at 1168 s, auv3 back on its journal at 1316 s treated 23 again at
    1445 s). Its journal is whole, but what it knows is as old as its death: it keeps
    station until it has learned the fleet's cleared set, as after a lost journal."""
    world = World((Fault("kill", 1200.0, "auv2"),))
    world.run_until(1500.0)
    cleared_by_fleet = set(world.agent("auv1").know.cleared)
    world.backend._start_agent("auv2", 1500.0, world.backend.seats["auv2"].journal.reopen())
    reborn = world.agent("auv2")
    assert reborn.rejoin.waiting and reborn.nav.rejoining
    assert not reborn.counters.get("journal_empty") and not reborn.counters.get("journal_damaged")
    assert not cleared_by_fleet <= set(reborn.know.cleared)  # what its peers did meanwhile
    world.run_until(3700.0)
    events = [(o.payload.t_s, o.payload.kind) for o in world.outputs["auv2"]
              if isinstance(o, Publish) and o.topic == "event"]
    rejoined = [t for t, k in events if k == "rejoined"]
    assert len(rejoined) == 1 and rejoined[0] - 1500.0 < 4 * 7.5 * 3  # a few cycles
    assert not any(k == "cleared" and 1500.0 <= t < rejoined[0] for t, k in events)
    assert set(reborn.know.cleared) >= cleared_by_fleet
    assert world.backend.ledger.duplicates() == 0


@pytest.mark.parametrize("restart_s", [1500.0])
def test_a_restart_on_a_lost_journal_rejoins_before_it_treats_anything(restart_s: float
                                                                        ) -> None:
    """Issue 31 item 5: auv2 killed at 1200 s comes back at ``restart_s`` with an empty
    journal. It keeps station until a peer's digest equals its own (the fleet's cleared set,
    pushed to it), then goes on; it treats nothing twice and says what it lost."""
    world = World((Fault("kill", 1200.0, "auv2"),))
    world.run_until(restart_s)
    cleared_by_fleet = set(world.agent("auv1").know.cleared)
    world.backend._start_agent("auv2", restart_s, MemoryJournal())  # the journal is gone
    reborn = world.agent("auv2")
    assert reborn.rejoin.waiting and reborn.counters.get("journal_empty") == 1
    world.run_until(3700.0)
    events = [(o.payload.t_s, o.payload.kind) for o in world.outputs["auv2"]
              if isinstance(o, Publish) and o.topic == "event"]
    rejoined = [t for t, k in events if k == "rejoined"]
    assert len(rejoined) == 1 and rejoined[0] - restart_s < 4 * 7.5 * 3  # a few cycles
    assert not any(k == "cleared" and restart_s <= t < rejoined[0] for t, k in events)
    assert set(reborn.know.cleared) >= cleared_by_fleet
    assert world.backend.ledger.duplicates() == 0
