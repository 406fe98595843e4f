"""The Zenoh backend of the agent driver: one OS process per vehicle on the shared warp clock.

Zenoh callbacks only enqueue into a bounded inbox; one loop feeds the inbox to the driver with
each item's arrival time on the mission clock, ticks the agent at its `next_wakeup`, and the
driver carries out the outputs: frames to ``fleet/tx/<id>`` (attachment: the relay's queue
class), telemetry to ``fleet/truth|status|event/<id>``, records to the journal. Commands
arrive on ``fleet/ctl/<id>``: ``abort`` goes to the agent's logic; ``stop`` ends the process
cleanly.

Start-up: the agent reads the mission record (``fleet/mission``: scenario, seed, run id),
computes the shared initial plan, declares the liveliness token ``fleet/alive/<id>``, then
waits for the clock record (``fleet/clock``), which the operator serves once every agent is
ready.
"""

from __future__ import annotations

import queue
import sys
import threading
import time
from pathlib import Path

import zenoh

from fleet_agent.agent import Agent
from fleet_agent.config import AgentConfig
from fleet_agent.driver import AgentDriver
from fleet_agent.fleet import Fleet
from fleet_agent.journal import Journal
from fleet_bus import keys
from fleet_bus.clock import WarpClock
from fleet_bus.commands import STOP, decode_command
from fleet_bus.mission import fetch_clock, fetch_mission
from fleet_bus.process import AGENT_READY, ready
from fleet_bus.telemetry import Event, Status, Truth
from hfc_core.problem import ScenarioError
from hfc_core.scenario import problem_from_dict

MAX_WAIT_WALL_S = 0.25  # longest sleep between looks at the stop flag
INBOX_LIMIT = 4096  # frames and commands waiting for the agent; beyond, the newest are dropped


class Inbox:
    """Bounded FIFO between Zenoh's threads and the agent loop. Items carry their arrival
    (wall) time: after a long computation the agent still sees each frame at the moment it
    came, not all of them at once."""

    def __init__(self, limit: int = INBOX_LIMIT) -> None:
        self._q: queue.Queue[tuple[str, bytes, float]] = queue.Queue(limit)
        self.overflow = 0

    def put(self, kind: str, payload: bytes) -> None:
        try:
            self._q.put_nowait((kind, payload, time.time()))
        except queue.Full:
            self.overflow += 1

    def take_overflow(self) -> int:
        """Items dropped since the last call (counted into the agent by its loop)."""
        n, self.overflow = self.overflow, 0
        return n

    def get(self, timeout_s: float) -> tuple[str, bytes, float] | None:
        try:
            return self._q.get(timeout=timeout_s) if timeout_s > 0 else self._q.get_nowait()
        except queue.Empty:
            return None


class ZenohTransport:
    """Puts the driver's frames and telemetry on the bus under this vehicle's keys."""

    def __init__(self, session: zenoh.Session, vid: str) -> None:
        self._tx = session.declare_publisher(keys.tx_key(vid))
        self._telemetry = {topic: session.declare_publisher(f"{keys.PREFIX}/{topic}/{vid}")
                           for topic in keys.TELEMETRY_KINDS}

    def send(self, frame: bytes, kind: str) -> None:
        self._tx.put(frame, attachment=kind.encode())

    def publish(self, topic: str, payload: Status | Event | Truth) -> None:
        self._telemetry[topic].put(payload.encode())


def main(conf: zenoh.Config, vid: str, config: AgentConfig, journal_path: Path,
         stop: threading.Event, mission_timeout_s: float = 120.0) -> int:
    """Run agent ``vid`` until ``stop``. Returns 0, 2 if the vehicle is not in the mission,
    or 3 if no mission or clock record came."""
    inbox = Inbox()
    with Journal(journal_path) as journal, zenoh.open(conf) as session, \
            session.declare_subscriber(keys.rx_key(vid),
                                       lambda s: inbox.put("rx", s.payload.to_bytes())), \
            session.declare_subscriber(keys.ctl_key(vid),
                                       lambda s: inbox.put("ctl", s.payload.to_bytes())):
        mission = fetch_mission(session, stop, mission_timeout_s)
        if mission is None:
            return 0 if stop.is_set() else 3
        try:
            problem = problem_from_dict(mission.scenario)
        except ScenarioError as exc:
            print(f"fleet_agent {vid}: the mission's scenario is not valid: {exc}",
                  file=sys.stderr)
            return 2
        if vid not in problem.vehicle_index:
            print(f"fleet_agent: {vid!r} is not a vehicle of the mission", file=sys.stderr)
            return 2
        fleet = Fleet.build(problem, config.fleet_key, mission.seed, config)  # initial plan
        with session.liveliness().declare_token(keys.alive_key(vid)):
            record = fetch_clock(session, stop, mission_timeout_s)
            if record is None:
                return 0 if stop.is_set() else 3
            clock = WarpClock(record.epoch_unix, record.warp)
            while clock.now() < 0 and not stop.is_set():
                stop.wait(min(MAX_WAIT_WALL_S, clock.wall_delay(-clock.now())))
            now = clock.now()
            agent = Agent(fleet, problem.vehicle_index[vid], config, now, journal.records)
            driver = AgentDriver(agent, ZenohTransport(session, vid), journal)
            start = f"restart, {len(journal.records)} records" if journal.records else "fresh"
            ready(AGENT_READY, f"{vid} at t={now:.1f} s ({start})")
            _loop(driver, inbox, clock, stop)
            driver.final_status(clock.now())
    return 0


def _loop(driver: AgentDriver, inbox: Inbox, clock: WarpClock, stop: threading.Event) -> None:
    driver.tick(clock.now())
    while not stop.is_set():
        wait = min(MAX_WAIT_WALL_S, clock.wall_delay(driver.next_wakeup() - clock.now()))
        item = inbox.get(wait)
        while item is not None:
            kind, payload, wall = item
            at = clock.sim_of(wall)
            if kind == "rx":
                driver.frame(payload, at)
            else:
                try:
                    name = decode_command(payload)
                except ValueError:
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
        driver.tick(clock.now())
