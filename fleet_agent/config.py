"""Agent parameters: one dataclass that validates itself, loadable from TOML.

Times are simulation seconds. The radio schedule is a self-organised TDMA: every vehicle owns
slot ``index`` of a cycle of ``n_vehicles * slot_s`` seconds (all clocks share the mission
epoch), so the fleet's own frames never collide; one frame per slot. A cycle is therefore the
heartbeat period: every frame a vehicle sends counts as its heartbeat.
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import Any

import tomli_w

from fleet_agent.association import AssociationParams


@dataclass(frozen=True)
class AgentConfig:
    # Radio (TDMA). 2.5 s holds a 64-byte frame at 1 kbps (0.81 s) plus 1.5 s of propagation
    # (2.2 km) and scheduling slack.
    slot_s: float = 2.5
    # Spatial reuse of slots (`fleet_bus.tdma.SpatialSchedule`, docs/membership.md): two
    # vehicles whose plan tracks stay this far apart (beyond the margin each may stray from
    # it) share a slot; 0: one slot per vehicle (plain TDMA). 3000 m: a frame from within
    # `hear_range_m` (1 km) keeps 97.7 % of its 99.3 % delivery with a co-slot sender 2 km
    # beyond the receiver (the default modem on a reef: 6 dB/km absorption). The schedule is
    # made anew for each epoch of about ``schedule_epoch_s`` from where the plan puts the
    # vehicles then, each allowed ``schedule_margin_m`` off its track; vehicles parked at one
    # place beyond ``park_group`` of them share slots in turn.
    slot_reuse_m: float = 3000.0
    schedule_margin_m: float = 300.0
    schedule_epoch_s: float = 300.0
    park_group: int = 4
    pose_every_cycles: int = 2  # a pose at least every this many own slots
    cleared_refresh_cycles: int = 8  # unprompted full-state push of the cleared set
    claim_repeats: int = 3  # each new claim/release is sent this many times
    claim_refresh_cycles: int = 12  # rebroadcast of standing claims (late joiners, loss)
    # A spot claimed after the initial plan is not worked until its claim has settled: this
    # many cycles after the claim, plus one slot and 1 s (`Knowledge.settled_s`). A new claim
    # goes out in the claimer's next slot, so an earlier claim of the same spot by a peer is
    # heard by then on a working link and the later claimer gives way instead of treating
    # the spot too (two vehicles that claimed a find seconds apart and were both at it).
    claim_settle_cycles: float = 1.0
    # ... and, settled, it waits up to this many cycles more while a frame heard but not yet
    # proven its sender's (`fleet_bus.tesla`) holds an earlier claim of it or a find that may
    # be it (`policies.unproven`): under loss the proof of a claim heard in time can come a
    # cycle or more after the settle.
    unproven_wait_cycles: float = 4.0
    abort_repeats: int = 4
    home_repeats: int = 3
    # A vehicle done with the mission (home or aborted) keeps watch: after its announcements
    # it still sends a pose every this many own slots (0: falls silent). Its "heard" codes are
    # what lets the last working vehicle confirm a silent peer (`membership`); the slot is its
    # own in the TDMA schedule, so a pose in every one costs the working vehicles nothing.
    watch_every_cycles: int = 1
    # Failure detection: suspected when no evidence of life (direct or relayed, dated by the
    # sender's clock) for this many cycles; declared lost when another vehicle's next frame
    # confirms it has not heard the suspect for 4 periods either (`membership`), so a vehicle
    # that really went silent is lost within about 5 cycles (4 + the confirmer's slot) of
    # n * slot_s seconds (the bound grows linearly with the fleet: docs/wire.md).
    lost_after_cycles: float = 4.0
    # Whom a vehicle expects to hear (`membership`): a peer within this range of it, on the
    # positions last known (a 64-byte frame decodes 99 % of the time at 1 km with the default
    # modem, 93 % at 1.5 km, 50 % at 2 km: docs/membership.md). Silence from farther away is
    # no evidence of anything, and a witness farther than this from a silent peer cannot
    # confirm its silence.
    hear_range_m: float = 1000.0
    # Takeover: of the spots a peer declared lost leaves, those it would itself have reached
    # within this many seconds go to the end of the taker's route (a peer presumed lost may
    # only be out of earshot; see `fleet_agent.decisions`).
    takeover_wait_s: float = 120.0
    # A silence is taken as a death outright (the replanner's routes as they are) only when
    # the chance the peer is alive and unheard, from the measured reception, is at most this;
    # otherwise the takeover keeps every spot the taker holds (see `Decisions.takeover`).
    takeover_doubt: float = 1e-4
    # Local replans: a lost peer's spots are replanned among at most this many survivors
    # nearest them (`policies.takeover`); the cooperation operator offers the replanner at most
    # ``coop_spots`` free spots, the cheapest detours within its spare battery.
    takeover_peers: int = 6
    coop_spots: int = 40
    # Planning (iteration budgets only: every agent must compute the same plans).
    plan_iterations: int = 500
    replan_iterations: int = 150
    # Polish the initial plan with inter-route moves (`hfc_core.best` SearchParams.polish):
    # +0.6 % priority on the paper preset, but its iteration budget takes longer: a sweep's
    # median paper-preset run 1.82 s (1.35 s before), a whole in-process run of 24 AUVs x 600
    # spots 32 s against 12 s without (same priority there); off for sweeps of large fleets.
    plan_polish: bool = True
    # A fleet of more than this many vehicles is planned region by region (sectors of spots
    # around the starts, each with its share of the vehicles: `plans.regions`), so the initial
    # plan costs in proportion to the fleet (one `best` run of 500 iterations: 27 s at 24
    # AUVs x 600 spots, 208 s at 48 x 1200, beyond 30 min at 100 x 2500). 0: never. Each
    # region searches ``plan_iterations`` per ``plan_region_vehicles`` of its vehicles.
    plan_region_vehicles: int = 12
    coop_period_s: float = 120.0  # online cooperation operator: how often to look for work
    coop_min_slack_s: float = 60.0  # below this spare battery, do not even look
    battery_reserve_s: float = 1.0  # keep this much battery at the rendezvous
    # Dynamic missions (a scenario with a hidden reef, `reef_sim.truth`): the map is a prior.
    # A predicted spot is planned at its expected value, p_cots * rho (eq. 2's priority times
    # the chance it holds COTS), and costs the look (the camera's inspect_s) plus p_cots times
    # its injection time; within aggregation_radius_m of a find its value uses
    # p_cots_near_find instead (COTS aggregate; the time stays at the prior's). 0.75: the share
    # of predicted spots that held COTS in the paper-like preset of `cotsfleet scenario
    # --dynamic` (67 of 90).
    discovery: bool = True  # False: --no-discovery (ignore sightings, no reallocation)
    p_cots: float = 0.75
    p_cots_near_find: float = 0.9
    aggregation_radius_m: float = 100.0
    find_slots: int = 24  # finds one vehicle may name (bounded memory: more are counted)
    find_repeats: int = 3  # each new find is sent this many times
    find_refresh_cycles: int = 6  # one known find rebroadcast every this many cycles
    find_settle_cycles: float = 3.0  # a find is planned this long after it is learned
    # Navigation as it is (`policies.navigation`): with no fix for nav_hold_s a vehicle under
    # way keeps station; for nav_limit_s it heads home. A vehicle whose projected end grew by
    # late_after_s since its route was set is late (its route refitted from its last fix).
    nav_hold_s: float = 10.0
    nav_limit_s: float = 120.0
    late_after_s: float = 60.0
    # A vehicle under way whose navigation reports a 1-sigma error per axis above this, m,
    # climbs to the surface for a GPS fix on its way (`policies.navigation`; 0: never). 3 m
    # puts 99 % of its error within 9 m, inside a look's footprint, and is what the dynamic
    # benchmark measures; off by default until the loss rules that its fault-fuzz duplicates
    # met are fixed (4 of 112 missions, traced in docs/search.md).
    surface_sigma_m: float = 0.0
    # The operator's live orders (`policies.orders`): one issued longer ago than this is
    # refused as stale (a recording kept back and played later, a topside far behind).
    ctl_max_age_s: float = 600.0
    # Spots the operator may add (`add-spot`): slots after the finds' in the working problem,
    # also on an exact map (the fleet's bitmaps cover them; more adds are refused, no_room).
    operator_slots: int = 4
    # A paused vehicle goes home once holding station longer would leave it less than this
    # beyond the time home from where it keeps station (the planner's reserve kept too).
    pause_margin_s: float = 60.0
    # Matching under uncertainty (`fleet_agent.association`, docs/search.md): how far a
    # predicted spot may be from its aggregation on the map (per axis, 1 sigma; a property of
    # the survey: 0.5 for the dynamic generator's exact maps) and an aggregation's radius.
    map_sigma_m: float = 3.0
    aggregation_extent_m: float = 5.0
    # And by the priority the camera measures (feature-aided: two estimates of unlike rho
    # are two aggregations): the camera's error on rho and the map's (relative, 1 sigma of
    # ln rho; 0: not compared. 0.3 for the dynamic generator's maps; a diver-checked map
    # like Green Island's is off by an absolute +-15 and is best left at 0).
    camera_priority_sigma: float = 0.1
    map_priority_sigma: float = 0.0
    # A predicted spot known present only from a sighting made with a navigation sigma above
    # this is looked at before it is injected: the vehicle may be a look's footprint (15 m,
    # 3.75 sigma of 4 m) off where it thinks, and would inject a neighbour or bare seabed.
    look_first_sigma_m: float = 4.0
    # A find is looked at before it is injected when the chance that the vehicle stands
    # nearer a treated aggregation of another rho than the find (so that it would inject
    # that one again: `discovery.needs_look`) exceeds this.
    look_first_p: float = 0.05
    # Map-relative navigation: a sighting surely of a predicted spot tells the vehicle its
    # navigation error (the map is the landmark); goals and reports are corrected by it.
    map_relative_nav: bool = True
    # Search (`fleet_agent.search`): the missed aggregations expected per predicted spot
    # (0: never search), where they lie from their spot (a ring, or a Gaussian spread when
    # search_ring_max_m is 0), how much less likely around an empty spot, and the orbits a
    # vehicle may fly at most.
    search_per_spot: float = 0.0
    search_ring_min_m: float = 0.0
    search_ring_max_m: float = 0.0
    search_spread_m: float = 50.0
    search_empty_weight: float = 1.0
    search_margin: float = 1.0  # a search's rate must beat the next spot's by this factor
    # Telemetry and persistence.
    status_period_s: float = 5.0
    truth_period_s: float = 5.0
    checkpoint_period_s: float = 10.0
    fleet_key_hex: str = ""  # HMAC key shared by the fleet (never sent on the bus)

    def __post_init__(self) -> None:
        positive = ("slot_s", "lost_after_cycles", "coop_period_s", "hear_range_m",
                    "schedule_epoch_s", "nav_hold_s", "nav_limit_s", "late_after_s",
                    "ctl_max_age_s", "status_period_s", "truth_period_s", "checkpoint_period_s")
        for name in positive:
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"agent config: {name} must be a positive number, got {value!r}")
        counts = ("pose_every_cycles", "cleared_refresh_cycles", "claim_repeats",
                  "claim_refresh_cycles", "abort_repeats", "home_repeats", "find_repeats",
                  "find_refresh_cycles")
        for name in counts:
            value = getattr(self, name)
            if not (isinstance(value, int) and value >= 1):
                raise ValueError(f"agent config: {name} must be an integer >= 1, got {value!r}")
        for name in ("takeover_peers", "coop_spots", "park_group"):
            value = getattr(self, name)
            if not (isinstance(value, int) and value >= 1):
                raise ValueError(f"agent config: {name} must be an integer >= 1, got {value!r}")
        for name in ("plan_iterations", "replan_iterations", "watch_every_cycles",
                     "plan_region_vehicles"):
            value = getattr(self, name)
            if not (isinstance(value, int) and value >= 0):
                raise ValueError(f"agent config: {name} must be an integer >= 0, got {value!r}")
        for name in ("p_cots", "p_cots_near_find", "look_first_p"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and 0.0 <= value <= 1.0):
                raise ValueError(f"agent config: {name} must be in 0..1, got {value!r}")
        for name in ("discovery", "plan_polish", "map_relative_nav"):
            if not isinstance(getattr(self, name), bool):
                raise ValueError(f"agent config: {name} must be true or false, got "
                                 f"{getattr(self, name)!r}")
        for name in ("find_slots", "operator_slots"):
            if not (isinstance(getattr(self, name), int) and 0 <= getattr(self, name) <= 64):
                raise ValueError(f"agent config: {name} must be an integer 0..64, got "
                                 f"{getattr(self, name)!r}")
        for name in ("coop_min_slack_s", "battery_reserve_s", "aggregation_radius_m",
                     "pause_margin_s",
                     "find_settle_cycles", "claim_settle_cycles", "unproven_wait_cycles",
                     "takeover_wait_s",
                     "slot_reuse_m", "schedule_margin_m",
                     "takeover_doubt", "map_sigma_m", "aggregation_extent_m",
                     "camera_priority_sigma", "map_priority_sigma", "look_first_sigma_m",
                     "search_per_spot", "search_ring_min_m", "search_ring_max_m",
                     "search_spread_m", "search_empty_weight", "search_margin",
                     "surface_sigma_m"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and value >= 0):
                raise ValueError(f"agent config: {name} must be >= 0, got {value!r}")
        if self.nav_limit_s < self.nav_hold_s:
            raise ValueError("agent config: nav_limit_s must be >= nav_hold_s")
        if self.fleet_key_hex:
            try:
                key = bytes.fromhex(self.fleet_key_hex)
            except ValueError:
                raise ValueError("agent config: fleet_key_hex is not hex") from None
            if len(key) < 16:
                raise ValueError("agent config: fleet key must be at least 16 bytes")

        if self.search_ring_max_m and not self.search_ring_min_m < self.search_ring_max_m:
            raise ValueError("agent config: search_ring_min_m must be below search_ring_max_m")

    @property
    def association(self) -> AssociationParams:
        """The matching rule's figures (`fleet_agent.association`)."""
        return AssociationParams(map_sigma_m=self.map_sigma_m,
                                 extent_m=self.aggregation_extent_m,
                                 camera_priority_sigma=self.camera_priority_sigma,
                                 map_priority_sigma=self.map_priority_sigma)

    @property
    def fleet_key(self) -> bytes:
        if not self.fleet_key_hex:
            raise ValueError("agent config: no fleet key (set fleet_key_hex)")
        return bytes.fromhex(self.fleet_key_hex)

    def with_key(self, key: bytes) -> AgentConfig:
        return replace(self, fleet_key_hex=key.hex())


def config_from_dict(doc: Mapping[str, Any]) -> AgentConfig:
    """Fields of `AgentConfig` from a plain mapping; unknown keys are an error (typos)."""
    known = {f.name for f in fields(AgentConfig)}
    unknown = set(doc) - known
    if unknown:
        raise ValueError(f"agent config: unknown settings {sorted(unknown)}")
    return AgentConfig(**dict(doc))


def load_config(path: str | Path) -> AgentConfig:
    """Read an agent config TOML file (a flat table, or an ``[agent]`` table)."""
    doc = tomllib.loads(Path(path).read_text(encoding="utf-8"))
    return config_from_dict(doc.get("agent", doc))


def dump_config(config: AgentConfig) -> str:
    """TOML text of ``config`` (what the launcher writes for each run), under ``[agent]``."""
    return tomli_w.dumps({"agent": {f.name: getattr(config, f.name) for f in fields(AgentConfig)}})
