"""Clustering operator (paper section III-1, eq. 10-11, Fig. 4).

The spots are split into c = k groups, one per AUV (eq. 10), by one of:

- ``kmeans``: Lloyd's algorithm from a k-means++ start; each spot joins its nearest centre.
- ``fcm-max``: fuzzy c-means (eq. 11, fuzzifier m); each spot joins its highest membership.
- ``fcm-roulette``: fuzzy c-means; each spot's cluster is drawn with probability equal to its
  membership (roulette wheel), which lets crowded areas spill over into neighbouring clusters.

The clustering is done once per run: "the solution space (task sequences) is identical for each
cluster", and only the visiting order differs between individuals. k-means keeps the best of
``restarts`` seedings (least within-cluster squared distance), as Lloyd's algorithm only finds
a local optimum. Clusters are matched to vehicles by the least total detour start -> centroid ->
rendezvous (Hungarian method), and an individual's route for a cluster is a uniformly random
sequence of its spots (the paper's initial population).
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import linear_sum_assignment
from scipy.spatial.distance import cdist

from hfc_core.model.cost import RouteModel

METHODS = ("kmeans", "fcm-max", "fcm-roulette")


def kmeans(
    points: np.ndarray, k: int, rng: np.random.Generator, *, max_iter: int = 100,
    restarts: int = 10,
) -> tuple[np.ndarray, np.ndarray]:
    """(labels[n], centres[k, dim]): the best of ``restarts`` runs of `lloyd`."""
    best: tuple[float, np.ndarray, np.ndarray] | None = None
    for _ in range(max(1, restarts)):
        labels, centres = lloyd(points, k, rng, max_iter=max_iter)
        inertia = float(((points - centres[labels]) ** 2).sum()) if len(points) else 0.0
        if best is None or inertia < best[0]:
            best = (inertia, labels, centres)
    assert best is not None
    return best[1], best[2]


def lloyd(
    points: np.ndarray, k: int, rng: np.random.Generator, *, max_iter: int = 100
) -> tuple[np.ndarray, np.ndarray]:
    """(labels[n], centres[k, dim]) by Lloyd's algorithm with k-means++ seeding."""
    n = len(points)
    if n == 0:
        return np.zeros(0, dtype=int), np.zeros((k, points.shape[1]))
    centres = [points[rng.integers(n)]]
    for _ in range(1, k):
        d2 = cdist(points, np.array(centres), "sqeuclidean").min(axis=1)
        total = d2.sum()
        pick = rng.choice(n, p=d2 / total) if total > 0 else rng.integers(n)
        centres.append(points[pick])
    centres_arr = np.array(centres, dtype=float)
    labels = np.full(n, -1)
    for _ in range(max_iter):
        new = cdist(points, centres_arr).argmin(axis=1)
        if np.array_equal(new, labels):
            break
        labels = new
        for j in range(k):
            members = points[labels == j]
            if len(members):
                centres_arr[j] = members.mean(axis=0)
    return labels, centres_arr


def fuzzy_cmeans(
    points: np.ndarray, k: int, rng: np.random.Generator, *, m: float = 2.0,
    max_iter: int = 200, tol: float = 1e-6,
) -> tuple[np.ndarray, np.ndarray]:
    """(memberships W[n, k], centres[k, dim]) minimising eq. (11) by alternating updates."""
    if m <= 1:
        raise ValueError(f"the fuzzifier m must be > 1, got {m}")
    n = len(points)
    w = rng.dirichlet(np.ones(k), size=n) if n else np.zeros((0, k))
    centres = np.zeros((k, points.shape[1]))
    for _ in range(max_iter):
        wm = w**m
        centres = (wm.T @ points) / np.maximum(wm.sum(axis=0), 1e-300)[:, None]
        dist = np.maximum(cdist(points, centres), 1e-12)
        # eq. (11): w_ij = 1 / sum_k (|x_i - c_j| / |x_i - c_k|)^(2/(m-1))
        ratio = (dist[:, :, None] / dist[:, None, :]) ** (2.0 / (m - 1.0))
        new = 1.0 / ratio.sum(axis=2)
        done = np.abs(new - w).max(initial=0.0) < tol
        w = new
        if done:
            break
    return w, centres


def assign_max(memberships: np.ndarray) -> np.ndarray:
    return memberships.argmax(axis=1)


def assign_roulette(memberships: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Draw each spot's cluster with probability equal to its membership."""
    cumulative = np.cumsum(memberships, axis=1)
    draws = rng.random(len(memberships))[:, None] * cumulative[:, -1:]
    return np.minimum((draws > cumulative).sum(axis=1), memberships.shape[1] - 1)


def cluster_labels(
    points: np.ndarray, k: int, rng: np.random.Generator, *, method: str = "kmeans",
    fuzzifier: float = 2.0,
) -> np.ndarray:
    """Cluster label (0..k-1) of every spot by ``method`` (one of `METHODS`)."""
    if method == "kmeans":
        return kmeans(points, k, rng)[0]
    if method not in METHODS:
        raise ValueError(f"unknown clustering {method!r}; choose from {', '.join(METHODS)}")
    w, _ = fuzzy_cmeans(points, k, rng, m=fuzzifier)
    return assign_max(w) if method == "fcm-max" else assign_roulette(w, rng)


def vehicle_of_cluster(labels: np.ndarray, model: RouteModel) -> np.ndarray:
    """``owner[c]``: the vehicle that gets cluster c, least total start->centroid->rendezvous."""
    k = model.k
    xyz = model.xyz
    detour = np.zeros((k, k))
    for c in range(k):
        members = xyz[: model.n][labels == c]
        if not len(members):
            continue  # an empty cluster costs nothing to whoever takes it
        centroid = members.mean(axis=0)
        for v in range(k):
            detour[c, v] = np.linalg.norm(xyz[model.start[v]] - centroid) + np.linalg.norm(
                centroid - xyz[model.end[v]]
            )
    rows, cols = linear_sum_assignment(detour)
    owner = np.empty(k, dtype=int)
    owner[rows] = cols
    return owner


def clusters_of_vehicles(
    model: RouteModel, rng: np.random.Generator, *, method: str = "kmeans", fuzzifier: float = 2.0
) -> list[np.ndarray]:
    """Algorithm 4 line 4: the spots (task indices) of each vehicle's cluster."""
    points = np.asarray(model.xyz[: model.n])
    labels = cluster_labels(points, model.k, rng, method=method, fuzzifier=fuzzifier)
    owner = vehicle_of_cluster(labels, model)
    members: list[np.ndarray] = [np.zeros(0, dtype=int) for _ in range(model.k)]
    for c in range(model.k):
        members[owner[c]] = np.flatnonzero(labels == c)
    return members


def initial_routes(clusters: list[np.ndarray], rng: np.random.Generator) -> list[list[int]]:
    """One individual of the initial population: each cluster's spots in a random order."""
    return [rng.permutation(members).tolist() for members in clusters]
