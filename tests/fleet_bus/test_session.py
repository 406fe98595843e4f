"""The fleet's Zenoh configurations (fleet_bus.session) without a network: endpoints and
the transport they name, which credentials take which endpoints, the TLS section and the
access control by certificate."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from fleet_bus.credentials import CredentialsError, write_run_credentials
from fleet_bus.session import (access_control, client_config, is_loopback, router_config,
                               split_endpoint, with_protocol)

VEHICLES = ("auv1", "auv2")


@pytest.fixture(scope="module")
def creds(tmp_path_factory) -> tuple[Path, Path]:
    root = tmp_path_factory.mktemp("session")
    write_run_credentials(root / "tls", VEHICLES, tls=True, linked_routers=("auv2",))
    write_run_credentials(root / "plain", VEHICLES)
    return root / "tls", root / "plain"


def test_endpoints() -> None:
    assert split_endpoint("tls/10.0.0.1:7447") == ("tls", "10.0.0.1", "7447")
    assert split_endpoint("0.0.0.0:7447") == ("", "0.0.0.0", "7447")
    assert split_endpoint("tcp/[::1]:7447#iface=lo") == ("tcp", "::1", "7447")
    assert [is_loopback(h) for h in ("127.0.0.2", "::1", "localhost", "0.0.0.0", "10.0.0.1",
                                     "ship.local")] == [True, True, True, False, False, False]
    assert with_protocol("0.0.0.0:7447", tls=True) == "tls/0.0.0.0:7447"
    assert with_protocol("127.0.0.1:7447", tls=False) == "tcp/127.0.0.1:7447"
    assert with_protocol("tls/127.0.0.1:7447", tls=True) == "tls/127.0.0.1:7447"
    with pytest.raises(ValueError, match="across machines the bus is TLS; use tls/0.0.0.0:7447"):
        with_protocol("tcp/0.0.0.0:7447", tls=True)
    with pytest.raises(ValueError, match=r"use tls/\[::1\]:7447"):
        with_protocol("tcp/[::1]:7447", tls=True)


def test_tls_credentials_take_tls_endpoints_and_plain_ones_stay_on_loopback(creds) -> None:
    tls, plain = creds
    with pytest.raises(CredentialsError, match="expected a tls/ endpoint"):
        client_config(["tcp/127.0.0.1:7447"], credentials=tls / "auv1")
    with pytest.raises(CredentialsError, match="expected a tls/ endpoint"):
        router_config(["tls/0.0.0.0:7447", "tcp/127.0.0.1:7448"], credentials=tls / "router")
    with pytest.raises(CredentialsError, match="loopback TCP only"):
        client_config(["tcp/10.0.0.1:7447"], credentials=plain / "auv1")
    with pytest.raises(CredentialsError, match="loopback TCP only"):
        router_config(["tcp/0.0.0.0:7447"], credentials=plain / "router")
    with pytest.raises(CredentialsError, match="loopback TCP only"):
        client_config(["tls/127.0.0.1:7447"], credentials=plain / "auv1")
    client_config(["tcp/127.0.0.1:7447"], credentials=plain / "auv1")


def test_a_tls_client_shows_its_certificate_and_trusts_the_missions_ca(creds) -> None:
    tls, _ = creds
    conf = json.loads(str(client_config(["tls/10.0.0.1:7447"], credentials=tls / "auv1")))
    link = conf["transport"]["link"]["tls"]
    assert link["enable_mtls"] is True and link["verify_name_on_connect"] is True
    assert link["root_ca_certificate"] == str((tls / "auv1" / "ca.pem").resolve())
    assert link["connect_certificate"] == str((tls / "auv1" / "tls.pem").resolve())
    assert link["listen_private_key"] is None  # a client does not listen
    assert conf["transport"]["auth"]["usrpwd"]["user"] is None  # no password anywhere
    router = json.loads(str(router_config(["tls/0.0.0.0:7447"], credentials=tls / "router")))
    link = router["transport"]["link"]["tls"]
    assert link["listen_certificate"] == str((tls / "router" / "tls.pem").resolve())
    assert router["access_control"]["enabled"] is True


def test_access_control_by_certificate_gives_a_linked_router_its_vehicles_rights() -> None:
    acl = access_control(VEHICLES, by_certificate=True)
    subjects = {s["id"]: s for s in acl["subjects"]}
    assert subjects["vehicle auv2"] == {"id": "vehicle auv2",
                                        "cert_common_names": ["auv2", "router-auv2"]}
    assert subjects["operator"] == {"id": "operator", "cert_common_names": ["operator"]}
    assert subjects["router"] == {"id": "router", "cert_common_names": ["router"]}
    assert "usernames" not in json.dumps(acl)
    rules = {r["id"]: r for r in acl["rules"]}
    assert rules["vehicle auv2"]["key_exprs"] == [
        f"fleet/{k}/auv2" for k in ("tx", "truth", "status", "event", "alive", "busy")]
    plain = access_control(VEHICLES)
    assert {s["id"]: s for s in plain["subjects"]}["vehicle auv2"] == {
        "id": "vehicle auv2", "usernames": ["auv2"]}
