"""`cotsfleet <command>`: one console script, one module per subcommand.

Subcommand modules are imported lazily, so `cotsfleet plan` never pays for Zenoh or Rerun.
Each module under `cotsfleet.commands` defines ``HELP``, ``add_arguments(parser)`` and
``run(args) -> int``.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from types import ModuleType
from typing import Sequence

from cotsfleet.errors import UsageError
from hfc_core.model.errors import ScenarioError

# name -> module under cotsfleet.commands
COMMANDS = {
    "scenario": "scenario",
    "plan": "plan",
    "run": "run",
    "sim": "sim",
    "compare": "compare",
    "report": "report",
    "link": "link",
    "credentials": "credentials",
    "water": "water",
    "agent": "agent",
    "ctl": "ctl",
}


def _available() -> dict[str, ModuleType]:
    mods = {}
    for name, module in COMMANDS.items():
        try:
            mods[name] = importlib.import_module(f"cotsfleet.commands.{module}")
        except ModuleNotFoundError as exc:
            if exc.name != f"cotsfleet.commands.{module}":
                raise
    return mods


def version() -> str:
    """The installed distribution's version (``pyproject.toml``), or the package's own when
    run from a source tree that was never installed."""
    from importlib import metadata

    try:
        return metadata.version("cotsfleet")
    except metadata.PackageNotFoundError:
        from cotsfleet import __version__

        return f"{__version__} (not installed)"


def build_parser() -> argparse.ArgumentParser:
    # allow_abbrev=False everywhere: "--kil auv3@1200" must be an error, not a --kill
    parser = argparse.ArgumentParser(
        prog="cotsfleet", description="COTSbot AUV fleet: planner, emulated missions, dashboard",
        allow_abbrev=False)
    parser.add_argument("--version", action="version", version=f"cotsfleet {version()}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, mod in _available().items():
        p = sub.add_parser(name, help=mod.HELP, description=mod.HELP, allow_abbrev=False)
        mod.add_arguments(p)
        p.set_defaults(_run=mod.run)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return int(args._run(args) or 0)
    except (ScenarioError, UsageError) as exc:
        print(f"cotsfleet {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 130


if __name__ == "__main__":
    raise SystemExit(main())
