"""Operator -> agent commands on ``fleet/ctl/<id>``: ``abort`` (fault injection: the vehicle
gives up and heads for the rendezvous) and ``stop`` (end the process cleanly: the launcher's
way to end an agent it did not start, e.g. one on another machine)."""

from __future__ import annotations

from enum import StrEnum

import msgpack

from fleet_bus import values as v


class Command(StrEnum):
    """What the operator may tell one agent (a `StrEnum`: packed as its word)."""

    ABORT = "abort"
    STOP = "stop"


ABORT, STOP = Command
COMMANDS = tuple(Command)


def encode_command(name: Command) -> bytes:
    """Payload of ``fleet/ctl/<id>``: ``{"cmd": "abort"}`` or ``{"cmd": "stop"}``."""
    if name not in COMMANDS:
        raise ValueError(f"unknown command {name!r}; known: {COMMANDS}")
    return msgpack.packb({"cmd": name})


def decode_command(payload: bytes) -> Command:
    """The command; ValueError on anything else."""
    doc = v.unpack_map(payload, "command")
    name = doc.get("cmd")
    if not isinstance(name, str) or name not in COMMANDS:
        raise ValueError(f"unknown command {name!r}")
    return Command(name)
