"""Fixtures of the ground-station tests: scenario documents."""

from __future__ import annotations

from typing import Any

import pytest

from gs_scripted import small_scenario
from reef_sim.scenarios.field import paper_preset_doc


@pytest.fixture
def small_doc() -> dict[str, Any]:
    return small_scenario()


@pytest.fixture(scope="session")
def paper_doc() -> dict[str, Any]:
    return paper_preset_doc(3)
