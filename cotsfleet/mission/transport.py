"""Which transport a mission's bus runs on: TLS across machines, plain TCP on one host.

A router that listens on anything but loopback is reached from other machines, so its bus
is TLS, with no flag to ask for it; so is any bus whose credentials were made with
certificates (`cotsfleet credentials`), and any with ``--tls``. A mission on loopback alone
stays on TCP with per-process logins by default: only root can read loopback traffic, and
root can read every key file as well (docs/security.md), so TLS there would hide nothing
from anyone the threat model leaves in; ``--tls`` is there for those who want one
configuration everywhere (its cost is measured in docs/security.md).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from fleet_bus.credentials import ROUTER_ID, load_tls, uses_tls
from fleet_bus.session import is_loopback, local_endpoint, split_endpoint, with_protocol

WILDCARDS = ("0.0.0.0", "::", "")


@dataclass(frozen=True)
class Transport:
    tls: bool
    listen: str | None  # the router's endpoint, with its protocol (None: a free loopback port)
    hosts: tuple[str, ...] = ()  # names the router's certificate carries beyond loopback

    @property
    def protocol(self) -> str:
        return "tls" if self.tls else "tcp"


def choose_transport(listen: str | None, tls: bool, credentials: Path | None) -> Transport:
    """The bus of a mission that listens on ``listen`` (``HOST:PORT`` or with a protocol),
    asked for ``tls`` or not, with ``credentials`` made beforehand or fresh ones (None).
    Refused, with the reason: plain TCP off loopback, plain credentials for a TLS bus, and
    TLS credentials whose router certificate does not name the address listened on."""
    host = split_endpoint(listen)[1] if listen else "127.0.0.1"
    premade_tls = credentials is not None and uses_tls(credentials)
    tls = (tls or premade_tls or not is_loopback(host)
           or (listen is not None and split_endpoint(listen)[0] == "tls"))
    if credentials is not None and tls and not premade_tls:
        raise ValueError(f"{credentials} holds plain logins, for a bus on loopback only; a "
                         "TLS bus needs credentials made by `cotsfleet credentials`")
    if listen is not None:
        listen = with_protocol(listen, tls)
    if premade_tls:
        assert credentials is not None
        # Checked now, not by a router that would die of it: the CA, the key, the dates
        # (every certificate of a mission shares them) and the names.
        info = load_tls(credentials / ROUTER_ID).info
        local = split_endpoint(local_endpoint(listen))[1] if listen else "127.0.0.1"
        if not info.names(local):
            raise ValueError(f"the router's certificate in {credentials} is for "
                             f"{', '.join(info.hosts)}, not {local}: make the credentials "
                             f"with --hosts {local}")
    hosts = () if premade_tls or host in WILDCARDS or is_loopback(host) else (host,)
    return Transport(tls, listen, hosts)
