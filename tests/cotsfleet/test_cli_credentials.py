"""`cotsfleet credentials`: TLS credentials for a mission across hosts, what it says to copy
where, and what it refuses."""

from __future__ import annotations

from pathlib import Path

from cotsfleet.cli import main
from fleet_bus.credentials import load_tls


def test_credentials_for_every_process_and_a_router_per_vehicle_host(tmp_path: Path,
                                                                    capsys) -> None:
    d = tmp_path / "creds"
    assert main(["credentials", str(d), "--vehicles", "2", "--hosts", "10.0.0.5",
                 "ship.local", "--valid-days", "3"]) == 0
    out = capsys.readouterr().out
    assert "(TLS; valid 3 days)" in out
    assert "its router's certificate is for loopback, 10.0.0.5, ship.local" in out
    for vid in ("auv1", "auv2"):
        assert f"vehicle {vid}: copy {d / vid} and {d / ('router-' + vid)} to its host" in out
        assert load_tls(d / f"router-{vid}").info.common_name == f"router-{vid}"
    assert {p.name for p in d.iterdir() if p.is_dir()} == {
        "operator", "relay", "ground", "station", "world", "router", "auv1", "auv2",
        "router-auv1", "router-auv2"}
    assert (f"ground station: copy {d / 'ground'} to its host; there, cotsfleet ctl --connect "
            "tls/HOST:7447 --credentials ground ORDER") in out
    assert load_tls(d / "ground").info.common_name == "ground"
    assert not list(d.rglob("zenoh.login")) and not list(d.rglob("users.txt"))
    assert load_tls(d / "router").info.names("ship.local")
    assert "no --hosts" not in out


def test_refusals(tmp_path: Path, capsys) -> None:
    d = tmp_path / "creds"
    assert main(["credentials", str(d), "--vehicles", "1"]) == 0
    assert "no --hosts: a router elsewhere cannot dial" in capsys.readouterr().out
    assert main(["credentials", str(d), "--vehicles", "1"]) == 2
    assert "exists; credentials are made fresh" in capsys.readouterr().err
    assert main(["credentials", str(tmp_path / "x"), "--vehicles", "1", "--hosts",
                 "not a host"]) == 2
    assert "'not a host' is neither an IP address nor a host name" in capsys.readouterr().err
    assert not (tmp_path / "x").exists()
