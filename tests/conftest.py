"""Shared fixtures. Paths to the shared benchmark data live here so tests never guess them."""

from __future__ import annotations

from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SHARED = REPO.parent / "shared"
TOP_DIR = SHARED / "bench" / "top" / "instances"


@pytest.fixture
def top_dir() -> Path:
    if not TOP_DIR.is_dir():
        pytest.skip(f"shared TOP instances not found at {TOP_DIR}")
    return TOP_DIR
