"""Travel metric between nodes (paper eq. 7-8: 3-D Euclidean distance), and around land.

Where a scenario has forbidden polygons (islands, coastline; vertical walls at every depth),
travel follows the shortest path around them. Such paths bend only at convex land corners, so
`LandMap` builds a visibility graph over those corners, pushed out to sea by ``clearance_m``
(the path keeps that distance from the corners it turns around), and runs scipy's shortest
paths over it once. Any two points then connect either straight (if the segment enters no
polygon) or through the graph: ``min over corners a, b of |p a| + G[a, b] + |b q|``.

Depth changes linearly along the horizontal path, so a path of horizontal length L between
points dz apart in depth is ``sqrt(L^2 + dz^2)`` long: the straight 3-D distance when nothing
is in the way, as in eq. 7.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
from numpy.typing import ArrayLike
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import shortest_path
from scipy.spatial.distance import cdist

EPS_M = 1e-9  # geometric tolerance: on-boundary within this counts as outside
CHUNK = 200_000  # segment-edge pairs per vectorised block (bounds temporary memory)


class LandError(ValueError):
    """A point that has to be in the water is on land, or no path exists."""


def _cross(ox, oy, ax, ay, bx, by):
    return (ax - ox) * (by - oy) - (ay - oy) * (bx - ox)


class LandMap:
    """Shortest paths around polygons; build once per scenario, query many times."""

    def __init__(self, polygons: Sequence[ArrayLike], clearance_m: float = 0.5) -> None:
        if not clearance_m > 0:
            raise ValueError(f"clearance must be positive, got {clearance_m}")
        self.clearance_m = float(clearance_m)
        self.polygons = [_counter_clockwise(np.asarray(p, dtype=float)[:, :2]) for p in polygons]
        self._a = np.concatenate([p for p in self.polygons])  # edge tails
        self._b = np.concatenate([np.roll(p, -1, axis=0) for p in self.polygons])  # heads
        self._edge_poly = np.concatenate([np.full(len(p), i) for i, p in enumerate(self.polygons)])
        self.corners = self._corners()
        self._graph_m, self._pred = self._corner_graph()
        self._cache: tuple[bytes, np.ndarray] | None = None

    # --- queries -------------------------------------------------------------------------
    def inside(self, xy: ArrayLike) -> np.ndarray:
        """Which points (``(N, 2)`` or ``(N, 3)``) lie strictly inside land."""
        xy = np.atleast_2d(np.asarray(xy, dtype=float))[:, :2]
        out = np.zeros(len(xy), dtype=bool)
        for poly in self.polygons:
            out |= _strictly_inside(xy, poly)
        return out

    def require_water(self, xyz: ArrayLike, what: str = "point") -> None:
        bad = np.flatnonzero(self.inside(xyz))
        if len(bad):
            raise LandError(f"{what} {np.asarray(xyz)[bad[0]].tolist()} is on land")

    def to_water(self, p: Sequence[float]) -> tuple[float, ...]:
        """``p`` if it is in the water, else the nearest point of the coast pushed
        ``clearance_m`` out to sea (the nearest sea corner if that lands on other land).
        A vehicle is always in the water; its estimate of where it is may not be (a drifted
        dead reckoning near the shore), and paths must start from the sea."""
        xy = np.asarray(p, dtype=float)[:2]
        if not self.inside(xy)[0]:
            return tuple(float(c) for c in p)
        a, e = self._a, self._b - self._a
        t = np.clip(((xy - a) * e).sum(axis=1) / np.maximum((e * e).sum(axis=1), 1e-300), 0, 1)
        foot = a + t[:, None] * e
        gap = np.linalg.norm(foot - xy, axis=1)
        i = int(gap.argmin())
        # Outward normal of a CCW edge: right of its direction (as `_corners`).
        n = np.array([e[i, 1], -e[i, 0]]) / max(float(np.linalg.norm(e[i])), 1e-300)
        out = foot[i] + n * self.clearance_m
        if self.inside(out)[0] and len(self.corners):
            out = self.corners[int(np.linalg.norm(self.corners - xy, axis=1).argmin())]
        return (float(out[0]), float(out[1]), *(float(c) for c in p[2:]))

    def visible(self, p: ArrayLike, q: ArrayLike) -> np.ndarray:
        """Elementwise: does the segment ``p[i] -> q[i]`` stay out of every polygon's interior?"""
        p = np.atleast_2d(np.asarray(p, dtype=float))[:, :2]
        q = np.atleast_2d(np.asarray(q, dtype=float))[:, :2]
        out = np.empty(len(p), dtype=bool)
        step = max(1, CHUNK // max(1, len(self._a)))
        for lo in range(0, len(p), step):
            out[lo : lo + step] = self._visible_block(p[lo : lo + step], q[lo : lo + step])
        return out

    def distance_matrix(self, xyz: ArrayLike) -> np.ndarray:
        """Pairwise shortest travel distances between the rows of ``xyz``."""
        xyz = np.asarray(xyz, dtype=float)
        self.require_water(xyz)
        m = len(xyz)
        to_corner = self._to_corners(xyz)  # (m, W)
        via_first = _min_plus(to_corner, self._graph_m)  # (m, W): p -> any corner -> corner b
        flat_m = np.empty((m, m))
        rows = max(1, CHUNK // max(1, m))
        for lo in range(0, m, rows):
            block = slice(lo, lo + rows)
            ii, jj = np.meshgrid(np.arange(lo, min(lo + rows, m)), np.arange(m), indexing="ij")
            seen = self.visible(xyz[ii.ravel()], xyz[jj.ravel()]).reshape(ii.shape)
            direct = np.where(seen, cdist(xyz[block, :2], xyz[:, :2]), np.inf)
            flat_m[block] = np.minimum(direct, _min_plus(via_first[block], to_corner.T))
        np.fill_diagonal(flat_m, 0.0)
        flat_m = np.minimum(flat_m, flat_m.T)  # exact symmetry despite rounding in min-plus
        if not np.all(np.isfinite(flat_m)):
            raise LandError("some points cannot reach each other around the land")
        dz = xyz[:, 2][:, None] - xyz[:, 2][None, :]
        return np.sqrt(flat_m**2 + dz**2)

    def distances_from(self, p: ArrayLike, targets: ArrayLike) -> np.ndarray:
        """Shortest travel distance from point ``p`` to each row of ``targets``."""
        p = _xyz(p).reshape(1, 3)
        targets = np.atleast_2d(np.asarray(targets, dtype=float))
        if targets.shape[1] != 3:
            raise ValueError(f"targets need shape (t, 3), got {targets.shape}")
        self.require_water(p, "position")
        to_corner_t = self._targets_to_corners(targets)
        via = _min_plus(_min_plus(self._to_corners(p), self._graph_m), to_corner_t.T)[0]
        seen = self.visible(np.repeat(p, len(targets), axis=0), targets)
        flat = np.where(seen, np.linalg.norm(targets[:, :2] - p[:, :2], axis=1), via)
        if not np.all(np.isfinite(flat)):
            raise LandError(f"position {p[0].tolist()} cannot reach every target around the land")
        return np.sqrt(flat**2 + (targets[:, 2] - p[0, 2]) ** 2)

    def shortest_path(
        self, p: ArrayLike, q: ArrayLike
    ) -> tuple[float, list[tuple[float, float, float]]]:
        """(length in metres, waypoints from ``p`` to ``q`` inclusive, 3-D, depth interpolated
        along the way) of the shortest path around the land."""
        pq = np.array([_xyz(p), _xyz(q)])
        self.require_water(pq)
        if self.visible(pq[:1], pq[1:])[0]:
            hops = [pq[0, :2], pq[1, :2]]
        else:
            to_c = self._to_corners(pq)  # (2, W)
            total = to_c[0][:, None] + self._graph_m + to_c[1][None, :]
            a, b = np.unravel_index(int(total.argmin()), total.shape)
            if not np.isfinite(total[a, b]):
                raise LandError(f"no path from {pq[0].tolist()} to {pq[1].tolist()} around "
                                "the land")
            chain = [int(b)]
            while chain[-1] != a:
                chain.append(int(self._pred[a, chain[-1]]))
            hops = [pq[0, :2], *self.corners[chain[::-1]], pq[1, :2]]
        hops_arr = np.array(hops)
        seg = np.linalg.norm(np.diff(hops_arr, axis=0), axis=1)
        along = np.concatenate([[0.0], np.cumsum(seg)])
        flat = float(along[-1])
        share = along / flat if flat > 0 else np.zeros_like(along)
        z = pq[0, 2] + share * (pq[1, 2] - pq[0, 2])
        points = [(float(x), float(y), float(zz)) for (x, y), zz in zip(hops_arr, z)]
        return float(np.hypot(flat, pq[1, 2] - pq[0, 2])), points

    # --- construction --------------------------------------------------------------------
    def _corners(self) -> np.ndarray:
        """Convex corners pushed out to sea along their bisector, keeping ``clearance_m`` from
        both adjacent edges; corners that land inside another polygon are dropped."""
        out = []
        for poly in self.polygons:
            prev, nxt = np.roll(poly, 1, axis=0), np.roll(poly, -1, axis=0)
            e_in = poly - prev
            e_out = nxt - poly
            e_in /= np.linalg.norm(e_in, axis=1, keepdims=True)
            e_out /= np.linalg.norm(e_out, axis=1, keepdims=True)
            convex = _cross(0, 0, e_in[:, 0], e_in[:, 1], e_out[:, 0], e_out[:, 1]) > 0
            # Outward normals of CCW edges point right of the direction of travel.
            n_in = np.stack([e_in[:, 1], -e_in[:, 0]], axis=1)
            n_out = np.stack([e_out[:, 1], -e_out[:, 0]], axis=1)
            bisector = n_in + n_out
            norm = np.linalg.norm(bisector, axis=1, keepdims=True)
            cos_half = np.clip(np.sum(bisector / norm * n_in, axis=1), 0.2, 1.0)
            offset = bisector / norm * (self.clearance_m / cos_half)[:, None]
            out.append((poly + offset)[convex])
        corners = np.concatenate(out) if out else np.zeros((0, 2))
        return corners[~self.inside(corners)]

    def _corner_graph(self) -> tuple[np.ndarray, np.ndarray]:
        w = len(self.corners)
        if w == 0:
            return np.zeros((0, 0)), np.zeros((0, 0), dtype=np.int64)
        ii, jj = np.triu_indices(w, 1)
        seen = self.visible(self.corners[ii], self.corners[jj])
        length = np.linalg.norm(self.corners[ii] - self.corners[jj], axis=1)
        i, j, d = ii[seen], jj[seen], length[seen]
        rows, cols = np.concatenate([i, j]), np.concatenate([j, i])
        graph = csr_matrix((np.concatenate([d, d]), (rows, cols)), shape=(w, w))
        dist, pred = shortest_path(graph, method="D", directed=False, return_predecessors=True)
        return dist, pred

    def _to_corners(self, xyz: np.ndarray) -> np.ndarray:
        """(N, W) straight distance from each point to each corner it sees (inf if blocked)."""
        w = len(self.corners)
        if w == 0:
            return np.full((len(xyz), 0), np.inf)
        ii, jj = np.meshgrid(np.arange(len(xyz)), np.arange(w), indexing="ij")
        seen = self.visible(xyz[ii.ravel(), :2], self.corners[jj.ravel()]).reshape(ii.shape)
        return np.where(seen, cdist(xyz[:, :2], self.corners), np.inf)

    def _targets_to_corners(self, targets: np.ndarray) -> np.ndarray:
        # Replans query the same task set from ever new positions: keep its corner distances.
        key = targets.tobytes()
        if self._cache is None or self._cache[0] != key:
            self._cache = (key, self._to_corners(targets))
        return self._cache[1]

    def _visible_block(self, p: np.ndarray, q: np.ndarray) -> np.ndarray:
        a, b = self._a[None, :, :], self._b[None, :, :]
        px, py = p[:, 0:1], p[:, 1:2]
        qx, qy = q[:, 0:1], q[:, 1:2]
        d1 = _cross(px, py, qx, qy, a[..., 0], a[..., 1])
        d2 = _cross(px, py, qx, qy, b[..., 0], b[..., 1])
        d3 = _cross(a[..., 0], a[..., 1], b[..., 0], b[..., 1], px, py)
        d4 = _cross(a[..., 0], a[..., 1], b[..., 0], b[..., 1], qx, qy)
        proper = ((d1 > 0) & (d2 < 0) | (d1 < 0) & (d2 > 0)) & (
            (d3 > 0) & (d4 < 0) | (d3 < 0) & (d4 > 0)
        )
        blocked = proper.any(axis=1)
        # Without a proper crossing a segment can still enter land through corners it passes
        # exactly, or lie inside between two boundary points: split it at the corners it
        # touches and test the middle of every piece.
        length = np.hypot(qx - px, qy - py)
        touches = (np.abs(d1) <= 1e-6 * length).any(axis=1)  # a corner within 1 um of the line
        blocked |= self.inside((p + q) / 2)
        for s in np.flatnonzero(touches & ~blocked):
            blocked[s] = self._pieces_enter(p[s], q[s])
        return ~blocked

    def _pieces_enter(self, p: np.ndarray, q: np.ndarray) -> bool:
        d = q - p
        length2 = float(d @ d)
        if length2 == 0:
            return False
        t = ((self._a - p) @ d) / length2
        cross = _cross(p[0], p[1], q[0], q[1], self._a[:, 0], self._a[:, 1])
        off = np.abs(cross) / np.sqrt(length2)
        cuts = np.unique(np.concatenate([[0.0, 1.0], t[(off <= 1e-6) & (t > 0) & (t < 1)]]))
        mids = p + ((cuts[:-1] + cuts[1:]) / 2)[:, None] * d
        return bool(self.inside(mids).any())


def _xyz(p: ArrayLike) -> np.ndarray:
    arr = np.asarray(p, dtype=float)
    return np.append(arr, 0.0) if arr.shape == (2,) else arr


def _counter_clockwise(poly: np.ndarray) -> np.ndarray:
    if len(poly) > 3 and np.array_equal(poly[0], poly[-1]):
        poly = poly[:-1]  # a closed ring repeats its first vertex
    x, y = poly[:, 0], poly[:, 1]
    area2 = float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))
    return poly if area2 > 0 else poly[::-1].copy()


