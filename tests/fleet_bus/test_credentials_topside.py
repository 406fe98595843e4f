"""The topside modem's key chain in a run's credentials (fleet_bus.credentials): a random seed
in the operator's directory only, its commitment in the public ring that every agent loads;
a ring made before it had one loads with no topside (no live orders), a bad one is refused."""

from __future__ import annotations

import json
import stat
from pathlib import Path

import pytest

from fleet_bus.credentials import (
    CredentialsError,
    load_frame_chains,
    load_frame_seed,
    write_run_credentials,
)
from fleet_bus.tesla import FleetChains, KeyChain

VEHICLES = ("auv1", "auv2", "auv3")


@pytest.fixture()
def creds(tmp_path: Path) -> Path:
    root = tmp_path / "creds"
    write_run_credentials(root, VEHICLES, "run-top")
    return root


def test_the_operator_holds_the_topside_seed_and_every_agent_its_commitment(creds: Path) -> None:
    seed = load_frame_seed(creds / "operator")
    assert stat.S_IMODE((creds / "operator" / "frames.key").stat().st_mode) == 0o600
    for vid in VEHICLES:  # a vehicle holds its own seed, never the topside's
        assert load_frame_seed(creds / vid) != seed
        chains = load_frame_chains(creds / vid, VEHICLES)
        assert chains.topside == KeyChain(seed, chains.length).commitment
        assert chains.topside_seed is None  # issued, not derived: the agents cannot sign
    for other in ("relay", "station", "world", "router"):
        assert not (creds / other / "frames.key").exists()


def test_each_run_draws_a_new_topside_seed(tmp_path: Path) -> None:
    a, b = tmp_path / "a", tmp_path / "b"
    write_run_credentials(a, VEHICLES, "run-same")
    write_run_credentials(b, VEHICLES, "run-same")
    assert load_frame_seed(a / "operator") != load_frame_seed(b / "operator")
    # not the chain a simulation derives from a fleet key either
    assert load_frame_chains(a, VEHICLES).topside != FleetChains.derived(
        b"\x00" * 16, "run-same", 3, 4096).topside


def _edit_ring(creds: Path, edit) -> None:
    ring = json.loads((creds / "ring.json").read_text())
    edit(ring["frames"])
    (creds / "ring.json").write_text(json.dumps(ring))


def test_a_ring_without_a_topside_loads_with_none(creds: Path) -> None:
    _edit_ring(creds, lambda frames: frames.pop("topside"))
    assert load_frame_chains(creds, VEHICLES).topside is None


@pytest.mark.parametrize("bad", ["00", "not hex", 7])
def test_a_malformed_topside_commitment_is_refused_in_one_line(creds: Path, bad) -> None:
    _edit_ring(creds, lambda frames: frames.update(topside=bad))
    with pytest.raises(CredentialsError, match="ring.json"):
        load_frame_chains(creds, VEHICLES)
