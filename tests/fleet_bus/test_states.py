"""The contract's names, once (`fleet_bus.states`): every word on the bus and in report.json
comes from an enum and is still that word."""

from __future__ import annotations

import json

import msgpack
import numpy as np

from cotsfleet.mission.faults import ATTACKS, FAULT_KINDS, VEHICLE_FAULTS
from fleet_agent.wire import Codec, WireError
from fleet_bus.states import DropReason, EventKind, FaultKind, VehicleState
from fleet_bus.telemetry import EVENT_KINDS


def test_the_kinds_are_the_enums_words() -> None:
    assert EVENT_KINDS == tuple(k.value for k in EventKind)
    assert FAULT_KINDS == tuple(k.value for k in FaultKind)
    assert set(VEHICLE_FAULTS) | set(ATTACKS) | {"loss", "ctl"} == set(FAULT_KINDS)


def test_a_member_travels_as_its_word() -> None:
    doc = {"state": VehicleState.HOME, "kind": EventKind.REJOINED}
    assert json.dumps(doc) == '{"state": "home", "kind": "rejoined"}'
    assert msgpack.unpackb(msgpack.packb(doc)) == {"state": "home", "kind": "rejoined"}


def test_every_reason_the_codec_refuses_for_is_a_drop_reason() -> None:
    codec = Codec(bytes(16), "run", 3, 90)
    rng = np.random.default_rng(0)
    reasons = set()
    for n in range(400):
        try:
            codec.unseal(rng.bytes(int(rng.integers(0, 80))))
        except WireError as exc:
            reasons.add(exc.reason)
    assert reasons and reasons <= {r.value for r in DropReason}
