"""Zenoh key expressions of the fleet bus, and their parsing.

Radio traffic: an agent puts wire frames on ``fleet/tx/<id>``; only the relay subscribes to
them and, through the channel model, puts what survives on ``fleet/rx/<dst>``. Agents never
subscribe to another vehicle's ``tx`` or ``truth``: ``truth`` is simulation bookkeeping (where
the vehicle really is) for the relay and the ground station, not a radio.
"""

from __future__ import annotations

PREFIX = "fleet"

TX_ALL = f"{PREFIX}/tx/*"
RX_ALL = f"{PREFIX}/rx/*"
TRUTH_ALL = f"{PREFIX}/truth/*"
STATUS_ALL = f"{PREFIX}/status/*"
EVENT_ALL = f"{PREFIX}/event/*"
LINK_ALL = f"{PREFIX}/link/**"
ALIVE_ALL = f"{PREFIX}/alive/*"
BUSY_ALL = f"{PREFIX}/busy/*"
LINK_CTL = f"{PREFIX}/ctl/link"  # operator -> relay: extra loss, partitions
LINK_STATS = f"{PREFIX}/stats/link"  # relay queryable: drop/delivery counters
MISSION = f"{PREFIX}/mission"  # operator queryable: scenario, seed, run id
CLOCK = f"{PREFIX}/clock"  # operator queryable: epoch and warp of the mission clock
# The operator's live orders (`fleet_bus.orders`): `cotsfleet ctl` -> the launcher, and the
# launcher's answers (accepted, acknowledged). Both the operator's only (kind ``ctl``).
ORDER_REQUEST = f"{PREFIX}/ctl/order"
ORDER_ANSWER = f"{PREFIX}/ctl/order/answer"

# The per-vehicle kinds of key, ``fleet/<kind>/<id>``.
TELEMETRY_KINDS = ("truth", "status", "event")


def vehicle_key(kind: str, vid: str) -> str:
    """``fleet/<kind>/<vid>``: one vehicle's key of a per-vehicle kind."""
    return f"{PREFIX}/{kind}/{vid}"


def all_vehicles(kind: str) -> str:
    """``fleet/<kind>/*``: the key expression of every vehicle's key of that kind."""
    return f"{PREFIX}/{kind}/*"


def tx_key(vid: str) -> str:
    return vehicle_key("tx", vid)


def rx_key(vid: str) -> str:
    return vehicle_key("rx", vid)


def truth_key(vid: str) -> str:
    return vehicle_key("truth", vid)


def status_key(vid: str) -> str:
    return vehicle_key("status", vid)


def event_key(vid: str) -> str:
    return vehicle_key("event", vid)


def ctl_key(vid: str) -> str:
    """Operator -> agent commands (abort, stop); not a radio either."""
    return vehicle_key("ctl", vid)


def alive_key(vid: str) -> str:
    """The liveliness token an agent declares once its initial plan is ready."""
    return vehicle_key("alive", vid)


def busy_key(vid: str) -> str:
    """Agent -> operator: this vehicle's process starts (or ends) a planner run; the operator
    holds the shared clock meanwhile (`cotsfleet.mission.pacing.Holds`). Not a radio."""
    return vehicle_key("busy", vid)


def link_event_key(src: str, dst: str) -> str:
    return f"{PREFIX}/link/{src}/{dst}"


def vid_of(key: str) -> str:
    """The vehicle id at the end of a per-vehicle key such as ``fleet/truth/auv2``."""
    return str(key).rsplit("/", 1)[-1]


def kind_of(key: str) -> str:
    """``fleet/<kind>/...`` -> kind; ValueError for a key outside the fleet's prefix or a link
    key that is not ``fleet/link/<src>/<dst>``."""
    parts = str(key).split("/")
    if len(parts) < 3 or parts[0] != PREFIX or not all(parts):
        raise ValueError(f"not a fleet key: {key!r}")
    if parts[1] == "link" and len(parts) != 4:
        raise ValueError(f"link keys are fleet/link/<src>/<dst>: {key!r}")
    return parts[1]


def link_ends(key: str) -> tuple[str, str]:
    """``fleet/link/<src>/<dst>`` -> (src, dst)."""
    if kind_of(key) != "link":
        raise ValueError(f"not a link key: {key!r}")
    _, _, src, dst = str(key).split("/")
    return src, dst
