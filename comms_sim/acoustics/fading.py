"""Block fading: the power gain of one frame over a multipath channel.

Shallow-water links fade: several paths (direct, surface, bottom) add with phases that drift
as vehicles move and the surface moves. A frame is short next to that drift (block fading), so
it sees one power gain ``x`` (mean 1) throughout: its instantaneous SNR is ``x`` times the mean
SNR of the sonar equation. The amplitude is Rician with factor K (power of the steady path over
the scattered ones): K = 0 is Rayleigh (no dominant path: x is exponential), K -> infinity no
fading. UnetStack's BasicAcousticChannel models Rician fading the same way.

Sampling: one frame's gain from two uniforms (Box-Muller for the two Gaussian quadratures of
the scattered part), so a link's random stream keeps a fixed number of draws per frame.
Averaging: the expected frame success over the gain distribution, by quadrature on a log grid
of ``x`` (deep fades matter: at high mean SNR the losses are the rare deep fades).
"""

from __future__ import annotations

import math
from functools import lru_cache
from typing import Callable

import numpy as np
from scipy.special import i0e

# Quadrature grid: x = e^t for t in [-30, 6]; below e^-30 the fade probability is < 1e-13.
_T = np.linspace(-30.0, 6.0, 2401)
_X = np.exp(_T)


def power_gain(u1: float, u2: float, rician_k: float | None) -> float:
    """One frame's power gain from uniforms ``u1``, ``u2`` in [0, 1); 1 without fading."""
    if rician_k is None:
        return 1.0
    if rician_k == 0.0:  # Rayleigh: the power gain is exponential with mean 1
        return -math.log1p(-u1)
    steady = math.sqrt(rician_k / (rician_k + 1.0))
    sigma = math.sqrt(0.5 / (rician_k + 1.0))  # per quadrature: scattered power 1/(K+1)
    radius = sigma * math.sqrt(-2.0 * math.log1p(-u1))  # 1 - u1 in (0, 1]
    return (steady + radius * math.cos(2.0 * math.pi * u2)) ** 2 + \
        (radius * math.sin(2.0 * math.pi * u2)) ** 2


@lru_cache(maxsize=32)
def gain_weights(rician_k: float) -> np.ndarray:
    """Quadrature weights w_i with sum_i w_i h(x_i) ~ E[h(x)] for the Rician power gain."""
    k = rician_k
    z = 2.0 * np.sqrt(k * (k + 1.0) * _X)
    # pdf of the power gain, with I0(z) = i0e(z) e^z to stay finite for large z
    pdf = (k + 1.0) * np.exp(-k - (k + 1.0) * _X + z) * i0e(z)
    w = pdf * _X  # dx = x dt
    w[0] *= 0.5
    w[-1] *= 0.5
    w = w / w.sum()
    w.flags.writeable = False  # cached: shared by every caller
    return w


def mean_success(success_at_snr_db: Callable[[float], float], mean_snr_db: float,
                 rician_k: float | None) -> float:
    """E[success(mean SNR + 10 log10 x)] over the fading gain ``x`` (no fading: success at
    the mean SNR)."""
    if rician_k is None:
        return success_at_snr_db(mean_snr_db)
    gains_db = mean_snr_db + 10.0 * _T / math.log(10.0)
    values = np.array([success_at_snr_db(float(s)) for s in gains_db])
    return float(np.clip(np.dot(gain_weights(rician_k), values), 0.0, 1.0))
