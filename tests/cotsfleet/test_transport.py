"""Which transport a mission's bus runs on (cotsfleet.mission.transport): TLS off loopback
with no flag, with TLS credentials, with --tls; plain TCP on loopback by default; the
combinations that cannot work refused with their reason."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from cotsfleet.mission.transport import Transport, choose_transport
from fleet_bus.credentials import CredentialsError, write_run_credentials


@pytest.fixture(scope="module")
def creds(tmp_path_factory) -> tuple[Path, Path]:
    root = tmp_path_factory.mktemp("transport")
    write_run_credentials(root / "tls", ("auv1",), tls=True, hosts=("10.0.0.5",))
    write_run_credentials(root / "plain", ("auv1",))
    return root / "tls", root / "plain"


def test_loopback_stays_plain_unless_asked() -> None:
    assert choose_transport(None, False, None) == Transport(False, None)
    assert choose_transport("127.0.0.1:7447", False, None) == Transport(False,
                                                                         "tcp/127.0.0.1:7447")
    assert choose_transport(None, True, None) == Transport(True, None)
    assert choose_transport("tls/127.0.0.1:7447", False, None).tls
    assert choose_transport(None, True, None).protocol == "tls"


def test_off_loopback_the_bus_is_tls_without_a_flag() -> None:
    assert choose_transport("0.0.0.0:7447", False, None) == Transport(True, "tls/0.0.0.0:7447")
    # fresh credentials name the address listened on
    assert choose_transport("10.0.0.7:7447", False, None) == Transport(
        True, "tls/10.0.0.7:7447", ("10.0.0.7",))
    with pytest.raises(ValueError, match="across machines the bus is TLS"):
        choose_transport("tcp/0.0.0.0:7447", False, None)


def test_credentials_made_beforehand_decide_and_are_checked(creds) -> None:
    tls, plain = creds
    assert choose_transport(None, False, tls) == Transport(True, None)
    assert choose_transport("0.0.0.0:7447", False, tls) == Transport(True, "tls/0.0.0.0:7447")
    assert choose_transport("10.0.0.5:7447", False, tls).listen == "tls/10.0.0.5:7447"
    with pytest.raises(ValueError, match="is for 127.0.0.1, ::1, 10.0.0.5, localhost, not "
                                         "10.0.0.9: make the credentials with --hosts 10.0.0.9"):
        choose_transport("10.0.0.9:7447", False, tls)
    with pytest.raises(ValueError, match="the bus is TLS here"):
        choose_transport("tcp/127.0.0.1:7447", False, tls)
    assert choose_transport("127.0.0.1:7447", False, plain) == Transport(
        False, "tcp/127.0.0.1:7447")
    for listen, flag in (("0.0.0.0:7447", False), (None, True)):
        with pytest.raises(ValueError, match="holds plain logins"):
            choose_transport(listen, flag, plain)


def test_credentials_that_cannot_work_are_refused_before_a_router_dies_of_them(
        creds, tmp_path: Path) -> None:
    tls, _ = creds
    broken = tmp_path / "broken"
    shutil.copytree(tls, broken)
    shutil.copy(tls / "auv1" / "tls.key", broken / "router" / "tls.key")
    with pytest.raises(CredentialsError, match="not the certificate's"):
        choose_transport(None, False, broken)
