"""The fleet picture: spot states, marks, links, labels, trails, routes, the current and the
series, from real records, without Zenoh or Rerun."""

from __future__ import annotations

import numpy as np
import pytest

from fleet_bus.link import LinkRecord
from fleet_bus.telemetry import Event, Status, Truth
from ground_station import palette
from ground_station.drawing import Current, Links, LogLine, Mark, Routes, SeriesRow, Spots, \
    Stations, Trails, Vehicles
from ground_station.mapview import map_layers
from ground_station.state import FleetPicture, Tuning
from hfc_core.model.current import TIDE_STEP_S


def status(t: float, vid: str, route=(), treated=(), claims=(), state="transit",
           pos=(0.0, 0.0, -2.0), battery_s=None, t_diff_s=100.0) -> Status:
    battery = 3600.0 - t if battery_s is None else battery_s
    return Status(t, vid, state, pos, battery, t_diff_s, list(route), list(treated), 0, 0.0,
                  0.0, claims=list(claims))


def of_type(drawings, kind):
    return [d for d in drawings if isinstance(d, kind)]


def scalars(drawings) -> dict[str, float]:
    """The series samples drawn (the lines that asked for a row), by path."""
    return {p: row.value(p) for row in of_type(drawings, SeriesRow) for p in row.drawn}


def drawn_of(drawings, path: str) -> list[tuple[float, float]]:
    return [(row.t_s, row.value(path)) for row in of_type(drawings, SeriesRow)
            if path in row.drawn]


@pytest.fixture
def picture(small_doc) -> FleetPicture:
    return FleetPicture(map_layers(small_doc), Tuning(link_ttl_s=20.0, trail_step_m=10.0,
                                                      silent_after_s=100.0))


def test_initially_every_spot_is_pending_and_the_stations_are_named(picture):
    out = picture.initial()
    (spots,) = of_type(out, Spots)
    assert spots.states == ("pending",) * 6
    assert (spots.colors == palette.SPOT_PENDING).all()
    assert of_type(out, Stations)[0].labels == ("start", "rendezvous")
    assert of_type(out, Current) == []  # still water


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
    assert of_type(out, Routes)[0].vids == ("auv1",)  # its route is wiped from the map
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
    assert of_type(out, Routes)[0].vids == ("auv1",)
    out = picture.apply("auv2", Truth(102, (1.0, 1.0, -2.0)))
    assert [(m.vid, m.kind) for m in of_type(out, Mark)] == [("auv2", "")]
    assert of_type(out, Routes)[0].vids == ("auv1", "auv2")  # heard again: its route is back


def test_an_abort_announced_late_outranks_the_stations_silence_verdict(picture):
    picture.apply("auv2", Truth(0, (5.0, 5.0, -2.0)))
    out = picture.apply("auv1", Truth(130, (6.0, 5.0, -2.0)))  # auv2 quiet for 130 s
    assert [(m.vid, m.kind) for m in of_type(out, Mark)] == [("auv2", "silent")]
    out = picture.apply("auv2", Event(10, "auv2", "abort"))  # delayed on a busy machine
    assert [(m.vid, m.kind, m.t_s) for m in of_type(out, Mark)] == [("auv2", "aborted", 130)]


def test_samples_arriving_later_than_the_silence_verdict_do_not_lift_it(picture):
    """A starved agent's samples may arrive minutes of simulation late: the vehicle is not
    'heard again' (only to fall silent at the next check) by a sample already stale."""
    picture.apply("auv2", Truth(0, (5.0, 5.0, -2.0)))
    picture.apply("auv1", Truth(130, (6.0, 5.0, -2.0)))
    out = picture.apply("auv2", Truth(5, (5.0, 6.0, -2.0)))  # 125 s old when it arrives
    assert of_type(out, Mark) == [] and of_type(out, LogLine) == []
    assert picture.vehicles["auv2"].silent
    out = picture.apply("auv2", Truth(120, (5.0, 7.0, -2.0)))  # recent: heard again
    assert [(m.vid, m.kind) for m in of_type(out, Mark)] == [("auv2", "")]


def located(picture, positions: dict[str, tuple[float, float]], t=1.0):
    out = []
    for vid, xy in positions.items():
        out += picture.apply(vid, Truth(t, (*xy, -2.0), 0.0, 0.0, "transit"))
    return out


def test_vehicles_are_one_layer_with_a_heading_and_a_label_each(picture):
    out = located(picture, {"auv1": (20.0, 80.0), "auv2": (80.0, 20.0)})
    vehicles = of_type(out, Vehicles)[-1]
    assert vehicles.vids == ("auv1", "auv2")
    np.testing.assert_allclose(vehicles.xy, [[20, 80], [80, 20]])
    assert vehicles.labels == ("auv1 transit", "auv2 transit")
    assert [tuple(c) for c in vehicles.colors] == [palette.vehicle_color(0),
                                                   palette.vehicle_color(1)]


