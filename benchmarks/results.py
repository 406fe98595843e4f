"""Write a benchmark's figures into its own section of benchmarks/RESULTS.md.

Each benchmark owns one section, delimited by HTML comments, and rewrites only that section,
so benchmarks can be rerun one at a time without touching each other's figures. Every section
is stamped with the date and the machine it was measured on.
"""

from __future__ import annotations

import datetime as _dt
import fcntl
import os
import platform
import re
from pathlib import Path

RESULTS = Path(__file__).with_name("RESULTS.md")
HEADER = (
    "# Benchmark results\n\n"
    "Written by the scripts in `benchmarks/` (`make bench` runs them all). Each section says\n"
    "when and on what machine it was measured; rerun a script to refresh its section.\n"
)


def machine() -> str:
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{cpu}, {os.cpu_count()} cores, Python {platform.python_version()}, {platform.system()}"


def write_section(name: str, title: str, body: str, path: Path = RESULTS) -> None:
    """Replace (or append) section ``name`` of RESULTS.md with ``body`` under ``title``."""
    stamp = f"_Measured {_dt.date.today().isoformat()} on {machine()}._"
    block = (
        f"<!-- section:{name} -->\n## {title}\n\n{stamp}\n\n{body.rstrip()}\n"
        f"<!-- /section:{name} -->\n"
    )
    path.touch(exist_ok=True)
    with open(path, "r+", encoding="utf-8") as fh:
        fcntl.flock(fh, fcntl.LOCK_EX)  # two benchmarks finishing together must not interleave
        text = fh.read() or HEADER
        pattern = re.compile(
            rf"<!-- section:{re.escape(name)} -->.*?<!-- /section:{re.escape(name)} -->\n",
            re.S,
        )
        text = pattern.sub(lambda _: block, text) if pattern.search(text) else (
            text.rstrip("\n") + "\n\n" + block
        )
        fh.seek(0)
        fh.write(text)
        fh.truncate()


def markdown_table(header: list[str], rows: list[list[object]]) -> str:
    def cell(x: object) -> str:
        return f"{x:.4g}" if isinstance(x, float) else str(x)

    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(cell(c) for c in row) + " |" for row in rows]
    return "\n".join(lines)


def print_misses(misses: list[str]) -> None:
    """The benchmark's verdict on stdout: each missed target, or that every one was met."""
    print("missed targets:" if misses else "every target met", flush=True)
    for m in misses:
        print(f"  - {m}", flush=True)


def misses_block(misses: list[str]) -> str:
    """The same verdict as the closing block of a RESULTS.md section."""
    if not misses:
        return "Every target met.\n"
    return "Missed targets:\n\n" + "\n".join(f"- {m}" for m in misses) + "\n"
