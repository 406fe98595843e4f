"""The multi-process backend: a mission as separate OS processes, over Zenoh.

Router -> relay (comms_sim) -> one agent per vehicle -> ground station, each in its own
process group. The operator (this backend, in the launcher's process) serves the mission
record (scenario, seed, run id) from the start and the clock record (epoch, warp) once every
agent has computed its initial plan; it applies faults at their mission times (abort: a
command; kill: SIGKILL; restart: the agent again on its journal; stall: SIGSTOP and SIGCONT
in wall time; partition, loss and attacks: link control to the relay), watches the fleet's
telemetry, and collects the relay's counters. Its parts, each one idea: `children` (the
processes), `clock_control` (the shared clock's pace and holds) and `intake` (what it takes
from the bus, checked), `helm_launch` (what each vehicle's helm needs: MOOS communities, ROS 2
vehicles, ``--helm``) and `modem_launch` (the relay or the emulated Micro-Modems, ``--modem``);
this module wires them to the bus and to the runner. With ``--helm moos`` the shared clock is
kept at the warp (`helm_launch.pins_clock`: no holds, no pacing).

Lifecycle: every child dies with its parent (`fleet_bus.process.die_with_parent`:
``PR_SET_PDEATHSIG`` on Linux, and a watch on the parent's pid everywhere), so whatever ends
the launcher, SIGKILL included, ends the children within seconds. A mission outlives its
parts: a child that exits on its own is named with its last lines (a full disk recognised)
and handled by what it is (`CRASH_POLICY`): the relay and the ground station are started
again (at most `MAX_RESTARTS` times each; the station then is only reported), an agent's
vehicle is lost to the fleet (the others take over its work, as after a kill), and only the
router, which carries everything, ends the mission (`ChildExited`). The report lists every
crash (``crashes``). A full disk costs what it must and no more: a reserve the size of the
report (`DiskReserve`) is kept in the run dir and given back before the event log and the
report are written.

Credentials (`fleet_bus.credentials`, `docs/security.md`): each run gets fresh ones under
``RUN_DIR/credentials`` (or ``credentials``, made beforehand with ``cotsfleet credentials``):
the operator's signing key stays in this process; every child is started with its own
directory (``--credentials DIR/<id>``) and nothing else. The router takes only the run's
processes (by certificate over TLS, `cotsfleet.mission.transport` says when; else by login),
each with its rights; every message is signed and checked
(`fleet_bus.auth`), and what the operator refuses is counted in the report's ``security``.

Across machines: ``listen`` on a reachable address and ``remote`` vehicles: no agent is
started for those; the launcher waits for their ready announcements like for its own agents
and ends them with a ``stop`` command. They need the credentials made beforehand (their own
directory copied to their host) and the fleet key of the agent config.
"""

from __future__ import annotations

import json
import os
import secrets
import signal
import threading
import time
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterator, Mapping, Sequence

import zenoh

from comms_sim.stats import LinkCounts
from cotsfleet.mission.fault_plan import Step, awaited, carry_out, plan
from cotsfleet.mission.faults import INSIDER_ATTACKS, Fault, FaultError
from cotsfleet.mission.insider_launch import Leaked
from cotsfleet.mission.children import Child, ChildExited, Children
from cotsfleet.mission.clock_control import ClockControl
from cotsfleet.mission.disk import DiskReserve, cut_to_whole_lines
from cotsfleet.mission.helm_launch import BRIDGE_READY, HelmLaunch, pins_clock
from cotsfleet.mission.intake import Intake
from cotsfleet.mission.intruder import Intruder, intruder_rng
from cotsfleet.mission.report import values_of
from cotsfleet.mission.modem_launch import ModemLaunch
from cotsfleet.mission.order_desk import OrderDesk
from cotsfleet.mission.run_record import RunRecord, remove_run_record, write_run_record
from cotsfleet.mission.topside import Topside, forged_frame, topside_position
from cotsfleet.mission.transport import choose_transport
from cotsfleet.reporting.terminal import progress_line
from fleet_agent.config import AgentConfig, dump_config
from fleet_agent.mission_file import write_mission_file
from fleet_agent.radio import LATE_SHARE
from fleet_bus import keys, topics
from fleet_bus.auth import BusAuth, seal_query
from fleet_bus.clock import MissionClock
from fleet_bus.commands import ABORT, STOP, Command
from fleet_bus.ledger import FleetLedger
from fleet_bus.link import LinkControl, Partition
from fleet_bus.mission import Mission
from fleet_bus.credentials import (OPERATOR_ID, ROUTER_ID, STATION_ID, CredentialsError,
                                   load_auth, load_frame_chains, load_frame_seed, load_ring,
                                   new_run_id, write_run_credentials)
from fleet_bus.orders import TOPSIDE, OrderCodec, TopsideSchedule
from fleet_bus.process import ROUTER_READY
from fleet_bus.query_limits import QueryGate, gate_queryable
from fleet_bus.states import FaultKind
from fleet_bus.session import client_config, free_tcp_endpoint, local_endpoint
from fleet_agent.beliefs import find_ids, operator_ids
from hfc_core.model.problem import Problem
from reef_sim.truth import reef_from_doc

