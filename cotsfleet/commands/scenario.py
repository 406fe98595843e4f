"""`cotsfleet scenario`: a scenario JSON drawn from the paper's model (eq. 1-2), or made from a
reef in GeoJSON (longitude/latitude, see `cotsfleet.geo.reef`)."""

from __future__ import annotations

import argparse
import json
import math
import sys
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from cotsfleet.cli import UsageError
from hfc_core.generate import (PAPER_PRESET, AreaParams, GeneratorParams, generate_area_doc,
                                generate_doc, out_of_reach)
from hfc_core.problem import ScenarioError
from hfc_core.scenario import problem_from_dict

if TYPE_CHECKING:
    from cotsfleet.geo import ReefOptions

HELP = ("make a COTS scenario: drawn from the eq. 1 probability map, or from your own reef "
        "in GeoJSON (--from-geojson)")
# Flags of the generator that mean nothing for a reef read from a file.
GENERATOR_ONLY = ("paper", "tasks", "size", "area_m", "centres", "land_forbidden")
# Flags of the eq. 1 field generator that mean nothing for a large area (--area-m).
FIELD_ONLY = ("paper", "size", "land_forbidden")
GEOJSON_ONLY = ("detect_radius_m", "p_detect", "inspect_s", "simplify_m")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--paper", action="store_true",
                        help="the paper's preset: 90 spots, 1 km x 1 km, 3 AUVs, 3600 s, 1 m/s, "
                             "90 s injections, one small cluster (flags below override it)")
    parser.add_argument("--tasks", "--spots", dest="tasks", type=int,
                        help="number of COTS spots (default 90)")
    parser.add_argument("--vehicles", type=int,
                        help="number of AUVs (default 3; from a reef with several start "
                             "points, one per start point)")
    parser.add_argument("--size", type=float, metavar="M",
                        help="side of the square field in metres, with one eq. 1 map over "
                             "the whole field (default 1000; for a few centres: many centres "
                             "over kilometres blur into one blob, use --area-m)")
    parser.add_argument("--area-m", type=float, metavar="M",
                        help="a large square area of this side (a few km): compact COTS "
                             "aggregations (--centres, default one per AUV) spread over it, "
                             "each as dense as the paper's, and one station (start and "
                             "rendezvous) at its centre")
    parser.add_argument("--battery-s", "--battery", dest="battery", type=float, metavar="S",
                        help="battery time budget per AUV, s (default 3600)")
    parser.add_argument("--speed-mps", "--speed", dest="speed", type=float, metavar="MPS",
                        help="cruise speed, m/s (default 1)")
    parser.add_argument("--service-s", "--service", dest="service", type=float, metavar="S",
                        help="fixed injection time per spot, s (default: U(60, 90) drawn "
                             "with --seed, eq. 2; with --from-geojson only for spots whose "
                             "feature has no service_s)")
    parser.add_argument("--centres", type=int, metavar="N",
                        help="number of random COTS centres, or aggregations with --area-m "
                             "(default: one per AUV; not with --paper)")
    parser.add_argument("--land-forbidden", action="store_true",
                        help="also write land polygons as the scenario's 'forbidden' areas")
    parser.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    reef = parser.add_argument_group(
        "your own reef", "a GeoJSON FeatureCollection in longitude/latitude; each feature's "
        "'role' property is land or no_go (polygons), cots (points with priority, optional "
        "service_s and id), start, rendezvous, or truth (points); see docs/scenario.md")
    reef.add_argument("--from-geojson", metavar="REEF.geojson",
                      help="make the scenario from this reef, projected to local metres (UTM)")
    reef.add_argument("--detect-radius-m", type=float, metavar="M",
                      help="truth: the camera sees a spot within this range (default 25)")
    reef.add_argument("--p-detect", type=float, metavar="P",
                      help="truth: chance that a pass within range sees it (default 0.9)")
    reef.add_argument("--inspect-s", type=float, metavar="S",
                      help="truth: time to look at a predicted spot (default 20)")
    reef.add_argument("--simplify-m", type=float, metavar="M",
                      help="simplify land/no-go outlines to this tolerance, never shrinking "
                           "them (detailed outlines slow the planner's routing around land)")
    parser.add_argument("--name", help="scenario name")
    parser.add_argument("-o", "--output", metavar="OUT.json",
                        help="write here (default: print the JSON on stdout)")


