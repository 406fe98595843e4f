"""A mission's certificate authority and its certificates, for Zenoh's TLS transport.

One CA per mission signs one certificate per process; the certificate's common name is the
process's id (``operator``, ``relay``, ``station``, ``router``, a vehicle id, ``router-<id>``),
which is what the routers' access control knows it by (Zenoh 1.x ``cert_common_names``
subjects, from the peer certificate of a mutual-TLS link). The CA's private key is used
while the certificates are made and never written: no one can add a certificate to a
mission afterwards, which is also why credentials are made fresh for each mission.

Keys are ECDSA P-256 (ASN.1 PKCS#8 PEM), certificates X.509 v3 after RFC 5280: the CA with
``basicConstraints CA:TRUE, pathlen 0`` and ``keyCertSign``; each leaf with ``CA:FALSE``,
``digitalSignature``, both ``serverAuth`` and ``clientAuth`` (a router listens and dials),
and subject alternative names for the names it is reached at (loopback always; a router's
hosts as given), which rustls checks when a client dials by name or address (Zenoh's
``verify_name_on_connect``). P-256 rather than Ed25519: rustls takes both, but embedded TLS
stacks a vehicle may run (mbedTLS under zenoh-pico) sign and verify P-256, not Ed25519.
"""

from __future__ import annotations

import datetime as dt
import ipaddress
import re
from dataclasses import dataclass
from typing import Sequence

from cryptography import x509
from cryptography.exceptions import InvalidSignature
from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.x509.oid import ExtendedKeyUsageOID, NameOID

LOOPBACK_NAMES = ("localhost", "127.0.0.1", "::1")
# Certificates start an hour in the past, so that a host whose clock is a little behind the
# one that made them still takes them (a host far off fails with "not yet valid").
BACKDATE = dt.timedelta(hours=1)
_DNS_LABEL = re.compile(r"(?!-)[A-Za-z0-9-]{1,63}(?<!-)")


class CertificateError(ValueError):
    """A host name that cannot be put in a certificate, or a certificate that cannot be read."""


@dataclass(frozen=True)
class Issued:
    """A private key and its certificate, as PEM text."""

    key_pem: bytes
    cert_pem: bytes


def _name(common_name: str) -> x509.Name:
    return x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, common_name)])


def host_name(host: str) -> x509.GeneralName:
    """A subject alternative name for ``host``: an IP address, or a DNS name (ASCII, after
    RFC 1123; a leading ``*.`` label is refused: a mission's certificates name real hosts)."""
    try:
        return x509.IPAddress(ipaddress.ip_address(host.strip("[]")))
    except ValueError:
        pass
    labels = host.rstrip(".").split(".")
    if len(host) > 253 or not all(_DNS_LABEL.fullmatch(label) for label in labels):
        raise CertificateError(f"{host!r} is neither an IP address nor a host name")
    return x509.DNSName(host.rstrip(".").lower())


class Authority:
    """A mission's CA, in memory only. ``valid_days`` bounds every certificate it signs."""

    def __init__(self, valid_days: float, now: dt.datetime | None = None) -> None:
        if not 0 < valid_days <= 3650:
            raise CertificateError(f"validity must be in (0, 3650] days, got {valid_days}")
        self.not_before = (now or dt.datetime.now(dt.timezone.utc)) - BACKDATE
        self.not_after = self.not_before + BACKDATE + dt.timedelta(days=valid_days)
        self._key = ec.generate_private_key(ec.SECP256R1())
        subject = _name("cotsfleet mission CA")
        public = self._key.public_key()
        self.cert = (
            x509.CertificateBuilder().subject_name(subject).issuer_name(subject)
            .public_key(public).serial_number(x509.random_serial_number())
            .not_valid_before(self.not_before).not_valid_after(self.not_after)
            .add_extension(x509.BasicConstraints(ca=True, path_length=0), critical=True)
            .add_extension(x509.KeyUsage(
                digital_signature=False, content_commitment=False, key_encipherment=False,
                data_encipherment=False, key_agreement=False, key_cert_sign=True,
                crl_sign=True, encipher_only=False, decipher_only=False), critical=True)
            .add_extension(x509.SubjectKeyIdentifier.from_public_key(public), critical=False)
            .sign(self._key, hashes.SHA256()))

    @property
    def cert_pem(self) -> bytes:
        return self.cert.public_bytes(serialization.Encoding.PEM)

    def issue(self, common_name: str, hosts: Sequence[str] = ()) -> Issued:
        """A key and a certificate for ``common_name``, valid at loopback and at ``hosts``."""
        names: list[x509.GeneralName] = []
        for host in (*LOOPBACK_NAMES, *hosts):
            name = host_name(host)
            if name not in names:
                names.append(name)
        key = ec.generate_private_key(ec.SECP256R1())
        cert = (
            x509.CertificateBuilder().subject_name(_name(common_name))
            .issuer_name(self.cert.subject).public_key(key.public_key())
            .serial_number(x509.random_serial_number())
            .not_valid_before(self.not_before).not_valid_after(self.not_after)
            .add_extension(x509.BasicConstraints(ca=False, path_length=None), critical=True)
            .add_extension(x509.KeyUsage(
                digital_signature=True, content_commitment=False, key_encipherment=False,
                data_encipherment=False, key_agreement=False, key_cert_sign=False,
                crl_sign=False, encipher_only=False, decipher_only=False), critical=True)
            .add_extension(x509.ExtendedKeyUsage([ExtendedKeyUsageOID.SERVER_AUTH,
                                                  ExtendedKeyUsageOID.CLIENT_AUTH]),
                           critical=False)
            .add_extension(x509.SubjectAlternativeName(names), critical=False)
            .add_extension(x509.AuthorityKeyIdentifier.from_issuer_public_key(
                self._key.public_key()), critical=False)
            .sign(self._key, hashes.SHA256()))
        return Issued(key.private_bytes(serialization.Encoding.PEM,
                                        serialization.PrivateFormat.PKCS8,
                                        serialization.NoEncryption()),
                      cert.public_bytes(serialization.Encoding.PEM))