POLL_WALL_S = 0.05
ROUTER_ATTEMPTS = 3  # free loopback ports tried for the router
MAX_RESTARTS = 3  # times the relay or the ground station is started again after a crash
# What a crash of each child costs the mission: "restart" (then, once the restarts are
# spent, "report" for a passive process, else "end"), "vehicle" (lost to the fleet), "end".
# A helm's process (a MOOS app, a ROS 2 vehicle) is "helm": reported, not started again.
CRASH_POLICY = {"router": "end", "relay": "restart", "water": "restart",
                "ground_station": "restart"}
PASSIVE = ("ground_station",)  # nothing depends on it: reported once it cannot be restarted
# Start-up (launch to the clock's start) measured on the 2-core machine, paper preset:
# 4.2 s (3 vehicles), 9.4 s (6), 38.8 s (12), 165.5 s (24): about 0.29 s x vehicles²
# (every agent plans the same initial plan, a bigger one for a bigger fleet, all on two
# cores). The default allows twice that, plus a minute, and never less than 90 s.
STARTUP_BASE_S, STARTUP_PER_VEHICLE2_S, STARTUP_MIN_S = 60.0, 0.6, 90.0


def startup_timeout_for(vehicles: int) -> float:
    """The default wall seconds to wait for ``vehicles`` agents to be ready
    (`benchmarks/startup_scale.py`): 90 s up to 6 vehicles, 146 s for 12, 406 s for 24."""
    return max(STARTUP_MIN_S, STARTUP_BASE_S + STARTUP_PER_VEHICLE2_S * vehicles ** 2)


