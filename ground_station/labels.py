"""Where labels go so that they do not pile up (pure).

The viewer writes each label centred under its anchor, in screen pixels, whatever the zoom;
the map opens showing the whole scenario, so a label's footprint is a fixed share of the
map's size there (`box_of`). Labels whose boxes would overlap are stacked: each one keeps its
anchor if it is free, else moves down one box height at a time until it is (the first in
order stays where it belongs). Labels of one thing at one place are merged before this, by
whoever knows they belong together (vehicles at a station are named in its label).
"""

from __future__ import annotations

import numpy as np

Box = tuple[float, float]  # width, height in world metres


def box_of(bounds: tuple[float, float, float, float], share: tuple[float, float]) -> Box:
    """A label's footprint in metres: ``share`` of the map's larger side."""
    xmin, xmax, ymin, ymax = bounds
    extent = max(xmax - xmin, ymax - ymin)
    return share[0] * extent, share[1] * extent


def stack(anchors: np.ndarray, box: Box) -> np.ndarray:
    """``anchors`` (n, 2), moved down (south: y decreases, as the map shows north up) until
    no two label boxes overlap; returns a new array."""
    out = np.array(anchors, float).reshape(-1, 2).copy()
    w, h = box
    placed: list[np.ndarray] = []
    for i in range(len(out)):
        for _ in range(len(out) + 1):  # at most one step per label already placed
            if not any(abs(out[i, 0] - p[0]) < w and abs(out[i, 1] - p[1]) < h
                       for p in placed):
                break
            out[i, 1] -= h
        placed.append(out[i])
    return out
