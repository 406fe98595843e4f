"""A mission's TLS credentials on disk (fleet_bus.credentials with tls, fleet_bus.certificates):
what each directory holds and nothing more, the certificates' names and lifetimes, and the
mistakes `load_tls` says in one line (another mission's CA, a key that is not the
certificate's, a certificate out of its validity)."""

from __future__ import annotations

import datetime as dt
import ipaddress
import shutil
import stat
from pathlib import Path

import pytest
from cryptography import x509
from cryptography.x509.oid import ExtendedKeyUsageOID

from fleet_bus.certificates import (Authority, CertificateError, check_identity, host_name,
                                    read_certificate)
from fleet_bus.credentials import (CredentialsError, load_auth, load_ring, load_tls, uses_tls,
                                   write_run_credentials)

VEHICLES = ("auv1", "auv2", "auv3")
SIGNERS = ("operator", "relay", "ground", *VEHICLES)


@pytest.fixture(scope="module")
def creds(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("tls") / "creds"
    write_run_credentials(root, VEHICLES, "run-t", tls=True, hosts=("10.0.0.5", "ship.local"),
                          linked_routers=("auv3",), valid_days=2.0)
    return root


def test_each_directory_holds_its_own_secrets_and_no_password(creds: Path) -> None:
    dirs = {p.name for p in creds.iterdir() if p.is_dir()}
    assert dirs == {*SIGNERS, "station", "world", "router", "router-auv3"}
    assert {p.name for p in creds.iterdir() if p.is_file()} == {"ring.json", "ca.pem"}
    public = {"ca.pem", "ring.json", "tls.pem"}
    for d in dirs:
        names = {p.name for p in (creds / d).iterdir()}
        expect = public | {"tls.key"} | ({"signing.key"} if d in SIGNERS else set()) | (
            {"frames.key"} if d in (*VEHICLES, "operator") else set())  # its key chain's
        # seed (`tesla`); the operator's is the topside modem's (live orders)
        assert names == expect, d
        assert stat.S_IMODE((creds / d).stat().st_mode) == 0o700
        for secret in expect - public:
            assert stat.S_IMODE((creds / d / secret).stat().st_mode) == 0o600, (d, secret)
    # The CA's key is nowhere: one private key per directory, and it is the directory's own.
    keys = [p for p in creds.rglob("*") if p.is_file() and b"PRIVATE KEY" in p.read_bytes()]
    assert sorted(p.parent.name for p in keys) == sorted(dirs)
    assert all(p.name == "tls.key" for p in keys)
    assert uses_tls(creds) and uses_tls(creds / "auv1")
    assert load_ring(creds / "router-auv3").run_id == "run-t"
    assert load_auth(creds / "auv3", "auv3").signer is not None


def test_certificates_name_their_process_and_the_router_its_hosts(creds: Path) -> None:
    ca = x509.load_pem_x509_certificate((creds / "ca.pem").read_bytes())
    assert ca.extensions.get_extension_for_class(x509.BasicConstraints).value.ca
    for d in (*SIGNERS, "station", "router", "router-auv3"):
        ident = load_tls(creds / d)  # signed by the CA beside it, its key, valid now
        assert ident.info.common_name == d
        cert = x509.load_pem_x509_certificate(ident.cert.read_bytes())
        cert.verify_directly_issued_by(ca)
        assert not cert.extensions.get_extension_for_class(x509.BasicConstraints).value.ca
        eku = cert.extensions.get_extension_for_class(x509.ExtendedKeyUsage).value
        assert set(eku) == {ExtendedKeyUsageOID.SERVER_AUTH, ExtendedKeyUsageOID.CLIENT_AUTH}
        hosts = set(ident.info.hosts)
        loopback = {"localhost", "127.0.0.1", "::1"}
        assert hosts == (loopback | {"10.0.0.5", "ship.local"} if d == "router" else loopback)
        life = ident.info.not_after - ident.info.not_before
        assert life == dt.timedelta(days=2, hours=1)  # an hour back, for slow clocks
    router = load_tls(creds / "router").info
    assert router.names("10.0.0.5") and router.names("SHIP.local") and router.names("::1")
    assert not router.names("10.0.0.6") and not load_tls(creds / "auv1").info.names("10.0.0.5")


def test_mistakes_are_said_before_zenoh_times_out(creds: Path, tmp_path: Path) -> None:
    mixed = tmp_path / "mixed"
    shutil.copytree(creds / "auv1", mixed)
    shutil.copy(creds / "auv2" / "tls.key", mixed / "tls.key")
    with pytest.raises(CredentialsError, match="not the certificate's"):
        load_tls(mixed)
    other = tmp_path / "other"
    write_run_credentials(other, VEHICLES, tls=True)
    shutil.copy(other / "ca.pem", mixed / "ca.pem")  # another mission's CA
    with pytest.raises(CredentialsError, match="not signed by the CA beside it"):
        load_tls(mixed)
    shutil.rmtree(mixed)
    shutil.copytree(creds / "auv1", mixed)
    (mixed / "tls.pem").unlink()
    with pytest.raises(CredentialsError, match="cannot read .*tls.pem"):
        load_tls(mixed)
    pems = [(creds / "auv1" / n).read_bytes() for n in ("ca.pem", "tls.pem", "tls.key")]
    info = check_identity(*pems)
    with pytest.raises(CertificateError, match="not now"):
        check_identity(*pems, now=info.not_after + dt.timedelta(seconds=1))
    with pytest.raises(CertificateError, match="not now"):
        check_identity(*pems, now=info.not_before - dt.timedelta(seconds=1))
    with pytest.raises(CertificateError, match="not a PEM certificate"):
        check_identity(b"junk", pems[1], pems[2])
    with pytest.raises(CertificateError, match="not a PEM private key"):
        check_identity(pems[0], pems[1], b"junk")


def test_what_cannot_be_made_is_refused_before_anything_is_written(tmp_path: Path) -> None:
    cases = [((("auv1", "router-x"),), {"tls": True}, "cannot have credentials"),
             ((VEHICLES,), {"tls": True, "hosts": ("bad host!",)}, "neither an IP"),
             ((VEHICLES,), {"tls": True, "hosts": ("*.example.org",)}, "neither an IP"),
             ((VEHICLES,), {"tls": True, "linked_routers": ("auv9",)}, "not a vehicle"),
             ((VEHICLES,), {"hosts": ("10.0.0.1",)}, "for TLS credentials"),
             ((VEHICLES,), {"tls": True, "valid_days": 0}, "validity")]
    for i, (args, kwargs, message) in enumerate(cases):
        with pytest.raises(CredentialsError, match=message):
            write_run_credentials(tmp_path / f"c{i}", *args, **kwargs)
        assert not (tmp_path / f"c{i}").exists()


def test_host_names() -> None:
    assert host_name("10.1.2.3") == x509.IPAddress(ipaddress.ip_address("10.1.2.3"))
    assert host_name("[fe80::1]").value.compressed == "fe80::1"
    assert host_name("Ship-1.Local.").value == "ship-1.local"
    for bad in ("", "-ship", "a..b", "x" * 64, "ship_1", "é.org"):
        with pytest.raises(CertificateError):
            host_name(bad)
    with pytest.raises(CertificateError):
        Authority(valid_days=4000)
    issued = Authority(1.0).issue("auv1", ("127.0.0.1",))  # loopback given twice: once
    assert read_certificate(issued.cert_pem).hosts.count("127.0.0.1") == 1
