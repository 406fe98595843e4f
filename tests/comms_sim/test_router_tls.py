"""The embedded router with a mission's TLS credentials, as real processes on loopback: a
main router and the router of auv2's host linked to it, both mutual TLS. Each process is
known by its certificate: it speaks only on its own keys, and the linked router forwards
only auv2's; whoever has no certificate of the mission (none, another mission's, or plain
TCP) does not get in."""

from __future__ import annotations

import json
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
import zenoh

from fleet_bus import keys
from fleet_bus.credentials import write_run_credentials
from fleet_bus.process import ROUTER_READY
from fleet_bus.session import client_config, free_tcp_endpoint

pytestmark = pytest.mark.integration


def _router(args: list[str]) -> subprocess.Popen:
    proc = subprocess.Popen([sys.executable, "-m", "comms_sim.router", *args],
                            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    assert proc.stdout is not None
    line = proc.stdout.readline()
    assert line.startswith(ROUTER_READY) and "(TLS, by certificate)" in line, line
    return proc


@pytest.fixture(scope="module")
def routers(tmp_path_factory):
    creds = tmp_path_factory.mktemp("tls") / "c"
    write_run_credentials(creds, ("auv1", "auv2"), tls=True, linked_routers=("auv2",))
    main, linked = free_tcp_endpoint(proto="tls"), free_tcp_endpoint(proto="tls")
    procs = [_router(["--listen", main, "--credentials", str(creds / "router")])]
    try:
        procs.append(_router(["--listen", linked, "--connect", main, "--credentials",
                              str(creds / "router-auv2")]))
        time.sleep(1.0)  # the link between them
        yield main, linked, creds
    finally:
        for p in procs:
            p.terminate()
            p.wait(10)


def heard(listener: tuple[str, Path], puts: list[tuple[str, str, str]]) -> set[tuple[str, str]]:
    """Which (who, key) of ``puts`` (who, where they connect, key) reach a listener."""
    got: set[tuple[str, str]] = set()
    lock = threading.Lock()

    def on(sample: zenoh.Sample) -> None:
        with lock:
            got.add((sample.payload.to_bytes().decode(), str(sample.key_expr)))

    sessions: dict[tuple[str, str], zenoh.Session] = {}
    with zenoh.open(client_config([listener[0]], credentials=listener[1])) as s, \
            s.declare_subscriber("fleet/**", on):
        try:
            for who, where, _ in puts:
                if (who, where) not in sessions:
                    sessions[who, where] = zenoh.open(client_config(
                        [where], credentials=listener[1].parent / who))
            time.sleep(1.0)
            for who, where, key in puts:
                sessions[who, where].put(key, who.encode())
            time.sleep(1.0)
        finally:
            for session in sessions.values():
                session.close()
    return got


def test_each_certificate_speaks_only_on_its_keys_across_the_link(routers) -> None:
    main, linked, creds = routers
    allowed = [("operator", main, keys.ctl_key("auv2")), ("relay", main, keys.rx_key("auv2")),
               ("auv1", main, keys.status_key("auv1")), ("auv2", linked, keys.tx_key("auv2")),
               ("auv2", linked, keys.status_key("auv2")), ("ground", main, keys.ORDER_REQUEST)]
    denied = [("station", main, keys.ctl_key("auv1")),
              # the remote ground station's certificate: order requests only
              ("ground", main, keys.ctl_key("auv2")), ("ground", main, keys.LINK_CTL),
              ("ground", main, keys.status_key("auv1")), ("auv1", main, keys.status_key("auv2")),
              ("auv2", linked, keys.status_key("auv1")), ("auv2", linked, keys.ctl_key("auv2")),
              # auv1 may speak as auv1 on auv2's host, but that host's router may forward
              # only what auv2 says: it goes no further than auv2's host
              ("auv1", linked, keys.status_key("auv1"))]
    at_main = heard((main, creds / "station"), allowed + denied)
    assert at_main == {(w, k) for w, _, k in allowed}
    # the other way: what the operator and the relay say on the main router reaches auv2's
    # host, and auv1's own keys too (the main router forwards anything)
    at_linked = heard((linked, creds / "station"), [
        ("operator", main, keys.ctl_key("auv2")), ("relay", main, keys.rx_key("auv2")),
        ("auv1", main, keys.status_key("auv1"))])
    assert at_linked == {("operator", keys.ctl_key("auv2")), ("relay", keys.rx_key("auv2")),
                         ("auv1", keys.status_key("auv1"))}


def _stranger(endpoint: str, tls: dict) -> None:
    conf = zenoh.Config()
    for key, value in (("mode", "client"), ("scouting/multicast/enabled", False),
                       ("connect/endpoints", [endpoint]), ("connect/timeout_ms", 1500),
                       ("transport/link/tls", tls)):
        conf.insert_json5(key, json.dumps(value))
    zenoh.open(conf).close()


def test_no_one_gets_in_without_a_certificate_of_the_mission(routers, tmp_path: Path) -> None:
    main, _, creds = routers
    other = tmp_path / "other"
    write_run_credentials(other, ("auv1", "auv2"), tls=True)
    ca = str(creds / "ca.pem")
    strangers = {
        # it knows the mission's CA (public) but has no certificate
        "no certificate": {"root_ca_certificate": ca},
        # a certificate named auv1, of another mission's CA
        "another mission's": {"root_ca_certificate": ca, "enable_mtls": True,
                              "connect_certificate": str(other / "auv1" / "tls.pem"),
                              "connect_private_key": str(other / "auv1" / "tls.key")}}
    for name, tls in strangers.items():
        with pytest.raises(zenoh.ZError):
            _stranger(main, tls)
            pytest.fail(f"{name} got in")
    with pytest.raises(zenoh.ZError):  # plain TCP to the TLS port
        _stranger(main.replace("tls/", "tcp/"), {})
    # a client that does not know the mission's CA does not take the router's certificate
    with pytest.raises(zenoh.ZError):
        zenoh.open(client_config([main], timeout_s=1.5, credentials=other / "auv1")).close()
    # the same configuration with the mission's own certificate gets in: the strangers were
    # refused for what they lack
    _stranger(main, {**strangers["another mission's"],
                     "connect_certificate": str(creds / "auv1" / "tls.pem"),
                     "connect_private_key": str(creds / "auv1" / "tls.key")})


def test_a_router_given_a_plain_endpoint_says_why_and_exits(routers) -> None:
    _, _, creds = routers
    done = subprocess.run([sys.executable, "-m", "comms_sim.router", "--listen",
                           free_tcp_endpoint(), "--credentials", str(creds / "router")],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 2
    assert "holds TLS credentials: expected a tls/ endpoint" in done.stderr
