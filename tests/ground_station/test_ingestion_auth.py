"""The ground station's ingestion under forgery: the subscriber's inbox opens envelopes with
the run's ring (the station holds no signing key), refuses what a key's rightful sender did
not sign before it takes a queue slot, and the station keeps state only for the roster,
counting every refusal on its dashboard."""

from __future__ import annotations

from pathlib import Path

from fleet_bus import keys
from fleet_bus.credentials import load_auth, write_run_credentials
from fleet_bus.link import LinkRecord
from fleet_bus.telemetry import Truth
from gs_scripted import mission_of, small_scenario
from ground_station.blueprint import live_blueprint
from ground_station.rerun_log import legend_bounds
from ground_station.station import APPLICATION_ID, GroundStation, mission_layers
from ground_station.subscriber import Inbox
from ground_station.viewer import ViewerOptions, open_recording


def test_forgeries_never_reach_the_picture(tmp_path: Path) -> None:
    write_run_credentials(tmp_path / "c", ("auv1", "auv2", "auv3"))
    auth = load_auth(tmp_path / "c" / "station")
    auv1 = load_auth(tmp_path / "c" / "auv1", "auv1")
    relay = load_auth(tmp_path / "c" / "relay", "relay")
    inbox = Inbox(maxsize=100, auth=auth)
    truth = Truth(1.0, (5.0, 5.0, 0.0)).encode()
    inbox.offer(keys.truth_key("auv1"), auv1.seal(keys.truth_key("auv1"), truth))
    inbox.offer(keys.truth_key("auv2"), auv1.seal(keys.truth_key("auv2"), truth))
    inbox.offer(keys.truth_key("auv1"), truth)  # unsigned
    for _ in range(500):  # a flood: refused before the bounded queue
        inbox.offer(keys.status_key("auv3"), b"\x00" * 40)
    link = keys.link_event_key("auv1", "auv9")
    # a genuine relay's record about an unknown vehicle
    inbox.offer(link, relay.seal(link, LinkRecord("auv1", "auv9", 1.0, 1.0, 10, True).encode()))
    assert inbox.overflow == 0
    refused = inbox.take_refused()
    assert refused == {"not_allowed": 1, "malformed": 501}

    mission = mission_of(small_scenario())
    layers = mission_layers(mission)
    sinks = open_recording(APPLICATION_ID, "r", ViewerOptions("none", tmp_path / "x.rrd"),
                           live_blueprint(layers[0].bounds, legend_bounds(layers[0])))
    station = GroundStation(mission, sinks.rec, layers)
    taken = []
    while (item := inbox.get(0.01)) is not None:
        taken.append(station.handle(*item))
    for reason, n in refused.items():
        station.refused(reason, n)
    station.close()
    sinks.close()
    assert taken == [True, False]  # auv1's truth; the link to a vehicle not in the roster
    assert station.dropped["unknown_vehicle"] == 1
    assert station.dropped["auth_malformed"] == 501 and station.dropped["auth_not_allowed"] == 1
    assert set(station.picture.vehicles) <= {"auv1", "auv2", "auv3"}
