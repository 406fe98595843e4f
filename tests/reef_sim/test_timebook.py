"""The world's book of where a simulated vehicle's battery went (`reef_sim.timebook`)."""

from __future__ import annotations

import math

import pytest

from fleet_bus.vehicle_port import HOME_TARGET, GoTo, ReturnHome, StationKeep, Work
from hfc_core.model.problem import Problem, Task, Vehicle as Spec
from reef_sim.camera import ReefCamera
from reef_sim.timebook import ACTIVITIES, TimeBook
from reef_sim.truth import Reef, TruthSpot
from reef_sim.vehicle import SimVehicle


def test_the_book_keeps_running_totals_and_the_open_interval() -> None:
    book = TimeBook(10.0)
    book.enter(15.0, "transit")
    book.enter(40.0, "holding", ended_as="look_cots")  # what the interval was, known at its end
    book.enter(35.0, "injecting")  # a time that ran back books nothing
    assert book.seconds["holding"] == 5.0 and book.seconds["look_cots"] == 25.0
    assert book.seconds["transit"] == 0.0
    totals = book.totals(100.0)
    assert totals["injecting"] == 60.0 and sum(totals.values()) == 90.0
    assert book.totals(30.0)["injecting"] == 0.0  # never a negative interval
    with pytest.raises(ValueError, match="unknown activity 'napping'"):
        book.enter(50.0, "napping")
    assert set(ACTIVITIES) == set(totals)


def test_a_vehicle_books_every_second_of_its_mission_by_what_it_did() -> None:
    # two predicted spots on a line: the first holds COTS, the second is bare seabed
    tasks = [Task(1, (100.0, 0.0, 0.0), 50.0, 60.0), Task(2, (200.0, 0.0, 0.0), 40.0, 60.0)]
    problem = Problem.build("line", [Spec("auv1", (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 3600.0,
                                          1.0)], tasks)
    reef = Reef(5.0, 1.0, 20.0, (TruthSpot((100.0, 0.0, 0.0), 50.0, 60.0, 0),))
    v = SimVehicle(problem, 0, camera=ReefCamera(reef, seed=0, vehicle=0))
    v.command(GoTo(0, ((100.0, 0.0, 0.0),)), 0.0)
    v.poll(100.0)
    v.command(StationKeep(Work.WAIT, 0, 0.0), 100.0)  # a claim settling
    v.command(StationKeep(Work.LOOK, 0, 20.0), 105.0)
    v.poll(125.0)
    v.command(StationKeep(Work.INJECT, 0, 60.0), 125.0)
    v.poll(185.0)
    v.command(GoTo(1, ((200.0, 0.0, 0.0),)), 185.0)
    v.poll(285.0)
    v.command(StationKeep(Work.LOOK, 1, 20.0), 285.0)
    v.poll(305.0)
    v.command(ReturnHome(((0.0, 0.0, 0.0),)), 305.0)
    v.poll(600.0)
    assert v.target == HOME_TARGET
    book = v.time.totals(3600.0)
    assert book == pytest.approx({"transit": 200.0, "holding": 5.0, "look_cots": 20.0,
                                  "injecting": 60.0, "look_empty": 20.0, "homing": 200.0,
                                  "recovered": 3095.0})
    assert math.isclose(sum(book.values()), 3600.0)