def _strictly_inside(xy: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Even-odd ray casting; points within EPS_M of the boundary count as outside."""
    a, b = poly, np.roll(poly, -1, axis=0)
    x, y = xy[:, 0:1], xy[:, 1:2]
    ax, ay, bx, by = a[:, 0], a[:, 1], b[:, 0], b[:, 1]
    straddle = (ay > y) != (by > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        x_cross = ax + (y - ay) * (bx - ax) / (by - ay)
    inside = (straddle & (x < x_cross)).sum(axis=1) % 2 == 1
    # Distance to the boundary, to let points on the coast count as water.
    ex, ey = bx - ax, by - ay
    t = np.clip(((x - ax) * ex + (y - ay) * ey) / np.maximum(ex * ex + ey * ey, 1e-300), 0, 1)
    near = np.hypot(x - (ax + t * ex), y - (ay + t * ey)).min(axis=1)
    return inside & (near > EPS_M * 1e3)


def _min_plus(left: np.ndarray, right: np.ndarray) -> np.ndarray:
    """(a, c) = min over b of left[a, b] + right[b, c], in blocks to bound memory."""
    a, inner = left.shape
    c = right.shape[1]
    if inner == 0:
        return np.full((a, c), np.inf)
    out = np.empty((a, c))
    rows = max(1, CHUNK * 10 // max(1, inner * c))
    for lo in range(0, a, rows):
        out[lo : lo + rows] = (left[lo : lo + rows, :, None] + right[None, :, :]).min(axis=1)
    return out


def distance_matrix(xyz: ArrayLike, forbidden: Sequence[ArrayLike] = ()) -> np.ndarray:
    """Pairwise travel distance in metres between the rows of ``xyz`` (shape ``(m, 3)``)."""
    if len(forbidden):
        return LandMap(forbidden).distance_matrix(xyz)
    points = np.asarray(xyz, dtype=float)
    return cdist(points, points)
