"""`benchmarks.fleet_scale`'s part (b) waits for its agents as long as their plans need on this
machine, never less than `cotsfleet run`'s default."""

from __future__ import annotations

import os

from benchmarks.fleet_scale import startup_wait_s
from cotsfleet.mission.processes import startup_timeout_for


def test_the_startup_wait_is_the_default_for_a_quick_plan_and_grows_with_a_slow_one() -> None:
    cores = os.cpu_count() or 1
    assert startup_wait_s(24, 0.1) == startup_timeout_for(24)
    slow = 31.0 * cores  # each agent's plan: the wait covers 24 of them on these cores twice
    assert startup_wait_s(24, slow) == 60.0 + 2.0 * 24 * 31.0
    assert startup_wait_s(24, slow) > startup_timeout_for(24)
