"""`cotsfleet run`: a whole mission as separate OS processes on one machine.

Router -> relay (comms_sim) -> one agent per vehicle -> ground station, each in its own
process group. The launcher serves ``fleet/mission`` (scenario, epoch, warp, seed) once every
agent has its plan, shows progress, injects faults at simulation times (abort: a command on
``fleet/ctl/<id>``; kill: SIGKILL; restart: the agent again on the same journal), stops when
every vehicle is home, aborted or dead (or the battery horizon passed), and writes the report
(`fleet_agent.report`, the same format as `cotsfleet sim`). Ctrl-C stops everything cleanly.

Across machines: with ``listen`` on a reachable address and ``remote`` vehicles, the launcher
starts no agent for those; it prints the command to start each one elsewhere (against a router
linked to this one), waits for their liveliness tokens like for its own agents, and ends them
with a ``stop`` command. They must share the fleet key, so it comes from the agent config.
"""

from __future__ import annotations

import dataclasses
import json
import os
import secrets
import signal
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Sequence

import zenoh

from comms_sim import bus
from comms_sim.clock import WarpClock
from comms_sim.session import client_config, free_tcp_endpoint
from comms_sim.stats import decode_stats
from fleet_agent.config import AgentConfig, dump_config
from fleet_agent.node import ALIVE_PREFIX, encode_command
from fleet_agent.report import FaultRecord, build_report, format_report
from fleet_agent.telemetry import Event, Status
from hfc_core.problem import Problem
from hfc_core.scenario import problem_from_dict

ROUTER_READY = "comms_sim router listening on"
RELAY_READY = "comms_sim relay ready"


@dataclass(frozen=True)
class LaunchOptions:
    scenario: dict[str, Any]
    seed: int = 0
    warp: float = 60.0
    loss: float = 0.0
    aborts: tuple[tuple[str, float], ...] = ()
    kills: tuple[tuple[str, float], ...] = ()
    restarts: tuple[tuple[str, float], ...] = ()
    viewer: str = "none"  # web | native | none
    rrd: Path | None = None
    web_port: int = 9090
    run_dir: Path | None = None
    report: Path | None = None
    agent_config: AgentConfig = field(default_factory=AgentConfig)
    horizon_s: float | None = None
    progress_every_s: float = 3.0  # wall seconds between progress lines (0: none)
    # Keep the ground station (and so the web viewer it serves) up after the mission until
    # Ctrl-C: an operator watching in a browser should not lose the picture at the end.
    hold_viewer: bool = False
    listen: str | None = None  # router endpoint (default: a free loopback port)
    remote: tuple[str, ...] = ()  # vehicles whose agents run elsewhere (not started here)
    startup_timeout_s: float = 90.0

    def __post_init__(self) -> None:
        if not self.warp > 0:
            raise ValueError(f"warp must be positive, got {self.warp}")
        if not 0.0 <= self.loss <= 1.0:
            raise ValueError(f"loss must be in [0, 1], got {self.loss}")
        if self.viewer not in ("web", "native", "none"):
            raise ValueError(f"viewer must be web, native or none, got {self.viewer!r}")


@dataclass
class _Proc:
    name: str
    popen: subprocess.Popen
    ready: threading.Event = field(default_factory=threading.Event)
    lines: list[str] = field(default_factory=list)