def test_vehicles_at_a_station_are_named_by_its_label_not_piled_on_it(picture):
    out = located(picture, {"auv1": (0.0, 0.0), "auv2": (1.0, 0.5), "auv3": (50.0, 20.0)})
    vehicles = of_type(out, Vehicles)[-1]
    assert vehicles.labels == ("", "", "auv3 transit")  # no label at the shared start point
    assert of_type(out, Stations)[-1].labels == ("start: auv1 auv2 transit", "rendezvous")
    out = picture.apply("auv1", Truth(5.0, (40.0, 40.0, -2.0), 0.0, 0.0, "transit"))
    assert of_type(out, Stations)[-1].labels == ("start: auv2 transit", "rendezvous")
    assert of_type(picture.apply("auv2", Truth(6.0, (1.0, 0.6, -2.0))), Stations) == []


def test_vehicles_whose_labels_would_overlap_share_one(picture):
    out = located(picture, {"auv1": (50.0, 50.0), "auv2": (55.0, 51.0), "auv3": (50.0, 90.0)})
    assert of_type(out, Vehicles)[-1].labels == ("auv1 auv2 transit", "", "auv3 transit")
    out = picture.apply("auv2", Truth(2.0, (56.0, 51.0, -2.0), 0.0, 0.0, "injecting"))
    assert of_type(out, Vehicles)[-1].labels == ("auv1 transit, auv2 injecting", "",
                                                 "auv3 transit")


def test_a_marked_vehicle_is_named_by_its_mark_not_a_second_label(picture):
    located(picture, {"auv1": (50.0, 50.0), "auv2": (20.0, 80.0)})
    out = picture.apply("auv2", Event(2.0, "auv2", "abort"))
    assert of_type(out, Mark)[0].kind == "aborted"
    assert of_type(out, Vehicles)[-1].labels == ("auv1 transit", "")


def test_links_are_one_snapshot_of_the_latest_frame_per_link(picture):
    picture.apply("auv1", Truth(0, (0.0, 0.0, -2.0)))
    picture.apply("auv2", Truth(0, (30.0, 40.0, -2.0)))
    out = picture.apply("auv1", LinkRecord("auv1", "auv2", 1.0, 1.5, 24, True, None, 31.0))
    (links,) = of_type(out, Links)
    (line,) = links.lines
    assert (line.a, line.b, line.delivered, line.snr_db, line.label()) == \
        ((0.0, 0.0), (30.0, 40.0), True, 31.0, "")
    # within the window the next frames wait; the next snapshot has the latest of each link
    out = picture.apply("auv2", LinkRecord("auv2", "auv1", 2.0, 2.5, 30, False, "sinr", 4.4))
    assert of_type(out, Links) == []
    # a new drop reason appears at once; the dropped count moved 1 s ago: it waits its turn
    assert scalars(out) == {"fleet/drops/sinr": 1}
    picture.apply("auv1", LinkRecord("auv1", "auv2", 3.0, 3.5, 24, False, "collision", 30.0))
    (links,) = of_type(picture.apply("auv1", Truth(6.5, (1.0, 0.0, -2.0))), Links)
    assert [(x.src, x.reason, x.label()) for x in links.lines] == [
        ("auv1", "collision", "collision SNR 30 dB"), ("auv2", "sinr", "sinr SNR 4 dB")]
    assert links.t_s == 6.5
    assert picture.link_counts == {"delivered": 1, "bytes": 24, "dropped": 2,
                                   "drop:collision": 1, "drop:sinr": 1}
    # each line goes when its time to live is over, the last one with a clearing snapshot
    (links,) = of_type(picture.apply("auv1", Truth(23.0, (2.0, 0.0, -2.0))), Links)
    assert [x.src for x in links.lines] == ["auv1"]
    (links,) = of_type(picture.apply("auv1", Truth(30.0, (3.0, 0.0, -2.0))), Links)
    assert links.lines == ()
    assert of_type(picture.apply("auv1", Truth(40.0, (4.0, 0.0, -2.0))), Links) == []


def test_a_drop_with_no_receiver_is_counted_but_not_drawn(picture):
    picture.apply("auv1", Truth(0, (0.0, 0.0, -2.0)))
    out = picture.apply("auv1", LinkRecord("auv1", "*", 1.0, 1.0, 99, False, "oversize"))
    assert of_type(out, Links) == []
    assert picture.link_counts["drop:oversize"] == 1


