"""The intruder of the attack faults: a foreign modem in the water, without the fleet's keys.

It overhears frames (up to `CAPTURE_LIMIT`) and transmits, one at a time, hostile frames of
three kinds: ``garbage`` (random bytes of random length), ``replay`` (a frame it overheard,
sent again), ``forge`` (a well-formed, plausible pose under a key of its own). Both backends
use it, so an attack is the same attack in-process and across processes.
"""

from __future__ import annotations

import numpy as np

from comms_sim.seeds import MISSION_STREAMS
from fleet_agent.wire import Codec, Digest, Pose
from hfc_core.model.problem import Problem

NODE = "intruder"
CAPTURE_LIMIT = 256


def intruder_rng(seed: int) -> np.random.Generator:
    """The intruder's stream of a mission seeded ``seed`` (the second child of its seed)."""
    return np.random.default_rng(np.random.SeedSequence(seed).spawn(MISSION_STREAMS)[1])


class Intruder:
    def __init__(self, problem: Problem, rng: np.random.Generator) -> None:
        self.problem, self.rng = problem, rng
        self.captured: list[bytes] = []

    def overhear(self, frame: bytes) -> None:
        if len(self.captured) < CAPTURE_LIMIT:
            self.captured.append(bytes(frame))

    def position(self) -> tuple[float, float, float]:
        """Where its modem is: over the middle of the spots, at the surface."""
        c = self.problem.xyz[: self.problem.n_tasks].mean(axis=0)
        return (float(c[0]), float(c[1]), 0.0)

    def frame(self, kind: str, now_s: float) -> bytes:
        """One hostile frame of ``kind`` (a replay without anything overheard is a forgery)."""
        rng = self.rng
        if kind == "garbage":
            return rng.bytes(int(rng.integers(1, 65)))
        if kind == "replay" and self.captured:
            return self.captured[int(rng.integers(len(self.captured)))]
        codec = Codec.for_problem(self.problem, rng.bytes(16), "intruder")
        sender = int(rng.integers(self.problem.n_vehicles))
        return codec.encode(Pose(sender, int(now_s) + 10**6, (0.0, 0.0, 0.0), 0, "home",
                                 Digest(0, 0)))
