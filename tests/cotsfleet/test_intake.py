"""What the operator takes from the bus (`cotsfleet.mission.intake.Intake`): real credentials
and signatures, no session; a sample is only its key and payload."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import msgpack
import numpy as np
import pytest

from cotsfleet.mission.intake import Intake
from fleet_bus import keys
from fleet_bus.credentials import (OPERATOR_ID, RELAY_ID, load_auth, new_run_id,
                                   write_run_credentials)
from fleet_bus.telemetry import Event, Status, encode_busy
from reef_sim.scenarios.field import GeneratorParams, generate_doc
from hfc_core.formats.scenario import problem_from_dict


@dataclass
class _Payload:
    data: bytes

    def to_bytes(self) -> bytes:
        return self.data


@dataclass
class Sample:
    """The two fields of a `zenoh.Sample` the intake reads."""
    key_expr: str
    payload: _Payload


@dataclass
class Fleet:
    intake: Intake
    creds: Path
    busy: list[tuple[str, bool]]
    overheard: list[bytes]

    def put(self, signer: str, key: str, payload: bytes) -> Sample:
        return Sample(key, _Payload(load_auth(self.creds / signer, signer).seal(key, payload)))


@pytest.fixture
def fleet(tmp_path: Path) -> Fleet:
    doc = generate_doc(GeneratorParams(name="intake", n_tasks=8, n_vehicles=2, size_m=400.0,
                                       battery_s=900.0, service_s=60.0),
                       np.random.default_rng(1))
    problem, run_id = problem_from_dict(doc), new_run_id()
    ids = [v.id for v in problem.vehicles]
    busy: list[tuple[str, bool]] = []
    overheard: list[bytes] = []
    intake = Intake(problem, ids, run_id, range(0), lambda vid, b: busy.append((vid, b)),
                    overheard.append)
    creds = tmp_path / "credentials"
    write_run_credentials(creds, ids, run_id)
    intake.auth = load_auth(creds / OPERATOR_ID, OPERATOR_ID)
    return Fleet(intake, creds, busy, overheard)


def status(vid: str, treated: list[int]) -> bytes:
    return Status(t_s=60.0, id=vid, state="transit", pos=(0.0, 0.0, 0.0), battery_s=800.0,
                  t_diff_s=10.0, route=[], treated=treated, cleared_known=len(treated),
                  priority_collected=0.0, distance_m=0.0).encode()


def test_each_kind_of_sample_is_taken_from_its_own_vehicle(fleet: Fleet) -> None:
    intake, tasks = fleet.intake, fleet.intake.problem.tasks
    ready = {"id": "auv1", "run_id": intake.run_id}
    intake.alive(fleet.put("auv1", keys.alive_key("auv1"), msgpack.packb(ready)))
    intake.status(fleet.put("auv1", keys.status_key("auv1"), status("auv1", [tasks[0].id])))
    intake.busy(fleet.put("auv2", keys.busy_key("auv2"), encode_busy(True)))
    assert intake.missing() == ["auv2"] and intake.statuses()["auv1"].treated == [tasks[0].id]
    assert fleet.busy == [("auv2", True)] and intake.refused_counts() == {}


def test_what_does_not_decode_or_speaks_for_another_is_counted_not_taken(fleet: Fleet) -> None:
    intake = fleet.intake
    intake.busy(fleet.put("auv1", keys.busy_key("auv1"), b"\x01\x01"))
    for doc in ({"id": "auv2", "run_id": intake.run_id},  # auv1 announcing auv2
                {"id": "auv1", "run_id": "another-run"}):
        intake.alive(fleet.put("auv1", keys.alive_key("auv1"), msgpack.packb(doc)))
    intake.alive(fleet.put("auv1", keys.alive_key("auv1"), b"\xc1"))
    intake.status(fleet.put("auv1", keys.status_key("auv1"), b"not a status"))
    intake.status(fleet.put("auv1", keys.status_key("auv1"), status("auv2", [])))
    intake.status(fleet.put("auv1", keys.status_key("auv1"), status("auv1", [10**6])))
    unknown = Event(t_s=5.0, id="auv1", kind="cleared", tasks=[10**6]).encode()
    intake.event(fleet.put("auv1", keys.event_key("auv1"), unknown))
    assert intake.refused_counts() == {"invalid": 8}
    assert fleet.busy == [] and intake.missing() == ["auv1", "auv2"]
    assert intake.statuses() == {} and intake.ledger.events == []


def test_a_forged_sender_is_refused_by_the_signature_before_any_decoding(fleet: Fleet) -> None:
    intake = fleet.intake
    forged = {"id": "auv2", "run_id": intake.run_id}  # auv1's key under auv2's name
    intake.alive(fleet.put("auv1", keys.alive_key("auv2"), msgpack.packb(forged)))
    intake.rx(fleet.put("auv1", keys.rx_key("auv2"), b"frame"))  # only the relay delivers
    counts = intake.refused_counts()
    assert "invalid" not in counts and sum(counts.values()) == 2
    assert intake.missing() == ["auv1", "auv2"] and fleet.overheard == []
    intake.rx(fleet.put(RELAY_ID, keys.rx_key("auv2"), b"frame"))
    assert fleet.overheard == [b"frame"]
