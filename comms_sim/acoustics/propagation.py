"""Transmission loss: how many dB a tone loses between 1 m from the source and ``r`` metres.

    TL(r, f) = k * 10 log10(r) + alpha(f) * r / 1000            [dB re 1 m]

``k`` is the spreading exponent: 1 cylindrical, 2 spherical, 1.5 "practical" spreading, the
usual compromise for shallow water (Stojanovic 2007, eq. 1; Urick 1983, ch. 5). ``alpha(f)`` is
the absorption coefficient in dB/km, by default Thorp's formula (f in kHz):

    alpha(f) = 0.11 f^2 / (1 + f^2) + 44 f^2 / (4100 + f^2) + 2.75e-4 f^2 + 0.003

(W. H. Thorp, "Analytic description of the low-frequency attenuation coefficient", JASA 42,
1967, in the form quoted by Stojanovic 2007, eq. 3). It is an empirical fit for sea water at
about 4 degC and 1 km depth, valid above a few hundred Hz; at reef temperatures absorption is
somewhat lower (Francois-Garrison), so Thorp errs on the side of shorter ranges.
"""

from __future__ import annotations

import math

REFERENCE_RANGE_M = 1.0  # source levels are quoted at 1 m; nothing is louder than that


def thorp_db_per_km(f_khz: float) -> float:
    """Thorp's absorption coefficient in dB/km at ``f_khz`` kilohertz."""
    if not f_khz > 0:
        raise ValueError(f"frequency must be > 0 kHz, got {f_khz}")
    f2 = f_khz * f_khz
    return 0.11 * f2 / (1.0 + f2) + 44.0 * f2 / (4100.0 + f2) + 2.75e-4 * f2 + 0.003


def transmission_loss_db(range_m: float, f_khz: float, spreading_k: float = 1.5,
                         absorption_db_per_km: float | None = None) -> float:
    """TL in dB over ``range_m`` metres at ``f_khz`` (Thorp unless an absorption is given).
    Ranges under 1 m count as 1 m: the source level is defined there."""
    alpha = thorp_db_per_km(f_khz) if absorption_db_per_km is None else absorption_db_per_km
    r = max(range_m, REFERENCE_RANGE_M)
    return spreading_k * 10.0 * math.log10(r) + alpha * r / 1000.0
