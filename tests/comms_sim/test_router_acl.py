"""The embedded router with a run's credentials: Zenoh user/password authentication and the
fleet's access control per key expression (fleet_bus.session.access_control), on a real
router process on loopback."""

from __future__ import annotations

import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
import zenoh

from fleet_bus import keys
from fleet_bus.credentials import ZenohLogin, write_run_credentials
from fleet_bus.process import ROUTER_READY
from fleet_bus.session import client_config, free_tcp_endpoint

pytestmark = pytest.mark.integration


@pytest.fixture(scope="module")
def router(tmp_path_factory):
    creds = tmp_path_factory.mktemp("acl") / "c"
    write_run_credentials(creds, ("auv1", "auv2"))
    endpoint = free_tcp_endpoint()
    proc = subprocess.Popen([sys.executable, "-m", "comms_sim.router", "--listen", endpoint,
                             "--credentials", str(creds / "router")],
                            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    assert proc.stdout is not None and proc.stdout.readline().startswith(ROUTER_READY)
    yield endpoint, creds
    proc.terminate()
    proc.wait(10)


def heard(endpoint: str, creds: Path, puts: list[tuple[str, str]]) -> set[tuple[str, str]]:
    """Which (login, key) puts reach a listener (the station's login) through the router."""
    got: set[tuple[str, str]] = set()
    lock = threading.Lock()

    def on(sample: zenoh.Sample) -> None:
        with lock:
            got.add((sample.payload.to_bytes().decode(), str(sample.key_expr)))

    sessions: dict[str, zenoh.Session] = {}
    with zenoh.open(client_config([endpoint], credentials=creds / "station")) as listener, \
            listener.declare_subscriber("fleet/**", on):
        try:
            for who in {w for w, _ in puts}:
                sessions[who] = zenoh.open(client_config([endpoint], credentials=creds / who))
            time.sleep(0.5)
            for who, key in puts:
                sessions[who].put(key, who.encode())
            time.sleep(1.0)
        finally:
            for s in sessions.values():
                s.close()
    return got


def test_each_login_speaks_only_on_its_keys(router) -> None:
    endpoint, creds = router
    allowed = [("operator", keys.ctl_key("auv1")), ("operator", keys.LINK_CTL),
               ("auv1", keys.status_key("auv1")), ("auv1", keys.tx_key("auv1")),
               ("relay", keys.rx_key("auv2")), ("relay", keys.link_event_key("auv1", "auv2")),
               ("ground", keys.ORDER_REQUEST), ("operator", keys.ORDER_REQUEST),
               ("operator", keys.ORDER_ANSWER)]
    denied = [("station", keys.ctl_key("auv1")), ("station", keys.status_key("auv1")),
              ("auv1", keys.status_key("auv2")), ("auv1", keys.ctl_key("auv2")),
              ("auv2", keys.rx_key("auv1")), ("relay", keys.ctl_key("auv1")),
              ("operator", keys.status_key("auv1")), ("station", keys.ORDER_REQUEST),
              ("auv1", keys.ORDER_REQUEST),
              # the remote ground station: order requests only
              ("ground", keys.ctl_key("auv1")), ("ground", keys.LINK_CTL),
              ("ground", keys.ORDER_ANSWER), ("ground", keys.MISSION), ("ground", keys.CLOCK),
              ("ground", keys.tx_key("auv1")), ("ground", keys.status_key("auv1")),
              ("ground", keys.rx_key("auv1")), ("ground", keys.busy_key("auv2"))]
    got = heard(endpoint, creds, allowed + denied)
    assert got == set(allowed)


def test_no_login_without_the_password(router) -> None:
    endpoint, _ = router
    for login in (None, ZenohLogin("auv1", "not-the-password")):
        conf = client_config([endpoint], timeout_s=1.0)
        if login is not None:
            conf.insert_json5("transport/auth/usrpwd",
                              f'{{"user": "{login.user}", "password": "{login.password}"}}')
        with pytest.raises(Exception):
            zenoh.open(conf).close()


def test_ground_hears_the_order_answers_and_nothing_else(router) -> None:
    """``ground`` (`cotsfleet ctl --connect` from another host) subscribes to everything,
    which the router refuses, and to the answers, which it gets; the station hears all."""
    endpoint, creds = router
    got: dict[str, set[str]] = {"all": set(), "answers": set(), "station": set()}
    lock = threading.Lock()

    def on(what: str):
        def put(sample: zenoh.Sample) -> None:
            with lock:
                got[what].add(str(sample.key_expr))
        return put

    said = (keys.ORDER_ANSWER, keys.ctl_key("auv1"), keys.MISSION)
    with zenoh.open(client_config([endpoint], credentials=creds / "ground")) as ground, \
            zenoh.open(client_config([endpoint], credentials=creds / "station")) as station, \
            zenoh.open(client_config([endpoint], credentials=creds / "operator")) as op, \
            zenoh.open(client_config([endpoint], credentials=creds / "auv1")) as auv1, \
            ground.declare_subscriber("fleet/**", on("all")), \
            ground.declare_subscriber(keys.ORDER_ANSWER, on("answers")), \
            station.declare_subscriber("fleet/**", on("station")):
        time.sleep(0.5)
        for key in said:
            op.put(key, b"x")
        auv1.put(keys.status_key("auv1"), b"x")
        time.sleep(1.0)
    # what reaches ground's session is the answers alone (its session then hands them to
    # both its subscribers: "fleet/**" matches too); the station hears everything
    assert got == {"all": {keys.ORDER_ANSWER}, "answers": {keys.ORDER_ANSWER},
                   "station": {*said, keys.status_key("auv1")}}
