"""Zenoh configuration shared by every process of the fleet.

Multicast scouting is off everywhere: the processes of one mission find each other through
explicit endpoints, so two missions (or two test runs) on one machine never mix.
"""

from __future__ import annotations

import json
import socket
from typing import Sequence

import zenoh

DEFAULT_ENDPOINT = "tcp/127.0.0.1:7447"


def _base(mode: str) -> zenoh.Config:
    conf = zenoh.Config()
    conf.insert_json5("mode", json.dumps(mode))
    conf.insert_json5("scouting/multicast/enabled", "false")
    return conf


def router_config(listen_endpoints: Sequence[str] = (DEFAULT_ENDPOINT,),
                  connect_endpoints: Sequence[str] = ()) -> zenoh.Config:
    """A session that is itself the router (embedded: no zenohd to install). With
    ``connect_endpoints`` it also links to other routers, e.g. one per machine or vehicle, so
    a fleet spread over several hosts forms one bus."""
    conf = _base("router")
    conf.insert_json5("listen/endpoints", json.dumps(list(listen_endpoints)))
    if connect_endpoints:
        conf.insert_json5("connect/endpoints", json.dumps(list(connect_endpoints)))
    return conf


def client_config(connect_endpoints: Sequence[str] = (DEFAULT_ENDPOINT,),
                  timeout_s: float = 10.0) -> zenoh.Config:
    """A client of the router(s) at ``connect_endpoints``; `zenoh.open` retries for up to
    ``timeout_s`` so processes may start before the router is up."""
    conf = _base("client")
    conf.insert_json5("connect/endpoints", json.dumps(list(connect_endpoints)))
    conf.insert_json5("connect/timeout_ms", json.dumps(int(timeout_s * 1000)))
    conf.insert_json5("listen/endpoints", "[]")
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