def test_link_colour_tells_the_snr_and_drops_are_red():
    assert palette.link_color(True, None) == palette.LINK_DELIVERED
    assert palette.link_color(True, 80.0) == palette.LINK_DELIVERED
    assert palette.link_color(True, -3.0) == palette.LINK_WEAK
    middle = palette.link_color(True, (palette.LINK_SNR_WEAK_DB + palette.LINK_SNR_STRONG_DB) / 2)
    assert middle not in (palette.LINK_WEAK, palette.LINK_DELIVERED)
    assert palette.link_color(False, 80.0) == palette.LINK_DROPPED
    assert "drops/sinr" in palette.FLEET_SERIES and "drops/collision" in palette.FLEET_SERIES


def test_fleet_figures_count_each_spot_once_and_duplicates_apart(picture):
    picture.apply("auv1", status(10, "auv1", treated=[10, 12]))
    out = picture.apply("auv2", status(11, "auv2", treated=[12, 13]))
    fleet = {p: v for p, v in scalars(out).items() if p.startswith("fleet/")}
    assert fleet == {"fleet/spots_cleared": 3, "fleet/priority_collected": 10 + 100 + 30,
                     "fleet/duplicates": 1}
    # a vehicle killed before its next status still announced its treatment as an event
    out = picture.apply("auv3", Event(12, "auv3", "cleared", [13]))
    assert scalars(out) == {"spots_treated/auv3": 1, "fleet/duplicates": 2}  # what changed
    assert picture.fleet_figures()["spots_cleared"] == 3


def test_unchanged_counts_are_repeated_only_as_a_heartbeat(picture):
    counts = []
    for t in range(0, 130, 5):
        out = picture.apply("auv1", status(t, "auv1", treated=[10]))
        counts += [t for t, _ in drawn_of(out, "fleet/spots_cleared")]
    assert counts == [0, 60, 120]


def test_the_battery_is_thinned_and_ends_on_its_last_value(picture):
    drawn = []
    for t in range(0, 200, 5):
        drawn += drawn_of(picture.apply("auv1", status(t, "auv1")), "battery_s/auv1")
    assert [t for t, _ in drawn] == [0, 60, 120, 180]
    assert drawn_of(picture.flush(), "battery_s/auv1") == [(195, 3600.0 - 195)]


def test_a_jump_in_t_diff_is_drawn_at_once_with_its_corner(picture):
    drawn = []
    for t, t_diff in [(0, 100.0), (5, 100.0), (10, 101.0), (15, -40.0)]:
        drawn += drawn_of(picture.apply("auv1", status(t, "auv1", t_diff_s=t_diff)),
                          "t_diff_s/auv1")
    assert drawn == [(0, 100.0), (10, 101.0), (15, -40.0)]


def test_a_plot_is_one_row_of_every_vehicle_never_going_back_in_time(picture):
    out = picture.apply("auv2", status(30, "auv2", battery_s=3000.0))
    (row,) = [r for r in of_type(out, SeriesRow) if r.entity == "battery_s"]
    assert row.names == ("auv1", "auv2", "auv3") and row.t_s == 30
    assert np.isnan(row.values[0]) and row.values[1] == 3000.0  # auv1: nothing yet
    out = picture.apply("auv1", status(20, "auv1", battery_s=3100.0))  # arrives late
    (row,) = [r for r in of_type(out, SeriesRow) if r.entity == "battery_s"]
    assert row.t_s == 30 and row.values[:2] == (3100.0, 3000.0)


def test_link_counters_are_drawn_at_most_every_few_seconds_and_flushed(picture):
    picture.apply("auv1", Truth(0, (0.0, 0.0, -2.0)))
    drawn = []
    for i in range(40):
        t = 0.5 * i
        out = picture.apply("auv1", LinkRecord("auv1", "auv2", t, t, 10, True, None))
        drawn += drawn_of(out, "fleet/messages/delivered")
    assert [v for _, v in drawn] == [1, 31]  # at t = 0 and t = 15, of 40 frames
    assert drawn_of(picture.flush(), "fleet/messages/delivered")[-1][1] == 40
    assert picture.link_counts["delivered"] == 40


def test_trail_is_decimated_and_only_its_recent_stretch_is_redrawn(small_doc):
    picture = FleetPicture(map_layers(small_doc), Tuning(trail_step_m=10.0, trail_stretch=4))
    recent, earlier = [], []
    for i in range(61):
        out = picture.apply("auv1", Truth(float(i), (float(i), 0.0, -2.0), 0.0, 0.0, "transit"))
        recent += [t for t in of_type(out, Trails) if t.part == "recent"]
        earlier += [t for t in of_type(out, Trails) if t.part == "earlier"]
    # a point every 10 m; stretches of 4 points, each starting where the last one ended:
    # the recent one grows to 3 points, then moves to the earlier layer in one piece
    assert [[len(s) for s in t.strips] for t in recent] == [[2], [3], [], [2], [3], []]
    np.testing.assert_allclose(recent[-2].strips[0], [[30, 0], [40, 0], [50, 0]])
    assert [t.t_s for t in earlier] == [30, 60]
    np.testing.assert_allclose(earlier[-1].strips[0], [[0, 0], [10, 0], [20, 0], [30, 0]])
    np.testing.assert_allclose(earlier[-1].strips[1], [[30, 0], [40, 0], [50, 0], [60, 0]])


