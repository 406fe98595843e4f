"""The world's book of where a simulated vehicle's battery went: seconds per activity.

A vehicle's mission time is spent flying to a spot (``transit``), flying home (``homing``),
keeping station to look at a spot (``look_cots`` when the look found an aggregation,
``look_empty`` when it found bare seabed), injecting (``injecting``), keeping station with
nothing to do (``holding``: waiting for a claim to settle, for orders, or a refused command),
and recovered at the rendezvous before the mission ends (``recovered``: battery left unused).
The simulated vehicle enters an activity at each change of its state machine; the book keeps
only the running totals and the open interval, so its memory does not grow with the mission.

It is the simulator's truth, like `reef_sim.score.world_tally`: benchmarks read it to say how
a fleet's time compares with the clairvoyant plan's (`benchmarks/dynamic_budget.py`); the
agents never see it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

ACTIVITIES = ("transit", "homing", "look_cots", "look_empty", "injecting", "holding",
              "recovered")


@dataclass
class TimeBook:
    """Seconds per activity (`ACTIVITIES`) up to the open interval, which began at
    ``since_s`` doing ``doing``."""

    since_s: float = 0.0
    doing: str = "holding"
    seconds: dict[str, float] = field(default_factory=lambda: dict.fromkeys(ACTIVITIES, 0.0))

    def enter(self, t_s: float, activity: str, ended_as: str | None = None) -> None:
        """From ``t_s`` on, the vehicle does ``activity``; the interval closing now is booked
        as ``ended_as`` when given (a look's result is known only at its end)."""
        if activity not in self.seconds or (ended_as is not None and ended_as not in
                                             self.seconds):
            raise ValueError(f"unknown activity {ended_as or activity!r}")
        t_s = max(float(t_s), self.since_s)  # time never runs back in the book
        self.seconds[ended_as or self.doing] += t_s - self.since_s
        self.since_s, self.doing = t_s, activity

    def totals(self, until_s: float) -> dict[str, float]:
        """Seconds per activity from the start to ``until_s`` (the open interval included)."""
        out = dict(self.seconds)
        out[self.doing] += max(0.0, float(until_s) - self.since_s)
        return out
