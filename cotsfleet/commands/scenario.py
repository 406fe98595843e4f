"""`cotsfleet scenario`: a scenario JSON drawn from the paper's model (eq. 1-2), optionally with
a hidden reef the map predicts imperfectly (``--dynamic``), or made from a reef in GeoJSON
(longitude/latitude, see `cotsfleet.geo.reef`)."""

from __future__ import annotations

import argparse
import json
import math
import sys
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from cotsfleet.errors import UsageError
from fleet_agent.wire import MAX_VEHICLES
from hfc_core.formats.scenario import problem_from_dict
from hfc_core.model.errors import ScenarioError
from hfc_core.model.problem import Problem
from reef_sim.scenarios.area import AreaParams, generate_area_doc, out_of_reach
from reef_sim.scenarios.dynamic import DynamicParams, generate_dynamic_doc
from reef_sim.scenarios.field import PAPER_PRESET, GeneratorParams, generate_doc
from reef_sim.truth import reef_from_doc

if TYPE_CHECKING:
    from cotsfleet.geo import ReefOptions

HELP = ("make a COTS scenario: drawn from the eq. 1 probability map, or from your own reef "
        "in GeoJSON (--from-geojson)")
# Flags of the generator that mean nothing for a reef read from a file.
GENERATOR_ONLY = ("paper", "tasks", "size", "area_m", "centres", "land_forbidden")
# Flags of the eq. 1 field generator that mean nothing for a large area (--area-m).
FIELD_ONLY = ("paper", "size", "land_forbidden")
# The truth's camera: for a reef file's truth points, or a drawn hidden reef (--dynamic).
SENSOR = ("detect_radius_m", "p_detect", "inspect_s")
GEOJSON_ONLY = ("simplify_m",)
# Flag -> `DynamicParams` field of the hidden reef's knobs (--dynamic).
DYNAMIC_ONLY = {"empty_share": "empty_share", "priority_error": "priority_error",
                "unmapped": "n_unmapped", "unmapped_spread_m": "unmapped_spread_m"}


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
                      help="truth (also --dynamic): the camera sees a spot within this range "
                           "(default 25)")
    reef.add_argument("--p-detect", type=float, metavar="P",
                      help="truth (also --dynamic): chance that a pass within range sees it "
                           "(default 0.9)")
    reef.add_argument("--inspect-s", type=float, metavar="S",
                      help="truth (also --dynamic): time spent at a predicted spot to see what "
                           "is there (default 20)")
    reef.add_argument("--simplify-m", type=float, metavar="M",
                      help="simplify land/no-go outlines to this tolerance, never shrinking "
                           "them (detailed outlines slow the planner's routing around land)")
    dynamic = parser.add_argument_group(
        "dynamic missions", "a hidden reef (the scenario's 'truth') drawn with the map: some "
        "predicted spots are empty, the others' priorities are off, and aggregations the map "
        "missed lie near the predicted ones; the camera flags above apply; see docs/scenario.md")
    dynamic.add_argument("--dynamic", action="store_true",
                         help="also draw the hidden reef (with --paper: the demo's scenario)")
    dynamic.add_argument("--empty-share", type=float, metavar="X",
                         help="share of the predicted spots that hold nothing (default 0.25)")
    dynamic.add_argument("--priority-error", type=float, metavar="X",
                         help="relative spread of a spot's real priority around the predicted "
                              "one, lognormal and right on average (default 0.3)")
    dynamic.add_argument("--unmapped", type=int, metavar="N",
                         help="number of aggregations the map missed (default 12 per 90 "
                              "predicted spots)")
    dynamic.add_argument("--unmapped-spread-m", type=float, metavar="M",
                         help="Gaussian spread (per axis) of the missed aggregations around "
                              "the predicted spots, m (default 50)")
    parser.add_argument("--name", help="scenario name")
    parser.add_argument("-o", "--output", metavar="OUT.json",
                        help="write here (default: print the JSON on stdout)")


def params_from_args(args: argparse.Namespace) -> GeneratorParams:
    """The generator parameters the flags ask for (raises `UsageError` on bad values)."""
    base = PAPER_PRESET if args.paper else GeneratorParams()
    changes: dict[str, Any] = {}
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
    changes: dict[str, Any] = {}
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
        return AreaParams(**changes)
    except ValueError as exc:
        raise UsageError(str(exc)) from None


def area_scenario(args: argparse.Namespace) -> tuple[dict, str]:
    """The document of ``--area-m`` and the line that says what was written."""
    params = area_params_from_args(args)
    doc = draw(params, args)
    if not args.name:
        doc["name"] = (f"area{params.area_m:g}m-{params.n_vehicles}auv-{params.n_tasks}spots-"
                       f"{'dynamic-' if args.dynamic else ''}seed{args.seed}")
    problem = problem_from_dict(doc)  # a generated document must load: fail here, not in `plan`
    x, y, _ = params.station_point
    line = (f"{len(doc['tasks'])} spots in {params.n_clusters or params.n_vehicles} "
            f"aggregations, {params.n_vehicles} AUVs, {params.area_m:g} m area, station at "
            f"({x:g}, {y:g}), battery {params.battery_s:g} s, seed {args.seed}")
    far = out_of_reach(doc)
    if far:
        line += (f"\nnote: {far} spot(s) lie beyond a round trip of the battery from the "
                 "station: no vehicle can treat them (a longer --battery-s, or a smaller area)")
    if args.dynamic:
        line += "\n" + truth_summary(doc, problem)
    return doc, line


