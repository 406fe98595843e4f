"""What the launcher takes from the bus (`ProcessBackend._from_fleet` and its four handlers):
real credentials and signatures, no session; a sample is only its key and payload."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import msgpack
import numpy as np
import pytest

from cotsfleet.mission.processes import ProcessBackend, ProcessOptions
from fleet_bus import keys
from fleet_bus.credentials import OPERATOR_ID, load_auth, write_run_credentials
from fleet_bus.telemetry import encode_busy
from hfc_core.generate import GeneratorParams, generate_doc
from hfc_core.scenario import problem_from_dict


@dataclass
class _Payload:
    data: bytes

    def to_bytes(self) -> bytes:
        return self.data


@dataclass
class Sample:
    """The two fields of a `zenoh.Sample` the launcher reads."""
    key_expr: str
    payload: _Payload


@pytest.fixture
def launcher(tmp_path: Path) -> tuple[ProcessBackend, Path]:
    doc = generate_doc(GeneratorParams(name="intake", n_tasks=8, n_vehicles=2, size_m=400.0,
                                       battery_s=900.0, service_s=60.0),
                       np.random.default_rng(1))
    backend = ProcessBackend(problem_from_dict(doc), doc, 0,
                             ProcessOptions(run_dir=tmp_path / "run"), out=lambda line: None)
    creds = tmp_path / "credentials"
    write_run_credentials(creds, backend.ids, backend.run_id)
    backend.auth = load_auth(creds / OPERATOR_ID, OPERATOR_ID)
    return backend, creds


def signed(creds: Path, signer: str, key: str, payload: bytes) -> Sample:
    return Sample(key, _Payload(load_auth(creds / signer, signer).seal(key, payload)))


def test_a_vehicles_busy_flag_holds_the_clock_and_its_end_releases_it(launcher) -> None:
    backend, creds = launcher
    backend._on_busy(signed(creds, "auv1", keys.busy_key("auv1"), encode_busy(True)))
    assert backend.pacer.holds.held and backend.pacer.holds.count == 1
    backend._on_busy(signed(creds, "auv1", keys.busy_key("auv1"), encode_busy(False)))
    assert not backend.pacer.holds.held and backend.refused == {}


def test_what_does_not_decode_or_speaks_for_another_vehicle_is_counted_not_taken(
        launcher) -> None:
    backend, creds = launcher
    backend._on_busy(signed(creds, "auv1", keys.busy_key("auv1"), b"\x01\x01"))
    ready = {"id": "auv2", "run_id": backend.run_id}  # auv1 announcing auv2
    backend._on_alive(signed(creds, "auv1", keys.alive_key("auv1"), msgpack.packb(ready)))
    stale = {"id": "auv1", "run_id": "another-run"}
    backend._on_alive(signed(creds, "auv1", keys.alive_key("auv1"), msgpack.packb(stale)))
    backend._on_alive(signed(creds, "auv1", keys.alive_key("auv1"), b"\xc1"))
    backend._on_status(signed(creds, "auv1", keys.status_key("auv1"), b"not a status"))
    assert backend.refused == {"invalid": 5}
    assert not backend.pacer.holds.held and backend._alive == set()


def test_a_ready_vehicle_is_taken_and_a_forged_one_is_refused_by_the_signature(
        launcher) -> None:
    backend, creds = launcher
    ok = {"id": "auv1", "run_id": backend.run_id}
    backend._on_alive(signed(creds, "auv1", keys.alive_key("auv1"), msgpack.packb(ok)))
    forged = {"id": "auv2", "run_id": backend.run_id}  # auv1's key under auv2's name
    backend._on_alive(signed(creds, "auv1", keys.alive_key("auv2"), msgpack.packb(forged)))
    assert backend._alive == {"auv1"}
    assert "invalid" not in backend.refused  # the verifier refused it before any decoding
    assert sum(backend.auth.verifier.refused.values()) == 1
