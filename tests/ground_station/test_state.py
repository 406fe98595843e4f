"""The fleet picture: spot states, marks, link lines and fleet figures from real records."""

from __future__ import annotations

import numpy as np
import pytest

from fleet_bus.link import LinkRecord
from fleet_bus.telemetry import Event, Status, Truth
from ground_station import palette
from ground_station.drawing import LinkClear, LinkLine, LogLine, Mark, Pose, Route, Scalar, \
    Spots, Trail
from ground_station.mapview import map_layers
from ground_station.state import FleetPicture, Tuning


def status(t: float, vid: str, route=(), treated=(), claims=(), state="transit",
           pos=(0.0, 0.0, -2.0)) -> Status:
    return Status(t, vid, state, pos, 3600.0 - t, 100.0, list(route), list(treated), 0, 0.0,
                  0.0, claims=list(claims))


def of_type(drawings, kind):
    return [d for d in drawings if isinstance(d, kind)]


@pytest.fixture
def picture(small_doc) -> FleetPicture:
    return FleetPicture(map_layers(small_doc), Tuning(link_ttl_s=20.0, trail_step_m=10.0,
                                                      silent_after_s=100.0))


def test_initially_every_spot_is_pending(picture):
    (spots,) = picture.initial()
    assert spots.states == ("pending",) * 6
    assert (spots.colors == palette.SPOT_PENDING).all()


def test_spot_states_follow_routes_claims_and_clears(picture):
    picture.apply("auv1", status(10, "auv1", route=[10, 11], treated=[]))
    picture.apply("auv2", status(10, "auv2", route=[12, 13], claims=[13]))
    out = picture.apply("auv3", status(10, "auv3", route=[], treated=[15]))
    (spots,) = of_type(out, Spots)
    assert spots.states == ("planned:auv1", "planned:auv1", "planned:auv2", "claimed:auv2",
                            "pending", "cleared")
    assert tuple(spots.colors[0]) == picture.vehicles["auv1"].color
    assert tuple(spots.colors[3]) == palette.SPOT_CLAIMED
    assert tuple(spots.colors[5]) == palette.SPOT_CLEARED


def test_unchanged_spot_states_are_not_logged_again(picture):
    picture.apply("auv1", status(10, "auv1", route=[10]))
    assert of_type(picture.apply("auv1", status(20, "auv1", route=[10])), Spots) == []


def test_abort_abandons_the_route_until_a_peer_takes_it_over(picture):
    picture.apply("auv1", status(10, "auv1", route=[10]))
    picture.apply("auv2", status(10, "auv2", route=[11, 12]))
    out = picture.apply("auv2", Event(50, "auv2", "abort", detail="thruster"))
    assert of_type(out, Spots)[0].states[:3] == ("planned:auv1", "abandoned", "abandoned")
    assert [m.kind for m in of_type(out, Mark)] == ["aborted"]
    assert of_type(out, Route)[0].points.shape == (0, 2)  # its route is wiped from the map
    assert any(line.level == "WARN" and "abort" in line.text for line in of_type(out, LogLine))
    # a late status from before the abort cannot revive it
    picture.apply("auv2", status(49, "auv2", route=[11, 12], state="transit"))
    assert picture.vehicles["auv2"].state == "aborted"
    out = picture.apply("auv1", status(60, "auv1", route=[10, 11, 12], claims=[11, 12]))
    assert of_type(out, Spots)[0].states[:3] == ("planned:auv1", "claimed:auv1",
                                                  "claimed:auv1")


def test_lost_and_revived_marks(picture):
    picture.apply("auv3", Truth(60, (30.0, 40.0, -2.0)))
    out = picture.apply("auv1", Event(100, "auv1", "lost", peer="auv3"))
    (mark,) = of_type(out, Mark)
    assert (mark.vid, mark.kind, mark.xy) == ("auv3", "lost", (30.0, 40.0))
    out = picture.apply("auv1", Event(110, "auv1", "revived", peer="auv3"))
    assert [(m.vid, m.kind) for m in of_type(out, Mark)] == [("auv3", "")]


def test_a_vehicle_that_falls_silent_is_marked_and_its_spots_abandoned(picture):
    picture.apply("auv1", status(0, "auv1", route=[10]))
    picture.apply("auv2", status(0, "auv2", route=[11]))
    picture.apply("auv1", Truth(50, (5.0, 5.0, -2.0)))
    assert of_type(picture.apply("auv1", Truth(100, (6.0, 5.0, -2.0))), Mark) == []
    out = picture.apply("auv1", Truth(101, (7.0, 5.0, -2.0)))  # auv2 last heard at t=0
    assert [(m.vid, m.kind) for m in of_type(out, Mark)] == [("auv2", "silent")]
    assert of_type(out, Spots)[0].states[1] == "abandoned"
    out = picture.apply("auv2", Truth(102, (1.0, 1.0, -2.0)))
    assert [(m.vid, m.kind) for m in of_type(out, Mark)] == [("auv2", "")]


