"""Zenoh configuration shared by every process of the fleet.

Multicast scouting is off everywhere: the processes of one mission find each other through
explicit endpoints, so two missions (or two test runs) on one machine never mix.

Identity on the bus comes from the process's credentials directory (`fleet_bus.credentials`):
with TLS credentials, mutual TLS (Zenoh 1.x ``transport/link/tls``: every link encrypted,
the router and each client show a certificate of the mission's CA, and the access control
knows each by its certificate's common name); with plain credentials, a Zenoh user/password
login over TCP, which this module allows on loopback only. Across machines the bus is TLS.
"""

from __future__ import annotations

import ipaddress
import json
import socket
from pathlib import Path
from typing import Any, Sequence

import zenoh

from fleet_bus import keys
from fleet_bus.credentials import (GROUND_ID, OPERATOR_ID, RELAY_ID, ROUTER_ID, ROUTER_USERS,
                                   STATION_ID, WORLD_ID, CredentialsError, TlsIdentity,
                                   ZenohLogin, linked_router_id, load_login, load_ring,
                                   load_router_zid, load_tls, uses_tls)

DEFAULT_ENDPOINT = "tcp/127.0.0.1:7447"
_EVERY_MESSAGE = ["put", "delete", "declare_subscriber", "query", "reply", "declare_queryable",
                  "liveliness_token", "declare_liveliness_subscriber", "liveliness_query"]
_LISTEN = ["declare_subscriber", "query", "declare_liveliness_subscriber", "liveliness_query"]


def _base(mode: str) -> zenoh.Config:
    conf = zenoh.Config()
    conf.insert_json5("mode", json.dumps(mode))
    conf.insert_json5("scouting/multicast/enabled", "false")
    return conf


def _login(conf: zenoh.Config, login: ZenohLogin, dictionary: Path | None = None) -> None:
    usrpwd: dict[str, str] = {"user": login.user, "password": login.password}
    if dictionary is not None:
        usrpwd["dictionary_file"] = str(dictionary)
    conf.insert_json5("transport/auth/usrpwd", json.dumps(usrpwd))


def access_control(vehicles: Sequence[str], upstream_zid: str | None = None,
                   by_certificate: bool = False) -> dict[str, Any]:
    """Zenoh 1.x ``access_control`` of the fleet's router: every process of the mission may
    listen (the ground station, any process) but ``ground``, a ground station elsewhere that
    may only put order requests and hear their answers; only the operator may command, serve
    the mission and clock records and control the link; only the relay may deliver, report
    link fates and serve link stats; only vehicle X may speak on ``fleet/*/X``; the main
    router may
    forward anything (a router linked to it sees it as a peer that carries the operator's
    host), and so may, on plain logins, any router logging in as ``router`` and the main
    router's id (``upstream_zid``). Everything else is denied.

    Subjects are logins (``usernames``), or with ``by_certificate`` the common names of the
    TLS certificates (``cert_common_names``). With certificates a linked router is known
    apart: ``router-X``, the router of vehicle X's host, may forward only what X may say (a
    stolen remote host is worth no more on the bus than its vehicle)."""
    def rule(rid: str, messages: list[str], key_exprs: list[str],
             flows: tuple[str, ...] = ("ingress",)) -> dict[str, Any]:
        return {"id": rid, "permission": "allow", "flows": list(flows), "messages": messages,
                "key_exprs": key_exprs}

    def subject(sid: str, *names: str) -> dict[str, Any]:
        return {"id": sid, ("cert_common_names" if by_certificate else "usernames"): list(names)}

    p = keys.PREFIX
    rules = [rule("egress", _EVERY_MESSAGE, ["**"], ("egress",)),
             rule("listen", _LISTEN, [f"{p}/**"]),
             rule("forward", _EVERY_MESSAGE, ["**"]),
             rule("operator", ["put", "declare_queryable", "reply"],
                  [f"{p}/ctl/**", keys.MISSION, keys.CLOCK]),
             rule("relay", ["put", "declare_queryable", "reply"],
                  [f"{p}/rx/*", f"{p}/link/**", keys.LINK_STATS]),
             # `cotsfleet ctl --connect`: its requests in, the launcher's answers out
             rule("ground", ["put"], [keys.ORDER_REQUEST]),
             rule("ground answers", ["declare_subscriber"], [keys.ORDER_ANSWER])]
    # Who may listen: every identity of the mission but ``ground`` (a subject with no
    # attribute would match it too, and Zenoh has no "all but"; a deny rule would also take
    # the answers away: its deny wins over any allow on keys it includes).
    listeners = [ROUTER_ID, OPERATOR_ID, RELAY_ID, STATION_ID, WORLD_ID, *vehicles,
                 *((linked_router_id(v) for v in vehicles) if by_certificate else ())]
    subjects: list[dict[str, Any]] = [{"id": "anyone"}, subject("listeners", *listeners),
                                      subject("router", ROUTER_ID),
                                      subject("operator", OPERATOR_ID),
                                      subject("relay", RELAY_ID), subject("ground", GROUND_ID)]
    policies = [{"rules": ["egress"], "subjects": ["anyone"]},
                {"rules": ["listen"], "subjects": ["listeners"]},
                {"rules": ["forward"], "subjects": ["router"]},
                {"rules": ["operator"], "subjects": ["operator"]},
                {"rules": ["relay"], "subjects": ["relay"]},
                {"rules": ["ground", "ground answers"], "subjects": ["ground"]}]
    for vid in vehicles:
        own = [f"{p}/{kind}/{vid}"
               for kind in ("tx", "truth", "status", "event", "alive", "busy")]
        rules.append(rule(f"vehicle {vid}", ["put", "liveliness_token"], own))
        names = (vid, linked_router_id(vid)) if by_certificate else (vid,)
        subjects.append(subject(f"vehicle {vid}", *names))
        policies.append({"rules": [f"vehicle {vid}"], "subjects": [f"vehicle {vid}"]})
    if upstream_zid is not None:
        subjects.append({"id": "upstream", "zids": [upstream_zid]})
        policies.append({"rules": ["forward"], "subjects": ["upstream"]})
    return {"enabled": True, "default_permission": "deny", "rules": rules,
            "subjects": subjects, "policies": policies}


