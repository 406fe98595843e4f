"""The mission report as a typed tree: what `report.build_report` returns and every reader in
the product reads (the terminal summary, ``report.md`` and its figures, sweeps, `cotsfleet
report`), by attribute.

msgspec Structs rather than dataclasses: reading a ``report.json`` back (`MissionReport.
from_dict`) is a validation of a nested document against these types, and msgspec does it in
one call with an error that names the offending field (``Expected `int`, got `str` - at
`$.fleet.spots_total```), where dataclasses would need a hand-written checker per section;
its `to_builtins` gives the JSON document in field order. (Issue 27 asks the same of the
wire records of `fleet_bus`.)

`MissionReport.to_dict` gives the field names and values ``report.json`` has always had
(``tests/cotsfleet/test_report_model.py`` holds it to reports written before the tree
existed; one field was added since, ``dynamic.unmapped_found``). Sections a mission does
not have are absent from the document (`None` here); fields whose absence differs from a
null (`UNSET`) keep that difference. A report's
top-level fields this version does not know (a newer writer's) are kept in ``other`` and
written back unchanged; nested sections refuse unknown fields, so a typo or a drift between
writer and types fails loudly in the tests instead of vanishing from the file.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import msgspec
from msgspec import UNSET, Struct, UnsetType

from fleet_bus.ledger import Collected


class ReportError(ValueError):
    """A document that is not a mission report (the message says where and why)."""


class _Section(Struct, kw_only=True, forbid_unknown_fields=True, omit_defaults=True):
    pass


class FaultRow(_Section):
    kind: str
    vid: str
    t_s: float
    value: float
    order: str = ""  # a ``ctl``'s order words


class OrderRow(_Section):
    """One of the operator's live orders (`cotsfleet.mission.topside`)."""

    seq: int
    order: str
    verb: str
    target: str
    issued_s: float
    transmissions: int
    acked: dict[str, float]  # vehicle -> when the topside heard its acknowledgement
    refused: dict[str, str]  # vehicle -> why it refused
    by: str = ""  # who signed its request (operator, ground); empty: scheduled (--ctl)


class Commands(_Section):
    """The operator's live orders: what was sent and what came of it (docs/operator.md)."""

    topside: list[float]  # where the topside modem was
    sent: list[OrderRow]
    refused: dict[str, int]  # by the vehicles, by reason (unsigned, replayed, stale, ...)
    repeats: int  # orders heard again after they were taken (not acted on twice)
    taken: dict[str, int]  # vehicle -> orders it took
    operator_refused: dict[str, int]  # requests the operator's side refused, by reason


class VehicleRow(_Section):
    id: str
    state: str
    tasks_treated: int  # scenario ids it treated (predicted spots and finds)
    priority: float  # on the real reef in a dynamic mission, else the map's
    distance_m: float
    battery_used_s: float
    t_diff_s: float | None  # battery left at the rendezvous; None unless home
    home: bool
    aborted: bool
    killed: bool
    restarted: bool
    stalled: bool
    counters: dict[str, int]
    helm: str = "sim"  # what drove it (`cotsfleet run --helm`: sim, moos, ros2, remote)
    nav_fixes: int = 0  # navigation fixes its agent used

    @property
    def flags(self) -> list[str]:
        """The faults it was given (`cotsfleet.mission.faults.VEHICLE_FLAGS` order)."""
        return [k for k in ("aborted", "killed", "restarted", "stalled") if getattr(self, k)]


class FleetSection(_Section):
    spots_total: int  # the scenario's (predicted) spots
    spots_cleared: int  # scenario ids some vehicle treated (predicted spots and finds)
    priority: float  # collected: on the real reef in a dynamic mission, else the map's
    priority_total: float  # of the real reef in a dynamic mission, else the map's
    treatments: int  # (vehicle, scenario id) treatments
    duplicate_treatments: int  # on the real reef in a dynamic mission
    duplicate_share: float  # duplicate_treatments / treatments
    vehicles_home: int
    detection_delay_s: dict[str, dict[str, float | None]]
    false_alarms: int
    spots_taken_over: int
    claims: int
    claims_lost: int
    replans: int


class Messages(_Section):
    frames_sent: int
    bytes_sent: int
    bytes_per_vehicle_minute: float
    largest_frame_bytes: int
    by_kind: dict[str, int]
    dropped_by_agents: dict[str, int]
    link: dict[str, int] | None  # the relay's totals; None: the relay never answered
    link_by_sender: dict[str, dict[str, int]]


def drop_reasons(counts: Mapping[str, Any]) -> dict[str, int]:
    """The drop counters of a link-totals row (`Messages.link`, a row of ``link_by_sender``):
    everything but sent, delivered and bytes."""
    return {k: int(v) for k, v in counts.items()
            if k not in ("sent", "delivered", "bytes") and isinstance(v, (int, float))}


