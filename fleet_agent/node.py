"""The Zenoh backend of the agent driver: one OS process per vehicle on the shared mission clock.

Zenoh callbacks and the modem's reader only enqueue into a bounded inbox; one loop feeds the
inbox to the driver with each item's arrival time on the mission clock, ticks the agent at its
`next_wakeup`, and the driver carries out the outputs: frames to the modem (`--modem`: the
emulated water over Zenoh, `fleet_agent.modems.water`, or a WHOI Micro-Modem,
`fleet_agent.modems.micromodem`), telemetry to ``fleet/truth|status|event/<id>``, records to
the journal, commands to the vehicle (``--helm``: `fleet_agent.helms.choice.open_vehicle`,
the one place the shell picks it). Commands arrive on
``fleet/ctl/<id>``: ``abort`` goes to the agent's logic; ``stop`` ends the process cleanly.

Start-up: the agent reads the mission record (``fleet/mission``: scenario, seed, run id),
computes the shared initial plan, opens a live helm (MOOS, ROS 2: on a `PendingClock` until
the clock comes, so its vehicle answers before the mission starts; the simulated vehicle is
made at mission time 0, where the journal left it), announces itself ready on
``fleet/alive/<id>`` (a signed
put, repeated until the clock comes, and a liveliness token), then waits for the clock record
(``fleet/clock``), which the operator serves once every agent is ready, and keeps its
`MissionClock` on the operator's (`ClockSync`: monotonic, offset measured, records followed;
a step of this host's wall clock is counted as ``clock_wall_steps`` and changes nothing).
`build_fleet` and `drive` are shared with the on-board shell (`fleet_agent.onboard`).

Authentication (`fleet_bus.auth`, with ``--credentials``): everything this agent puts is
signed with its own key; it takes deliveries only signed by the relay and commands, mission
and clock records only signed by the operator. Envelopes are opened on Zenoh's threads, so a
forgery never reaches the inbox; refusals are counted into the agent's counters
(``drop_auth_<reason>``, in its statuses and so in the mission report).
"""

from __future__ import annotations

import queue
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

import zenoh

from fleet_agent.agent import Agent
from fleet_agent.config import AgentConfig
from fleet_agent.driver import AgentDriver
from fleet_agent.fleet import Fleet
from fleet_agent.journal import Journal
from fleet_agent.plans import set_planning_hook
from fleet_agent.driver import Telemetry, TruePose
from fleet_agent.helms.choice import BEFORE_S, HelmChoice, PendingClock, open_vehicle
from fleet_agent.helms.sim import camera_figures, sim_vehicle
from fleet_agent.modems.choice import ModemChoice
from fleet_agent.modems.water import ZenohWater
from fleet_bus import topics
from fleet_bus.auth import BusAuth, unseal
from fleet_bus.clock import Clock, MissionClock
from fleet_bus.commands import STOP, Command
from fleet_bus.credentials import CredentialsError, load_frame_chains, load_frame_seed
from fleet_bus.mission import ClockSync, Mission, fetch_mission
from fleet_bus.modem_port import ModemPort, ModemReport, Received
from fleet_bus.process import AGENT_READY, ready
from fleet_bus.telemetry import Event, Ready, Status, Truth
from fleet_bus.topics import Publisher, TopicError
from fleet_bus.vehicle_port import VehiclePort
from hfc_core.formats.scenario import problem_from_dict
from hfc_core.model.errors import ScenarioError
from hfc_core.model.problem import Problem
from reef_sim.navigation import NavigationParams, navigation_from_doc
from reef_sim.truth import Reef, reef_from_doc

MAX_WAIT_WALL_S = 0.25  # longest sleep between looks at the stop flag
INBOX_LIMIT = 4096  # frames and commands waiting for the agent; beyond, the newest are dropped
ALIVE_EVERY_S = 1.0  # the ready announcement is repeated until the clock record comes


