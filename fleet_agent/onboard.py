"""The agent on board: one vehicle in real time, its mission from a file, no operator.

`main` runs the same agent and driver as the emulated fleet (`fleet_agent.node.drive`), with
what a vehicle under water has instead of an operator on the bus:

- **the mission** from a file loaded before the dive (`fleet_agent.mission_file`: scenario,
  seed, run id, start), the fleet key from the agent config, the credentials (if any) from
  their directory;
- **the clock** is the vehicle's own real time at warp 1: mission time 0 is the file's
  ``start_unix`` (or ``--start``), placed once, at start, on this host's monotonic clock
  through its wall clock (`own_clock`). The wall clock is what the fleet shares: each
  vehicle's is set at the surface before the dive (GPS, NTP, or chrony against the support
  ship), so the vehicles' slots line up to the accuracy of that setting; during the dive
  mission time runs on the monotonic clock (a crystal's drift, tens of ppm, is under 0.1 s
  an hour against slots of seconds), and a step of the wall clock mid-dive changes nothing
  but the ``clock_wall_steps`` counter. No clock records, no holds, no pacing: the vehicle
  does not wait for its planner (a replan's burst is late decisions, counted as ``lag_s``);
- **the peers** through its modem (``--modem micromodem:LINK``: a WHOI Micro-Modem on its
  serial line, or an emulated one on TCP), never through Zenoh;
- **telemetry** to the vehicle's own Zenoh router if ``--connect`` is given (its network,
  the surface link when there is one), else to a file of JSON lines beside the journal
  (``<journal>.telemetry.jsonl``) and its events on standard output (the system journal
  under systemd).

It starts before mission time 0 and waits for it, or after it (a restart: `Restart=` of the
systemd unit) from its journal at mission time now.
"""

from __future__ import annotations

import dataclasses
import json
import sys
import threading
import time
from pathlib import Path
from typing import IO, Callable

import zenoh

from fleet_agent.config import AgentConfig
from fleet_agent.helms.choice import HelmChoice
from fleet_agent.journal import Journal
from fleet_agent.mission_file import MissionFileError, read_mission_file
from fleet_agent.modems.choice import ModemChoice
from fleet_agent.node import Inbox, ZenohTelemetry, build_fleet, drive
from fleet_agent.plans import set_planning_hook
from fleet_bus import topics
from fleet_bus.auth import BusAuth, unseal
from fleet_bus.clock import MissionClock, WallWatch
from fleet_bus.mission import ClockRecord
from fleet_bus.telemetry import Event, Status, Truth

MAX_START_AHEAD_S = 7 * 86400.0  # a start further ahead than this is a mistake, not a plan


def own_clock(start_unix: float, mono: Callable[[], float] = time.monotonic,
              wall: Callable[[], float] = time.time) -> MissionClock:
    """Mission time at warp 1 from ``start_unix`` on this host's wall clock, read once now
    and kept on the monotonic clock from then on (module docstring)."""
    ref, warp, seq = ClockRecord(start_unix, 1.0).timing(mono, wall)
    return MissionClock(ref, warp, seq, epoch_unix=start_unix, mono=mono, wall=wall)


class WallSteps:
    """This host's wall-clock steps, for the agent's ``clock_wall_steps`` counter."""

    def __init__(self) -> None:
        self.watch = WallWatch()
        self._seen = 0

    def take_wall_steps(self) -> int:
        self.watch.check()
        n, self._seen = self.watch.steps - self._seen, self.watch.steps
        return n


class FileTelemetry:
    """Statuses and events as JSON lines in a file, events also one line on ``out``."""

    def __init__(self, path: Path, out: IO[str] = sys.stdout) -> None:
        self._file = open(path, "a", encoding="utf-8")
        self._out = out

    def publish(self, topic: str, payload: Status | Event | Truth) -> None:
        doc = payload.to_dict() if isinstance(payload, Event) else dataclasses.asdict(payload)
        try:
            self._file.write(json.dumps({"topic": topic, **doc}) + "\n")
            self._file.flush()
        except OSError:  # a full disk costs the telemetry, never the agent
            pass
        if isinstance(payload, Event):
            e = payload
            print(f"t={e.t_s:.0f} s {e.kind} {e.tasks or ''} {e.peer} {e.detail}".rstrip(),
                  file=self._out, flush=True)

    def close(self) -> None:
        self._file.close()


def main(vid: str, config: AgentConfig, journal_path: Path, stop: threading.Event,
         mission_path: Path, *, start_unix: float | None = None,
         modem: ModemChoice = ModemChoice(), helm: HelmChoice = HelmChoice(),
         conf: zenoh.Config | None = None, auth: BusAuth | None = None,
         credentials: Path | None = None) -> int:
    """Run agent ``vid`` on board until ``stop``: 0, or 2 (said on stderr) for a mission
    that cannot run: no file, no start, another run's credentials, the emulated water as the
    modem, credentials without this vehicle's key chain, a helm that does not answer."""
    def refuse(why: str) -> int:
        print(f"fleet_agent {vid}: {why}", file=sys.stderr, flush=True)
        return 2

    try:
        mission, file_start = read_mission_file(mission_path)
    except MissionFileError as exc:
        return refuse(str(exc))
    start = start_unix if start_unix is not None else file_start
    if start is None:
        return refuse(f"{mission_path} says no start: give --start (when mission time 0 is, "
                      "the same for every vehicle)")
    if start - time.time() > MAX_START_AHEAD_S:
        return refuse(f"the mission starts {(start - time.time()) / 86400:.0f} days from now")
    if auth is not None and auth.run_id != mission.run_id:
        return refuse(f"the credentials are for run {auth.run_id!r}, the mission file for "
                      f"{mission.run_id!r}")
    if modem.name == "water":
        return refuse("on board the agent talks through its modem: --modem micromodem:LINK")
    spec = modem.spec
    packet_s = spec.airtime_s(spec.frames_per_packet * spec.max_frame_bytes)
    if config.slot_s < packet_s:
        return refuse(f"slot_s {config.slot_s:g} s cannot hold a {spec.name} packet "
                      f"({packet_s:.2f} s on the air, then its way across the reef): set "
                      "slot_s in the agent config (docs/modems.md)")
    built = build_fleet(mission, vid, config, modem, credentials)
    if isinstance(built, int):
        return built
    clock = own_clock(start)
    inbox = Inbox()
    port = modem.open(inbox.hear, clock)
    try:
        with Journal(journal_path) as journal:
            if conf is None:
                telemetry = FileTelemetry(journal_path.with_name(
                    journal_path.name + ".telemetry.jsonl"))
                try:
                    return drive(built, vid, config, journal, clock, port, telemetry, helm,
                                 stop, inbox, auth, WallSteps())
                finally:
                    telemetry.close()
            with zenoh.open(conf) as session:
                ctl = topics.CTL.of(vid)

                def take_ctl(sample: zenoh.Sample) -> None:
                    payload = unseal(auth, ctl.key, sample.payload.to_bytes())
                    if payload is not None:
                        inbox.put("ctl", payload)

                with session.declare_subscriber(ctl.key, take_ctl):
                    bus = ZenohTelemetry(session, vid, auth)
                    set_planning_hook(None)  # no operator holds a clock on board
                    return drive(built, vid, config, journal, clock, port, bus, helm, stop,
                                 inbox, auth, WallSteps())
    finally:
        port.close()