class TreatedRow(_Section):
    spot: int  # index of the real spot (``truth.spots``)
    vehicle: str
    t_s: float


class DynamicSection(_Section):
    """The real reef: every treatment of a real spot, in time order, and its figures."""

    treated: list[TreatedRow]
    spots_discovered: int  # real spots the fleet's finds are
    empty_inspected: int  # predicted spots found empty
    truth_priority: float
    truth_spots: int
    unmapped: int  # real spots the map missed
    unmapped_treated: int
    priority_treated: float
    duplicate_treatments: int
    unmapped_found: int | UnsetType = UNSET  # of the unmapped ones, found (absent: older reports)


class Baseline(_Section):
    """The no-communication baseline: every vehicle flies its initial plan (what the map
    predicts it is worth)."""

    priority: float
    spots: int


class Oracle(_Section):
    vid: str
    t_s: float
    priority: float
    survivors: list[str]
    collected: float
    ratio: float


class WarpChange(_Section):
    t_s: float
    warp: float
    lag_s: float | UnsetType = UNSET


class Clock(_Section):
    warp: float
    final_warp: float | UnsetType = UNSET
    effective_warp: float | None | UnsetType = UNSET
    slowdowns: list[WarpChange] | UnsetType = UNSET
    speedups: list[WarpChange] | UnsetType = UNSET
    max_lag_s: float | UnsetType = UNSET
    holds: int | UnsetType = UNSET
    held_wall_s: float | UnsetType = UNSET
    slots_late: int | UnsetType = UNSET
    max_frame_late_s: float | None | UnsetType = UNSET
    # a planning hold that ran out of its allowance, busy flags refused meanwhile, and hosts
    # whose wall clock stepped (mission time runs on the monotonic clock): by process
    holds_expired: dict[str, int] | UnsetType = UNSET
    holds_refused: dict[str, int] | UnsetType = UNSET
    wall_steps: dict[str, int] | UnsetType = UNSET
    relay_sync: dict[str, float] | UnsetType = UNSET  # the relay's clock exchanges


class Crash(_Section):
    """A child process that ended untold, and what the launcher did about it."""

    name: str
    t_s: float
    code: int | None
    why: str
    action: str  # "restart" | "vehicle" | "report" | "end"


class Saved(_Section):
    """What a full disk let the launcher keep of the event log."""

    events: int
    events_total: int | UnsetType = UNSET
    events_error: str | UnsetType = UNSET


class HelmSection(_Section):
    """Which helm drove each vehicle (`cotsfleet run --helm`), and whether the mission clock
    was held at the warp for it."""

    name: str
    clock_pinned: bool
    vehicles: dict[str, str]
    clock_drift_max_s: dict[str, float] | None = None  # MOOS: each vehicle's clock
    ros_domain_id: int | None = None  # ROS 2: the run's own domain


class ModemSection(_Section):
    """The modem every agent drove (`cotsfleet run --modem`) and the slot it needs."""

    name: str
    spec: str
    frames_per_packet: int
    max_frame_bytes: int
    bit_rate_bps: float
    slot_s: float
    slot_from: str  # "modem" (derived from its packet) | "config"
    rate: int | None = None  # Micro-Modem rate


class Queries(_Section):
    """Queries to the operator's and the relay's queryables: answered and rationed by asker,
    refused in all."""

    operator: dict[str, Any]
    relay: dict[str, Any]


class Security(_Section):
    refused_total: int
    operator: dict[str, int]
    relay: dict[str, int] | None  # None: the relay's counters never came
    agents: dict[str, dict[str, int]]
    # Requests on fleet/ctl/order the launcher refused (`cotsfleet ctl`'s key: not the
    # operator's signature, garbage, not an order), by reason; absent when none.
    orders: dict[str, int] = msgspec.field(default_factory=dict)
    # The requests it took (numbered and sent), by signer: operator, ground; absent when none.
    orders_taken: dict[str, int] = msgspec.field(default_factory=dict)


