"""Progress with an ETA on stderr for work done in steps (planner modes, Monte Carlo runs).

On a terminal: a tqdm bar naming the step under way and the last result. Elsewhere (a pipe,
a CI log), where a redrawn bar would pile up as one long line: one plain line per finished
step with the elapsed time and the ETA. Either way stdout stays for results.
"""

from __future__ import annotations

import sys
import time
from typing import IO, Any

from tqdm import tqdm


class Progress:
    """``with Progress(5, "compare", "mode") as p: p.start("ga"); ...; p.done("ga", "49/90")``."""

    def __init__(self, total: int, what: str, unit: str = "step",
                 stream: IO[str] | None = None) -> None:
        self.total, self.what, self.unit = total, what, unit
        self.stream = stream if stream is not None else sys.stderr
        self.count = 0
        self._t0 = time.monotonic()
        self._bar: Any = None
        if _is_tty(self.stream):
            self._bar = tqdm(total=total, desc=what, unit=unit, file=self.stream, leave=False,
                             bar_format="{desc}: {n}/{total} {unit}s |{bar}| "
                                        "{elapsed}<{remaining}{postfix}")

    def start(self, label: str) -> None:
        """Say which step is under way (shown on the bar; a plain log waits for the result)."""
        if self._bar is not None:
            self._bar.set_description_str(f"{self.what}: {label}")

    def done(self, label: str, note: str = "") -> None:
        self.count += 1
        if self._bar is not None:
            self._bar.set_postfix_str(f"{label} {note}".strip())
            self._bar.update(1)
            return
        elapsed = time.monotonic() - self._t0
        eta = elapsed / self.count * (self.total - self.count)
        print(f"{self.what}: {self.count}/{self.total} {label} {note} "
              f"[{tqdm.format_interval(elapsed)} elapsed, ETA {tqdm.format_interval(eta)}]"
              .replace("  ", " "), file=self.stream, flush=True)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None

    def __enter__(self) -> "Progress":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _is_tty(stream: IO[str]) -> bool:
    try:
        return stream.isatty()
    except (AttributeError, ValueError):
        return False
