"""Agent parameters: one dataclass that validates itself, loadable from TOML.

Times are simulation seconds. The radio schedule is a self-organised TDMA: every vehicle owns
slot ``index`` of a cycle of ``n_vehicles * slot_s`` seconds (all clocks share the mission
epoch), so the fleet's own frames never collide; one frame per slot. A cycle is therefore the
heartbeat period: every frame a vehicle sends counts as its heartbeat.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import Any, Mapping

import tomli_w


@dataclass(frozen=True)
class AgentConfig:
    # Radio (TDMA). 2.5 s holds a 64-byte frame at 1 kbps (0.81 s) plus 1.5 s of propagation
    # (2.2 km) and scheduling slack.
    slot_s: float = 2.5
    pose_every_cycles: int = 2  # a pose at least every this many own slots
    cleared_refresh_cycles: int = 8  # unprompted full-state push of the cleared set
    claim_repeats: int = 3  # each new claim/release is sent this many times
    claim_refresh_cycles: int = 12  # rebroadcast of standing claims (late joiners, loss)
    abort_repeats: int = 4
    home_repeats: int = 3
    # Failure detection: lost when no evidence of life (direct or relayed, dated by the
    # sender's clock) for this many cycles: four frames in a row must go missing, and a
    # vehicle that really went silent is still detected within 5 cycles (4.5 + latency).
    lost_after_cycles: float = 4.5
    # Planning (iteration budgets only: every agent must compute the same plans).
    plan_iterations: int = 500
    replan_iterations: int = 150
    coop_period_s: float = 120.0  # online cooperation operator: how often to look for work
    coop_min_slack_s: float = 60.0  # below this spare battery, do not even look
    battery_reserve_s: float = 1.0  # keep this much battery at the rendezvous
    # Telemetry and persistence.
    status_period_s: float = 5.0
    truth_period_s: float = 5.0
    checkpoint_period_s: float = 10.0
    fleet_key_hex: str = ""  # HMAC key shared by the fleet (never sent on the bus)

    def __post_init__(self) -> None:
        positive = ("slot_s", "lost_after_cycles", "coop_period_s",
                    "status_period_s", "truth_period_s", "checkpoint_period_s")
        for name in positive:
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"agent config: {name} must be a positive number, got {value!r}")
        counts = ("pose_every_cycles", "cleared_refresh_cycles", "claim_repeats",
                  "claim_refresh_cycles", "abort_repeats", "home_repeats")
        for name in counts:
            value = getattr(self, name)
            if not (isinstance(value, int) and value >= 1):
                raise ValueError(f"agent config: {name} must be an integer >= 1, got {value!r}")
        for name in ("plan_iterations", "replan_iterations"):
            value = getattr(self, name)
            if not (isinstance(value, int) and value >= 0):
                raise ValueError(f"agent config: {name} must be an integer >= 0, got {value!r}")
        for name in ("coop_min_slack_s", "battery_reserve_s"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and value >= 0):
                raise ValueError(f"agent config: {name} must be >= 0, got {value!r}")
        if self.fleet_key_hex:
            try:
                key = bytes.fromhex(self.fleet_key_hex)
            except ValueError:
                raise ValueError("agent config: fleet_key_hex is not hex") from None
            if len(key) < 16:
                raise ValueError("agent config: fleet key must be at least 16 bytes")

    @property
    def fleet_key(self) -> bytes:
        if not self.fleet_key_hex:
            raise ValueError("agent config: no fleet key (set fleet_key_hex)")
        return bytes.fromhex(self.fleet_key_hex)

    def with_key(self, key: bytes) -> "AgentConfig":
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
