"""The operator's add-spot at the agents, in-process with an injected clock: every vehicle names
the spot alike (the operator's slot its number names), the slots are bounded (``no_room``), a
forgery is refused, a restarted agent rebuilds the spot from its journal; and a paused vehicle
goes home before holding station costs it the way home."""

from __future__ import annotations

import pytest

from cotsfleet.mission.topside import Topside, forged_order, topside_of
from fleet_agent.agent import Agent, Frame, Tick
from fleet_agent.config import AgentConfig
from fleet_agent.fleet import Fleet
from fleet_agent.io_types import Publish, Record
from fleet_bus.orders import REFUSALS, AckFrame, Order, parse_words
from fleet_bus.telemetry import Event
from hfc_core.formats.scenario import problem_from_dict
from reef_sim.scenarios.field import paper_preset_doc

CONFIG = AgentConfig(plan_iterations=60, replan_iterations=30, operator_slots=2)


@pytest.fixture(scope="module")
def fleet() -> Fleet:
    p = problem_from_dict(paper_preset_doc(5))
    return Fleet.build(p, b"k" * 16, 0, CONFIG, run_id="t-add-spot")


def _run(top: Topside, agents: list[Agent], start: float, until: float) -> list:
    """Every topside frame to every agent from ``start`` (each heard a second later), and each
    agent's ACK back to the topside; the agents' outputs."""
    out: list = []
    t: float | None = start
    while t is not None and t < until:
        for a in agents:
            for f in top.frames(t) if a is agents[0] else []:
                for b in agents:
                    out += b.step(Frame(f, t + 1.0))
        for a in agents:
            frame = a.orders.take_frame(t + 2.0, 0.0)
            while frame is not None:
                top.hear(frame, t + 3.0)
                frame = a.orders.take_frame(t + 2.0, 0.0)
        t = top.next_s(t)
    return out


def _events(outputs: list, kind: str) -> list[Event]:
    return [o.payload for o in outputs if isinstance(o, Publish) and o.topic == "event"
            and isinstance(o.payload, Event) and o.payload.kind == kind]


def _mid(fleet: Fleet) -> tuple[float, float]:
    xyz = fleet.given.xyz[:fleet.given.n_tasks]
    return float(xyz[:, 0].mean()), float(xyz[:, 1].mean())


def _fleet_at(fleet: Fleet, t: float) -> tuple[list[Agent], Topside, tuple[float, float]]:
    """Three agents stepped to ``t``, the topside, and the middle of the map."""
    agents = [Agent(fleet, i, CONFIG, 0.0) for i in range(3)]
    for a in agents:
        a.step(Tick(t))
    return agents, topside_of(fleet.given, fleet, CONFIG), _mid(fleet)


def test_every_vehicle_names_the_added_spot_alike_and_plans_it(fleet) -> None:
    agents, top, (x, y) = _fleet_at(fleet, 400.0)
    top.submit(parse_words(["add-spot", f"{x:.1f}", f"{y:.1f}", "80"]), 400.0)
    out = _run(top, agents, 400.0, 600.0)
    n, slots = fleet.given.n_tasks, {a.know.beliefs.op_from for a in agents}
    assert len(slots) == 1 and fleet.problem.n_tasks == slots.pop() + 2  # two operator slots
    slot = agents[0].know.beliefs.op_from
    for a in agents:
        spot = a.know.beliefs.added[slot]
        assert spot.pos[:2] == (round(x, 1), round(y, 1)) and spot.priority == 80.0
        assert slot not in a.know.blocked(600.0)  # the planner may take it
        assert a.problem.priority[slot] == 80.0 and a.counters["ctl_taken"] == 1
    added = _events(out, "added")
    assert sorted(e.id for e in added) == ["auv1", "auv2", "auv3"]
    first_id = max(t.id for t in fleet.given.tasks) + 1 + 3 * CONFIG.find_slots
    assert {tuple(e.tasks) for e in added} == {(first_id,)}  # after the finds' ids
    assert n <= slot and set(top.orders[1].acked) == {"auv1", "auv2", "auv3"}
    # Journalled for a restart, with the order's number.
    docs = [o.doc for o in out if isinstance(o, Record)]
    assert sum(d["k"] == "add" and d["s"] == slot for d in docs) == 3
    assert sum(d["k"] == "ord" and d["verb"] == "add-spot" for d in docs) == 3


