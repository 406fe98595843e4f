"""Reefs on the globe: GeoJSON in longitude/latitude <-> scenarios in local metres.

`frame` is the projection (UTM, zone from the data) and its inverse; `reef` turns a GeoJSON
reef into a scenario document; `export` writes plans back as GeoJSON in longitude/latitude.
"""

from cotsfleet.geo.frame import LocalFrame
from cotsfleet.geo.reef import ReefOptions, scenario_from_geojson

__all__ = ["LocalFrame", "ReefOptions", "scenario_from_geojson"]