def params_from_args(args: argparse.Namespace) -> GeneratorParams:
    """The generator parameters the flags ask for (raises `UsageError` on bad values)."""
    base = PAPER_PRESET if args.paper else GeneratorParams()
    changes: dict[str, object] = {}
    for flag, name in (("tasks", "n_tasks"), ("vehicles", "n_vehicles"), ("size", "size_m"),
                       ("battery", "battery_s"), ("speed", "speed_mps"), ("service", "service_s"),
                       ("centres", "n_centres"), ("name", "name")):
        value = getattr(args, flag)
        if value is None:
            continue
        if isinstance(value, float) and not math.isfinite(value):
            raise UsageError(f"--{flag} must be finite, got {value}")
        changes[name] = value
    if args.land_forbidden:
        changes["land_forbidden"] = True
    if args.paper and ("n_centres" in changes or "size_m" in changes):
        raise UsageError("--paper fixes the field and its COTS centres; drop --size/--centres")
    try:
        return replace(base, **changes)
    except ValueError as exc:
        raise UsageError(str(exc)) from None


def area_params_from_args(args: argparse.Namespace) -> AreaParams:
    """The large-area generator's parameters (``--area-m``; raises `UsageError`)."""
    given = [f"--{k.replace('_', '-')}" for k in FIELD_ONLY if getattr(args, k)]
    if given:
        raise UsageError(f"{', '.join(given)}: not with --area-m (a large area has its own "
                         "layout; --size is the eq. 1 field's side)")
    changes: dict[str, object] = {}
    for flag, name in (("tasks", "n_tasks"), ("vehicles", "n_vehicles"), ("area_m", "area_m"),
                       ("battery", "battery_s"), ("speed", "speed_mps"), ("service", "service_s"),
                       ("centres", "n_clusters"), ("name", "name")):
        value = getattr(args, flag)
        if value is None:
            continue
        if isinstance(value, float) and not math.isfinite(value):
            raise UsageError(f"--{flag.replace('_', '-')} must be finite, got {value}")
        changes[name] = value
    try:
        return AreaParams(**changes)  # type: ignore[arg-type]
    except ValueError as exc:
        raise UsageError(str(exc)) from None


def area_scenario(args: argparse.Namespace) -> tuple[dict, str]:
    """The document of ``--area-m`` and the line that says what was written."""
    params = area_params_from_args(args)
    try:
        doc = generate_area_doc(params, np.random.default_rng(args.seed))
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    if not args.name:
        doc["name"] = (f"area{params.area_m:g}m-{params.n_vehicles}auv-{params.n_tasks}spots-"
                       f"seed{args.seed}")
    problem_from_dict(doc)  # a generated document must load: fail here, not in `plan`
    x, y, _ = params.station_point
    line = (f"{len(doc['tasks'])} spots in {params.n_clusters or params.n_vehicles} "
            f"aggregations, {params.n_vehicles} AUVs, {params.area_m:g} m area, station at "
            f"({x:g}, {y:g}), battery {params.battery_s:g} s, seed {args.seed}")
    far = out_of_reach(doc)
    if far:
        line += (f"\nnote: {far} spot(s) lie beyond a round trip of the battery from the "
                 "station: no vehicle can treat them (a longer --battery-s, or a smaller area)")
    return doc, line


def reef_options(args: argparse.Namespace) -> "ReefOptions":
    """The `ReefOptions` the flags ask for (raises `UsageError` on bad values or flags that
    mean nothing for a reef file)."""
    from cotsfleet.geo import ReefOptions

    given = [f"--{k.replace('_', '-')}" for k in GENERATOR_ONLY if getattr(args, k)]
    if given:
        raise UsageError(f"{', '.join(given)}: not with --from-geojson (for drawn scenarios)")
    changes: dict[str, object] = {"seed": args.seed}
    for flag, name in (("name", "name"), ("vehicles", "vehicles"), ("battery", "battery_s"),
                       ("speed", "speed_mps"), ("service", "service_s"),
                       *((k, k) for k in GEOJSON_ONLY)):
        if getattr(args, flag) is not None:
            changes[name] = getattr(args, flag)
    try:
        return ReefOptions(**changes)  # type: ignore[arg-type]
    except ValueError as exc:
        raise UsageError(str(exc)) from None


