"""Shortest paths around land, and the checker's independent land test."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hfc_core.model.check import _segment_enters, check_routes
from hfc_core.model.errors import ScenarioError
from hfc_core.model.geometry import LandMap, distance_matrix
from hfc_core.model.problem import Problem, Task, Vehicle
from hfc_core.solve import solve

SQUARE = np.array([[0, 0], [10, 0], [10, 10], [0, 10]], dtype=float)
# A U open to the north: its pocket is water reachable only from above.
U_SHAPE = np.array([[0, 0], [30, 0], [30, 30], [20, 30], [20, 10], [10, 10], [10, 30], [0, 30]],
                   dtype=float)


def ring(poly: np.ndarray) -> list[tuple[float, float]]:
    return [tuple(p) for p in poly.tolist()]


def assert_path_in_water(path, polygons):
    for p, q in zip(path[:-1], path[1:]):
        for poly in polygons:
            assert not _segment_enters(p[:2], q[:2], ring(poly)), f"{p}->{q} crosses land"


def test_path_around_a_square_keeps_the_clearance():
    land = LandMap([SQUARE], clearance_m=0.5)
    length, path = land.shortest_path((-5, 5, 0), (15, 5, 0))
    # Around the south side: (-5,5) -> (-0.5,-0.5) -> (10.5,-0.5) -> (15,5), or the north twin.
    expected = 2 * math.hypot(4.5, 5.5) + 11
    assert length == pytest.approx(expected)
    assert len(path) == 4 and path[0] == (-5, 5, 0) and path[-1] == (15, 5, 0)
    assert_path_in_water(path, [SQUARE])
    assert sum(math.dist(p, q) for p, q in zip(path[:-1], path[1:])) == pytest.approx(length)


def test_depth_changes_linearly_along_the_way():
    land = LandMap([SQUARE])
    length, path = land.shortest_path((-5, 5, 0), (15, 5, -30))
    flat = sum(math.dist(p[:2], q[:2]) for p, q in zip(path[:-1], path[1:]))
    assert length == pytest.approx(math.hypot(flat, 30))
    z = [p[2] for p in path]
    assert z == sorted(z, reverse=True) and z[-1] == -30


def test_visible_pairs_are_straight_and_grazing_the_coast_is_allowed():
    land = LandMap([SQUARE])
    p = np.array([[-1, -1], [-1, 0], [-1, -1], [5, -1]], dtype=float)
    q = np.array([[11, 11], [11, 0], [11, -1], [5, 11]], dtype=float)
    # Diagonal through two corners: blocked. Along an edge: fine. Below: fine. Through: blocked.
    np.testing.assert_array_equal(land.visible(p, q), [False, True, True, False])


def test_the_pocket_of_a_concave_coast():
    land = LandMap([U_SHAPE])
    inside_pocket, outside = (15, 20, 0), (15, -5, 0)
    length, path = land.shortest_path(inside_pocket, outside)
    assert_path_in_water(path, [U_SHAPE])
    assert length > 2 * 10 + 10  # up out of the pocket, round a corner, down below
    assert len(path) >= 4


def test_distance_matrix_is_a_metric_that_only_lengthens_blocked_pairs():
    rng = np.random.default_rng(0)
    land = LandMap([U_SHAPE, SQUARE + [40, 5]])
    pts = rng.uniform(-10, 60, (80, 3))
    pts[:, 2] = rng.uniform(-5, 0, 80)
    pts = pts[~land.inside(pts)]
    dist = land.distance_matrix(pts)
    straight = distance_matrix(pts)
    np.testing.assert_array_equal(dist, dist.T)
    assert np.all(dist >= straight - 1e-9)
    assert (dist > straight + 1e-6).sum() > 0
    # Triangle inequality, up to the clearance: a path may pass a corner closer than the
    # clearance when it stops at a spot there (these corners are right angles).
    slack = 2 * land.clearance_m * math.sqrt(2)
    assert np.all(dist[:, None, :] <= dist[:, :, None] + dist[None, :, :] + slack)
    for i, j in [(0, 1), (2, 7), (5, 30), (11, 40)]:
        length, path = land.shortest_path(pts[i], pts[j])
        assert length == pytest.approx(dist[i, j])
        assert_path_in_water(path, land.polygons)
    from_first = land.distances_from(pts[0], pts)
    np.testing.assert_allclose(from_first, dist[0], atol=1e-9)


def test_points_on_land_are_errors():
    land = LandMap([SQUARE])
    with pytest.raises(ValueError, match="on land"):
        land.shortest_path((5, 5, 0), (20, 20, 0))
    with pytest.raises(ValueError, match="on land"):
        land.distances_from((5, 5, 0), np.array([[20.0, 20.0, 0.0]]))
    assert not land.inside(np.array([[0.0, 5.0]]))[0]  # on the coast is water


@pytest.mark.parametrize("point, expected", [
    ((3.0, 5.0, -4.0), (-0.5, 5.0, -4.0)),    # nearest the west coast: out past it, depth kept
    ((5.0, 9.0, -2.0), (5.0, 10.5, -2.0)),    # nearest the north coast
    ((12.0, 5.0, -1.0), (12.0, 5.0, -1.0)),   # already at sea: unchanged
    ((25.0, 4.0, -3.0), (25.0, -0.5, -3.0)),  # the U's south wall: the nearest coast is below
])
def test_a_point_on_land_goes_to_the_nearest_sea_past_the_clearance(point, expected):
    """A drifted dead reckoning near the shore puts the vehicle's estimate on land; paths
    must start at sea (`LandMap.to_water`): the nearest coast, `clearance_m` out."""
    land = LandMap([SQUARE] if point[0] < 20 else [U_SHAPE], clearance_m=0.5)
    out = land.to_water(point)
    assert out == pytest.approx(expected)
    assert not land.inside(np.array([out]))[0]
    land.shortest_path(out, (40.0, 40.0, 0.0))  # paths start from it without an error


def test_problem_with_land_rejects_a_spot_on_land_and_keeps_its_land_map():
    vehicles = [Vehicle("a", (-5, 5, 0), (15, 5, 0), 100.0, 1.0)]
    with pytest.raises(ScenarioError, match="task 1: pos .* on land"):
        Problem.build("x", vehicles, [Task(1, (5, 5, 0), 1.0, 0.0)], [SQUARE.tolist()])
    problem = Problem.build("x", vehicles, [Task(1, (5, 12, 0), 1.0, 0.0)], [SQUARE.tolist()])
    assert problem.land is not None
    assert problem.dist_m[problem.start_node(0), problem.end_node(0)] == pytest.approx(
        2 * math.hypot(4.5, 5.5) + 11)


def test_segment_enters_cases():
    sq = ring(SQUARE)
    assert _segment_enters((-1, 5), (11, 5), sq)  # straight through
    assert _segment_enters((-1, -1), (11, 11), sq)  # through two corners
    assert _segment_enters((0, 0), (10, 10), sq)  # a diagonal between corners
    assert not _segment_enters((-1, 0), (11, 0), sq)  # along an edge
    assert not _segment_enters((-1, 1), (1, -1), sq)  # touching a corner
    assert not _segment_enters((-5, -5), (-1, 20), sq)


def test_checker_times_legs_by_their_paths_around_land():
    vehicles = [Vehicle("a", (-5, 5, 0), (15, 5, 0), 25.5, 1.0)]
    tasks = [Task(1, (5, -3, 0), 1.0, 0.0)]
    problem = Problem.build("x", vehicles, tasks, [SQUARE.tolist()])
    # Straight lines would take 2 * hypot(10, 8) = 25.6 s, round the corners a bit more:
    # the route through the spot must be rejected with a 25.5 s battery, the empty one kept.
    assert check_routes(problem, {"a": [1]})
    assert check_routes(problem, {"a": []}) == []


def test_best_plans_around_islands_are_feasible():
    rng = np.random.default_rng(2)
    polygons = [U_SHAPE * 10 + [200, 200], SQUARE * 15 + [650, 500]]
    land = LandMap(polygons)
    xyz = rng.uniform(0, 1000, (200, 3))
    xyz[:, 2] = -rng.uniform(0, 20, 200)
    xyz = xyz[~land.inside(xyz)][:60]
    vehicles = [Vehicle(f"v{i}", (50, 50, 0), (950, 950, 0), 2500.0, 1.0) for i in range(3)]
    tasks = [Task(i, tuple(p), float(rng.integers(1, 100)), 30.0) for i, p in enumerate(xyz)]
    problem = Problem.build("islands", vehicles, tasks, [p.tolist() for p in polygons])
    result = solve(problem, "best", max_iterations=60, seed=0)  # checked by the autouse fixture
    assert sum(len(r) for r in result.plan.routes) > 10
