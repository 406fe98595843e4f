"""What every agent of a mission knows before the first message: the shared context."""

from __future__ import annotations

from dataclasses import dataclass, replace

from fleet_agent.beliefs import FIND_MARGIN_M, expected_problem, initial_working_problem
from fleet_agent.config import AgentConfig
from fleet_agent.plans import Planner, nominal_tracks
from fleet_agent.sensor import Camera
from fleet_agent.wire import Codec
from fleet_bus.modem_port import WATER_SPEC, ModemSpec
from fleet_bus.orders import OrderCodec, TopsideSchedule
from fleet_bus.tdma import SpatialSchedule, Track
from fleet_bus.tesla import FleetChains
from hfc_core.model.paths import PathFn, path_function
from hfc_core.model.problem import Problem


@dataclass(frozen=True)
class Dynamic:
    """A dynamic mission (the scenario has a hidden reef): the map the fleet was given and
    the camera its vehicles carry (never the reef itself)."""

    scenario: Problem
    camera: Camera


@dataclass(frozen=True)
class Fleet:
    """The scenario, the wire codec under the run's keys (fleet key and run id) and the
    modem's frame budget, the planner, the land metric, the mission seed, the initial fleet
    plan every agent computes alone (no messages), where that plan puts each vehicle over
    time (``tracks``) and the slot schedule made from them (``schedule``: spatial TDMA,
    `fleet_bus.tdma.SpatialSchedule`). In process one Fleet serves every agent: what they
    would all compute alike is computed once.

    In a dynamic mission ``problem`` is the working problem before anything is seen
    (`fleet_agent.beliefs`: predicted spots at their expected value, then a slot per possible
    find and the operator's slots) and the initial plan is made on the expected values. On an
    exact map it is the scenario and the operator's slots (the scenario itself without them),
    and the initial plan is made on the scenario (``scenario``: the map as given)."""

    problem: Problem
    codec: Codec
    planner: Planner
    paths: PathFn
    seed: int
    base_routes: tuple[tuple[int, ...], ...]
    dynamic: Dynamic | None = None
    modem: ModemSpec = WATER_SPEC
    tracks: tuple[Track, ...] = ()
    schedule: SpatialSchedule | None = None
    chains: FleetChains | None = None  # every vehicle's key chain (`fleet_bus.tesla`)
    orders: OrderCodec | None = None  # the operator's orders' frames (`fleet_bus.orders`)
    topside: TopsideSchedule = TopsideSchedule()  # the topside's key intervals
    scenario: Problem | None = None  # the map as given (None: ``problem`` itself)

    @property
    def given(self) -> Problem:
        """The scenario as given, without the slots of the working problem."""
        return self.scenario if self.scenario is not None else self.problem

    @staticmethod
    def build(problem: Problem, key: bytes, seed: int, config: AgentConfig,
              planner: Planner | None = None, *, run_id: str,
              camera: Camera | None = None, modem: ModemSpec = WATER_SPEC,
              chains: FleetChains | None = None) -> "Fleet":
        """``modem``: what every vehicle's modem carries (one frame budget for the fleet);
        ValueError if its frames cannot carry what the mission needs. ``chains``: the key
        chains the credentials issued (None: derived from the fleet key, as a simulation's);
        ValueError if they are too short for the mission's turns on the fleet's schedule."""
        if chains is not None and len(chains.commitments) != problem.n_vehicles:
            raise ValueError(f"key chains for {len(chains.commitments)} vehicles, the "
                             f"scenario has {problem.n_vehicles}")
        if camera is not None:
            fleet = Fleet._build_dynamic(problem, key, seed, config, run_id, camera, modem,
                                         chains)
        else:
            working = initial_working_problem(problem, None, config)
            codec = Codec.for_problem(working, key, run_id,
                                      max_frame_bytes=modem.max_frame_bytes)
            planner = planner or Planner.from_config(problem, seed, config)
            routes = planner.initial_routes()
            if working is not problem:  # the operator's slots: replans are on the working one
                planner = Planner.from_config(working, seed, config)
            tracks = tuple(nominal_tracks(problem, routes))
            schedule = schedule_of(tracks, config)
            fleet = Fleet(working, codec, planner, path_function(working), seed, routes,
                          modem=modem, tracks=tracks, schedule=schedule,
                          chains=chains_for(problem, schedule, key, run_id, chains))
        return replace(fleet, orders=OrderCodec(key, run_id, tuple(
            v.id for v in problem.vehicles)), topside=TopsideSchedule.for_fleet(
            problem.n_vehicles * config.slot_s), scenario=problem)

    @staticmethod
    def wire_of(problem: Problem, key: bytes, run_id: str, config: AgentConfig,
                camera: Camera | None = None, modem: ModemSpec = WATER_SPEC) -> Codec:
        """The wire codec every agent of this mission builds (`build`), without the initial
        plan: what a launcher needs to speak the fleet's frames (its insider attacks)."""
        if camera is None:
            return Codec.for_problem(initial_working_problem(problem, None, config), key,
                                     run_id, max_frame_bytes=modem.max_frame_bytes)
        working = initial_working_problem(problem, camera, config)
        return _dynamic_codec(working, problem.n_tasks, key, run_id, modem)

    @staticmethod
    def _build_dynamic(scenario: Problem, key: bytes, seed: int, config: AgentConfig,
                       run_id: str, camera: Camera, modem: ModemSpec,
                       chains: FleetChains | None) -> "Fleet":
        working = initial_working_problem(scenario, camera, config)
        codec = _dynamic_codec(working, scenario.n_tasks, key, run_id, modem)
        expected = expected_problem(scenario, camera, config.p_cots)
        routes = Planner.from_config(expected, seed, config).initial_routes()
        planner = Planner.from_config(working, seed, config)
        tracks = tuple(nominal_tracks(expected, routes))
        schedule = schedule_of(tracks, config)
        return Fleet(working, codec, planner, path_function(working), seed, routes,
                     Dynamic(scenario, camera), modem, tracks, schedule,
                     chains_for(scenario, schedule, key, run_id, chains))