def _tls(conf: zenoh.Config, identity: TlsIdentity, listens: bool) -> None:
    """Mutual TLS (Zenoh 1.x ``transport/link/tls``): the mission's CA is the root of trust
    on both ends, and every link shows its own certificate, dialled or accepted; TLS 1.3 only
    (Zenoh's rustls with client authentication). A client also checks that the router's
    certificate names the host it dialled (``verify_name_on_connect``)."""
    tls: dict[str, Any] = {
        "root_ca_certificate": str(identity.ca.resolve()), "enable_mtls": True,
        "connect_private_key": str(identity.key.resolve()),
        "connect_certificate": str(identity.cert.resolve()), "verify_name_on_connect": True}
    if listens:
        tls.update(listen_private_key=str(identity.key.resolve()),
                   listen_certificate=str(identity.cert.resolve()))
    conf.insert_json5("transport/link/tls", json.dumps(tls))


def _check_endpoints(endpoints: Sequence[str], tls: bool, directory: Path) -> None:
    """TLS credentials take ``tls/`` endpoints only (a plain one would let anyone in with
    no identity); plain logins stay on loopback (their traffic is not encrypted)."""
    for endpoint in endpoints:
        proto, host, _ = split_endpoint(endpoint)
        if tls and proto != "tls":
            raise CredentialsError(f"{directory} holds TLS credentials: expected a tls/ "
                                   f"endpoint, got {endpoint}")
        if not tls and (proto == "tls" or not is_loopback(host)):
            raise CredentialsError(
                f"{endpoint}: {directory} holds plain logins, for one host over loopback "
                "TCP only; across machines make TLS credentials (`cotsfleet credentials`)")


