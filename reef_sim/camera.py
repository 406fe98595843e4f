"""The camera on the hidden reef: what a simulated vehicle sees of `reef_sim.truth.Reef`.

Two things the camera does, both pure and seeded:

- *inspection*: a vehicle that keeps station at a predicted spot to look learns whether COTS
  are there and, if so, their real priority rho and injection time t (paper eq. 2, as they
  really are);
- *sighting*: along any path (transit included), a truth spot within ``detect_radius_m`` of
  the vehicle's true track is seen with probability ``p_detect`` per pass. A pass begins when
  the track comes within reach of the spot after being out of it; each pass has its own draw,
  from a stream keyed by (mission seed, vehicle, spot, pass number), so the in-process
  simulation and the multi-process fleet draw the same numbers whatever their step times.

The camera works on true positions; the vehicle that carries it reports what it saw in its own
navigation frame (`reef_sim.vehicle`).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from reef_sim.truth import Reef

Point3 = tuple[float, float, float]
SENSOR_STREAM = 0x5E50  # keeps the camera's draws apart from every other seeded stream


class SeenSpot(NamedTuple):
    """An aggregation seen along the track: where it really is, what it is worth (rho, t)."""

    pos: Point3
    priority: float
    service_s: float


class Inspection(NamedTuple):
    """What a look at a predicted spot showed: COTS (``present``) with their real priority
    and injection time, or nothing."""

    present: bool
    priority: float = 0.0
    service_s: float = 0.0


def pass_seen(seed: int, vehicle: int, spot: int, pass_no: int, p_detect: float) -> bool:
    """Whether pass ``pass_no`` of ``vehicle`` by truth spot ``spot`` sees it: one uniform
    draw of its own stream against ``p_detect`` (0 never, 1 always)."""
    rng = np.random.default_rng([SENSOR_STREAM, seed, vehicle, spot, pass_no])
    return bool(rng.random() < p_detect)


def segment_distance_m(a: Point3, b: Point3, points: np.ndarray) -> np.ndarray:
    """Distance from each row of ``points`` (m, 3) to the segment a-b (3-D)."""
    pa, ab = points - np.asarray(a, float), np.asarray(b, float) - np.asarray(a, float)
    denom = float(ab @ ab)
    if denom <= 0.0:
        return np.linalg.norm(pa, axis=1)
    f = np.clip(pa @ ab / denom, 0.0, 1.0)
    return np.linalg.norm(pa - f[:, None] * ab, axis=1)


class ReefCamera:
    """The hidden reef as one vehicle's camera meets it: call `sweep` with each point of the
    true track and `inspect` when the vehicle keeps station at a predicted spot to look."""

    # Slack on the reach, so a spot exactly at the detect radius is within it despite the
    # rounding of positions computed along a leg.
    REACH_EPS_M = 1e-6

    def __init__(self, reef: Reef, seed: int, vehicle: int) -> None:
        self.reef, self.seed, self.vehicle = reef, int(seed), int(vehicle)
        self._xyz = np.array([s.pos for s in reef.spots], dtype=float).reshape(-1, 3)
        self._inside = np.zeros(len(reef.spots), dtype=bool)
        self._passes = np.zeros(len(reef.spots), dtype=np.int64)
        self._last: Point3 | None = None

    @property
    def reach_m(self) -> float:
        return self.reef.detect_radius_m + self.REACH_EPS_M

    def sweep(self, pos: Point3) -> list[SeenSpot]:
        """The track went (in a straight line) from the last position swept to ``pos``: the
        spots seen on the way, each pass drawing once."""
        a = pos if self._last is None else self._last
        self._last = (float(pos[0]), float(pos[1]), float(pos[2]))
        if not len(self._xyz):
            return []
        near = segment_distance_m(a, pos, self._xyz) <= self.reach_m
        entering = near & ~self._inside
        # Still within reach at the end of the piece: the same pass goes on next time.
        self._inside = np.linalg.norm(self._xyz - np.asarray(pos, float), axis=1) <= self.reach_m
        seen = []
        for i in np.flatnonzero(entering).tolist():
            self._passes[i] += 1
            if pass_seen(self.seed, self.vehicle, i, int(self._passes[i]), self.reef.p_detect):
                s = self.reef.spots[i]
                seen.append(SeenSpot(s.pos, s.priority, s.service_s))
        return seen

    def inspect(self, task: int) -> Inspection:
        """What predicted spot ``task`` really holds."""
        i = self.reef.of_task(task)
        if i is None:
            return Inspection(False)
        s = self.reef.spots[i]
        return Inspection(True, s.priority, s.service_s)