class MissionReport(Struct, kw_only=True, forbid_unknown_fields=True, omit_defaults=True):
    """One mission's report (docs/reports.md)."""

    mode: str  # "sim" | "run"
    scenario: str
    seed: int
    end_s: float
    faults: list[FaultRow]
    vehicles: list[VehicleRow]
    fleet: FleetSection
    messages: Messages
    dynamic: DynamicSection | None = None
    baseline: Baseline | None = None
    oracle: Oracle | None = None
    run_id: str | None = None
    run_dir: str | None = None
    warp: float | None = None
    loss: float | None = None
    wall_s: float | None = None
    run_s: float | None = None
    interrupted: bool | None = None
    clock: Clock | None = None
    exit_codes: dict[str, int | None] | None = None
    exited: dict[str, str] | None = None
    security: Security | None = None
    crashes: list[Crash] | None = None
    saved: Saved | None = None
    queries: Queries | None = None
    helm: HelmSection | None = None
    modem: ModemSection | None = None
    failure: str | None = None
    # accused -> accuser -> how many things it said that could not be (`fleet_agent.policies.
    # plausible`); absent when nobody lied
    suspects: dict[str, dict[str, int]] | None = None
    commands: Commands | None = None  # the operator's live orders
    other: dict[str, Any] = {}  # top-level fields this version does not know

    # -- the document ------------------------------------------------------------------------

    def to_dict(self) -> dict[str, Any]:
        """The ``report.json`` document."""
        doc = msgspec.to_builtins(self)
        other = doc.pop("other", {})
        return {**doc, **other}

    @classmethod
    def from_dict(cls, doc: Any, where: str = "report") -> MissionReport:
        """A report document read back (raises `ReportError` naming the bad field)."""
        if not isinstance(doc, Mapping):
            raise ReportError(f"{where}: not a mission report (expected an object, got "
                              f"{type(doc).__name__})")
        missing = [k for k in ("fleet", "vehicles", "messages") if k not in doc]
        if missing:
            raise ReportError(f"{where}: not a mission report (no {', '.join(missing)})")
        known = set(cls.__struct_fields__) - {"other"}
        main = {k: v for k, v in doc.items() if k in known}
        main["other"] = {k: v for k, v in doc.items() if k not in known}
        try:
            return msgspec.convert(main, cls)
        except msgspec.ValidationError as exc:
            raise ReportError(f"{where}: not a valid mission report: {exc}") from None

    @classmethod
    def read(cls, path: str | Path) -> MissionReport:
        """``report.json`` from a file (raises `ReportError`, or OSError if unreadable)."""
        try:
            doc = msgspec.json.decode(Path(path).read_bytes())
        except msgspec.DecodeError as exc:
            raise ReportError(f"{path}: not valid JSON: {exc}") from None
        return cls.from_dict(doc, str(path))

    # -- figures read off the tree -----------------------------------------------------------

    @property
    def collected(self) -> Collected:
        """What the fleet collected, with what each figure is out of: on the real reef in a
        dynamic mission, on the map's predicted spots otherwise (`fleet_bus.ledger.
        Collected`; the figures `build_report` wrote, from `FleetLedger.collected`)."""
        f, d = self.fleet, self.dynamic
        if d is None:
            return Collected(False, f.spots_cleared, f.spots_total, f.priority,
                             f.priority_total, f.treatments, f.duplicate_treatments,
                             {v.id: (v.tasks_treated, v.priority) for v in self.vehicles})
        mine: dict[str, set[int]] = {}
        for t in d.treated:
            mine.setdefault(t.vehicle, set()).add(t.spot)
        return Collected(True, len({t.spot for t in d.treated}), d.truth_spots,
                         d.priority_treated, d.truth_priority, len(d.treated),
                         d.duplicate_treatments,
                         {v.id: (len(mine.get(v.id, ())), v.priority) for v in self.vehicles})

    @property
    def slowest_detection_s(self) -> float | None:
        """The longest any vehicle took to declare a lost one lost (None: nobody did)."""
        delays = [d for row in self.fleet.detection_delay_s.values() for d in row.values()
                  if d is not None]
        return max(delays) if delays else None

    def vehicle(self, vid: str) -> VehicleRow | None:
        return next((v for v in self.vehicles if v.id == vid), None)


class FailedRun(Struct, kw_only=True, forbid_unknown_fields=True, omit_defaults=True):
    """A sweep's run that raised: its seed and the error (`cotsfleet.sweep.task`)."""

    seed: int
    error: str
    traceback: str | None = None
    run_s: float | None = None

    def to_dict(self) -> dict[str, Any]:
        return msgspec.to_builtins(self)


RunResult = MissionReport | FailedRun


def run_from_dict(doc: Any, where: str = "run") -> RunResult:
    """One entry of a sweep's JSON: a mission report, or a run that failed."""
    if isinstance(doc, Mapping) and "error" in doc:
        try:
            return msgspec.convert(doc, FailedRun)
        except msgspec.ValidationError as exc:
            raise ReportError(f"{where}: not a failed run: {exc}") from None
    return MissionReport.from_dict(doc, where)


def runs_from_list(doc: Any, where: str = "runs") -> list[RunResult]:
    """A sweep's JSON (a list of runs) read back (raises `ReportError`)."""
    if not isinstance(doc, list) or not doc:
        raise ReportError(f"{where}: expected a non-empty list of mission reports")
    return [run_from_dict(r, f"{where}[{i}]") for i, r in enumerate(doc)]