def test_link_lines_join_the_vehicles_and_expire(picture):
    picture.apply("auv1", Truth(0, (0.0, 0.0, -2.0)))
    picture.apply("auv2", Truth(0, (30.0, 40.0, -2.0)))
    out = picture.apply("auv1", LinkRecord("auv1", "auv2", 1.0, 1.5, 24, True, None))
    (line,) = of_type(out, LinkLine)
    assert (line.a, line.b, line.delivered, line.reason) == ((0.0, 0.0), (30.0, 40.0), True, "")
    out = picture.apply("auv2", LinkRecord("auv2", "auv1", 2.0, 2.5, 30, False, "collision"))
    assert of_type(out, LinkLine)[0].reason == "collision"
    scalars = {s.path: s.value for s in of_type(out, Scalar)}
    assert scalars == {"fleet/messages/dropped": 1, "fleet/drops/collision": 1}  # what changed
    assert picture.link_counts == {"delivered": 1, "bytes": 24, "dropped": 1,
                                   "drop:collision": 1}
    assert of_type(picture.apply("auv1", Truth(21.0, (1.0, 0.0, -2.0))), LinkClear) == []
    out = picture.apply("auv1", Truth(30.0, (2.0, 0.0, -2.0)))
    assert [(c.t_s, c.src, c.dst) for c in of_type(out, LinkClear)] == [
        (21.5, "auv1", "auv2"), (22.5, "auv2", "auv1")]


def test_a_drop_with_no_receiver_is_counted_but_not_drawn(picture):
    picture.apply("auv1", Truth(0, (0.0, 0.0, -2.0)))
    out = picture.apply("auv1", LinkRecord("auv1", "*", 1.0, 1.0, 99, False, "oversize"))
    assert of_type(out, LinkLine) == []
    assert picture.link_counts["drop:oversize"] == 1


def test_fleet_figures_count_each_spot_once_and_duplicates_apart(picture):
    picture.apply("auv1", status(10, "auv1", treated=[10, 12]))
    out = picture.apply("auv2", status(11, "auv2", treated=[12, 13]))
    fleet = {s.path: s.value for s in of_type(out, Scalar) if s.path.startswith("fleet/")}
    assert fleet == {"fleet/spots_cleared": 3, "fleet/priority_collected": 10 + 100 + 30,
                     "fleet/duplicates": 1}
    # a vehicle killed before its next status still announced its treatment as an event
    out = picture.apply("auv3", Event(12, "auv3", "cleared", [13]))
    scalars = {s.path: s.value for s in of_type(out, Scalar)}
    assert scalars == {"spots_treated/auv3": 1, "fleet/duplicates": 2}  # only what changed
    assert picture.fleet_figures()["spots_cleared"] == 3


def test_unchanged_counts_are_repeated_only_as_a_heartbeat(picture):
    counts = []
    for t in range(0, 70, 5):
        out = picture.apply("auv1", status(t, "auv1", treated=[10]))
        counts += [s.t_s for s in of_type(out, Scalar) if s.path == "fleet/spots_cleared"]
    assert counts == [0, 30, 60]


def test_trail_is_decimated_and_pose_carries_heading(picture):
    trails = []
    for i in range(30):
        out = picture.apply("auv1", Truth(float(i), (float(i), 0.0, -2.0), 0.0, 0.0, "transit"))
        trails += of_type(out, Trail)
        (pose,) = of_type(out, Pose)
        assert pose.xy == (float(i), 0.0)
    assert [len(t.points) for t in trails] == [2, 3]  # a point every 10 m
    np.testing.assert_allclose(trails[-1].points, [[0, 0], [10, 0], [20, 0]])


def test_route_runs_from_the_vehicle_through_its_spots_to_the_rendezvous(picture):
    picture.apply("auv1", Truth(0, (5.0, 5.0, -2.0)))
    out = picture.apply("auv1", status(1, "auv1", route=[11, 99, 15]))  # 99: not a spot
    (route,) = of_type(out, Route)
    np.testing.assert_allclose(route.points, [[5, 5], [40, 20], [80, 60], [100, 100]])
    out = picture.apply("auv1", status(2, "auv1", route=[], state="home"))
    assert of_type(out, Route)[0].points.shape == (0, 2)


def test_late_join_rebuilds_the_picture_from_statuses_alone(small_doc):
    late = FleetPicture(map_layers(small_doc))
    late.apply("auv1", status(900, "auv1", route=[11], treated=[10]))
    out = late.apply("auv2", status(901, "auv2", route=[], treated=[12], state="home"))
    assert of_type(out, Spots)[0].states[:3] == ("cleared", "planned:auv1", "cleared")
    assert late.vehicles["auv1"].xy == (0.0, 0.0)  # from the status until a truth arrives


def test_out_of_order_samples_never_stamp_a_newer_picture_earlier(picture):
    """Zenoh may deliver different vehicles' samples out of order: the row with the latest
    time must hold the latest picture, whatever the arrival order."""
    rows = []
    rows += of_type(picture.apply("auv2", status(30, "auv2", route=[12])), Spots)
    rows += of_type(picture.apply("auv1", status(10, "auv1", route=[10])), Spots)  # late
    assert [r.t_s for r in rows] == [30, 30]  # on a tie Rerun shows the row logged last
    assert rows[-1].states[:3] == ("planned:auv1", "pending", "planned:auv2")
    # a stale status of the same vehicle cannot roll its route back
    picture.apply("auv1", status(40, "auv1", route=[11]))
    out = picture.apply("auv1", status(35, "auv1", route=[10]))
    assert of_type(out, Spots) == [] and of_type(out, Route) == []
    assert picture.vehicles["auv1"].status.route == [11]
    assert {s.path for s in of_type(out, Scalar)} >= {"battery_s/auv1", "t_diff_s/auv1"}


def test_a_stale_pose_is_not_drawn_over_a_newer_one(picture):
    picture.apply("auv1", Truth(10, (5.0, 0.0, -2.0)))
    assert of_type(picture.apply("auv1", Truth(9, (4.0, 0.0, -2.0))), Pose) == []
    assert picture.vehicles["auv1"].xy == (5.0, 0.0)
