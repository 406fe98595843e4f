"""Ambient noise: power spectral density of the sea and its level over a modem's band.

The four empirical spectra summarised by Stojanovic (2007, eq. 6, after Coates, *Underwater
Acoustic Systems*, 1989), in dB re 1 uPa^2/Hz with f in kHz:

    turbulence  10 log N_t  = 17 - 30 log f
    shipping    10 log N_s  = 40 + 20 (s - 0.5) + 26 log f - 60 log(f + 0.03)    s in [0, 1]
    wind        10 log N_w  = 50 + 7.5 sqrt(w) + 20 log f - 40 log(f + 0.4)      w in m/s
    thermal     10 log N_th = -15 + 20 log f

N(f) = N_t + N_s + N_w + N_th (in linear units). In an acoustic modem's band (10-40 kHz) wind
dominates; shipping matters below ~1 kHz, thermal noise above ~100 kHz.

Reefs add biological noise the open-sea spectra do not have: snapping shrimp. Over a shrimp
bed the spectrum is "roughly independent of frequency from 2 to 24 kc" and "at 20 kc about
25 db above the ambient noise which accompanies a sea state of 2" (Everest, Young and Johnson,
"Acoustical characteristics of noise produced by snapping shrimp", JASA 20(2), 1948). Cato and
Bell ("Ultrasonic ambient noise in Australian shallow waters at frequencies up to 200 kHz",
MRL-TR-91-23, 1992) find it dominating Australian waters shallower than ~60 m, loudest near
coral and rock outcrops, varying over hundreds of metres but little with the hour or season.
`SeaState.shrimp_db` adds it as a flat spectral level; `SHRIMP_BED_DB` is Everest's figure
put on the wind spectrum below (sea state 2 taken as a 4 m/s wind), about 63.6 dB re 1 uPa^2/Hz.

The noise level a receiver sees is the PSD integrated over its band [fc - B/2, fc + B/2]
(composite Simpson rule on a linear grid; the PSD is smooth there, so 65 points are exact to
far better than 0.01 dB).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


def _wind_db(f_khz: float, wind_mps: float) -> float:
    return 50.0 + 7.5 * math.sqrt(wind_mps) + 20.0 * math.log10(f_khz) - 40.0 * math.log10(
        f_khz + 0.4)


# Everest et al. (1948): a shrimp bed is 25 dB above sea-state-2 noise at 20 kHz, flat.
SHRIMP_BED_DB = _wind_db(20.0, 4.0) + 25.0


@dataclass(frozen=True)
class SeaState:
    """What makes the water noisy: wind speed, distant shipping, snapping shrimp. The default
    is open water; `REEF` is the water the COTSbots work in."""

    wind_mps: float = 5.0  # ~10 knots, Beaufort 3
    shipping: float = 0.5  # Stojanovic's activity factor: 0 none, 0.5 moderate, 1 heavy
    shrimp_db: float = -math.inf  # flat biological noise, dB re 1 uPa^2/Hz (-inf: none)

    def __post_init__(self) -> None:
        if not (math.isfinite(self.wind_mps) and self.wind_mps >= 0):
            raise ValueError(f"wind_mps must be a finite number >= 0, got {self.wind_mps!r}")
        if not 0.0 <= self.shipping <= 1.0:
            raise ValueError(f"shipping must be in [0, 1], got {self.shipping!r}")
        if math.isnan(self.shrimp_db) or self.shrimp_db == math.inf:
            raise ValueError(f"shrimp_db must be a finite level or -inf, got {self.shrimp_db!r}")


REEF = SeaState(shrimp_db=SHRIMP_BED_DB)


def turbulence_db(f_khz: float) -> float:
    return 17.0 - 30.0 * math.log10(f_khz)


def shipping_db(f_khz: float, shipping: float) -> float:
    return (40.0 + 20.0 * (shipping - 0.5) + 26.0 * math.log10(f_khz)
            - 60.0 * math.log10(f_khz + 0.03))


def wind_db(f_khz: float, wind_mps: float) -> float:
    return _wind_db(f_khz, wind_mps)


def thermal_db(f_khz: float) -> float:
    return -15.0 + 20.0 * math.log10(f_khz)


def noise_psd_db(f_khz: float, sea: SeaState) -> float:
    """Total ambient noise PSD in dB re 1 uPa^2/Hz at ``f_khz``."""
    if not f_khz > 0:
        raise ValueError(f"frequency must be > 0 kHz, got {f_khz}")
    parts = (turbulence_db(f_khz), shipping_db(f_khz, sea.shipping),
             wind_db(f_khz, sea.wind_mps), thermal_db(f_khz), sea.shrimp_db)
    return 10.0 * math.log10(sum(10.0 ** (p / 10.0) for p in parts))


def band_noise_db(centre_khz: float, bandwidth_khz: float, sea: SeaState,
                  points: int = 65) -> float:
    """Noise level in dB re 1 uPa^2 over the band ``centre_khz +- bandwidth_khz / 2``."""
    low, high = centre_khz - bandwidth_khz / 2.0, centre_khz + bandwidth_khz / 2.0
    if not (bandwidth_khz > 0 and low > 0):
        raise ValueError(f"band {low:g}..{high:g} kHz must be non-empty and above 0 Hz")
    n = points if points % 2 else points + 1  # Simpson needs an even number of intervals
    f = np.linspace(low, high, n)
    psd = np.array([10.0 ** (noise_psd_db(x, sea) / 10.0) for x in f])  # uPa^2/Hz
    w = np.ones(n)
    w[1:-1:2], w[2:-1:2] = 4.0, 2.0
    power = float(np.dot(w, psd)) * (f[1] - f[0]) / 3.0 * 1000.0  # df in Hz
    return 10.0 * math.log10(power)