def chains_for(problem: Problem, schedule: SpatialSchedule, key: bytes, run_id: str,
               chains: FleetChains | None) -> FleetChains:
    """The fleet's key chains: one key per turn of a vehicle (`fleet_bus.tesla`: a sender's
    cycles are its turns on the schedule, which come faster where slots are reused). Derived
    from the fleet key when none were issued, long enough for the vehicle with the most
    turns; issued chains too short for the mission are refused (ValueError)."""
    battery_s = max(v.battery_s for v in problem.vehicles)
    if chains is None:
        turns = max(schedule.turns_before(v, battery_s + 600.0) for v in range(schedule.n))
        return FleetChains.derived(key, run_id, problem.n_vehicles, turns + 16)
    turns = max(schedule.turns_before(v, battery_s) for v in range(schedule.n))
    if chains.length < turns:
        raise ValueError(f"key chains of {chains.length} cycles are too short for a "
                         f"mission of {turns} turns")
    return chains


def schedule_of(tracks: tuple[Track, ...], config: AgentConfig) -> SpatialSchedule:
    """The fleet's slot schedule from its plan's tracks and the agents' settings."""
    return SpatialSchedule(tracks, config.slot_s, config.slot_reuse_m or None,
                           config.schedule_margin_m, config.schedule_epoch_s,
                           config.park_group)


def _dynamic_codec(working: Problem, n_predicted: int, key: bytes, run_id: str,
                   modem: ModemSpec) -> Codec:
    """A dynamic mission's codec: the working problem's spots and find slots, finds named
    from ``n_predicted`` on, a margin for finds off the map."""
    return Codec.for_problem(working, key, run_id, FIND_MARGIN_M, found_from=n_predicted,
                             max_frame_bytes=modem.max_frame_bytes)
