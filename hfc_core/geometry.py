"""Travel metric between nodes (paper eq. 7-8: 3-D Euclidean distance).

Where a scenario has forbidden polygons (land), distances become shortest paths around them;
that metric lives here too so every consumer of `Problem.dist_m` sees one consistent geometry.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
from scipy.spatial.distance import cdist


def distance_matrix(xyz: np.ndarray, forbidden: Sequence[np.ndarray] = ()) -> np.ndarray:
    """Pairwise travel distance in metres between the rows of ``xyz`` (shape ``(m, 3)``)."""
    if len(forbidden):
        raise NotImplementedError("shortest paths around forbidden polygons: see issue 3")
    return cdist(xyz, xyz)
