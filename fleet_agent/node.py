"""The Zenoh shell around one agent: clock, radio keys, telemetry, journal. No decisions.

Zenoh callbacks only enqueue; one loop feeds the queue to `Agent.step` with the shared
`WarpClock` time, ticks the agent at its `next_wakeup`, and carries out the outbox: frames to
``fleet/tx/<id>`` (attachment: the relay's queue class), telemetry to ``fleet/truth|status|
event/<id>``, records to the journal. Commands arrive on ``fleet/ctl/<id>``: ``abort`` goes to
the agent's logic; ``stop`` ends the process cleanly (the launcher's way to end an agent it did
not start, e.g. one on another machine).

Readiness: once the initial plan is computed and the subscriptions are up, the agent declares
the liveliness token ``fleet/alive/<id>``; the launcher waits for every token before it fixes
the mission epoch and serves ``fleet/mission``, which the agent then reads for the clock.
"""

from __future__ import annotations

import json
import queue
import sys
import threading
import time
from pathlib import Path
from typing import Any

import msgpack
import zenoh

from comms_sim import bus
from comms_sim.clock import WarpClock
from fleet_agent.config import AgentConfig
from fleet_agent.journal import Journal
from fleet_agent.logic import Agent, Command, Fleet, Frame, Output, Publish, Record, Send, Tick
from hfc_core.problem import Problem
from hfc_core.scenario import problem_from_dict

ALIVE_PREFIX = "fleet/alive"
MAX_WAIT_WALL_S = 0.25  # longest sleep between looks at the stop flag


def alive_key(vid: str) -> str:
    return f"{ALIVE_PREFIX}/{vid}"


COMMANDS = ("abort", "stop")


def encode_command(name: str) -> bytes:
    """Payload of ``fleet/ctl/<id>``: ``{"cmd": "abort"}`` or ``{"cmd": "stop"}``."""
    return msgpack.packb({"cmd": name})


def decode_command(payload: bytes) -> str:
    """The command name; ValueError on anything else."""
    try:
        doc: Any = msgpack.unpackb(payload, raw=False)
        name = doc["cmd"]
    except Exception as exc:  # msgpack raises several unrelated types on garbage
        raise ValueError(f"malformed command: {exc!r}") from None
    if name not in COMMANDS:
        raise ValueError(f"unknown command {name!r}")
    return str(name)


def load_scenario(path: str | Path) -> tuple[Problem, dict[str, Any]]:
    doc = json.loads(Path(path).read_text(encoding="utf-8"))
    return problem_from_dict(doc), doc


def fetch_mission(session: zenoh.Session, stop: threading.Event,
                  timeout_s: float) -> bus.Mission | None:
    deadline = time.monotonic() + timeout_s
    while not stop.is_set() and time.monotonic() < deadline:
        for reply in session.get(bus.MISSION, timeout=2.0):
            if reply.ok is not None:
                try:
                    return bus.Mission.decode(reply.ok.payload.to_bytes())
                except ValueError:
                    continue
        stop.wait(0.2)
    return None


class _Outbox:
    """Carries out an agent's outputs on a session and a journal."""

    def __init__(self, session: zenoh.Session, vid: str, journal: Journal) -> None:
        self.session, self.vid, self.journal = session, vid, journal
        self.tx, self.truth = bus.tx_key(vid), bus.truth_key(vid)
        self.status, self.event = bus.status_key(vid), bus.event_key(vid)

    def handle(self, outputs: list[Output]) -> None:
        for o in outputs:
            if isinstance(o, Record):
                self.journal.append(o.doc, o.durable)  # before the frame that announces it
        for o in outputs:
            if isinstance(o, Send):
                self.session.put(self.tx, o.frame, attachment=o.kind.encode())
            elif isinstance(o, Publish):
                key = {"truth": self.truth, "status": self.status, "event": self.event}[o.topic]
                self.session.put(key, o.payload.encode())


def main(conf: zenoh.Config, vid: str, scenario_path: Path, config: AgentConfig,
         journal_path: Path, stop: threading.Event, seed: int | None = None,
         mission_timeout_s: float = 120.0) -> int:
    """Run agent ``vid`` until ``stop``. Returns 0, or 3 if no mission record came."""
    problem, _ = load_scenario(scenario_path)
    if vid not in problem.vehicle_index:
        print(f"fleet_agent: {vid!r} is not a vehicle of the scenario", file=sys.stderr)
        return 2
    index = problem.vehicle_index[vid]
    # Items carry their arrival (wall) time: after a long computation the agent still sees
    # each frame at the moment it came, not all of them at once.
    inbox: queue.SimpleQueue[tuple[str, bytes, float]] = queue.SimpleQueue()
    with Journal(journal_path) as journal, zenoh.open(conf) as session, \
            session.declare_subscriber(bus.rx_key(vid),
                                       lambda s: inbox.put(("rx", s.payload.to_bytes(), time.time()))), \
            session.declare_subscriber(bus.ctl_key(vid),
                                       lambda s: inbox.put(("ctl", s.payload.to_bytes(), time.time()))):
        mission = None
        if seed is None:
            mission = fetch_mission(session, stop, mission_timeout_s)
            if mission is None:
                return 0 if stop.is_set() else 3
            seed = mission.seed
        fleet = Fleet.build(problem, config.fleet_key, seed, config)  # the initial plan
        with session.liveliness().declare_token(alive_key(vid)):
            if mission is None:
                mission = fetch_mission(session, stop, mission_timeout_s)
                if mission is None:
                    return 0 if stop.is_set() else 3
            if mission.seed != seed:
                print(f"fleet_agent {vid}: mission seed {mission.seed} != --seed {seed}",
                      file=sys.stderr)
                return 2
            clock = WarpClock(mission.epoch_unix, mission.warp)
            while clock.now() < 0 and not stop.is_set():
                stop.wait(min(MAX_WAIT_WALL_S, clock.wall_delay(-clock.now())))
            now = clock.now()
            agent = Agent(fleet, index, config, now, journal.records)
            out = _Outbox(session, vid, journal)
            print(f"fleet_agent {vid}: running at t={now:.1f} s "
                  f"({'restart, ' + str(len(journal.records)) + ' records' if journal.records else 'fresh'})",
                  flush=True)
            _loop(agent, out, inbox, clock, stop)
            out.handle([Publish("status", agent.status(clock.now()))])
    return 0


def _loop(agent: Agent, out: _Outbox, inbox: "queue.SimpleQueue[tuple[str, bytes, float]]",
          clock: WarpClock, stop: threading.Event) -> None:
    out.handle(agent.step(Tick(clock.now())))
    while not stop.is_set():
        wait = min(MAX_WAIT_WALL_S, clock.wall_delay(agent.next_wakeup() - clock.now()))
        try:
            item = inbox.get(timeout=wait) if wait > 0 else inbox.get_nowait()
        except queue.Empty:
            item = None
        while item is not None:
            kind, payload, wall = item
            at = (wall - clock.epoch_unix) * clock.warp
            if kind == "rx":
                out.handle(agent.step(Frame(payload, at)))
            else:
                try:
                    name = decode_command(payload)
                except ValueError:
                    agent.counters["ctl_malformed"] = agent.counters.get("ctl_malformed", 0) + 1
                    name = None
                if name == "stop":
                    stop.set()
                    return
                if name is not None:
                    out.handle(agent.step(Command(name, at)))
            try:
                item = inbox.get_nowait()
            except queue.Empty:
                item = None
        out.handle(agent.step(Tick(clock.now())))
