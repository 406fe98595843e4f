"""Navigation as it is: what the agent does when its fixes stop, and when its vehicle lags.

The agent plans and tells the fleet where its vehicle is from the vehicle's navigation fixes
only (`fleet_bus.vehicle_port.NavFix`); it never dead-reckons a position it was not given.
The driver tells it, at every step, the age of the last fix (`nav_age_s`: a live helm's own
figure, else the time since the last fix the driver handed over). Two rules, after
`docs/onboard.md`:

- *Navigation that stops.* While the age is within ``config.nav_hold_s`` nothing changes
  (fixes come at the helm's rate). Past it, a vehicle under way keeps station where it is
  (`StationKeep(WAIT)`: a vehicle without navigation must not fly on, and the last fix stays
  where it is); the work at a spot goes on (the vehicle keeps station anyway). When fixes come
  back it goes on from where the new fix says it is. Past ``config.nav_limit_s`` it gives the
  mission up and heads home through the last position it was given (an abort, announced to
  the fleet as the operator's is, so its spots are taken over), and says so: the event
  ``navigation`` and the counter ``nav_lost``.
- *A vehicle that lags its plan* (a current the plan did not know, a behaviour that refuses,
  a slow helm): its projected end, mission time plus the time it still needs from where its
  last fix puts it (`OwnVehicle.time_to_finish_s`), should stay where it was when the route
  was set; it grows when the vehicle falls behind. Once it has grown by
  ``config.late_after_s`` the vehicle is late: the event ``late``, the counter ``late``, and
  its route refitted from where the vehicle really is (`Steer`, the battery fit from the last
  fix). The baseline restarts whenever the route changes (a spot done, a replan) and after
  each ``late``.
- *Navigation grown uncertain.* A vehicle under way whose fix reports a 1-sigma error per
  axis above ``config.surface_sigma_m`` climbs to the surface where it is for a GPS fix, and
  goes on from there to its next spot (`OwnVehicle.detour`: the climb is flown first and
  timed with the leg, as a search is, until the fix comes). Why: under dead reckoning the
  error grows with the distance run (1 % of it, 10 m after a kilometre), and beyond a look's
  footprint the vehicle looks at bare seabed and takes its finds for new aggregations
  (docs/search.md); on a reef a few metres deep the climb costs seconds. The event
  ``navigation`` and the counter ``surfaced``; a climb after which the error did not fall
  back (a helm whose navigation takes no GPS) counts ``surface_no_fix``, and after
  `SURFACE_TRIES` of them in a row the vehicle stops trying. Not again within
  `SURFACE_GAP_M` of the last climb.
- *A vehicle the operator paused* keeps station (`command`) until resumed, but never past its
  battery: once what is left of it, less the planner's reserve, is within
  ``config.pause_margin_s`` of the time home from where it keeps station, it gives the mission
  up and heads home (an abort, announced so its spots are taken over), and says so: the event
  ``abort`` (detail: why) and the counter ``pause_battery_home``.

Pure: no clock, no I/O; the agent keeps one `Navigation`, applies what `check` returns and
commands its vehicle through `command_key` and `command` (the route's, or the hold).
"""

from __future__ import annotations

import math

from fleet_agent import records as rec
from fleet_agent.config import AgentConfig
from fleet_agent.intents import Count, Intent, Note, Owe, Steer, Tell
from fleet_agent.knowledge import Knowledge
from fleet_agent.motion import Activity, OwnVehicle
from fleet_agent.outbox import Owed
from fleet_bus.states import EventKind
from fleet_bus.vehicle_port import HelmCommand, StationKeep, Work

MOVING = (Activity.TRANSIT, Activity.RETURNING)
SURFACE_GAP_M = 100.0  # metres run between two climbs for a fix, at least
SURFACE_TRIES = 3  # climbs in a row that brought no fix before the vehicle stops climbing
HOLD = StationKeep(Work.WAIT, -1, 0.0)  # keep station where you are, until told otherwise