def test_route_runs_from_the_vehicle_through_its_spots_and_is_redrawn_when_it_changes(picture):
    picture.apply("auv1", Truth(0, (5.0, 5.0, -2.0)))
    out = picture.apply("auv1", status(1, "auv1", route=[11, 99, 15]))  # 99: not a spot
    (routes,) = of_type(out, Routes)
    np.testing.assert_allclose(routes.strips[0], [[5, 5], [40, 20], [80, 60], [100, 100]])
    picture.apply("auv1", Truth(2, (6.0, 5.0, -2.0)))
    assert of_type(picture.apply("auv1", status(3, "auv1", route=[11, 99, 15])), Routes) == []
    out = picture.apply("auv1", status(4, "auv1", route=[15]))
    np.testing.assert_allclose(of_type(out, Routes)[0].strips[0], [[6, 5], [80, 60], [100, 100]])
    out = picture.apply("auv1", status(5, "auv1", route=[], state="home"))
    assert of_type(out, Routes)[0].strips == ()


def test_late_join_rebuilds_the_picture_from_statuses_alone(small_doc):
    late = FleetPicture(map_layers(small_doc))
    late.apply("auv1", status(900, "auv1", route=[11], treated=[10], pos=(30.0, 30.0, -2.0)))
    out = late.apply("auv2", status(901, "auv2", route=[], treated=[12], state="home"))
    assert of_type(out, Spots)[0].states[:3] == ("cleared", "planned:auv1", "cleared")
    assert late.vehicles["auv1"].xy == (30.0, 30.0)  # from the status until a truth arrives
    assert of_type(out, Vehicles)[0].vids == ("auv1", "auv2")


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
    assert of_type(out, Spots) == [] and of_type(out, Routes) == []
    assert picture.vehicles["auv1"].status.route == [11]


def test_a_stale_pose_is_not_drawn_over_a_newer_one(picture):
    picture.apply("auv1", Truth(10, (5.0, 0.0, -2.0)))
    assert of_type(picture.apply("auv1", Truth(9, (4.0, 0.0, -2.0))), Vehicles) == []
    assert picture.vehicles["auv1"].xy == (5.0, 0.0)


def test_a_steady_current_is_drawn_once(small_doc):
    small_doc["current"] = {"kind": "uniform", "velocity_mps": [0.2, 0.0]}
    picture = FleetPicture(map_layers(small_doc))
    (current,) = of_type(picture.initial(), Current)
    assert current.steady and current.t_s == 0.0
    np.testing.assert_allclose(current.uv_mps, [[0.2, 0.0]] * len(current.xy))
    assert of_type(picture.apply("auv1", Truth(5000.0, (1.0, 1.0, -2.0))), Current) == []


def test_a_tidal_current_follows_the_picture_clock_not_every_sample(small_doc):
    small_doc["current"] = {"kind": "tidal", "velocity_mps": [0.3, 0.0], "period_s": 3600.0}
    picture = FleetPicture(map_layers(small_doc))
    (first,) = of_type(picture.initial(), Current)
    assert not first.steady and first.uv_mps[0, 0] == pytest.approx(0.3, abs=1e-3)
    drawn = []
    for t in np.arange(0.0, 1800.0, 2.0):
        drawn += of_type(picture.apply("auv1", Truth(float(t), (1.0, 1.0, -2.0))), Current)
    # the tide turns from flood to ebb: redrawn at most once per tide step, only when it moved
    assert 5 < len(drawn) <= 1800 / TIDE_STEP_S
    assert all(d.t_s % TIDE_STEP_S < 2.0 for d in drawn)
    assert drawn[-1].uv_mps[0, 0] == pytest.approx(-0.3, abs=0.01)
    layer = picture.layers.current
    np.testing.assert_allclose(drawn[-1].uv_mps, layer.field.velocity(drawn[-1].xy,
                                                                      drawn[-1].t_s))


def test_a_drop_label_gives_the_sinr_too_once_the_bus_carries_it():
    from ground_station.drawing import LinkLine

    line = LinkLine(1.0, "a", "b", (0, 0), (1, 1), False, "collision", 20, 24.6, 2.2)
    assert line.label() == "collision SNR 25 dB SINR 2 dB"
    assert LinkLine(1.0, "a", "b", (0, 0), (1, 1), False, "range", 20).label() == "range"