def reef_scenario(args: argparse.Namespace) -> dict:
    """The scenario document of ``--from-geojson`` (checked against the schema and loadable)."""
    from cotsfleet.geo import scenario_from_geojson
    from cotsfleet.io import check_schema, read_json

    options = reef_options(args)
    source = args.from_geojson
    geojson = read_json(source)
    try:
        doc = scenario_from_geojson(geojson, options, fallback_name=Path(source).stem)
    except ScenarioError as exc:
        raise UsageError(f"{source}: {exc}") from None
    check_schema(doc, "scenario", "generated scenario", ScenarioError)  # our own contract
    try:
        problem_from_dict(doc)  # e.g. a start walled in by no-go zones: fail here
    except ScenarioError as exc:
        raise UsageError(f"{source}: {exc}") from None
    return doc


def reef_summary(doc: dict, output: str) -> str:
    from cotsfleet.geo import LocalFrame
    from cotsfleet.geo.reef import MANY_VERTICES, polygon_vertices

    roles = doc["geo"].get("forbidden_roles", [])
    vertices = polygon_vertices(doc)
    truth = doc.get("truth", {}).get("spots", [])
    frame = LocalFrame.of_scenario(doc)
    assert frame is not None
    e0, n0 = frame.origin_m
    lines = [f"wrote {output}: {len(doc['tasks'])} spots, {len(doc['vehicles'])} AUVs, "
             f"{roles.count('land')} land and {roles.count('no_go')} no-go polygon(s) "
             f"({vertices} vertices), {len(truth)} truth spot(s)",
             f"local metres: x = easting - {e0:.0f}, y = northing - {n0:.0f} in "
             f"{frame.crs} ({frame.crs_name})"]
    if vertices > MANY_VERTICES:
        lines.append(f"note: {vertices} polygon vertices make routing around land slow; "
                     "consider --simplify-m 5")
    return "\n".join(lines)


def write_doc(doc: dict, output: str | None) -> bool:
    """Write (or print) the document; False when it went to stdout."""
    text = json.dumps(doc, indent=1)
    if output is None:
        sys.stdout.write(text + "\n")
        return False
    try:
        Path(output).write_text(text + "\n", encoding="utf-8")
    except OSError as exc:
        raise UsageError(f"cannot write {output}: {exc}") from None
    return True


def run(args: argparse.Namespace) -> int:
    if args.from_geojson is not None:
        doc = reef_scenario(args)
        if write_doc(doc, args.output):
            print(reef_summary(doc, args.output))
        return 0
    given = [f"--{k.replace('_', '-')}" for k in GEOJSON_ONLY if getattr(args, k) is not None]
    if given:
        raise UsageError(f"{', '.join(given)}: only with --from-geojson")
    if args.area_m is not None:
        doc, line = area_scenario(args)
        if write_doc(doc, args.output):
            print(f"wrote {args.output}: {line}")
        return 0
    params = params_from_args(args)
    try:
        doc = generate_doc(params, np.random.default_rng(args.seed))
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    if not args.name:
        doc["name"] = f"{'paper' if args.paper else 'generated'}-seed{args.seed}"
    try:
        problem_from_dict(doc)  # a generated document must load: fail here, not in `plan`
    except NotImplementedError:
        pass  # routing around "forbidden" land needs hfc_core.geometry's land metric
    if not write_doc(doc, args.output):
        return 0
    n, k = len(doc["tasks"]), len(doc["vehicles"])
    print(f"wrote {args.output}: {n} spots, {k} AUVs, {params.size_m:g} m field, seed {args.seed}")
    return 0