def router_config(listen_endpoints: Sequence[str] = (DEFAULT_ENDPOINT,),
                  connect_endpoints: Sequence[str] = (),
                  credentials: Path | None = None) -> zenoh.Config:
    """A session that is itself the router (embedded: no zenohd to install). With
    ``connect_endpoints`` it also links to other routers, e.g. one per machine or vehicle, so
    a fleet spread over several hosts forms one bus. With ``credentials`` (a router's
    credentials directory, `fleet_bus.credentials`) only the mission's processes may
    connect, each with the rights of `access_control`: by their certificates (TLS), or by
    their logins (plain, loopback; it logs in to linked routers as ``router``)."""
    conf = _base("router")
    conf.insert_json5("listen/endpoints", json.dumps(list(listen_endpoints)))
    if connect_endpoints:
        conf.insert_json5("connect/endpoints", json.dumps(list(connect_endpoints)))
    if credentials is None:
        return conf
    credentials = Path(credentials)
    tls = uses_tls(credentials)
    _check_endpoints([*listen_endpoints, *connect_endpoints], tls, credentials)
    vehicles = [sid for sid, m in load_ring(credentials).ring.items() if m.role == "vehicle"]
    if tls:
        _tls(conf, load_tls(credentials), listens=True)
        conf.insert_json5("access_control", json.dumps(access_control(
            vehicles, by_certificate=True)))
        return conf
    _login(conf, load_login(credentials), credentials / ROUTER_USERS)
    zid = load_router_zid(credentials)
    if connect_endpoints:  # a linked router: trusts the main one it dials
        conf.insert_json5("access_control", json.dumps(access_control(vehicles, zid)))
    else:  # the main router: known by its id to the routers linked to it
        conf.insert_json5("id", json.dumps(zid))
        conf.insert_json5("access_control", json.dumps(access_control(vehicles)))
    return conf


def client_config(connect_endpoints: Sequence[str] = (DEFAULT_ENDPOINT,),
                  timeout_s: float = 10.0, credentials: Path | None = None) -> zenoh.Config:
    """A client of the router(s) at ``connect_endpoints``; `zenoh.open` retries for up to
    ``timeout_s`` so processes may start before the router is up. With ``credentials`` it
    shows its certificate (TLS) or logs in with its login (plain, loopback)."""
    conf = _base("client")
    conf.insert_json5("connect/endpoints", json.dumps(list(connect_endpoints)))
    conf.insert_json5("connect/timeout_ms", json.dumps(int(timeout_s * 1000)))
    conf.insert_json5("listen/endpoints", "[]")
    if credentials is not None:
        credentials = Path(credentials)
        tls = uses_tls(credentials)
        _check_endpoints(connect_endpoints, tls, credentials)
        if tls:
            _tls(conf, load_tls(credentials), listens=False)
        else:
            _login(conf, load_login(credentials))
    return conf


def open_session(conf: zenoh.Config) -> zenoh.Session:
    """Open a session (use it in a ``with`` block)."""
    return zenoh.open(conf)


def split_endpoint(endpoint: str) -> tuple[str, str, str]:
    """(protocol, host, port) of ``proto/host:port`` (protocol "" if there is none; Zenoh's
    ``?`` metadata and ``#`` configuration suffixes are ignored)."""
    proto, sep, rest = endpoint.partition("/")
    if not sep:
        proto, rest = "", endpoint
    host, _, port = rest.split("?")[0].split("#")[0].rpartition(":")
    return proto, host.strip("[]"), port


def is_loopback(host: str) -> bool:
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def with_protocol(endpoint: str, tls: bool) -> str:
    """``endpoint`` on the bus's transport: ``HOST:PORT`` gets ``tls/`` or ``tcp/``; an
    endpoint that names another transport is refused (plain TCP across machines above all)."""
    proto, host, port = split_endpoint(endpoint)
    want = "tls" if tls else "tcp"
    if not proto:
        return f"{want}/{endpoint}"
    if proto != want:
        why = ("across machines the bus is TLS" if tls and not is_loopback(host)
               else "the bus is TLS here" if tls else "the bus is plain TCP here")
        bracketed = f"[{host}]" if ":" in host else host
        raise ValueError(f"{endpoint}: {why}; use {want}/{bracketed}:{port} "
                         f"(or {bracketed}:{port})")
    return endpoint


def free_tcp_endpoint(host: str = "127.0.0.1", proto: str = "tcp") -> str:
    """An endpoint on a port that is free now (for tests and ad-hoc missions): TCP's, which
    a TLS endpoint runs on too."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind((host, 0))
        return f"{proto}/{host}:{s.getsockname()[1]}"


def local_endpoint(listen: str) -> str:
    """Where processes on this machine reach a router listening on ``listen``
    (``tcp/0.0.0.0:7447`` listens everywhere; locally it is ``tcp/127.0.0.1:7447``)."""
    proto, _, rest = listen.partition("/")
    host, _, port = rest.rpartition(":")
    return f"{proto}/127.0.0.1:{port}" if host in ("0.0.0.0", "[::]", "") else listen
