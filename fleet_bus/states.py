"""The states a vehicle reports and the states a vehicle gives its peers, named once.

Both are `StrEnum`s: a member is its string (equal to it, hashed like it, packed by msgpack
and written by json as it), so the bus records, the journal and report.json carry exactly the
words they carried before these names existed (``"transit"``, ``"lost"``...).
"""

from __future__ import annotations

from enum import StrEnum


class VehicleState(StrEnum):
    """A vehicle's state as its agent reports it (`fleet_bus.telemetry.Status.state`) and the
    dashboard and the report show it."""

    TRANSIT = "transit"
    INJECTING = "injecting"
    RETURNING = "returning"
    HOME = "home"
    ABORTED = "aborted"
    DEAD = "dead"  # the mission runner's word for an agent killed and not restarted


FINAL_STATES = (VehicleState.HOME, VehicleState.ABORTED, VehicleState.DEAD)  # left the mission
STOPPED_STATES = (VehicleState.ABORTED, VehicleState.DEAD)  # its route is abandoned


class PeerState(StrEnum):
    """What a vehicle makes of a peer (`fleet_bus.telemetry.Status.peers`)."""

    ALIVE = "alive"
    SUSPECT = "suspect"
    LOST = "lost"
    ABORTED = "aborted"
    HOME = "home"


class EventKind(StrEnum):
    """What an event says happened (`fleet_bus.telemetry.Event.kind`; worded as a sentence by
    `fleet_bus.event_text`)."""

    CLEARED = "cleared"  # this vehicle finished injecting a spot
    CLAIM = "claim"  # claimed spots (cooperation or takeover)
    CLAIM_LOST = "claim_lost"  # lost a conflicting claim and dropped the spots
    ABORT = "abort"  # this vehicle aborted (announced)
    SUSPECT = "suspect"  # a peer went silent; nothing is taken until another vehicle confirms it
    LOST = "lost"  # this vehicle declared a peer lost (silence confirmed, or abort heard)
    REVIVED = "revived"  # a peer declared lost was heard again
    TAKEOVER = "takeover"  # spots of a lost vehicle taken into this vehicle's route
    REPLAN = "replan"  # local route changed
    RESTART = "restart"  # the agent process restarted from its log
    # after a lost or damaged journal: the fleet's cleared set learned, going on
    REJOINED = "rejoined"
    REFUSED = "refused"  # the vehicle did not carry out a command (detail: which, and why)
    # fixes stopped (keeping station), came back, or stopped too long (home)
    NAVIGATION = "navigation"
    LATE = "late"  # the vehicle fell behind its plan (detail: by how much); refitted from its fix
    # the operator's live orders (`fleet_bus.orders`, docs/operator.md)
    ORDER = "order"  # an order taken (detail: which, #number) or refused (detail: why)
    RECALL = "recall"  # recalled by the operator: heading home now, announced as an abort
    PAUSE = "pause"  # paused by the operator: keeping station
    RESUME = "resume"  # resumed by the operator
    DROPPED = "dropped"  # a spot the operator dropped: nobody treats it
    ADDED = "added"  # a spot the operator added (tasks: its id; detail: "x,y,z rho r")
    # dynamic missions (a hidden reef): what the camera showed
    FOUND = "found"  # an aggregation the map missed (tasks: its find id; detail: "x,y,z rho r")
    EMPTY = "empty"  # a predicted spot inspected and found empty
    INSPECTED = "inspected"  # a predicted spot inspected and found to hold COTS
    # spots whose estimate could be an aggregation already treated: skipped
    JUDGED_TREATED = "judged_treated"
    SEARCH = "search"  # an orbit around a spot just treated (tasks: it; detail: "x,y,z expected n")


class FaultKind(StrEnum):
    """What a mission can be given (`cotsfleet.mission.faults`: their values and meaning)."""

    ABORT = "abort"
    KILL = "kill"
    RESTART = "restart"
    PARTITION = "partition"
    STALL = "stall"
    LOSS = "loss"
    # an intruder's modem (no key)
    FORGE = "forge"
    REPLAY = "replay"
    GARBAGE = "garbage"
    # an insider (one vehicle's leaked credentials: `cotsfleet.mission.insider`)
    ALL_CLEARED = "all-cleared"
    CLAIM_OWN = "claim-own"
    CLAIM_ALL = "claim-all"
    ABORT_AS = "abort-as"
    PHANTOM = "phantom"
    BUSY_HOLD = "busy-hold"
    # the operator's live order (`fleet_bus.orders`)
    CTL = "ctl"


class DropReason(StrEnum):
    """Why an agent dropped a frame off its modem (counted as ``drop_<reason>``): the wire
    codec's refusals (`fleet_agent.wire.WireError`), then the agent's (`fleet_agent.provenance`:
    who sent it, and when)."""

    SHORT = "short"
    LONG = "long"
    VERSION = "version"
    KIND = "kind"
    SENDER = "sender"
    MAC = "mac"  # the fleet MAC: not from this fleet
    MALFORMED = "malformed"
    SELF = "self"  # its own frame played back
    FUTURE = "future"  # a seq further ahead of its clock than `wire.MAX_LEAD_S`
    LATE_KEY = "late_key"  # heard after its cycle's key could be out: proves nothing
    FORGED_KEY = "forged_key"  # a disclosed key that does not hash down to the sender's chain
    FORGED = "forged"  # a tag that fails under the disclosed key
    REPLAY = "replay"  # a sequence number already taken
    CHAIN_SPENT = "chain_spent"  # own frame: the key chain ran out
