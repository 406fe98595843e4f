"""The world's tally of what the vehicles really treated (`reef_sim.score`)."""

from __future__ import annotations

from reef_sim.score import world_tally
from reef_sim.truth import Reef, TruthSpot
from reef_sim.vehicle import Treatment

REEF = Reef(25.0, 0.9, 20.0, (TruthSpot((0.0, 0.0, -5.0), 40.0, 60.0, 0),
                              TruthSpot((50.0, 0.0, -5.0), 30.0, 60.0, None),
                              TruthSpot((90.0, 0.0, -5.0), 20.0, 60.0, 1)))


def test_each_spot_counts_once_and_the_first_vehicle_has_it():
    books = {"auv2": [Treatment(100.0, 7, (49.0, 1.0, -5.0), 1),
                      Treatment(300.0, 0, (1.0, 0.0, -5.0), 0)],
             "auv1": [Treatment(200.0, 0, (0.0, 0.0, -5.0), 0),
                      Treatment(250.0, 9, (200.0, 0.0, -5.0), None)]}
    got = world_tally(REEF, books)
    assert got["priority"] == 70.0 and got["spots_treated"] == 2
    assert got["duplicates"] == 1  # auv2 treated spot 0 after auv1 had
    assert got["missed"] == 1 and got["injections"] == 4
    assert got["unmapped_treated"] == 1
    assert got["by_vehicle"] == {"auv1": [0], "auv2": [1]}


def test_nothing_treated_is_nothing():
    got = world_tally(REEF, {"auv1": []})
    assert got["priority"] == 0 and got["duplicates"] == got["missed"] == 0