class Navigation:
    """One vehicle's watch on its navigation and on its progress (module docstring)."""

    def __init__(self, config: AgentConfig) -> None:
        self.hold_s, self.limit_s = config.nav_hold_s, config.nav_limit_s
        self.late_s = config.late_after_s
        self.reserve_s, self.pause_margin_s = config.battery_reserve_s, config.pause_margin_s
        self.holding = False  # keeping station for want of navigation
        self.lost = False  # gave the mission up for want of navigation
        self.paused = False  # the operator's pause (`policies.orders`): hold while under way
        self.rejoining = False  # a lost journal (`policies.rejoin`): hold until rejoined
        self._stale_since: float | None = None
        self._base_end_s: float | None = None  # projected end when the route was set
        self._base_route: tuple[int, ...] = ()
        self.surface_sigma_m = config.surface_sigma_m
        self._climb = False  # a climb under way, its fix not seen yet
        self._last_climb_m = -math.inf
        self._no_fix = 0  # climbs in a row after which the error did not fall

    def _holds(self, own: OwnVehicle) -> bool:
        return self.holding or ((self.paused or self.rejoining) and own.activity in MOVING
                                and not own.aborted)

    def command_key(self, own: OwnVehicle) -> object:
        """What changes the vehicle's command: the route's (`OwnVehicle.command_key`), or the
        hold while there is no navigation or the operator paused it."""
        return HOLD if self._holds(own) else own.command_key()

    def command(self, own: OwnVehicle) -> HelmCommand | None:
        """The vehicle's command: the route's, or keeping station while it holds."""
        return HOLD if self._holds(own) else own.command()

    def check(self, know: Knowledge, now: float, nav_age_s: float | None) -> list[Intent]:
        """What the age of the last fix (None: fresh) and the vehicle's progress call for."""
        own = know.own
        age = 0.0 if nav_age_s is None or math.isnan(nav_age_s) else max(0.0, nav_age_s)
        active = not (own.done or own.aborted)
        if age > self.hold_s and not self.lost:
            return self._stale(know, now, age, active)
        out: list[Intent] = []
        if self.paused and active and self._holds(own):
            out += self._pause_battery(know, now)
        if self._stale_since is not None:  # fixes came back
            gap = max(0.0, now - self._stale_since)
            out += [Tell(now, EventKind.NAVIGATION, detail=f"back after {gap:.0f} s; going on from "
                         "the new fix"), Count("nav_back")]
            self._stale_since, self.holding = None, False
            if active:  # on from where the vehicle now is (the route refitted there)
                out.append(Steer(tuple(own.route), "navigation"))
            self._base_end_s = None
        if self.paused or self.rejoining:
            self._base_end_s = None  # a pause is not lateness; measured again on resume
        elif active and not self.holding:
            out += self._surface(know, now)
            out += self._progress(know, now)
        return out

    def _surface(self, know: Knowledge, now: float) -> list[Intent]:
        """Climb for a GPS fix when the navigation's error has grown past the threshold."""
        own = know.own
        out: list[Intent] = []
        if self._climb:
            # The fix came if the error fell back within the threshold (the reported sigma
            # also falls without one when the vehicle runs back toward where it was reset).
            if own.sigma_m <= self.surface_sigma_m:
                self._climb, self._no_fix = False, 0
                if own.detour is not None:  # the climb is flown: on to the spot from here
                    own.detour = None
                    know.touch()
            elif own.detour is None:  # the leg ended (or changed) and no fix came
                self._climb, self._no_fix = False, self._no_fix + 1
                out.append(Count("surface_no_fix"))
            else:
                return out
        if (not self.surface_sigma_m or own.sigma_m <= self.surface_sigma_m
                or own.activity is not Activity.TRANSIT or own.detour is not None
                or not own.route or self._no_fix >= SURFACE_TRIES
                or own.distance_m - self._last_climb_m < SURFACE_GAP_M):
            return out
        x, y, z = own.pos
        up = (x, y, 0.0)
        goal = tuple(float(c) for c in own.problem.xyz[own.route[0]])
        cost = own.leg_time_s(own.pos, up) + own.leg_time_s(up, goal) - \
            own.leg_time_s(own.pos, goal)
        if not math.isfinite(cost):
            return out
        own.set_detour((own.pos, up), max(0.0, cost))
        self._climb, self._last_climb_m = True, own.distance_m
        know.touch()
        return out + [Count("surfaced"),
                      Tell(now, EventKind.NAVIGATION, detail=f"error {own.sigma_m:.1f} m "
                           f"(1 sigma): climbing {-z:.1f} m for a GPS fix")]

    def _stale(self, know: Knowledge, now: float, age: float, active: bool) -> list[Intent]:
        """No fix for ``age`` > hold: keep station under way; past the limit, go home."""
        own = know.own
        out: list[Intent] = []
        self._base_end_s = None
        if self._stale_since is None:
            self._stale_since = now - age
            out += [Tell(now, EventKind.NAVIGATION, detail=f"no fix for {age:.0f} s: "
                         + ("keeping station" if own.activity in MOVING else "working on")),
                    Count("nav_stale")]
        if age > self.limit_s:
            self.lost, self.holding = True, False
            out += [Count("nav_lost"),
                    Tell(now, EventKind.NAVIGATION, detail=f"no fix for {age:.0f} s: heading home "
                         "from the last fix")]
            if active:  # an abort, as the operator's (`Agent._on_command`), said why
                own.abort()
                out += [Owe(Owed.OWN_ABORT), Note(rec.Aborted(now)),
                        Tell(now, EventKind.ABORT, detail=f"no navigation for {age:.0f} s")]
            return out
        self.holding = own.activity in MOVING
        return out

    def _pause_battery(self, know: Knowledge, now: float) -> list[Intent]:
        """Paused: home once holding longer would leave too little battery to get there."""
        own = know.own
        home_s = own.leg_time_s(own.pos, own.rendezvous)
        left_s = own.battery_left_s(now) - self.reserve_s
        if left_s - home_s > self.pause_margin_s:
            return []
        self.paused = False
        own.abort()
        return [Count("pause_battery_home"), Owe(Owed.OWN_ABORT),
                Note(rec.Aborted(now)),
                Tell(now, EventKind.ABORT, detail=f"paused with {max(0.0, left_s):.0f} s of "
                     f"battery left, {home_s:.0f} s from home: heading home")]

    def _progress(self, know: Knowledge, now: float) -> list[Intent]:
        """Late: the projected end has grown by ``late_s`` since the route was set."""
        own = know.own
        route = tuple(own.route)
        end = now + own.time_to_finish_s()
        if self._base_end_s is None or route != self._base_route or not math.isfinite(end):
            self._base_end_s, self._base_route = end, route
            return []
        behind = end - self._base_end_s
        if behind <= self.late_s:
            return []
        self._base_end_s = None  # measured again from the refitted route
        return [Tell(now, EventKind.LATE, detail=f"{behind:.0f} s behind its plan; refitted from "
                     f"its last fix"), Count("late"), Steer(route, "late")]
