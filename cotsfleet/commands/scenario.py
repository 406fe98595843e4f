"""`cotsfleet scenario`: draw a scenario from the paper's model (eq. 1-2) into a JSON file."""

from __future__ import annotations

import argparse
import json
import math
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

from cotsfleet.cli import UsageError
from hfc_core.generate import PAPER_PRESET, GeneratorParams, generate_doc
from hfc_core.scenario import problem_from_dict

HELP = "generate a COTS scenario (tasks drawn from the eq. 1 probability map)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--paper", action="store_true",
                        help="the paper's preset: 90 spots, 1 km x 1 km, 3 AUVs, 3600 s, 1 m/s, "
                             "90 s injections, one small cluster (flags below override it)")
    parser.add_argument("--tasks", type=int, help="number of COTS spots (default 90)")
    parser.add_argument("--vehicles", type=int, help="number of AUVs (default 3)")
    parser.add_argument("--size", type=float, metavar="M",
                        help="side of the square field in metres")
    parser.add_argument("--battery", type=float, metavar="S", help="battery time budget per AUV, s")
    parser.add_argument("--speed", type=float, metavar="MPS", help="cruise speed, m/s")
    parser.add_argument("--service", type=float, metavar="S",
                        help="fixed injection time per spot, s (default: U(60, 90), eq. 2)")
    parser.add_argument("--centres", type=int, metavar="N",
                        help="number of random COTS centres (default: one per AUV; "
                             "not with --paper)")
    parser.add_argument("--land-forbidden", action="store_true",
                        help="also write land polygons as the scenario's 'forbidden' areas")
    parser.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
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


def run(args: argparse.Namespace) -> int:
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
    text = json.dumps(doc, indent=1)
    if args.output is None:
        sys.stdout.write(text + "\n")
        return 0
    try:
        Path(args.output).write_text(text + "\n", encoding="utf-8")
    except OSError as exc:
        raise UsageError(f"cannot write {args.output}: {exc}") from None
    n, k = len(doc["tasks"]), len(doc["vehicles"])
    print(f"wrote {args.output}: {n} spots, {k} AUVs, {params.size_m:g} m field, seed {args.seed}")
    return 0
