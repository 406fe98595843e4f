import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal
from scipy.spatial.distance import cdist

from hfc_core.engines.operators.clustering import (
    assign_max,
    assign_roulette,
    cluster_labels,
    clusters_of_vehicles,
    fuzzy_cmeans,
    initial_routes,
    kmeans,
)
from hfc_core.model.cost import RouteModel
from hfc_core.model.problem import Problem, Task, Vehicle


@pytest.fixture
def blobs() -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(7)
    centres = np.array([[0.0, 0.0, 0.0], [500.0, 0.0, 0.0], [0.0, 500.0, 0.0]])
    truth = np.repeat(np.arange(3), [20, 8, 14])
    return centres[truth] + rng.normal(0.0, 20.0, size=(len(truth), 3)), truth


def same_partition(a: np.ndarray, b: np.ndarray) -> bool:
    return len(set(zip(a.tolist(), b.tolist()))) == len(set(a.tolist())) == len(set(b.tolist()))


def test_kmeans_recovers_separated_blobs(blobs):
    points, truth = blobs
    labels, centres = kmeans(points, 3, np.random.default_rng(0))
    assert same_partition(labels, truth)
    for c in range(3):
        assert_allclose(centres[c], points[labels == c].mean(axis=0))


def test_fcm_memberships_satisfy_eq11(blobs):
    points, truth = blobs
    w, centres = fuzzy_cmeans(points, 3, np.random.default_rng(0), m=2.0)
    assert_allclose(w.sum(axis=1), 1.0)
    d = cdist(points, centres)
    expected = 1.0 / ((d[:, :, None] / d[:, None, :]) ** 2).sum(axis=2)
    assert_allclose(w, expected, atol=1e-5)
    assert same_partition(assign_max(w), truth)


def test_roulette_draws_clusters_with_membership_probability():
    w = np.tile([0.2, 0.5, 0.3], (20000, 1))
    labels = assign_roulette(w, np.random.default_rng(1))
    assert_allclose(np.bincount(labels, minlength=3) / len(labels), [0.2, 0.5, 0.3], atol=0.01)


def test_every_method_labels_every_spot(blobs):
    points, _ = blobs
    for method in ("kmeans", "fcm-max", "fcm-roulette"):
        labels = cluster_labels(points, 3, np.random.default_rng(2), method=method)
        assert labels.shape == (len(points),) and set(labels.tolist()) <= {0, 1, 2}
    with pytest.raises(ValueError):
        cluster_labels(points, 3, np.random.default_rng(2), method="spectral")


@pytest.fixture
def two_sided() -> Problem:
    """Vehicle "west" starts and ends at x = 0, "east" at x = 1000: each should get its side."""
    vehicles = [Vehicle("east", (1000, 0, 0), (1000, 10, 0), 1e4, 1.0),
                Vehicle("west", (0, 0, 0), (0, 10, 0), 1e4, 1.0)]
    tasks = [Task(i, (x, 5.0 * i, 0.0), 1.0, 0.0)
             for i, x in enumerate([10, 20, 30, 980, 990, 15, 985])]
    return Problem.build("sides", vehicles, tasks)


def test_clusters_go_to_the_nearest_vehicle_and_partition_the_spots(two_sided):
    model = RouteModel(two_sided)
    clusters = clusters_of_vehicles(model, np.random.default_rng(0))
    assert sorted(clusters[0].tolist()) == [3, 4, 6]
    assert sorted(clusters[1].tolist()) == [0, 1, 2, 5]
    routes = initial_routes(clusters, np.random.default_rng(1))
    assert_array_equal(sorted(routes[0]), sorted(clusters[0]))
    assert_array_equal(sorted(routes[1]), sorted(clusters[1]))
