"""Zenoh configuration shared by every process of the fleet.

Multicast scouting is off everywhere: the processes of one mission find each other through
explicit endpoints, so two missions (or two test runs) on one machine never mix.
"""

from __future__ import annotations

import json
import socket
from pathlib import Path
from typing import Any, Sequence

import zenoh

from fleet_bus import keys
from fleet_bus.credentials import (OPERATOR_ID, RELAY_ID, ROUTER_ID, ROUTER_USERS, ZenohLogin,
                                   load_login, load_ring, load_router_zid)

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


def access_control(vehicles: Sequence[str], upstream_zid: str | None = None) -> dict[str, Any]:
    """Zenoh 1.x ``access_control`` of the fleet's router: anyone logged in may listen (the
    ground station, any process); only the operator's login may command, serve the mission and
    clock records and control the link; only the relay's may deliver, report link fates and
    serve link stats; only vehicle X's may speak on ``fleet/*/X``; a linked router's login may
    forward anything (it carries its own host's processes), and so may the main router
    (``upstream_zid``) seen from a router linked to it. Everything else is denied."""
    def rule(rid: str, messages: list[str], key_exprs: list[str],
             flows: tuple[str, ...] = ("ingress",)) -> dict[str, Any]:
        return {"id": rid, "permission": "allow", "flows": list(flows), "messages": messages,
                "key_exprs": key_exprs}

    p = keys.PREFIX
    rules = [rule("egress", _EVERY_MESSAGE, ["**"], ("egress",)),
             rule("listen", _LISTEN, [f"{p}/**"]),
             rule("forward", _EVERY_MESSAGE, ["**"]),
             rule("operator", ["put", "declare_queryable", "reply"],
                  [f"{p}/ctl/**", keys.MISSION, keys.CLOCK]),
             rule("relay", ["put", "declare_queryable", "reply"],
                  [f"{p}/rx/*", f"{p}/link/**", keys.LINK_STATS])]
    routers: dict[str, Any] = {"id": "router", "usernames": [ROUTER_ID]}
    subjects: list[dict[str, Any]] = [{"id": "anyone"}, routers,
                                      {"id": "operator", "usernames": [OPERATOR_ID]},
                                      {"id": "relay", "usernames": [RELAY_ID]}]
    policies = [{"rules": ["egress", "listen"], "subjects": ["anyone"]},
                {"rules": ["forward"], "subjects": ["router"]},
                {"rules": ["operator"], "subjects": ["operator"]},
                {"rules": ["relay"], "subjects": ["relay"]}]
    for vid in vehicles:
        own = [f"{p}/{kind}/{vid}"
               for kind in ("tx", "truth", "status", "event", "alive", "busy")]
        rules.append(rule(f"vehicle {vid}", ["put", "liveliness_token"], own))
        subjects.append({"id": f"vehicle {vid}", "usernames": [vid]})
        policies.append({"rules": [f"vehicle {vid}"], "subjects": [f"vehicle {vid}"]})
    if upstream_zid is not None:
        subjects.append({"id": "upstream", "zids": [upstream_zid]})
        policies.append({"rules": ["forward"], "subjects": ["upstream"]})
    return {"enabled": True, "default_permission": "deny", "rules": rules,
            "subjects": subjects, "policies": policies}


def router_config(listen_endpoints: Sequence[str] = (DEFAULT_ENDPOINT,),
                  connect_endpoints: Sequence[str] = (),
                  credentials: Path | None = None) -> zenoh.Config:
    """A session that is itself the router (embedded: no zenohd to install). With
    ``connect_endpoints`` it also links to other routers, e.g. one per machine or vehicle, so
    a fleet spread over several hosts forms one bus. With ``credentials`` (a router's
    credentials directory, `fleet_bus.credentials`) only logins of its dictionary may
    connect, each with the rights of `access_control`; it logs in to linked routers as
    ``router``."""
    conf = _base("router")
    conf.insert_json5("listen/endpoints", json.dumps(list(listen_endpoints)))
    if connect_endpoints:
        conf.insert_json5("connect/endpoints", json.dumps(list(connect_endpoints)))
    if credentials is not None:
        credentials = Path(credentials)
        _login(conf, load_login(credentials), credentials / ROUTER_USERS)
        vehicles = [sid for sid, m in load_ring(credentials).ring.items() if m.role == "vehicle"]
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
    logs in with the Zenoh login found there."""
    conf = _base("client")
    conf.insert_json5("connect/endpoints", json.dumps(list(connect_endpoints)))
    conf.insert_json5("connect/timeout_ms", json.dumps(int(timeout_s * 1000)))
    conf.insert_json5("listen/endpoints", "[]")
    if credentials is not None:
        _login(conf, load_login(Path(credentials)))
    return conf


def open_session(conf: zenoh.Config) -> zenoh.Session:
    """Open a session (use it in a ``with`` block)."""
    return zenoh.open(conf)


def free_tcp_endpoint(host: str = "127.0.0.1") -> str:
    """A loopback endpoint on a port that is free now (for tests and ad-hoc missions)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind((host, 0))
        return f"tcp/{host}:{s.getsockname()[1]}"


def local_endpoint(listen: str) -> str:
    """Where processes on this machine reach a router listening on ``listen``
    (``tcp/0.0.0.0:7447`` listens everywhere; locally it is ``tcp/127.0.0.1:7447``)."""
    proto, _, rest = listen.partition("/")
    host, _, port = rest.rpartition(":")
    return f"{proto}/127.0.0.1:{port}" if host in ("0.0.0.0", "[::]", "") else listen
