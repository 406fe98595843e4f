"""The Team Orienteering yardstick: the 33 Chao et al. instances copied into benchmarks/top."""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

from hfc_core.formats.top import parse_top
from hfc_core.model.problem import Problem

TOP_DIR = Path(__file__).resolve().with_name("top")


@dataclass(frozen=True)
class TopInstance:
    name: str
    path: Path
    bks: float  # best-known score
    total_score: float

    def problem(self) -> Problem:
        return parse_top(self.path.read_text(), self.name)


def instances(top_dir: Path = TOP_DIR, table: str = "bks.csv") -> list[TopInstance]:
    """The 33 shared instances (``table="extra.csv"``: the exact-budget ones of README.md)."""
    with open(top_dir / table, newline="") as fh:
        rows = list(csv.DictReader(fh))
    return [
        TopInstance(r["instance"], top_dir / "instances" / f"{r['instance']}.txt",
                    float(r["bks"]), float(r["total_score"]))
        for r in rows
    ]


def gap_pct(score: float, bks: float) -> float:
    """Relative gap to the best-known score, in percent (negative = a new best)."""
    return 100.0 * (bks - score) / bks