@contextmanager
def _signals_deferred() -> Iterator[None]:
    """Cleanup is not interrupted by a second Ctrl-C or SIGTERM (main thread only: that is
    where Python runs signal handlers); it is bounded by the grace periods of `Children.stop`."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    sigs = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
    old = {s: signal.signal(s, signal.SIG_IGN) for s in sigs}
    try:
        yield
    finally:
        for s, handler in old.items():
            signal.signal(s, handler)


@dataclass(frozen=True)
class ProcessOptions:
    warp: float = 60.0
    loss: float = 0.0
    viewer: str = "none"  # web | native | none
    rrd: Path | None = None
    web_port: int = 9090
    run_dir: Path | None = None
    agent_config: AgentConfig = field(default_factory=AgentConfig)
    progress_every_s: float = 3.0  # wall seconds between progress lines (0: none)
    # Keep the ground station (and so the web viewer it serves) up after the mission until
    # Ctrl-C: an operator watching in a browser should not lose the picture at the end.
    hold_viewer: bool = False
    listen: str | None = None  # router endpoint (default: a free loopback port)
    remote: tuple[str, ...] = ()  # vehicles whose agents run elsewhere (not started here)
    startup_timeout_s: float | None = None  # None: `startup_timeout_for` the fleet
    # Extra environment for one child by name (fault injection, e.g. a wall clock that steps
    # in that process only: tests/integration/test_clock_steps.py).
    child_env: Mapping[str, Mapping[str, str]] = field(default_factory=dict)
    disk_reserve_bytes: int = 4 << 20  # kept free in the run dir for the report (full disk)
    credentials: Path | None = None  # made beforehand (`cotsfleet credentials`); else fresh
    tls: bool = False  # TLS on loopback too (off loopback, or with TLS credentials, it always is)
    helm: str = "sim"  # sim | moos | ros2: what each vehicle's agent drives (`helm_launch`)
    modem: str = "water"  # water | micromodem: the water and each agent's modem (`modem_launch`)
    modem_rate: int = 1  # the emulated Micro-Modems' rate
    slot_from_modem: bool = False  # the agents' slot_s was derived from the modem (report)
    # Keep the shared clock at the warp (no planning holds, no pacing); None: when the helm
    # cannot follow a changing clock (MOOS: `helm_launch.pins_clock`).
    pin_clock: bool | None = None

    def __post_init__(self) -> None:
        if not self.warp > 0:
            raise ValueError(f"warp must be positive, got {self.warp}")
        if not 0.0 <= self.loss <= 1.0:
            raise ValueError(f"loss must be in [0, 1], got {self.loss}")
        if self.viewer not in ("web", "native", "none"):
            raise ValueError(f"viewer must be web, native or none, got {self.viewer!r}")


class ProcessBackend:
    mode = "run"

    def __init__(self, problem: Problem, scenario: dict[str, Any], seed: int,
                 opts: ProcessOptions, out: Callable[[str], None] = print) -> None:
        self._values = values_of(problem, reef_from_doc(scenario, problem))
        self.problem, self.scenario, self.seed, self.opts, self.out = (
            problem, scenario, seed, opts, out)
        self.ids = [v.id for v in problem.vehicles]
        for vid in opts.remote:
            if vid not in self.ids:
                raise ValueError(f"unknown remote vehicle {vid!r}; the scenario has {self.ids}")
        if opts.remote and not opts.agent_config.fleet_key_hex:
            raise ValueError("remote agents need the fleet key they share with this launcher: "
                             "set fleet_key_hex in the agent config (--config)")
        if opts.remote and opts.credentials is None:
            raise ValueError("remote agents need their credentials before the mission: make "
                             "them with `cotsfleet credentials DIR`, copy DIR/<id> to each "
                             "remote host and pass --credentials DIR")
        # A run's id is its credentials' (signatures bind it): fresh unless made beforehand.
        self.run_id = new_run_id()
        if opts.credentials is not None:
            ring = load_ring(opts.credentials)
            signers = {sid for sid, m in ring.ring.items() if m.role == "vehicle"}
            if signers != set(self.ids):
                raise ValueError(f"{opts.credentials} is for vehicles {sorted(signers)}, the "
                                 f"scenario has {self.ids}")
            self.run_id = ring.run_id
        self.transport = choose_transport(opts.listen, opts.tls, opts.credentials)
        self.run_dir = opts.run_dir or Path(os.environ.get("TMPDIR", "/tmp")) / \
            "cotsfleet-runs" / self.run_id
        self.startup_timeout_s = opts.startup_timeout_s or startup_timeout_for(
            len(self.ids) - len(opts.remote))
        self.procs = Children(self.run_dir, out, self.startup_timeout_s)
        self.helm = HelmLaunch(opts.helm, problem, self.run_dir, opts.warp, self.run_id)
        self.modem = ModemLaunch(opts.modem, opts.modem_rate)
        self.pinned = pins_clock(opts.helm) if opts.pin_clock is None else opts.pin_clock
        self.crashes: list[dict[str, Any]] = []  # every child that ended untold, and what then
        self.reserve = DiskReserve(self.run_dir / DiskReserve.NAME, opts.disk_reserve_bytes)
        self.saved: dict[str, Any] = {}  # what the end could write (`_write_events`)
        self._relay_back: float | None = None  # a restarted relay not ready yet: since
        self.applied: list[Fault] = []
        self.dead: set[str] = set()
        self.endpoint = ""
        self.started = threading.Event()  # set once the mission clock runs
        self.interrupted = False
        self._pending: list[Step] = []  # the fault plan's steps still to come
        self._link: LinkCounts | None = None
        self._session: zenoh.Session | None = None
        self._closers: list[Any] = []
        self.intruder = Intruder(problem, intruder_rng(seed))
        self.auth: BusAuth | None = None  # the operator's key and the run's ring (start)
        self._relay_extra: dict[str, Any] = {}
        self._wall0 = time.monotonic()
        # The clock never outruns the fleet: its pace follows the hosts' lateness (bound: as
        # late as a host may run before its frames are dated back, `Radio.take_slot`) and it
        # is held while an agent plans (`fleet/busy/<id>`).
        self.pacer = ClockControl(opts.warp, LATE_SHARE * opts.agent_config.slot_s,
                                 self._put_clock, out)
        self._next_progress = 0.0
        self._closed = False
        self._closing = threading.Event()  # ends stall threads (they SIGCONT on the way out)
        self._stallers: list[threading.Thread] = []
        # Dynamic missions: finds are named by ids past the scenario's (`beliefs.find_ids`);
        # the operator's added spots by ids past those, in every mission (`operator_ids`).
        added = operator_ids(problem, opts.agent_config)
        finds = range(find_ids(problem, opts.agent_config).start if "truth" in scenario
                      else added.start, added.stop)
        self.intake = Intake(problem, self.ids, self.run_id, finds, self._busy,
                             self.intruder.overhear)
        self.queries = QueryGate(None)  # who asks the operator what (`start`: with the key)
        self.desk: OrderDesk | None = None  # the operator's live orders (`start`)

    # -- the runner's interface --------------------------------------------------------------

    def check(self, faults: Sequence[Fault]) -> None:
        for f in faults:
            if f.kind == FaultKind.CTL and self.modem.name != "water":
                raise FaultError(f"{f.describe()}: the operator's orders go into the water "
                                 "through the relay (--modem water); the emulated "
                                 "Micro-Modems do not carry the topside's frames yet")
            if f.kind in (FaultKind.KILL, FaultKind.RESTART, FaultKind.STALL) \
                    and f.vid in self.opts.remote:
                raise FaultError(f"{f.describe()}: a {f.kind} needs the agent's process "
                                 "here; not for --remote vehicles")

    def start(self, faults: Sequence[Fault]) -> None:
        opts = self.opts
        self.run_dir.mkdir(parents=True, exist_ok=True)
        if not self.reserve.take():
            self.out(f"warning: could not set {opts.disk_reserve_bytes} bytes aside in "
                     f"{self.run_dir} ({self.reserve.error}): a full disk may cost the report")
        config = opts.agent_config
        if not config.fleet_key_hex:  # a fresh fleet key per run; never on the bus
            config = config.with_key(secrets.token_bytes(16))
        cfg_path = self.run_dir / "agent.toml"
        cfg_path.touch(mode=0o600)
        cfg_path.write_text(dump_config(config), encoding="utf-8")
        (self.run_dir / "scenario.json").write_text(json.dumps(self.scenario), encoding="utf-8")
        # The mission as an agent on board loads it (`cotsfleet agent --mission`): on record.
        write_mission_file(self.run_dir / "mission.json",
                           Mission(self.scenario, self.seed, self.run_id))
        creds = self.creds = opts.credentials or self.run_dir / "credentials"
        if opts.credentials is None:
            write_run_credentials(creds, self.ids, self.run_id, tls=self.transport.tls,
                                  hosts=self.transport.hosts)
        auth = self.auth = self.intake.auth = load_auth(creds / OPERATOR_ID, OPERATOR_ID)
        self.queries = QueryGate(auth)
        listen = self._start_router(creds)
        session = self._session = zenoh.open(client_config([self.endpoint],
                                                           credentials=creds / OPERATOR_ID))
        if any(f.kind == FaultKind.REPLAY for f in faults):  # the modem intruder's material only
            self._closers.append(session.declare_subscriber(topics.RX.all.key, self.intake.rx))
        desk = self.desk = self._order_desk(creds, config)
        self._closers += [
            session.declare_subscriber(keys.ORDER_REQUEST, lambda sample: desk.request(
                sample.payload.to_bytes()) if sample.kind == zenoh.SampleKind.PUT else None),
            session.declare_subscriber(topics.RX.of(TOPSIDE).key, self._topside_heard),
            session.declare_subscriber(topics.STATUS.all.key, self.intake.status),
            session.declare_subscriber(topics.EVENT.all.key, self.intake.event),
            session.declare_subscriber(topics.ALIVE.all.key, self.intake.alive),
            session.declare_subscriber(topics.BUSY.all.key, self.intake.busy)]
        mission = topics.MISSION.encode(Mission(self.scenario, self.seed, self.run_id))
        on_mission = topics.MISSION.key
        self._closers.append(session.declare_queryable(on_mission, gate_queryable(
            self.queries, on_mission,
            lambda q: q.reply(on_mission, auth.seal(on_mission, mission)))))
        relay = self.procs.spawn(
            self.modem.child, self.modem.water_argv(
                self.endpoint, creds, self.run_dir, self.seed, len(self.ids), opts.loss,
                2 * self.startup_timeout_s), self.modem.ready_prefix,
            env=opts.child_env.get(self.modem.child))
        if opts.viewer != "none" or opts.rrd is not None:
            self.procs.spawn("ground_station", self._station_argv(0), echo=True,
                             env=opts.child_env.get("ground_station"))
        local = [vid for vid in self.ids if vid not in opts.remote]
        helm_env = self.helm.env()
        if self.helm.name == "moos":  # the communities first: the agents connect to them
            for name, argv in self.helm.moos_argvs(local):
                self.procs.spawn(name, argv, env=helm_env)
        bridges = [self.procs.spawn(name, argv, BRIDGE_READY, env=helm_env)
                   for name, argv in (self.helm.bridge_argvs(local, self.endpoint, creds)
                                      if self.helm.name == "ros2" else [])]
        for bridge in bridges:  # each vehicle serves (at its start) before its agent looks
            self.procs.wait_ready(bridge)
        for vid in self.ids:
            if vid in opts.remote:
                self.out(f"waiting for {vid} elsewhere: python -m fleet_agent --id {vid} "
                         f"--config AGENT.toml --credentials {creds / vid} "
                         f"--connect <a router linked to {listen}>")
            else:
                self.procs.spawn(vid, self._agent_argv(vid), env=self._agent_env(vid))
        self._wait_agents()
        self.pacer.start()
        self._closers.append(session.declare_queryable(  # the newest record, timed
            keys.CLOCK, gate_queryable(self.queries, keys.CLOCK, lambda q: q.reply(
                keys.CLOCK, auth.seal(keys.CLOCK, self.pacer.answer(str(q.parameters)))))))
        self.procs.wait_ready(relay)
        if opts.loss and self.modem.name != "water":  # the relay takes it as an option
            self._put_link(LinkControl(extra_loss=opts.loss))
        self._insiders = self._make_insiders(faults, config)
        self._pending = plan(faults)
        self.started.set()
        write_run_record(self.run_dir, RunRecord(self.run_id, self.endpoint, os.getpid(),
                                                 str(creds.resolve()), tuple(self.ids)))
        self.out(f"mission {self.run_id}: {len(self.ids)} vehicles, warp {opts.warp:g}"
                 f"{' (held fixed: ' + self.helm.name + ')' if self.pinned else ''}, loss "
                 f"{opts.loss:g}, helm {self.helm.name}, modem {self.modem.name} (slot "
                 f"{opts.agent_config.slot_s:g} s), run dir {self.run_dir}")

    def _start_router(self, creds: Path) -> str:
        """Start the router; returns where it listens. Without ``listen`` it takes a free
        loopback port, and another if that one was taken meanwhile (a port is only free
        until someone binds it); a port asked for is checked by the command line first."""
        for attempt in range(ROUTER_ATTEMPTS):
            listen = self.transport.listen or free_tcp_endpoint(proto=self.transport.protocol)
            self.endpoint = local_endpoint(listen)
            router = self.procs.spawn("router", ["-m", "comms_sim.router", "--listen", listen,
                                                 "--credentials", str(creds / ROUTER_ID)],
                                      ROUTER_READY, env=self.opts.child_env.get("router"))
            try:
                self.procs.wait_ready(router)
                return listen
            except ChildExited:
                router.expected_exit = True
                if self.opts.listen or attempt == ROUTER_ATTEMPTS - 1:
                    raise
        raise AssertionError("unreachable")

    def now(self) -> float:
        return self.clock.now() if self.clock is not None else 0.0

    def advance(self, t_s: float) -> None:
        while self.now() < t_s:
            self._apply_due()
            self._orders_due()
            self._pace_clock()
            self._watch_children()
            self._progress()
            time.sleep(POLL_WALL_S)
        self._apply_due()

    def finished(self) -> bool:
        if awaited(self._pending, self.now()):
            return False
        return self.intake.all_final(self.dead)

    def link_counts(self) -> LinkCounts | None:
        return self._link

    def _pace_clock(self) -> None:
        """Slow or speed the shared clock with the hosts' pace (`ClockControl.pace`)."""
        if self.clock is None or self.pinned:
            return
        self.pacer.pace(self.intake.statuses().values())

    def _busy(self, vid: str, busy: bool) -> None:
        """A planning hold begins or ends (`ClockControl.busy`); none on a pinned clock."""
        if not self.pinned:
            self.pacer.busy(vid, busy)

    def _put_clock(self, record: bytes) -> None:
        """Put a new clock record on the bus, signed: every process follows it. (Only the
        mission changes the clock: started, the session is open until `close`.)"""
        if self._session is not None and self.auth is not None:
            self._session.put(keys.CLOCK, self.auth.seal(keys.CLOCK, record))

    @property
    def clock(self) -> MissionClock | None:
        """The shared mission clock (`ClockControl`), once every agent is ready."""
        return self.pacer.clock

    @property
    def ledger(self) -> FleetLedger:
        """What the fleet reported (`Intake`): the report is built from it."""
        return self.intake.ledger

    @property
    def children(self) -> dict[str, Child]:
        """The mission's processes by name (each name's latest)."""
        return self.procs.by_name

    @property
    def clock_held(self) -> bool:
        """The shared clock runs at HOLD_WARP now because an agent plans."""
        return self.pacer.held

    def _clock_report(self) -> dict[str, Any]:
        """`ClockControl.report`, with the slots hosts ran late for (their frames dated back:
        `Radio.take_slot`) and the most the relay placed a frame back from its arrival."""
        report = self.pacer.report()
        if self.clock is None:
            return report
        statuses = self.intake.statuses().values()
        relay_clock = self._relay_extra.get("clock") or {}
        if relay_clock.get("wall_steps"):
            report["wall_steps"] = {**report["wall_steps"], "relay": relay_clock["wall_steps"]}
        return {**report, "slots_late": sum(s.counters.get("slots_late", 0) for s in statuses),
                "max_frame_late_s": self._relay_extra.get("max_late_s"),
                "relay_sync": relay_clock}

    def extra(self) -> dict[str, Any]:
        return {"run_id": self.run_id, "run_dir": str(self.run_dir), "warp": self.opts.warp,
                "loss": self.opts.loss, "wall_s": round(time.monotonic() - self._wall0, 2),
                "interrupted": self.interrupted, "clock": self._clock_report(),
                "exit_codes": {n: c.popen.returncode for n, c in self.children.items()},
                "exited": {n: c.tail() for n, c in self.children.items()
                           if c.popen.returncode not in (None, 0) and not c.expected_exit},
                "security": self._security(), "crashes": list(self.crashes),
                "saved": dict(self.saved),
                "queries": {"operator": self.queries.counts(),
                            "relay": self._relay_extra.get("queries", {})},
                "helm": self._helm_report(), **self._commands(),
                "modem": self.modem.describe(self.opts.agent_config.slot_s,
                                             self.opts.slot_from_modem)}

    def _commands(self) -> dict[str, Any]:
        """The report's ``commands`` section, if the operator gave any order."""
        if self.desk is None:
            return {}
        section = self.desk.section({vid: dict(s.counters)
                                     for vid, s in self.intake.statuses().items()})
        return {} if section is None else {"commands": section}

    def _helm_report(self) -> dict[str, Any]:
        """Which helm drove each vehicle, and whether the clock was kept at the warp for it
        (with the worst drift of each MOOS vehicle's clock from the mission clock)."""
        statuses = self.intake.statuses()
        out: dict[str, Any] = {
            "name": self.helm.name, "clock_pinned": self.pinned,
            "vehicles": {vid: "remote" if vid in self.opts.remote else self.helm.name
                         for vid in self.ids}}
        if self.helm.name == "moos":
            out["clock_drift_max_s"] = {
                vid: s.counters.get("helm_clock_drift_max_ms", 0) / 1000.0
                for vid, s in sorted(statuses.items())}
        if self.helm.name == "ros2":
            out["ros_domain_id"] = int(self.helm.env()["ROS_DOMAIN_ID"])
        return out

    def _security(self) -> dict[str, Any]:
        """What each part of the fleet refused, by reason: the operator (telemetry, ready
        announcements, deliveries it overheard), the relay (its ``auth_*`` and malformed
        counters) and each agent (its ``drop_auth_*`` counters, from its last status)."""
        operator, statuses = self.intake.refused_counts(), self.intake.statuses()
        relay_counts = self._relay_extra.get("relay", {})
        relay = {k: n for k, n in relay_counts.items() if isinstance(n, int) and n and (
            k.startswith(("auth_", "malformed_", "unknown_", "ctl_too")))}
        agents = {vid: row for vid, row in (
            (vid, {k[len("drop_auth_"):]: n for k, n in s.counters.items()
                   if k.startswith("drop_auth_")}) for vid, s in sorted(statuses.items())) if row}
        orders = self.desk.refusals() if self.desk is not None else {}
        taken = self.desk.takers() if self.desk is not None else {}
        total = sum(operator.values()) + sum(relay.values()) + sum(
            sum(a.values()) for a in agents.values()) + sum(orders.values())
        return {"refused_total": total, "operator": operator, "relay": relay,
                "agents": agents, **({"orders": orders} if orders else {}),
                **({"orders_taken": taken} if taken else {})}

    def close(self) -> None:
        """Stop the fleet (agents first: their final statuses), fetch the link counters, stop
        everything else; the ground station stays up if asked to hold the viewer."""
        if self._closed:
            return
        self._closed = True
        self._closing.set()
        for t in self._stallers:  # no agent is left frozen: SIGTERM must reach it
            t.join(5.0)
        with _signals_deferred():
            self._close()

    def _close(self) -> None:
        remove_run_record(self.run_dir)  # `cotsfleet ctl` finds no mission from now on
        try:
            self.procs.stop(self.ids)
            if self._session is not None:
                for vid in self.opts.remote:  # not ours to signal: ask them to stop
                    self._command(vid, STOP)
                time.sleep(0.3)  # the agents' final statuses
                self._link = self._fetch_link_stats()
        finally:
            for c in self._closers:
                try:
                    c.undeclare()
                except Exception:  # already gone with the session
                    pass
            if self._session is not None:
                self._session.close()
            held = ("ground_station",) if self.opts.hold_viewer and not self.interrupted else ()
            self.procs.stop([n for n in self.children if n not in ("router", *held)])
            self.procs.stop(["router"])
            self._write_events()

    # -- after the report --------------------------------------------------------------------

    def hold_viewer(self) -> None:
        """Serve the finished mission's dashboard until Ctrl-C (or the station exits)."""
        gs = self.children.get("ground_station")
        if gs is None or gs.popen.poll() is not None:
            return
        self.out("mission over: the dashboard stays up; press Ctrl-C to quit")
        try:
            gs.popen.wait()
        except KeyboardInterrupt:
            pass
        finally:
            self.procs.stop(["ground_station"])

    # -- processes --------------------------------------------------------------------------

    def _agent_argv(self, vid: str) -> list[str]:
        return ["-m", "fleet_agent", "--id", vid, "--config", str(self.run_dir / "agent.toml"),
                "--connect", self.endpoint, "--journal", str(self.run_dir / f"{vid}.journal"),
                "--credentials", str(self.creds / vid),
                "--mission-timeout", str(2 * self.startup_timeout_s),
                *self.helm.agent_argv(vid),
                *self.modem.agent_argv(self.problem.vehicle_index[vid])]

    def _agent_env(self, vid: str) -> dict[str, str]:
        """An agent's environment: its helm's (a ROS 2 domain) and the test's, if any."""
        return {**self.helm.env(), **self.opts.child_env.get(vid, {})}

    def _station_argv(self, incarnation: int) -> list[str]:
        """The ground station's command line; a restarted one records to a file of its own
        (``mission.1.rrd``, ...): the recording of its predecessor is kept."""
        opts = self.opts
        gs = ["-m", "ground_station", "--connect", self.endpoint, "--viewer", opts.viewer,
              "--web-port", str(opts.web_port), "--credentials", str(self.creds / STATION_ID)]
        if opts.rrd is None:
            return gs
        rrd = opts.rrd if not incarnation else opts.rrd.with_suffix(
            f".{incarnation}{opts.rrd.suffix}")
        return gs + ["--rrd", str(rrd)]

    def _wait_agents(self) -> None:
        deadline = time.monotonic() + self.startup_timeout_s
        while True:
            missing = self.intake.missing()
            if not missing:
                return
            if any(vid in self.dead for vid in missing):  # died while it planned
                raise ChildExited(self.crashes[-1]["why"])
            self._watch_children()
            if time.monotonic() > deadline:
                raise TimeoutError(f"agents not ready within {self.startup_timeout_s:g} s "
                                   f"(--startup-timeout): {missing}")
            time.sleep(POLL_WALL_S)

    def _watch_children(self) -> None:
        """A child that ended without being told to: restarted, reported or the end of the
        mission, as `CRASH_POLICY` says; named with its last lines either way."""
        relay = self.children.get(self.modem.child)
        if self._relay_back is not None and relay is not None and relay.ready.is_set():
            self._relay_back = None  # the relay is back on the clock: the hold ends
            self._busy("relay", False)
        c = self.procs.ended_untold()
        if c is None:
            return
        why = c.why()
        policy = "vehicle" if c.name in self.ids else "helm" if c.name in \
            self.helm.children else CRASH_POLICY.get(c.name, "end")
        restarts = sum(1 for x in self.crashes if x["name"] == c.name)
        if policy == "restart" and restarts >= MAX_RESTARTS:
            policy = "report" if c.name in PASSIVE else "end"
        now = round(self.now(), 1)
        self.crashes.append({"name": c.name, "t_s": now, "code": c.popen.returncode,
                             "why": why, "action": policy})
        if policy == "end":
            if c.name in self.ids:
                self.dead.add(c.name)
            raise ChildExited(why)
        if policy == "vehicle":
            self.dead.add(c.name)
            self._busy(c.name, False)  # a hold of the dead process ends with it
            self.out(f"t={now:6.0f} s  {why}; {c.name} is lost to the fleet, the others go on")
        elif policy == "helm":  # not started again: it would put its vehicle back at start
            self.out(f"t={now:6.0f} s  {why}; not started again: its agent sees the "
                     "vehicle's navigation stop")
        elif policy == "restart":
            argv = self._station_argv(restarts + 1) if c.name == "ground_station" else None
            self.procs.restart(c, argv)
            if c.name == self.modem.child:  # no frame crosses the water until it is back:
                self._relay_back = now  # hold the clock (rationed like any hold), so that
                self._busy("relay", True)  # silence does not look like death to the fleet
            self.out(f"t={now:6.0f} s  {why}; started again ({restarts + 1} of "
                     f"{MAX_RESTARTS})")
        else:
            self.out(f"t={now:6.0f} s  {why}; not started again ({MAX_RESTARTS} restarts "
                     "spent), the mission goes on without it")

    # -- faults ------------------------------------------------------------------------------

    def _apply_due(self) -> None:
        now = self.now()
        while self._pending and self._pending[0].t_s <= now:
            carry_out(self._pending.pop(0), self, now)

    def apply(self, f: Fault, now: float) -> None:
        """A fault at ``now`` (`fault_plan.FleetControl`)."""
        self.applied.append(Fault(f.kind, round(now, 1), f.vid, f.value, f.words))
        self.out(f"t={now:6.0f} s  fault: {f.describe()}")
        if f.kind == FaultKind.ABORT:
            self._command(f.vid, ABORT)
        elif f.kind == FaultKind.KILL:
            child = self.children.get(f.vid)
            if child is not None:
                self.procs.signal(child, signal.SIGKILL)
                child.popen.wait(5.0)
            self.dead.add(f.vid)
            self._busy(f.vid, False)  # a hold of the killed process ends with it
        elif f.kind == FaultKind.RESTART:
            self.procs.spawn(f.vid, self._agent_argv(f.vid), env=self._agent_env(f.vid))
            self.dead.discard(f.vid)
        elif f.kind == FaultKind.STALL:
            child = self.children.get(f.vid)
            if child is not None and child.popen.poll() is None:
                t = threading.Thread(target=self._stall, args=(child, f), daemon=True,
                                     name=f"stall-{f.vid}")
                self._stallers.append(t)
                t.start()
        elif f.kind == FaultKind.PARTITION:
            alone = (frozenset((f.vid,)),)  # the vehicle cut off from everyone
            self._put_link(LinkControl(partition=Partition(now, now + f.value, alone)))
        elif f.kind == FaultKind.LOSS:
            self._put_link(LinkControl(extra_loss=f.value))
        elif f.kind == FaultKind.CTL and f.unsigned:  # an insider: the fleet key, not the chain
            assert self.desk is not None and self.desk.topside is not None
            top = self.desk.topside
            frame = forged_frame(top.codec, top.schedule, top.chain.length, f.order(), now)
            self._put_link(LinkControl(inject=frame, inject_at=self.intruder.position()))
        elif f.kind == FaultKind.CTL:
            assert self.desk is not None
            answer = self.desk.submit(f.order(), now)
            if answer.error:
                self.out(f"t={now:6.0f} s  order refused: {answer.error}")
            self._orders_due()

    # -- the operator's live orders -----------------------------------------------------------

    def _order_desk(self, creds: Path, config: AgentConfig) -> OrderDesk:
        """The topside modem of this run (its chain's seed in the operator's credentials)
        behind the desk that takes `cotsfleet ctl`'s requests (`order_desk`)."""
        verifier = load_ring(creds / OPERATOR_ID)
        why = ("the emulated Micro-Modems do not carry the topside's frames yet (--modem "
               "water does)") if self.modem.name != "water" else ""
        try:
            seed = load_frame_seed(creds / OPERATOR_ID)
            length = load_frame_chains(creds / OPERATOR_ID, self.ids).length
        except CredentialsError:
            why = why or (f"{creds} holds no topside key chain (made before live orders): "
                          "make the credentials again to order this fleet")
            seed, length = b"", 0
        if why:
            return OrderDesk(None, verifier, why)
        codec = OrderCodec(config.fleet_key, self.run_id, tuple(self.ids))
        schedule = TopsideSchedule.for_fleet(len(self.ids) * config.slot_s)
        return OrderDesk(Topside(codec, schedule, seed, length, topside_position(self.problem),
                                 config.ctl_max_age_s), verifier)

    def _topside_heard(self, sample: Any) -> None:
        """A frame the water delivered to the topside (signed by the relay)."""
        if self.desk is None or sample.kind != zenoh.SampleKind.PUT:
            return
        assert self.auth is not None
        rx = topics.RX.of(TOPSIDE)
        frame = self.auth.open_payload(rx.key, sample.payload.to_bytes())
        if frame is not None:
            self.desk.hear(rx.decode(frame), self.now())

    def _orders_due(self) -> None:
        """The topside's frames due now go into the water from its place; the answers to
        `cotsfleet ctl` go out on the bus."""
        if self.desk is None or self._session is None or self.clock is None:
            return
        now = self.now()
        due = self.desk.due(now)
        top = self.desk.topside
        for frame in due.frames:
            assert top is not None
            self._put_link(LinkControl(inject=frame, inject_at=top.position,
                                       inject_from=TOPSIDE))
        for answer in due.answers:
            assert self.auth is not None
            topics.ORDER_ANSWER.put(self._session, self.auth, answer)
            if answer.error:
                self.out(f"t={now:6.0f} s  order refused: {answer.error}")
            elif not answer.acked and not answer.refused:
                self.out(f"t={now:6.0f} s  order #{answer.seq}: {answer.order} (topside)")
            else:
                self.out(f"t={now:6.0f} s  order #{answer.seq}: acknowledged by "
                         f"{', '.join(sorted(answer.acked)) or 'nobody'}"
                         + (f"; refused by {answer.refused}" if answer.refused else ""))

    def _stall(self, child: Child, f: Fault) -> None:
        """Freeze and thaw ``child`` as `Fault.thaw_at` says, in wall time at the requested
        warp (a 4 s frozen half is 40 ms at warp 100): a busy computer's stalls last wall
        time, so a clock the pacing rule slows makes them shorter in mission time. The child
        always runs again at the end, or when the mission closes."""
        t0, warp = time.monotonic(), self.opts.warp
        try:
            while not self._closing.is_set() and child.popen.poll() is None:
                t = f.t_s + (time.monotonic() - t0) * warp  # mission time, requested warp
                phase = f.stall_phase(t)
                if phase is None:
                    return
                frozen, until = phase
                child.signal_group(signal.SIGSTOP if frozen else signal.SIGCONT)
                self._closing.wait((until - t) / warp)
        finally:
            child.signal_group(signal.SIGCONT)

    def attack(self, f: Fault, now: float) -> None:
        """The intruder's modem transmits one hostile frame into the water (via the relay);
        an insider's frames leave from where its vehicle last said it was, and its busy
        announcements go out under its own bus login."""
        if f.kind not in INSIDER_ATTACKS:
            frame = self.intruder.frame(f.kind, now)
            self._put_link(LinkControl(inject=frame, inject_at=self.intruder.position()))
            return
        insider = self._insiders[f.vid]  # its leaked credentials
        if f.kind == FaultKind.BUSY_HOLD:
            insider.busy()
            return
        status = self.intake.statuses().get(f.vid)
        p = status.pos if status is not None else \
            self.problem.vehicles[self.problem.vehicle_index[f.vid]].start
        at = (float(p[0]), float(p[1]), float(p[2]))
        for frame in insider.insider.frames(f.kind, now):
            self._put_link(LinkControl(inject=frame, inject_at=at))

    def _make_insiders(self, faults: Sequence[Fault], config: AgentConfig) -> dict[str, Leaked]:
        """Each insider's leaked credentials (`insider_launch`), closed with the mission."""
        out = {}
        reef = reef_from_doc(self.scenario, self.problem)
        for vid in sorted({f.vid for f in faults if f.kind in INSIDER_ATTACKS}):
            out[vid] = Leaked.open(vid, self.problem, reef, config, self.run_id, self.seed,
                                   self.modem.spec, self.creds, self.ids, self.endpoint)
            self._closers.append(_Undeclare(out[vid].close))
        return out

    def _put_link(self, control: LinkControl) -> None:
        assert self._session is not None and self.auth is not None
        topics.LINK_CTL.put(self._session, self.auth, control)

    def _command(self, vid: str, name: Command) -> None:
        assert self._session is not None and self.auth is not None
        topics.CTL.of(vid).put(self._session, self.auth, name)

    def _fetch_link_stats(self) -> LinkCounts | None:
        assert self._session is not None and self.auth is not None
        nonce = secrets.token_hex(8)
        stats = topics.LINK_STATS
        for reply in self._session.get(f"{stats.key}?n={nonce}", timeout=3.0,
                                       attachment=seal_query(self.auth, stats.key, nonce)):
            if reply.ok is None:
                continue
            try:
                _, payload = self.auth.open(stats.key, reply.ok.payload.to_bytes())
                counts, self._relay_extra = stats.decode(payload)
                return counts
            except ValueError:  # a refused envelope (`Refused`) and a `TopicError` too
                continue
        return None

    def _write_events(self) -> None:
        """The whole event log, for whoever wants to dig deeper, after giving back the disk
        reserve: as many whole events as fit (a full disk), and ``saved`` says how many."""
        with self.intake.lock:
            events = list(self.ledger.events)
        self.reserve.give_back()
        self.saved = {"events": 0, "events_total": len(events)}
        path = self.run_dir / "events.jsonl"
        try:
            with open(path, "w", encoding="utf-8") as fh:
                for e in events:
                    fh.write(json.dumps(e.to_dict()) + "\n")
                    fh.flush()
                    self.saved["events"] += 1
        except OSError as exc:  # keep what was written whole: a cut last line is dropped
            self.saved["events_error"] = str(exc)
            cut_to_whole_lines(path)
            self.out(f"events.jsonl: {exc}; {self.saved['events']} of {len(events)} events "
                     "saved")

    def _progress(self) -> None:
        if not self.opts.progress_every_s or time.monotonic() < self._next_progress:
            return
        self._next_progress = time.monotonic() + self.opts.progress_every_s
        now = self.now()
        with self.intake.lock:  # the report's figures (`FleetLedger.collected`), so far
            statuses = dict(self.ledger.statuses)
            collected = self.ledger.collected(self._values)
        parts = []
        for vid in self.ids:
            s = statuses.get(vid)
            state = "dead" if vid in self.dead else (s.state if s else "starting")
            parts.append(f"{vid} {state} {len(s.treated) if s else 0}")
        self.out(progress_line(now, collected, parts))


@dataclass(frozen=True)
class _Undeclare:
    """A closer of the mission's `_closers` list that runs ``close``."""

    close: Any

    def undeclare(self) -> None:
        self.close()
