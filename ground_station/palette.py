"""Colours of the dashboard: one per vehicle, one per spot state, and the sea colormap.

Vehicle colours avoid the spot-state colours (green cleared, red abandoned, gold claimed,
grey pending) so a spot planned for a vehicle is never mistaken for a state.
"""

from __future__ import annotations

import numpy as np

Rgb = tuple[int, int, int]

VEHICLE_COLORS: tuple[Rgb, ...] = (
    (255, 127, 14),  # orange
    (0, 200, 255),  # sky blue
    (230, 90, 220),  # magenta
    (170, 140, 255),  # lavender
    (255, 170, 140),  # salmon
    (150, 255, 210),  # mint
    (205, 160, 90),  # tan
    (120, 160, 255),  # periwinkle
)

SPOT_PENDING: Rgb = (205, 205, 205)
SPOT_CLAIMED: Rgb = (255, 215, 0)
SPOT_CLEARED: Rgb = (40, 200, 70)
SPOT_ABANDONED: Rgb = (230, 40, 40)
SPOT_EMPTY: Rgb = (120, 120, 120)  # a predicted spot the camera found empty (dynamic missions)
# A prediction nobody has looked at yet (dynamic missions): filled with the deep sea's colour, so
# only its ring (`map/predictions`) shows: drawn hollow, a prediction and not a fact.
SPOT_HOLLOW: Rgb = (8, 24, 58)
REEF: Rgb = (255, 120, 200)  # the hidden reef (a layer to switch on: what the fleet cannot see)
FIND: Rgb = (0, 190, 255)  # an aggregation the map missed, once a vehicle reported it

LINK_DELIVERED: Rgb = (60, 230, 90)  # a strong frame (SNR at or above LINK_SNR_STRONG_DB)
LINK_WEAK: Rgb = (255, 235, 90)  # a frame delivered at or below LINK_SNR_WEAK_DB
LINK_DROPPED: Rgb = (255, 60, 60)
LINK_SNR_WEAK_DB = 10.0  # delivered frames are coloured from weak (yellow) to strong (green)
LINK_SNR_STRONG_DB = 40.0
CURRENT: tuple[int, int, int, int] = (215, 235, 255, 170)  # water current arrows, translucent
MARK_ABORTED: Rgb = (255, 40, 40)
MARK_LOST: Rgb = (255, 160, 0)
LAND: Rgb = (12, 10, 8)
FORBIDDEN: Rgb = (200, 60, 60)
STATION: Rgb = (255, 255, 255)

# Fleet time series, by path under ``series/fleet``; drop reasons share the "dropped" red family.
FLEET_SERIES: dict[str, Rgb] = {
    "spots_cleared": SPOT_CLEARED,
    "duplicates": SPOT_ABANDONED,
    "priority_collected": SPOT_CLAIMED,
    "messages/delivered": LINK_DELIVERED,
    "messages/dropped": LINK_DROPPED,
    "bytes/delivered": LINK_DELIVERED,
    "drops/range": (255, 150, 120),
    "drops/random": (200, 120, 255),
    "drops/sinr": (250, 240, 110),  # too weak to decode even alone
    "drops/collision": (255, 120, 200),  # would have decoded alone, not among the overlaps
    "drops/half_duplex": (255, 165, 60),
    "drops/oversize": (160, 160, 160),
    "drops/partition": (120, 200, 255),
}

# The ground station's own counts: samples it refused or failed on.
GROUND_STATION_SERIES: dict[str, Rgb] = {
    "dropped/malformed": (200, 120, 255),
    "dropped/error": LINK_DROPPED,
}

# Deep water -> shallow turquoise -> pale sand: low to high COTS probability (paper Fig. 6 uses
# dark -> yellow; a sea ramp keeps the gold "claimed" spots readable on top of it).
_SEA_STOPS = np.array([[8, 24, 58], [18, 84, 120], [40, 150, 150], [200, 210, 150]], float)


# Labels. The viewer writes a label in its entity's colour on a grey box of its own (Rerun's
# `widgets.inactive.bg_fill`): measured (116, 118, 122) in the bundled web viewer (docs/img),
# and about (44, 43, 43) in the dark desktop theme. On that grey, orange, red or green text
# is unreadable (contrast 1.0-1.9), and no colour reaches 4.5 but white: so every label is
# white, on an entity of its own where the geometry keeps its colour.
LABEL_TEXT: Rgb = (255, 255, 255)
LABEL_BACKGROUNDS: tuple[Rgb, ...] = ((116, 118, 122), (44, 43, 43))
MIN_CONTRAST = 4.5  # WCAG 2.x, AA for normal text
GRID: tuple[int, int, int, int] = (255, 255, 255, 70)  # grid lines: faint over the sea
SCALE_BAR: Rgb = (255, 255, 255)


def luminance(c: Rgb) -> float:
    """WCAG 2.x relative luminance of an sRGB colour."""
    def lin(v: int) -> float:
        s = v / 255.0
        return s / 12.92 if s <= 0.04045 else ((s + 0.055) / 1.055) ** 2.4
    r, g, b = (lin(v) for v in c[:3])
    return 0.2126 * r + 0.7152 * g + 0.0722 * b


def contrast(a: Rgb, b: Rgb) -> float:
    """WCAG 2.x contrast ratio of two colours (1 to 21)."""
    hi, lo = sorted((luminance(a), luminance(b)), reverse=True)
    return (hi + 0.05) / (lo + 0.05)


def vehicle_color(index: int) -> Rgb:
    return VEHICLE_COLORS[index % len(VEHICLE_COLORS)]


def link_color(delivered: bool, snr_db: float | None) -> Rgb:
    """Dropped frames red; delivered ones from yellow (weak) to green (strong) by their SNR
    (green when the channel gives none)."""
    if not delivered:
        return LINK_DROPPED
    if snr_db is None:
        return LINK_DELIVERED
    span = LINK_SNR_STRONG_DB - LINK_SNR_WEAK_DB
    a = min(max((snr_db - LINK_SNR_WEAK_DB) / span, 0.0), 1.0)
    r, g, b = (round(w + a * (s - w)) for w, s in zip(LINK_WEAK, LINK_DELIVERED))
    return r, g, b


def sea_colormap(prob: np.ndarray) -> np.ndarray:
    """``prob`` in [0, 1] (any shape) -> uint8 RGB of shape ``prob.shape + (3,)``."""
    p = np.clip(np.nan_to_num(np.asarray(prob, dtype=float)), 0.0, 1.0)
    pos = p * (len(_SEA_STOPS) - 1)
    lo = np.minimum(pos.astype(int), len(_SEA_STOPS) - 2)
    frac = (pos - lo)[..., None]
    rgb = _SEA_STOPS[lo] * (1.0 - frac) + _SEA_STOPS[lo + 1] * frac
    return rgb.round().astype(np.uint8)