class Inbox:
    """Bounded FIFO between Zenoh's and the modem's threads and the agent loop. Items carry
    their arrival time (monotonic, `MissionClock.sim_of` turns it into mission time): after a
    long computation the agent still sees each frame at the moment it came, not all of them at
    once."""

    def __init__(self, limit: int = INBOX_LIMIT) -> None:
        # (kind, payload, arrival): a frame heard ("rx") or a command ("ctl") as bytes, or
        # another report of the modem ("modem")
        self._q: queue.Queue[tuple[str, bytes | ModemReport, float]] = queue.Queue(limit)
        self.overflow = 0

    def put(self, kind: str, payload: bytes | ModemReport) -> None:
        try:  # the monotonic clock: a step of the wall clock must not move a frame in time
            self._q.put_nowait((kind, payload, time.monotonic()))
        except queue.Full:
            self.overflow += 1

    def hear(self, report: ModemReport) -> None:
        """The modem's sink (its thread): enqueue only."""
        if isinstance(report, Received):
            self.put("rx", report.frame)
        else:
            self.put("modem", report)

    def take_overflow(self) -> int:
        """Items dropped since the last call (counted into the agent by its loop)."""
        n, self.overflow = self.overflow, 0
        return n

    def get(self, timeout_s: float) -> tuple[str, bytes | ModemReport, float] | None:
        try:
            return self._q.get(timeout=timeout_s) if timeout_s > 0 else self._q.get_nowait()
        except queue.Empty:
            return None


class ZenohTelemetry:
    """Puts the driver's telemetry on the bus under this vehicle's keys, each record on its
    own topic (`fleet_bus.topics`: a truth can only go to ``fleet/truth/<id>``)."""

    def __init__(self, session: zenoh.Session, vid: str, auth: BusAuth | None = None) -> None:
        self._truth = Publisher(session, topics.TRUTH.of(vid), auth)
        self._status = Publisher(session, topics.STATUS.of(vid), auth)
        self._event = Publisher(session, topics.EVENT.of(vid), auth)
        self._busy = Publisher(session, topics.BUSY.of(vid), auth)

    def publish(self, topic: str, payload: Status | Event | Truth) -> None:
        """``payload`` on its record's topic (``topic`` names the same kind)."""
        if isinstance(payload, Truth):
            self._truth.put(payload)
        elif isinstance(payload, Status):
            self._status.put(payload)
        else:
            self._event.put(payload)

    def planning(self, busy: bool) -> None:
        """Tell the operator this process starts (ends) a planner run: it holds the shared
        clock meanwhile, so the burst costs no mission time (`fleet_agent.plans`)."""
        self._busy.put(busy)


def _announce_ready(session: zenoh.Session, vid: str, auth: BusAuth | None,
                    until: threading.Event) -> None:
    """Put the signed ready announcement every `ALIVE_EVERY_S` until ``until`` is set (the
    operator may subscribe after the first one, e.g. a launcher restarted)."""
    topic, ready = topics.ALIVE.of(vid), Ready(vid, auth.run_id if auth else "")
    while True:
        topic.put(session, auth, ready)
        if until.wait(ALIVE_EVERY_S):
            return


