"""Write ``green_island_reef.geojson``: an illustrative reef in longitude/latitude.

Synthetic, not survey data, not for navigation. The shapes imitate Green Island Reef, 27 km
north-east of Cairns: a vegetated cay (``land``) on the north-east part of a reef flat
(``no_go``: too shallow for the AUVs), a dive boat north of the flat where the vehicles start
and a pontoon nearby where they are recovered. COTS points imitate manta-tow survey results:
aggregations along the reef slope just outside the flat's edge, denser (higher priority) at
their centres, 3-12 m deep. ``truth`` points say what a diver would really find: most predicted
spots confirmed (some with a different priority), and a few aggregations the survey missed.

    .venv/bin/python examples/build_example_reef.py      # rewrites the GeoJSON next to it
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from cotsfleet.geo.frame import LocalFrame

CAY_LONLAT = (145.9711, -16.7586)  # Green Island, Queensland
OUT = Path(__file__).with_name("green_island_reef.geojson")


def outline(centre: tuple[float, float], a: float, b: float, tilt_deg: float, n: int,
            wobble: list[tuple[int, float, float]]) -> np.ndarray:
    """A star-shaped outline: an ellipse whose radius wobbles with a few smooth harmonics."""
    t = np.linspace(0.0, 2.0 * math.pi, n, endpoint=False)
    r = 1.0 + sum(amp * np.cos(k * t + phase) for k, amp, phase in wobble)
    x, y = a * r * np.cos(t), b * r * np.sin(t)
    c, s = math.cos(math.radians(tilt_deg)), math.sin(math.radians(tilt_deg))
    return np.column_stack([centre[0] + c * x - s * y, centre[1] + s * x + c * y])


FLAT = dict(centre=(-250.0, -140.0), a=560.0, b=330.0, tilt_deg=25.0,
            wobble=[(2, 0.05, 0.4), (3, 0.04, 1.3), (5, 0.025, 2.2), (8, 0.012, 0.7),
                    (13, 0.008, 1.9)])


def on_slope(theta: float, offset_m: float) -> tuple[float, float]:
    """A point ``offset_m`` outside the reef flat's edge, on the ray at angle ``theta``."""
    t = np.array([theta])
    r = 1.0 + sum(amp * np.cos(k * t + ph) for k, amp, ph in FLAT["wobble"])
    a, b = FLAT["a"] * r[0], FLAT["b"] * r[0]
    x, y = a * math.cos(theta), b * math.sin(theta)
    grow = 1.0 + offset_m / math.hypot(x, y)
    c, s = math.cos(math.radians(FLAT["tilt_deg"])), math.sin(math.radians(FLAT["tilt_deg"]))
    x, y = x * grow, y * grow
    return FLAT["centre"][0] + c * x - s * y, FLAT["centre"][1] + s * x + c * y


# Manta-tow hot spots: (angle on the flat's outline, spread in radians, number of spots).
AGGREGATIONS = [(1.75, 0.10, 18), (3.15, 0.09, 16), (4.35, 0.08, 14), (0.25, 0.08, 12)]
MISSED = [(4.55, 40.0), (4.62, 30.0), (5.3, 35.0), (2.4, 45.0)]  # the survey missed these


def main() -> None:
    rng = np.random.default_rng(17)
    frame = LocalFrame.centred_on(*CAY_LONLAT)  # local (0, 0) at the cay

    def lonlat(x: float, y: float, z: float | None = None) -> list[float]:
        lon, lat = frame.to_lonlat(x, y)
        out = [round(float(lon), 6), round(float(lat), 6)]
        return out if z is None else [*out, round(z, 1)]

    def polygon(xy: np.ndarray) -> dict:
        ring = [lonlat(x, y) for x, y in xy]
        return {"type": "Polygon", "coordinates": [ring + ring[:1]]}

    def point(x: float, y: float, z: float | None = None) -> dict:
        return {"type": "Point", "coordinates": lonlat(x, y, z)}

    features = [
        {"type": "Feature", "properties": {"role": "no_go", "name": "reef flat"},
         "geometry": polygon(outline(n=48, **FLAT))},
        {"type": "Feature", "properties": {"role": "land", "name": "Green Island (cay)"},
         "geometry": polygon(outline((0.0, 0.0), 220.0, 90.0, 25.0, 14,
                                     [(2, 0.06, 0.8), (3, 0.04, 0.1)]))},
        {"type": "Feature", "properties": {"role": "start", "name": "dive boat"},
         "geometry": point(-150.0, 420.0)},
        {"type": "Feature", "properties": {"role": "rendezvous", "name": "pontoon"},
         "geometry": point(40.0, 330.0)},
    ]
    spots: list[tuple[int, float, float, float]] = []
    for theta0, spread, count in AGGREGATIONS:
        for _ in range(count):
            d = rng.normal(0.0, spread)
            offset = rng.uniform(15.0, 70.0)
            x, y = on_slope(theta0 + d, offset)
            depth = 3.0 + 9.0 * (offset - 15.0) / 55.0 + rng.normal(0.0, 0.5)
            density = math.exp(-0.5 * (d / spread) ** 2) * rng.uniform(0.6, 1.0)
            priority = int(np.clip(round(90.0 * density + rng.uniform(1.0, 12.0)), 1, 100))
            tid = len(spots) + 1
            props: dict = {"role": "cots", "id": tid, "priority": priority}
            if tid % 2 == 0:  # half the survey records an estimated injection time
                props["service_s"] = round(float(rng.uniform(60.0, 90.0)), 1)
            features.append({"type": "Feature", "properties": props,
                             "geometry": point(x, y, -max(depth, 2.0))})
            spots.append((tid, x, y, priority))
    for tid, x, y, priority in spots[::5]:  # divers checked every fifth predicted spot
        found = int(np.clip(priority + rng.normal(0.0, 15.0), 1, 100))
        features.append({"type": "Feature",
                         "properties": {"role": "truth", "task": tid, "priority": found},
                         "geometry": point(x + rng.normal(0, 4), y + rng.normal(0, 4), -6.0)})
    for theta, offset in MISSED:
        x, y = on_slope(theta, offset)
        features.append({"type": "Feature",
                         "properties": {"role": "truth", "task": None,
                                        "priority": int(rng.integers(30, 90))},
                         "geometry": point(x, y, -8.0)})
    doc = {"type": "FeatureCollection", "name": "green-island-reef",
           "description": "Synthetic reef imitating Green Island Reef near Cairns (QLD): not "
                          "survey data, not for navigation. Made by build_example_reef.py.",
           "features": features}
    OUT.write_text(json.dumps(doc, indent=1) + "\n", encoding="utf-8")
    print(f"wrote {OUT}: {len(spots)} cots points, {len(features)} features")


if __name__ == "__main__":
    main()
