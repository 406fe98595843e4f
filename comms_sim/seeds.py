"""The channel's random stream for a mission seed, the same in every backend.

A mission seed is split with `numpy.random.SeedSequence.spawn` into three children: the
channel (this one), the intruder of the attack faults, and the in-process simulation's fleet
key. The relay and the in-process simulation both draw the channel from the first child, so
the same mission sees the same water whichever way it runs.
"""

from __future__ import annotations

import numpy as np

MISSION_STREAMS = 3  # channel, intruder, simulated fleet key


def channel_rng(mission_seed: int) -> np.random.Generator:
    return np.random.default_rng(np.random.SeedSequence(mission_seed).spawn(MISSION_STREAMS)[0])