def test_add_spots_beyond_the_operator_slots_are_refused_as_no_room(fleet) -> None:
    agents, top, (x, y) = _fleet_at(fleet, 300.0)
    for k in range(3):  # two slots: the third is refused by every vehicle
        top.submit(parse_words(["add-spot", f"{x + 20 * k:.0f}", f"{y:.0f}", "50"]), 300.0)
    _run(top, agents, 300.0, 500.0)
    for a in agents:
        assert len(a.know.beliefs.added) == 2 and a.counters["ctl_no_room"] >= 1  # per hearing
    assert set(top.orders[3].refused.values()) == {"no_room"} and not top.orders[3].acked
    assert all(set(top.orders[s].acked) == {"auv1", "auv2", "auv3"} for s in (1, 2))


def test_an_unsigned_add_spot_is_refused_and_counted(fleet) -> None:
    agent = Agent(fleet, 0, CONFIG, 0.0)
    agent.step(Tick(300.0))
    x, y = _mid(fleet)
    agent.step(Frame(forged_order(fleet, Order("add-spot", x=x, y=y, priority=90.0), 300.0),
                     301.0))
    top = topside_of(fleet.given, fleet, CONFIG)
    top.submit(parse_words(["pause", "auv3"]), 310.0)  # the genuine topside's keys
    _run(top, [agent], 310.0, 500.0)
    assert agent.counters["ctl_unsigned"] == 1 and agent.know.beliefs.added == {}


def test_a_restarted_agent_rebuilds_the_added_spot_from_its_journal(fleet) -> None:
    agent = Agent(fleet, 1, CONFIG, 0.0)
    journal = [o.doc for o in agent.step(Tick(400.0)) if isinstance(o, Record)]
    top = topside_of(fleet.given, fleet, CONFIG)
    x, y = _mid(fleet)
    top.submit(parse_words(["add-spot", f"{x:.0f}", f"{y:.0f}", "70"]), 400.0)
    first = top.frames(400.0)
    journal += [o.doc for o in _run(top, [agent], 400.0, 600.0) if isinstance(o, Record)]
    slot = agent.know.beliefs.op_from
    again = Agent(fleet, 1, CONFIG, 650.0, journal)
    assert again.know.beliefs.added == {slot: agent.know.beliefs.added[slot]}
    assert again.problem.priority[slot] == 70.0 and slot not in again.know.blocked(650.0)
    assert 1 in again.orders.taken
    # The topside's retransmission heard again after the restart: acknowledged, not re-added.
    again.step(Frame(first[0], 401.0))
    assert "ctl_taken" not in again.counters and len(again.know.beliefs.added) == 1


def test_the_ack_of_a_refusal_names_no_room() -> None:
    assert REFUSALS.index("no_room") == 5 and REFUSALS.index("on_land") == 6  # ACK results
    assert AckFrame(0, 0, 1, 1 + REFUSALS.index("no_room")).result == 6


def test_a_paused_vehicle_goes_home_before_its_battery_cannot_bring_it(fleet) -> None:
    # Injected clock: the agent is stepped at mission times of our choosing, never its own.
    agent = Agent(fleet, 0, CONFIG, 0.0)
    agent.step(Tick(10.0))
    agent.nav.paused = agent.orders.paused = True  # as the operator's pause leaves it
    own = agent.own
    home_s = own.leg_time_s(own.pos, own.rendezvous)
    last_s = own.capacity_s - CONFIG.battery_reserve_s - home_s - CONFIG.pause_margin_s
    out = agent.step(Tick(last_s - 30.0))
    assert agent.active and "pause_battery_home" not in agent.counters
    assert not _events(out, "abort")
    out = agent.step(Tick(last_s + 1.0))
    assert own.aborted and agent.counters["pause_battery_home"] == 1
    (abort,) = _events(out, "abort")
    assert "heading home" in abort.detail and not agent.nav.paused
    docs = [o.doc for o in out if isinstance(o, Record)]
    assert any(d["k"] == "abort" for d in docs)  # journalled: a restart stays aborted
