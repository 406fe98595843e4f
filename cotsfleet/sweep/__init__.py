"""Sweeps: many seeded in-process missions, run in parallel and aggregated.

`cotsfleet sim --runs N [--jobs K] [--scheduler [ADDRESS]]` is this package's front end.

- `spec`: `SweepSpec`, what every run of a sweep shares (picklable, import-light), and
  `build_mission(spec, seed)`, the mission of one seed exactly as a single `sim` builds it;
- `task`: `run_seed(spec, seed)`, one run: its report and wall time, or its error;
- `serial`, `local`, `cluster`: where the runs execute (this process; K worker processes
  of our own; a Dask cluster, named or started locally), each yielding results as they finish;
- `aggregate`: results sorted by seed, the comparable view (no wall clock), the terminal
  table, and the outputs (one JSON, ``sweep.md``).

See docs/sweeps.md.
"""

from cotsfleet.sweep.spec import SweepSpec, build_mission
from cotsfleet.sweep.task import run_seed

__all__ = ["SweepSpec", "build_mission", "run_seed"]