@dataclass(frozen=True)
class CertificateInfo:
    """What a process needs to know of its own certificate before it tries to use it."""

    common_name: str
    hosts: tuple[str, ...]  # subject alternative names, as text
    not_before: dt.datetime
    not_after: dt.datetime
    issuer: str

    def names(self, host: str) -> bool:
        """Whether a client that dials ``host`` will take this certificate."""
        try:
            wanted = host_name(host)
        except CertificateError:
            return False
        return any(host_name(h) == wanted for h in self.hosts)


def _info(cert: x509.Certificate) -> CertificateInfo:
    cns = cert.subject.get_attributes_for_oid(NameOID.COMMON_NAME)
    try:
        sans = cert.extensions.get_extension_for_class(x509.SubjectAlternativeName).value
        hosts = tuple(str(v) for v in sans.get_values_for_type(x509.IPAddress)) + tuple(
            sans.get_values_for_type(x509.DNSName))
    except x509.ExtensionNotFound:
        hosts = ()
    return CertificateInfo(str(cns[0].value) if cns else "", hosts, cert.not_valid_before_utc,
                           cert.not_valid_after_utc, cert.issuer.rfc4514_string())


def _load(pem: bytes, what: str) -> x509.Certificate:
    try:
        return x509.load_pem_x509_certificate(pem)
    except ValueError as exc:
        raise CertificateError(f"{what}: not a PEM certificate ({exc})") from None


def check_identity(ca_pem: bytes, cert_pem: bytes, key_pem: bytes,
                   now: dt.datetime | None = None) -> CertificateInfo:
    """The certificate of a process's directory, checked as its peers will check it, so that
    a mistake is said in one line before Zenoh says "timeout": signed by the directory's CA
    (not another mission's), holding the directory's key, and valid now."""
    ca, cert = _load(ca_pem, "CA certificate"), _load(cert_pem, "certificate")
    try:
        cert.verify_directly_issued_by(ca)
    except (ValueError, TypeError, InvalidSignature):
        raise CertificateError("certificate not signed by the CA beside it (another "
                               "mission's?)") from None
    try:
        key = serialization.load_pem_private_key(key_pem, password=None)
    except (ValueError, TypeError) as exc:
        raise CertificateError(f"not a PEM private key ({exc})") from None
    if key.public_key() != cert.public_key():
        raise CertificateError("the private key is not the certificate's")
    info = _info(cert)
    now = now or dt.datetime.now(dt.timezone.utc)
    if not info.not_before <= now <= info.not_after:
        raise CertificateError(f"certificate valid from {info.not_before:%Y-%m-%d %H:%M} to "
                               f"{info.not_after:%Y-%m-%d %H:%M} UTC, not now "
                               f"({now:%Y-%m-%d %H:%M} UTC on this host's clock)")
    return info


def read_certificate(pem: bytes) -> CertificateInfo:
    return _info(_load(pem, "certificate"))
