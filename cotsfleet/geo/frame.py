"""The local metric frame of a scenario and its way back to longitude/latitude.

Scenarios are in metres (x east, y north). A scenario made from longitude/latitude records how:
``"geo": {"crs": "EPSG:32755", "origin_m": [E0, N0]}`` says local ``(x, y)`` is the point
``(E0 + x, N0 + y)`` of that projected CRS (WGS 84 / UTM, zone chosen from the data). UTM is
conformal and its scale error is below 0.1 % anywhere in a zone, far less than an AUV's
navigation error over a reef, so distances in local metres are distances on the water.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import Any, Mapping

import numpy as np
from pyproj import CRS, Transformer
from pyproj.exceptions import CRSError

from hfc_core.model.errors import ScenarioError

LONLAT = "EPSG:4326"  # GeoJSON's coordinates (RFC 7946: WGS 84, longitude first)


def utm_crs(lon: float, lat: float) -> str:
    """The WGS 84 / UTM zone holding ``(lon, lat)``, as ``"EPSG:326zz"`` (north) or
    ``"EPSG:327zz"`` (south). Norway's and Svalbard's irregular zones are not special-cased:
    the regular zone is still accurate there, only not the locally customary one."""
    if not (-180.0 <= lon <= 180.0 and -80.0 <= lat <= 84.0):
        raise ScenarioError(f"no UTM zone for lon {lon}, lat {lat} (UTM covers 80S..84N)")
    zone = min(int((lon + 180.0) // 6.0), 59) + 1  # 180 E is the east edge of zone 60
    return f"EPSG:{(32600 if lat >= 0 else 32700) + zone}"


@lru_cache(maxsize=16)
def _transformers(crs: str) -> tuple[Transformer, Transformer]:
    try:
        projected = CRS.from_user_input(crs)
    except CRSError as exc:
        raise ScenarioError(f"geo: unknown crs {crs!r}: {exc}") from None
    if not projected.is_projected:
        raise ScenarioError(f"geo: crs {crs!r} is not a projected (metric) CRS")
    forward = Transformer.from_crs(LONLAT, projected, always_xy=True)
    inverse = Transformer.from_crs(projected, LONLAT, always_xy=True)
    return forward, inverse


@dataclass(frozen=True)
class LocalFrame:
    """Local metres ``(x, y) = projected - origin_m`` in the projected CRS ``crs``."""

    crs: str
    origin_m: tuple[float, float]

    def __post_init__(self) -> None:
        _transformers(self.crs)  # fail now on an unknown CRS, not at the first conversion
        e0, n0 = (float(c) for c in self.origin_m)
        if not (math.isfinite(e0) and math.isfinite(n0)):
            raise ScenarioError(f"geo: origin_m must be finite, got {self.origin_m}")
        object.__setattr__(self, "origin_m", (e0, n0))

    @staticmethod
    def around(lon: np.ndarray, lat: np.ndarray, margin_m: float = 100.0) -> "LocalFrame":
        """The frame for data at ``lon, lat``: the UTM zone of the centre of their bounding box,
        the origin at the south-west corner of their projected bounding box minus ``margin_m``
        (rounded down to 10 m), so every local coordinate is positive."""
        lon, lat = np.asarray(lon, dtype=float), np.asarray(lat, dtype=float)
        crs = utm_crs(float(lon.min() + lon.max()) / 2.0, float(lat.min() + lat.max()) / 2.0)
        east, north = _transformers(crs)[0].transform(lon, lat)
        e0 = math.floor((float(np.min(east)) - margin_m) / 10.0) * 10.0
        n0 = math.floor((float(np.min(north)) - margin_m) / 10.0) * 10.0
        return LocalFrame(crs, (e0, n0))

    @staticmethod
    def centred_on(lon: float, lat: float) -> "LocalFrame":
        """The frame of ``(lon, lat)``'s UTM zone with its origin at that point."""
        crs = utm_crs(lon, lat)
        east, north = _transformers(crs)[0].transform(lon, lat)
        return LocalFrame(crs, (float(east), float(north)))

    @property
    def crs_name(self) -> str:
        """The CRS's name, e.g. ``WGS 84 / UTM zone 55S``."""
        return str(CRS.from_user_input(self.crs).name)

    def to_local(self, lon: Any, lat: Any) -> tuple[np.ndarray, np.ndarray]:
        """Local metres of longitude/latitude (arrays or scalars)."""
        east, north = _transformers(self.crs)[0].transform(np.asarray(lon, dtype=float),
                                                           np.asarray(lat, dtype=float))
        return np.asarray(east) - self.origin_m[0], np.asarray(north) - self.origin_m[1]

    def to_lonlat(self, x: Any, y: Any) -> tuple[np.ndarray, np.ndarray]:
        """Longitude/latitude of local metres (the inverse of `to_local`)."""
        lon, lat = _transformers(self.crs)[1].transform(
            np.asarray(x, dtype=float) + self.origin_m[0],
            np.asarray(y, dtype=float) + self.origin_m[1])
        return np.asarray(lon), np.asarray(lat)

    def to_dict(self) -> dict[str, Any]:
        return {"crs": self.crs, "origin_m": [self.origin_m[0], self.origin_m[1]]}

    @staticmethod
    def of_scenario(doc: Mapping[str, Any] | None) -> "LocalFrame | None":
        """The frame a scenario document records in its ``geo`` section, or None."""
        geo = doc.get("geo") if isinstance(doc, Mapping) else None
        if geo is None:
            return None
        try:
            return LocalFrame(str(geo["crs"]), tuple(geo["origin_m"]))
        except ScenarioError:
            raise
        except KeyError as exc:
            raise ScenarioError(f"geo: missing field {exc}") from None
        except (TypeError, ValueError) as exc:
            raise ScenarioError(f"geo: expected {{'crs': 'EPSG:n', 'origin_m': [E, N]}}: "
                                f"{exc}") from None