def main(conf: zenoh.Config, vid: str, config: AgentConfig, journal_path: Path,
         stop: threading.Event, mission_timeout_s: float = 120.0,
         auth: BusAuth | None = None, modem: ModemChoice = ModemChoice(),
         credentials: Path | None = None, helm: HelmChoice = HelmChoice()) -> int:
    """Run agent ``vid`` until ``stop``. Returns 0, 2 if the vehicle is not in the mission,
    its credentials lack its key chain or its helm could not be opened, or 3 if no mission or
    clock record came. With ``auth`` (its own key and the run's ring) it signs what it puts
    and takes only what its rightful senders signed; with ``credentials`` (its directory) its
    frames are provably its own (its key chain, and the fleet's commitments:
    `fleet_bus.tesla`), else every chain derives from the fleet key."""
    inbox = Inbox()
    mission_time = PendingClock()  # -1 until the clock record comes
    hear = inbox.hear

    ctl = topics.CTL.of(vid)

    def take_ctl(sample: zenoh.Sample) -> None:
        payload = unseal(auth, ctl.key, sample.payload.to_bytes())
        if payload is not None:
            inbox.put("ctl", payload)

    with Journal(journal_path) as journal, zenoh.open(conf) as session, \
            session.declare_subscriber(ctl.key, take_ctl):
        port: ModemPort | None = None
        if modem.name == "water":  # listening from the start, as the relay may be early
            port = ZenohWater(session, vid, hear, mission_time, auth)
        mission = fetch_mission(session, stop, mission_timeout_s, auth)
        if mission is None:
            return 0 if stop.is_set() else 3
        built = build_fleet(mission, vid, config, modem, credentials)
        if isinstance(built, int):
            return built
        vehicle = None
        if helm.name != "sim":  # a live vehicle is there before the mission: ready first
            vehicle = open_live(helm, built, vid, mission_time)
            if vehicle is None:
                return 2
        clocked = threading.Event()
        threading.Thread(target=_announce_ready, args=(session, vid, auth, clocked),
                         name="ready", daemon=True).start()
        with session.liveliness().declare_token(topics.ALIVE.of(vid).key):
            sync = ClockSync(session, auth, stop)  # the operator's clock, measured
            try:
                clock = sync.join(mission_timeout_s)
            finally:
                clocked.set()
            if clock is None:
                return 0 if stop.is_set() else 3
            sync.start()
            mission_time.clock = clock
            if port is None:
                port = modem.open(hear, clock)
            telemetry = ZenohTelemetry(session, vid, auth)
            set_planning_hook(telemetry.planning)
            try:
                return drive(built, vid, config, journal, clock, port, telemetry, helm, stop,
                             inbox, auth, sync, vehicle)
            finally:
                sync.close()
                port.close()
                if vehicle is not None:
                    vehicle[0].close()


def build_fleet(mission: Mission, vid: str, config: AgentConfig, modem: ModemChoice,
                credentials: Path | None = None) -> Built | int:
    """The mission's fleet context (the initial plan: every agent computes the same) with
    the key chains of ``credentials`` (`fleet_bus.tesla`), or 2 after one line on stderr: a
    scenario that is not valid, a vehicle not in it, credentials without the chains."""
    try:
        problem = problem_from_dict(mission.scenario)
        reef = reef_from_doc(mission.scenario, problem)  # the simulated world's reef
        navigation = navigation_from_doc(mission.scenario)  # and its vehicles' navigation
    except ScenarioError as exc:
        print(f"fleet_agent {vid}: the mission's scenario is not valid: {exc}",
              file=sys.stderr)
        return 2
    if vid not in problem.vehicle_index:
        print(f"fleet_agent: {vid!r} is not a vehicle of the mission", file=sys.stderr)
        return 2
    chains, seed = None, None
    if credentials is not None:
        try:
            chains = load_frame_chains(credentials, [v.id for v in problem.vehicles])
            seed = load_frame_seed(credentials)
        except CredentialsError as exc:
            print(f"fleet_agent {vid}: {exc}", file=sys.stderr)
            return 2
    fleet = Fleet.build(problem, config.fleet_key, mission.seed, config,  # initial plan
                        run_id=mission.run_id,  # the wire keys bind the run
                        camera=None if reef is None else camera_figures(reef),
                        modem=modem.spec, chains=chains)
    return Built(mission, problem, reef, fleet, seed, navigation)


@dataclass(frozen=True)
class Built:
    mission: Mission
    problem: Problem
    reef: Reef | None
    fleet: Fleet
    chain_seed: bytes | None = None  # this vehicle's key chain (None: from the fleet key)
    navigation: NavigationParams | None = None  # the simulated vehicle's (None: exact)


class WallStepSource(Protocol):
    """Whatever tells the agent how often this host's wall clock stepped (`ClockSync` on the
    bus, `onboard.WallSteps` on a vehicle's own clock)."""

    def take_wall_steps(self) -> int: ...


def open_live(helm: HelmChoice, built: Built, vid: str, clock: Clock,
              now: float = BEFORE_S) -> tuple[VehiclePort, TruePose | None] | None:
    """The vehicle (`open_vehicle`), or None after one line on stderr."""
    index = built.problem.vehicle_index[vid]
    try:
        return open_vehicle(helm, built.problem, index, clock=clock, seed=built.mission.seed,
                            reef=built.reef, t_s=now, pos=built.problem.vehicles[index].start,
                            odometer_m=0.0)
    except (ConnectionError, ImportError, OSError, ValueError) as exc:
        print(f"fleet_agent {vid}: --helm {helm.name}: {exc}", file=sys.stderr, flush=True)
        return None