def dynamic_params(args: argparse.Namespace, base: GeneratorParams | AreaParams
                   ) -> DynamicParams:
    """The hidden reef's knobs the flags ask for (raises `UsageError` naming the flag)."""
    flags = {**DYNAMIC_ONLY, **{k: k for k in SENSOR}}
    changes = {field: getattr(args, flag) for flag, field in flags.items()
               if getattr(args, flag) is not None}
    try:
        return DynamicParams(base=base, **changes)
    except ValueError as exc:
        message = str(exc)
        for flag, field in flags.items():
            if message.startswith(field + " "):
                message = f"--{flag.replace('_', '-')}{message[len(field):]}"
        raise UsageError(message) from None


def draw(base: GeneratorParams | AreaParams, args: argparse.Namespace) -> dict:
    """The document ``base`` describes, seeded by ``--seed``; with ``--dynamic`` the same
    document plus its hidden reef, checked against the schema and `reef_from_doc`."""
    params = dynamic_params(args, base) if args.dynamic else None
    rng = np.random.default_rng(args.seed)
    try:
        if params is not None:
            doc = generate_dynamic_doc(params, rng)
        elif isinstance(base, AreaParams):
            doc = generate_area_doc(base, rng)
        else:
            doc = generate_doc(base, rng)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    if params is not None:
        from cotsfleet.io import check_schema

        check_schema(doc, "scenario", "generated scenario", ScenarioError)  # our own contract
    return doc


def truth_summary(doc: dict, problem: Problem) -> str:
    """What the hidden reef holds against what the map predicts, in one line."""
    reef = reef_from_doc(doc, problem)  # also checks the generator kept the contract
    assert reef is not None
    n = problem.n_tasks
    empty, unmapped = len(reef.empty(n)), len(reef.unmapped())
    mapped = reef.total_priority() - sum(reef.spots[i].priority for i in reef.unmapped())
    predicted = float(problem.priority.sum())
    share = f" ({reef.total_priority() / predicted:.0%})" if predicted > 0 else ""
    return (f"truth: {n - empty} of {n} predicted spots hold COTS ({empty} empty), {unmapped} "
            f"unmapped aggregation(s); real priority {reef.total_priority():.0f} vs the map's "
            f"{predicted:.0f}{share}, {mapped:.0f} of it at predicted spots")


def reef_options(args: argparse.Namespace) -> "ReefOptions":
    """The `ReefOptions` the flags ask for (raises `UsageError` on bad values or flags that
    mean nothing for a reef file)."""
    from cotsfleet.geo import ReefOptions

    given = [f"--{k.replace('_', '-')}" for k in GENERATOR_ONLY if getattr(args, k)]
    if given:
        raise UsageError(f"{', '.join(given)}: not with --from-geojson (for drawn scenarios)")
    changes: dict[str, Any] = {"seed": args.seed}
    for flag, name in (("name", "name"), ("vehicles", "vehicles"), ("battery", "battery_s"),
                       ("speed", "speed_mps"), ("service", "service_s"),
                       *((k, k) for k in (*SENSOR, *GEOJSON_ONLY))):
        if getattr(args, flag) is not None:
            changes[name] = getattr(args, flag)
    try:
        return ReefOptions(**changes)
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


def _given(args: argparse.Namespace, names) -> list[str]:
    return [f"--{k.replace('_', '-')}" for k in names if getattr(args, k) is not None]


def check_dynamic_flags(args: argparse.Namespace) -> None:
    """Flags that mean nothing without what they belong to (raises `UsageError`)."""
    if args.from_geojson is not None and args.dynamic:
        raise UsageError("--dynamic: not with --from-geojson (the reef's truth points are its "
                         "hidden reef)")
    given = _given(args, DYNAMIC_ONLY)
    if given and not args.dynamic:
        raise UsageError(f"{', '.join(given)}: only with --dynamic")
    given = _given(args, GEOJSON_ONLY)
    if given and args.from_geojson is None:
        raise UsageError(f"{', '.join(given)}: only with --from-geojson")
    given = _given(args, SENSOR)
    if given and args.from_geojson is None and not args.dynamic:
        raise UsageError(f"{', '.join(given)}: only with --from-geojson or --dynamic")


def run(args: argparse.Namespace) -> int:
    from cotsfleet.commands.checks import output_file

    output_file(args.output, "-o")
    if args.tasks is not None and args.tasks < 1:
        raise UsageError(f"--tasks must be at least 1 (a scenario without a COTS spot has "
                         f"nothing to plan), got {args.tasks}")
    check_dynamic_flags(args)
    if args.vehicles is not None and not 1 <= args.vehicles <= MAX_VEHICLES:
        raise UsageError(f"--vehicles must be 1..{MAX_VEHICLES} (the acoustic wire's limit: "
                         f"one byte of sender index), got {args.vehicles}")
    if args.from_geojson is not None:
        doc = reef_scenario(args)
        if write_doc(doc, args.output):
            print(reef_summary(doc, args.output))
        return 0
    if args.area_m is not None:
        doc, line = area_scenario(args)
        if write_doc(doc, args.output):
            print(f"wrote {args.output}: {line}")
        return 0
    params = params_from_args(args)
    doc = draw(params, args)
    if not args.name:
        doc["name"] = (f"{'paper' if args.paper else 'generated'}-"
                       f"{'dynamic-' if args.dynamic else ''}seed{args.seed}")
    problem = problem_from_dict(doc)  # a generated document must load: fail here, not in `plan`
    if not write_doc(doc, args.output):
        return 0
    n, k = len(doc["tasks"]), len(doc["vehicles"])
    print(f"wrote {args.output}: {n} spots, {k} AUVs, {params.size_m:g} m field, seed {args.seed}")
    if args.dynamic:
        print(truth_summary(doc, problem))
    return 0