class Launcher:
    def __init__(self, opts: LaunchOptions, out: Callable[[str], None] = print) -> None:
        self.opts = opts
        self.out = out
        self.problem: Problem = problem_from_dict(opts.scenario)
        self.ids = [v.id for v in self.problem.vehicles]
        known = set(self.ids)
        for vid, _ in (*opts.aborts, *opts.kills, *opts.restarts):
            if vid not in known:
                raise ValueError(f"unknown vehicle {vid!r}; the scenario has {sorted(known)}")
        for vid in opts.remote:
            if vid not in known:
                raise ValueError(f"unknown remote vehicle {vid!r}; the scenario has {sorted(known)}")
        if {v for v, _ in (*opts.kills, *opts.restarts)} & set(opts.remote):
            raise ValueError("kill/restart need the agent's process here; not for --remote ones")
        if opts.remote and not opts.agent_config.fleet_key_hex:
            raise ValueError("remote agents need the fleet key they share with this launcher: "
                             "set fleet_key_hex in the agent config (--config)")
        self.run_id = time.strftime("%Y%m%d-%H%M%S") + f"-{secrets.token_hex(2)}"
        self.run_dir = opts.run_dir or Path(os.environ.get("TMPDIR", "/tmp")) / \
            "cotsfleet-runs" / self.run_id
        self.procs: dict[str, _Proc] = {}
        self.statuses: dict[str, Status] = {}
        self.events: list[Event] = []
        self.faults: list[FaultRecord] = []
        self._lock = threading.Lock()
        self._alive: set[str] = set()
        self._pids: dict[str, list[int]] = {}
        self.started = threading.Event()  # set once the mission record is served
        self.endpoint = ""
        self.horizon_s = opts.horizon_s or max(v.battery_s for v in self.problem.vehicles) + 120

    # -- processes -------------------------------------------------------------------------

    def _spawn(self, name: str, argv: Sequence[str], ready_prefix: str | None = None,
               env: dict[str, str] | None = None, echo: bool = False) -> _Proc:
        log = open(self.run_dir / f"{name}.log", "ab")
        popen = subprocess.Popen(
            list(argv), stdout=subprocess.PIPE, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
            start_new_session=True, env={**os.environ, "PYTHONUNBUFFERED": "1", **(env or {})})
        proc = _Proc(name, popen)

        def pump() -> None:  # copy output to the log, watch for the ready line
            assert popen.stdout is not None
            for raw in popen.stdout:
                log.write(raw)
                log.flush()
                line = raw.decode(errors="replace").rstrip()
                proc.lines.append(line)
                if echo:  # e.g. the ground station's viewer address: the user needs it
                    self.out(line)
                if ready_prefix and line.startswith(ready_prefix):
                    proc.ready.set()
            log.close()

        threading.Thread(target=pump, name=f"pump-{name}", daemon=True).start()
        self.procs[name] = proc
        self._pids.setdefault(name, []).append(popen.pid)
        # Every process group this run ever started, for whoever must clean up after a crash.
        (self.run_dir / "pids.json").write_text(json.dumps(self._pids), encoding="utf-8")
        return proc

    def _wait_ready(self, proc: _Proc, timeout_s: float) -> None:
        deadline = time.monotonic() + timeout_s
        while not proc.ready.wait(0.1):
            if proc.popen.poll() is not None:
                raise RuntimeError(f"{proc.name} exited with {proc.popen.returncode}: "
                                   f"{' | '.join(proc.lines[-5:])}")
            if time.monotonic() > deadline:
                raise TimeoutError(f"{proc.name} not ready within {timeout_s} s")

    def _signal(self, proc: _Proc, sig: int) -> None:
        try:
            os.killpg(proc.popen.pid, sig)
        except (ProcessLookupError, PermissionError):
            pass

    def _stop(self, names: Sequence[str], grace_s: float = 5.0) -> None:
        procs = [self.procs[n] for n in names if n in self.procs
                 and self.procs[n].popen.poll() is None]
        for p in procs:
            self._signal(p, signal.SIGTERM)
        deadline = time.monotonic() + grace_s
        for p in procs:
            try:
                p.popen.wait(max(0.1, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                self._signal(p, signal.SIGKILL)
                p.popen.wait(5.0)

    def _agent_argv(self, vid: str) -> list[str]:
        return [sys.executable, "-m", "fleet_agent", "--id", vid,
                "--scenario", str(self.run_dir / "scenario.json"),
                "--config", str(self.run_dir / "agent.toml"), "--connect", self.endpoint,
                "--journal", str(self.run_dir / f"{vid}.journal"),
                "--seed", str(self.opts.seed)]

    # -- bus -------------------------------------------------------------------------------

    def _on_status(self, sample: zenoh.Sample) -> None:
        try:
            s = Status.decode(sample.payload.to_bytes())
        except ValueError:
            return
        with self._lock:
            old = self.statuses.get(s.id)
            if old is None or s.t_s >= old.t_s:
                self.statuses[s.id] = s

    def _on_event(self, sample: zenoh.Sample) -> None:
        try:
            e = Event.decode(sample.payload.to_bytes())
        except ValueError:
            return
        with self._lock:
            self.events.append(e)

    def _on_alive(self, sample: zenoh.Sample) -> None:
        vid = bus.vid_of(str(sample.key_expr))
        with self._lock:
            if sample.kind == zenoh.SampleKind.PUT:
                self._alive.add(vid)
            else:
                self._alive.discard(vid)

    # -- the mission -----------------------------------------------------------------------

    def run(self) -> dict[str, Any]:
        opts = self.opts
        self.run_dir.mkdir(parents=True, exist_ok=True)
        (self.run_dir / "scenario.json").write_text(json.dumps(opts.scenario), encoding="utf-8")
        # A fresh fleet key per run unless the config brings one (agents elsewhere must share
        # it); never on the bus.
        config = opts.agent_config
        if not config.fleet_key_hex:
            config = config.with_key(secrets.token_bytes(16))
        cfg_path = self.run_dir / "agent.toml"
        cfg_path.touch(mode=0o600)
        cfg_path.write_text(dump_config(config), encoding="utf-8")
        listen = opts.listen or free_tcp_endpoint()
        self.endpoint = local_endpoint(listen)
        wall0 = time.monotonic()
        interrupted = False
        clock: WarpClock | None = None
        end_s: float | None = None
        try:
            router = self._spawn("router", [sys.executable, "-m", "comms_sim.router",
                                            "--listen", listen], ROUTER_READY)
            self._wait_ready(router, opts.startup_timeout_s)
            with zenoh.open(client_config([self.endpoint])) as session, \
                    session.declare_subscriber(bus.STATUS_ALL, self._on_status), \
                    session.declare_subscriber(bus.EVENT_ALL, self._on_event), \
                    session.liveliness().declare_subscriber(f"{ALIVE_PREFIX}/*", self._on_alive,
                                                            history=True):
                relay_argv = [sys.executable, "-m", "comms_sim", "--connect", self.endpoint,
                              "--mission-from-bus", "--seed", str(opts.seed),
                              # it starts before the agents: it waits for their readiness too
                              "--mission-timeout", str(2 * opts.startup_timeout_s)]
                if opts.loss:
                    relay_argv += ["--loss", str(opts.loss)]
                relay = self._spawn("relay", relay_argv, RELAY_READY)
                if opts.viewer != "none" or opts.rrd is not None:
                    gs = [sys.executable, "-m", "ground_station", "--connect", self.endpoint,
                          "--viewer", opts.viewer, "--web-port", str(opts.web_port)]
                    if opts.rrd is not None:
                        gs += ["--rrd", str(opts.rrd)]
                    self._spawn("ground_station", gs, echo=True)
                for vid in self.ids:
                    if vid in opts.remote:
                        self.out(f"waiting for {vid} elsewhere: python -m fleet_agent --id {vid} "
                                 f"--scenario SCENARIO.json --config AGENT.toml --seed {opts.seed}"
                                 f" --connect <a router linked to {listen}> (scenario copy: "
                                 f"{self.run_dir / 'scenario.json'})")
                    else:
                        self._spawn(vid, self._agent_argv(vid))
                self._wait_agents(opts.startup_timeout_s)
                epoch = time.time() + 1.0
                clock = WarpClock(epoch, opts.warp)
                mission = bus.Mission(opts.scenario, epoch, opts.warp, opts.seed, self.run_id)
                payload = mission.encode()
                with session.declare_queryable(bus.MISSION,
                                               lambda q: q.reply(bus.MISSION, payload)):
                    self._wait_ready(relay, opts.startup_timeout_s)
                    self.started.set()
                    self.out(f"mission {self.run_id}: {len(self.ids)} vehicles, warp "
                             f"{opts.warp:g}, loss {opts.loss:g}, run dir {self.run_dir}")
                    try:
                        self._monitor(session, clock)
                        end_s = clock.now()
                    except KeyboardInterrupt:
                        interrupted = True
                        self.out("interrupted: stopping the fleet")
                    self._stop(self.ids)
                    for vid in opts.remote:  # not ours to signal: ask them to stop
                        session.put(bus.ctl_key(vid), encode_command("stop"))
                    time.sleep(0.3)  # the agents' final statuses
                    link = self._link_stats(session)
        except KeyboardInterrupt:
            interrupted = True
            link = None
        finally:
            held = ("ground_station",) if opts.hold_viewer and not interrupted else ()
            self._stop([n for n in self.procs if n not in ("router", *held)])
            self._stop(["router"])
        if end_s is None:
            end_s = max(0.0, clock.now()) if clock is not None else 0.0
        with self._lock:
            statuses, events = dict(self.statuses), list(self.events)
        report = build_report(
            self.problem, statuses, events, link, self.faults, mode="run", seed=opts.seed,
            end_s=min(end_s, self.horizon_s),
            extra={"run_id": self.run_id, "run_dir": str(self.run_dir), "warp": opts.warp,
                   "loss": opts.loss, "wall_s": round(time.monotonic() - wall0, 2),
                   "interrupted": interrupted,
                   "exit_codes": {n: p.popen.returncode for n, p in self.procs.items()}})
        with open(self.run_dir / "events.jsonl", "w", encoding="utf-8") as fh:
            for e in events:  # the whole event log, for whoever wants to dig deeper
                fh.write(json.dumps(dataclasses.asdict(e)) + "\n")
        path = opts.report or self.run_dir / "report.json"
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(report, indent=2), encoding="utf-8")
        self.out(format_report(report))
        self.out(f"report: {path}")
        if "ground_station" in self.procs and self.procs["ground_station"].popen.poll() is None:
            self._hold_viewer()
        return report

    def _hold_viewer(self) -> None:
        """Serve the finished mission's dashboard until Ctrl-C (or the station exits)."""
        self.out("mission over: the dashboard stays up; press Ctrl-C to quit")
        try:
            self.procs["ground_station"].popen.wait()
        except KeyboardInterrupt:
            pass
        finally:
            self._stop(["ground_station"])

    def _wait_agents(self, timeout_s: float) -> None:
        deadline = time.monotonic() + timeout_s
        while True:
            with self._lock:
                missing = [v for v in self.ids if v not in self._alive]
            if not missing:
                return
            for vid in missing:
                p = self.procs.get(vid)  # None: a remote agent, nothing to watch here
                if p is not None and p.popen.poll() is not None:
                    raise RuntimeError(f"agent {vid} exited with {p.popen.returncode}: "
                                       f"{' | '.join(p.lines[-5:])}")
            if time.monotonic() > deadline:
                raise TimeoutError(f"agents not ready within {timeout_s} s: {missing}")
            time.sleep(0.05)

    def _monitor(self, session: zenoh.Session, clock: WarpClock) -> None:
        opts = self.opts
        pending = sorted([(t, "abort", v) for v, t in opts.aborts] +
                         [(t, "kill", v) for v, t in opts.kills] +
                         [(t, "restart", v) for v, t in opts.restarts])
        dead: set[str] = set()
        next_progress = time.monotonic()
        while True:
            now = clock.now()
            while pending and pending[0][0] <= now:
                _, kind, vid = pending.pop(0)
                self._inject(session, kind, vid, now, dead)
            if opts.progress_every_s and time.monotonic() >= next_progress and now >= 0:
                next_progress = time.monotonic() + opts.progress_every_s
                self.out(self._progress(now, dead))
            if now >= self.horizon_s or (not pending and self._all_done(dead)):
                return
            for vid in self.ids:  # an agent that died on its own is dead too
                p = self.procs.get(vid)
                if vid not in dead and p is not None and p.popen.poll() is not None:
                    dead.add(vid)
                    self.out(f"agent {vid} exited with {p.popen.returncode}")
            time.sleep(0.05)

    def _inject(self, session: zenoh.Session, kind: str, vid: str, now: float,
                dead: set[str]) -> None:
        self.faults.append(FaultRecord(kind, vid, round(now, 1)))
        self.out(f"t={now:6.0f} s  fault: {kind} {vid}")
        if kind == "abort":
            session.put(bus.ctl_key(vid), encode_command("abort"))
        elif kind == "kill":
            p = self.procs.get(vid)
            if p is not None:
                self._signal(p, signal.SIGKILL)
                p.popen.wait(5.0)
            dead.add(vid)
        elif kind == "restart":
            if self.procs[vid].popen.poll() is None:
                self.out(f"restart {vid}: still running, not restarted")
                return
            self._spawn(vid, self._agent_argv(vid))
            dead.discard(vid)

    def _all_done(self, dead: set[str]) -> bool:
        with self._lock:
            states = {vid: s.state for vid, s in self.statuses.items()}
        return all(vid in dead or states.get(vid) in ("home", "aborted") for vid in self.ids)

    def _progress(self, now: float, dead: set[str]) -> str:
        with self._lock:
            statuses = dict(self.statuses)
        cleared = set().union(*(s.treated for s in statuses.values())) if statuses else set()
        prio = sum(self.problem.tasks[self.problem.task_index[t]].priority for t in cleared)
        parts = []
        for vid in self.ids:
            s = statuses.get(vid)
            state = "dead" if vid in dead else (s.state if s else "starting")
            parts.append(f"{vid} {state} {len(s.treated) if s else 0}")
        return (f"t={now:6.0f} s  cleared {len(cleared)}/{self.problem.n_tasks}  "
                f"priority {prio:.0f}  | " + " | ".join(parts))

    def _link_stats(self, session: zenoh.Session) -> dict | None:
        for reply in session.get(bus.LINK_STATS, timeout=3.0):
            if reply.ok is not None:
                try:
                    return decode_stats(reply.ok.payload.to_bytes())[0]
                except ValueError:
                    continue
        return None


def local_endpoint(listen: str) -> str:
    """Where processes on this machine reach a router listening on ``listen``
    (``tcp/0.0.0.0:7447`` listens everywhere; locally it is ``tcp/127.0.0.1:7447``)."""
    proto, _, rest = listen.partition("/")
    host, _, port = rest.rpartition(":")
    return f"{proto}/127.0.0.1:{port}" if host in ("0.0.0.0", "[::]", "") else listen


def run_mission(opts: LaunchOptions, out: Callable[[str], None] = print) -> dict[str, Any]:
    return Launcher(opts, out).run()


def scenario_doc(path: Path | None, vehicles: int | None, seed: int) -> dict[str, Any]:
    """The mission's scenario document: a file (JSON scenario or TOP instance), else the
    paper preset drawn with ``seed`` (``vehicles`` changes its fleet size)."""
    if path is not None:
        from cotsfleet.io import read_scenario
        from hfc_core.scenario import problem_to_dict

        problem, doc = read_scenario(path)  # validates, with a clear message
        return doc if doc is not None else problem_to_dict(problem)

    import numpy as np

    from hfc_core.generate import PAPER_PRESET, generate_doc, paper_preset_doc

    if vehicles is None or vehicles == PAPER_PRESET.n_vehicles:
        return paper_preset_doc(seed)
    if not 1 <= vehicles <= 16:
        raise ValueError(f"--vehicles must be 1..16, got {vehicles}")
    doc = generate_doc(dataclasses.replace(PAPER_PRESET, n_vehicles=vehicles),
                       np.random.default_rng(seed))
    doc["name"] = f"paper-{vehicles}auv-seed{seed}"
    return doc