def drive(built: Built, vid: str, config: AgentConfig, journal: Journal, clock: MissionClock,
          port: ModemPort, telemetry: Telemetry, helm: HelmChoice, stop: threading.Event,
          inbox: Inbox, auth: BusAuth | None = None, sync: WallStepSource | None = None,
          opened: tuple[VehiclePort, TruePose | None] | None = None) -> int:
    """The agent on its vehicle (``opened``, or opened here: the simulated one where the
    agent last knew it was) from mission time 0 (or now, restarted from its journal) until
    ``stop``: 0, or 2 if the helm could not be opened (said on stderr)."""
    while clock.now() < 0 and not stop.is_set():
        stop.wait(min(MAX_WAIT_WALL_S, clock.wall_delay(-clock.now())))
    now = clock.now()
    index = built.problem.vehicle_index[vid]
    agent = Agent(built.fleet, index, config, now, journal.records, built.chain_seed,
                  journal_damaged=journal.damage is not None)
    if opened is None and helm.name == "sim":
        sim = sim_vehicle(built.problem, index, seed=built.mission.seed, reef=built.reef,
                          t_s=now, pos=agent.own.pos, odometer_m=agent.own.distance_m,
                          navigation=built.navigation)
        opened = (sim, sim.true_pose)
    elif opened is None:
        opened = open_live(helm, built, vid, clock, now)
        if opened is None:
            return 2
    vehicle, truth = opened
    try:
        driver = AgentDriver(agent, vehicle, port, telemetry, journal, truth=truth,
                             truth_period_s=config.truth_period_s)
        start = f"restart, {len(journal.records)} records" if journal.records else "fresh"
        damage = journal.describe_damage()
        if damage:  # what the restart could not read, and where the evidence is
            print(f"fleet_agent {vid}: {damage}", file=sys.stderr, flush=True)
            start += f"; {damage}"
        if journal.damage is not None:
            agent.count("journal_damaged_bytes", journal.damage.damaged_bytes)
        ready(AGENT_READY, f"{vid} at t={clock.now():.1f} s ({start}), helm {vehicle.name}")
        _loop(driver, inbox, clock, stop, auth, sync)
        driver.final_status(clock.now())
    finally:
        vehicle.close()
    return 0


def _loop(driver: AgentDriver, inbox: Inbox, clock: MissionClock, stop: threading.Event,
          auth: BusAuth | None = None, sync: WallStepSource | None = None) -> None:
    driver.tick(clock.now())
    while not stop.is_set():
        due = driver.next_wakeup()
        wait = min(MAX_WAIT_WALL_S, clock.wall_delay(due - clock.now()))
        item = inbox.get(wait)
        while item is not None:
            kind, payload, wall = item
            at = clock.sim_of(wall)
            if not isinstance(payload, bytes):  # kind "modem"
                driver.agent.count(f"modem_{type(payload).__name__.lower()}")
            elif kind == "rx":
                driver.frame(payload, at)
            else:
                try:
                    name: Command | None = topics.CTL.of(driver.agent.id).decode(payload)
                except TopicError:
                    driver.agent.count("ctl_malformed")
                    name = None
                if name == STOP:
                    stop.set()
                    return
                if name is not None:
                    driver.command(name, at)
            item = inbox.get(0)
        dropped = inbox.take_overflow()
        if dropped:
            driver.agent.count("inbox_overflow", dropped)
        if auth is not None:
            for reason, n in auth.verifier.take_refused().items():
                driver.agent.count(f"drop_auth_{reason}", n)
        figures = getattr(driver.vehicle, "figures", None)
        if callable(figures):  # the live helm's own counts (fix lag, drops, its clock)
            driver.agent.counters.update(figures())
        steps = sync.take_wall_steps() if sync is not None else 0
        if steps:  # this host's wall clock stepped: named in the status, nothing else
            driver.agent.count("clock_wall_steps", steps)
        now = clock.now()
        driver.agent.note_lag(max(0.0, now - due))  # how late this host runs the mission
        driver.tick(now)
