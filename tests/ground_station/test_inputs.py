"""Validation of bus payloads: well-formed records pass, anything else is a ValueError."""

from __future__ import annotations

import math

import msgpack
import pytest

from fleet_bus.link import LinkRecord
from fleet_bus.telemetry import Event, Status, Truth
from ground_station.inputs import decode, kind_of


def good_status(**kw) -> dict:
    doc = dict(t_s=5.0, id="auv1", state="transit", pos=[1.0, 2.0, -3.0], battery_s=3500.0,
               t_diff_s=10.0, route=[3, 4], treated=[1], cleared_known=1,
               priority_collected=50.0, distance_m=100.0, peers={"auv2": "alive"}, claims=[],
               counters={"sent": 3})
    doc.update(kw)
    return doc


def test_round_trip_of_every_kind():
    truth = Truth(1.0, (1.0, 2.0, -3.0), 45.0, 0.0, "transit")
    assert decode("fleet/truth/auv1", truth.encode()) == ("auv1", truth)
    status = Status(**good_status())
    assert decode("fleet/status/auv1", status.encode())[1].route == [3, 4]
    event = Event(2.0, "auv1", "claim", [3], "auv2", "help")
    assert decode("fleet/event/auv1", event.encode()) == ("auv1", event)
    link = LinkRecord("auv1", "auv2", 1.0, 1.2, 24, False, "range")
    assert decode("fleet/link/auv1/auv2", link.encode()) == ("auv1", link)


@pytest.mark.parametrize("key, payload", [
    ("fleet/truth/auv1", b"\xc1garbage"),
    ("fleet/truth/auv1", msgpack.packb({"t": 1.0, "p": [1.0, 2.0]})),
    ("fleet/truth/auv1", msgpack.packb({"t": math.nan, "p": [1.0, 2.0, 3.0]})),
    ("fleet/status/auv1", msgpack.packb([1, 2, 3])),
    ("fleet/status/auv1", msgpack.packb(good_status(pos=["a", "b", "c"]))),
    ("fleet/status/auv1", msgpack.packb(good_status(route=[1, "x"]))),
    ("fleet/status/auv1", msgpack.packb(good_status(battery_s=math.inf))),
    ("fleet/status/auv1", msgpack.packb(good_status(id="auv2"))),  # impersonation
    ("fleet/status/auv1", msgpack.packb(good_status(counters={"sent": "many"}))),
    ("fleet/event/auv1", msgpack.packb({"t_s": 1.0, "id": "auv1"})),
    ("fleet/event/auv1", Event(1.0, "auv1", "claim", [True]).encode()),
    ("fleet/link/auv1/auv2", LinkRecord("auv2", "auv1", 1.0, 1.0, 1, True, None).encode()),
    ("fleet/link/auv1", LinkRecord("auv1", "auv2", 1.0, 1.0, 1, True, None).encode()),
    ("fleet/tx/auv1", b"anything"),
])
def test_malformed_payloads_are_refused(key, payload):
    with pytest.raises(ValueError):
        decode(key, payload)


def test_kind_of_reads_the_key():
    assert kind_of("fleet/link/a/b") == "link"
    with pytest.raises(ValueError):
        kind_of("other/truth/a")
