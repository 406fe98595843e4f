"""Operator -> agent commands on ``fleet/ctl/<id>``: ``abort`` (fault injection: the vehicle
gives up and heads for the rendezvous) and ``stop`` (end the process cleanly: the launcher's
way to end an agent it did not start, e.g. one on another machine)."""

from __future__ import annotations

import msgpack

from fleet_bus import values as v

ABORT, STOP = "abort", "stop"
COMMANDS = (ABORT, STOP)


def encode_command(name: str) -> bytes:
    """Payload of ``fleet/ctl/<id>``: ``{"cmd": "abort"}`` or ``{"cmd": "stop"}``."""
    if name not in COMMANDS:
        raise ValueError(f"unknown command {name!r}; known: {COMMANDS}")
    return msgpack.packb({"cmd": name})


def decode_command(payload: bytes) -> str:
    """The command name; ValueError on anything else."""
    doc = v.unpack_map(payload, "command")
    name = doc.get("cmd")
    if name not in COMMANDS:
        raise ValueError(f"unknown command {name!r}")
    return str(name)
