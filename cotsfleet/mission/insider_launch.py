"""An insider across processes: what a vehicle's leaked credentials give the attacker of
`cotsfleet run --attack KIND@S --insider ID` (`cotsfleet.mission.insider`): the fleet's frames
under the insider's chain (the fleet key of the run's ``agent.toml``, the seed of its
``frames.key``) and its own bus login, with a Zenoh session of its own."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

import zenoh

from cotsfleet.mission.insider import Insider, insider_rng
from fleet_agent.config import AgentConfig
from fleet_agent.fleet import Fleet
from fleet_agent.helms.sim import camera_figures
from fleet_bus import topics
from fleet_bus.auth import BusAuth
from fleet_bus.credentials import load_auth, load_frame_chains, load_frame_seed
from fleet_bus.modem_port import ModemSpec
from fleet_bus.session import client_config
from hfc_core.model.problem import Problem
from reef_sim.truth import Reef


@dataclass
class Leaked:
    """One insider's credentials in the attacker's hands."""

    vid: str
    insider: Insider
    auth: BusAuth
    session: Any  # zenoh.Session under the insider's login

    @staticmethod
    def open(vid: str, problem: Problem, reef: Reef | None, config: AgentConfig, run_id: str,
             seed: int, modem: ModemSpec, creds: Path, ids: Sequence[str],
             endpoint: str) -> "Leaked":
        index = problem.vehicle_index[vid]
        codec = Fleet.wire_of(problem, config.fleet_key, run_id, config,
                              None if reef is None else camera_figures(reef), modem)
        insider = Insider(problem, codec, load_frame_chains(creds, ids), config, index,
                         load_frame_seed(creds / vid), insider_rng(seed, index))
        session = zenoh.open(client_config([endpoint], credentials=creds / vid))
        return Leaked(vid, insider, load_auth(creds / vid, vid), session)

    def busy(self) -> None:
        """A busy announcement signed by the insider (`ClockControl` holds for it, within the
        hold limit)."""
        topics.BUSY.of(self.vid).put(self.session, self.auth, True)

    def close(self) -> None:
        self.session.close()
