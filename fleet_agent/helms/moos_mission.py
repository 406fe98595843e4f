"""The MOOS-IvP mission of one vehicle: its ``.moos`` and ``.bhv``, written for any scenario.

`write_moos_mission(problem, vehicle_index, run_dir, warp, port)` writes
``<run_dir>/<vehicle id>.moos`` and ``<vehicle id>.bhv`` and returns the ``.moos``: a MOOS
community (MOOSDB on ``port``, ``MOOSTimeWarp = warp``) with uSimMarineV22 (the vehicle, at
its start station), pMarinePIDV22 (heading, speed and depth control) and pHelmIvP driving the
behaviours `fleet_agent.helms.moos.MoosHelm` commands. A MOOS-IvP user starts it with
``pAntler <vehicle id>.moos``; the launcher may instead start each app with the file
(``MOOSDB f.moos``, ``uSimMarineV22 f.moos``, ...). The rendering is pure (`render_moos`,
`render_bhv`); the app parameters are those the apps document (``<app> --example``).

The behaviours (names are `MoosHelm`'s constants):

- ``transit`` (BHV_Waypoint): runs while ``COTS_MODE = TRANSIT`` and ``COTS_ARRIVED = false``;
  points from ``WPT_UPDATE``; at the end it posts ``COTS_ARRIVED = true`` and
  ``COTS_LEG_END = $[POINTS]`` (the points, the last tagged with the agent's leg number);
- ``return`` (BHV_Waypoint): the same for ``COTS_MODE = RETURN`` and ``RETURN_UPDATE``; its
  own points are the rendezvous, so an operator can send the vehicle home with
  ``COTS_MODE = RETURN`` alone;
- ``station`` (BHV_StationKeep, centred where it starts): holds while ``COTS_MODE = STATION``
  (a look, an injection, a wait), after a leg ended, and on the surface after an abort;
- ``depth`` (BHV_ConstantDepth): the leg's depth from ``DEPTH_UPDATE``; ``surface``: depth 0
  while ``COTS_MODE = SURFACE``.
"""

from __future__ import annotations

import math
import re
from pathlib import Path
from string import Template

from fleet_agent.helms import moos as m
from fleet_agent.helms.frames import LocalFrame, compass_from_yaw
from hfc_core.model.problem import Problem

# The apps a vehicle's community runs, in start order (MOOSDB first: the others connect to it).
MOOS_APPS = ("MOOSDB", "uSimMarineV22", "pMarinePIDV22", "pHelmIvP")
# Nominal origin of a scenario without geo-reference: Green Island, off Cairns (only NAV_LAT/
# NAV_LONG depend on it; the agent reads local metres).
DEFAULT_ORIGIN_LATLON = (-16.7597, 145.9741)
CAPTURE_RADIUS_M = 3.0  # a leg ends within this of its end (BHV_Waypoint capture_radius)
SLIP_RADIUS_M = 10.0  # ... or when the closest approach was within this and distance grows

_NAME_RE = re.compile(r"[A-Za-z0-9_-]{1,64}")

MOOS_TEMPLATE = Template("""\
// $vehicle: one cotsfleet AUV as a MOOS-IvP community (written by
// fleet_agent.helms.moos_mission for scenario "$scenario"; start with: pAntler $vehicle.moos)
ServerHost   = localhost
ServerPort   = $port
Community    = $vehicle
MOOSTimeWarp = $warp
LatOrigin    = $lat
LongOrigin   = $lon

ProcessConfig = ANTLER
{
  MSBetweenLaunches = 100
  Run = MOOSDB        @ NewConsole = false
  Run = uSimMarineV22 @ NewConsole = false
  Run = pMarinePIDV22 @ NewConsole = false
  Run = pHelmIvP      @ NewConsole = false
}

// The vehicle: starts at its start station, at rest; NAV_* is its true state (no
// navigation error here: the agent is given what the simulator says).
ProcessConfig = uSimMarineV22
{
  AppTick   = 10
  CommsTick = 10
  prefix    = NAV
  start_pos = x=$x, y=$y, heading=$heading, speed=0, depth=$depth
  max_speed = $max_speed
  // uSimMarineV22 turns at rudder x turn_rate/100 x speed/5 x thrust/50 degrees a second:
  // at cruise (thrust 50 for 1 m/s) that is a turning circle of a few metres, an AUV's.
  turn_rate  = 100
  // A COTSbot-class AUV turns on its thrusters without losing way (uSimMarine's default
  // turn_spd_loss 0.85 makes a 180-degree turn cost 30 s at 1 m/s, measured; 0: 15 s).
  turn_spd_loss = 0
  thrust_map = 0:0, 50:$speed, 100:$max_speed
  buoyancy_rate        = 0
  max_depth_rate       = 0.5
  max_depth_rate_speed = 1.0
}

ProcessConfig = pMarinePIDV22
{
  AppTick   = 10
  CommsTick = 10
  // thrust = speed x speed_factor, so that cruise speed takes thrust 50 (uSimMarine's map)
  speed_factor  = $speed_factor
  depth_control = true
  yaw_pid_kp = 0.5
  yaw_pid_kd = 0.1
  yaw_pid_ki = 0.01
  yaw_pid_integral_limit = 0.07
  speed_pid_kp = 0.8
  speed_pid_kd = 0.1
  speed_pid_ki = 0.1
  speed_pid_integral_limit = 0.07
  z_to_pitch_pid_kp = 0.12
  z_to_pitch_pid_kd = 1.0
  z_to_pitch_pid_ki = 0.004
  z_to_pitch_pid_integral_limit = 0.05
  pitch_pid_kp = 0.5
  pitch_pid_kd = 1.0
  pitch_pid_ki = 0
  pitch_pid_integral_limit = 0
  maxrudder   = 100
  maxthrust   = 100
  maxpitch    = 15
  maxelevator = 13
}

ProcessConfig = pHelmIvP
{
  AppTick   = 4
  CommsTick = 4
  behaviors = $bhv_path
  // In emulation the helm drives from the start; on a vehicle the operator deploys it.
  start_engaged = $engaged
  domain = course:0:359:360
  domain = speed:0:$max_speed:$speed_steps
  domain = depth:0:$max_depth:$depth_steps
}
""")

BHV_TEMPLATE = Template("""\
// $vehicle: the behaviours the cotsfleet agent drives (fleet_agent.helms.moos.MoosHelm),
// written by fleet_agent.helms.moos_mission for scenario "$scenario".
initialize $mode_var    = STATION
initialize $arrived_var = false
$deploy
Behavior = BHV_Waypoint
{
  name      = transit
  pwt       = 100
  condition = $mode_var = TRANSIT
  condition = $arrived_var = false
  updates   = $wpt_update
  points    = empty
  perpetual = true
  speed     = $speed
  capture_radius = $capture
  slip_radius    = $slip
  lead      = 8
  endflag   = $arrived_var = true
  endflag   = $leg_end = $$[POINTS]
}

Behavior = BHV_Waypoint
{
  name      = return
  pwt       = 100
  condition = $mode_var = RETURN
  condition = $arrived_var = false
  updates   = $return_update
  perpetual = true
  speed     = $speed
  capture_radius = $capture
  slip_radius    = $slip
  lead      = 8
  points    = $home
  endflag   = $arrived_var = true
  endflag   = $leg_end = $$[POINTS]
}

Behavior = BHV_StationKeep
{
  name      = station
  pwt       = 100
  condition = (($mode_var = STATION) or ($mode_var = SURFACE)) or ($arrived_var = true)
  center_activate = true
  inner_radius    = 2
  outer_radius    = 8
  outer_speed     = $speed
  transit_speed   = $speed
  swing_time      = 5
}

Behavior = BHV_ConstantDepth
{
  name      = depth
  pwt       = 100
  condition = $mode_var != SURFACE
  updates   = $depth_update
  depth     = $depth
  duration  = no-time-limit
}

Behavior = BHV_ConstantDepth
{
  name      = surface
  pwt       = 100
  condition = $mode_var = SURFACE
  depth     = 0
  duration  = no-time-limit
}
""")


def _num(v: float) -> str:
    return f"{v:.2f}".rstrip("0").rstrip(".") if math.isfinite(v) else "0"


def vehicle_name(problem: Problem, vehicle_index: int) -> str:
    """The vehicle's id, checked to be a MOOS community name and a file name."""
    if not 0 <= vehicle_index < len(problem.vehicles):
        raise ValueError(f"vehicle index {vehicle_index} not in 0..{len(problem.vehicles) - 1}")
    vid = problem.vehicles[vehicle_index].id
    if not _NAME_RE.fullmatch(vid):
        raise ValueError(f"vehicle id {vid!r} cannot name a MOOS community (letters, digits, _-)")
    return vid


def _fields(problem: Problem, vehicle_index: int, frame: LocalFrame) -> dict[str, str]:
    vehicle_name(problem, vehicle_index)
    v = problem.vehicles[vehicle_index]
    start, home = frame.to_helm(v.start), frame.to_helm(v.rendezvous)
    depths = [-float(z) for z in problem.xyz[:, 2]] + [0.0]
    max_depth = max(10.0, math.ceil(max(depths) / 10.0) * 10.0 + 10.0)
    max_speed = max(2.0, math.ceil(2.0 * v.speed_mps))
    heading = compass_from_yaw(math.degrees(math.atan2(home[1] - start[1], home[0] - start[0])))
    return {
        "vehicle": v.id, "scenario": problem.name,
        "x": _num(start[0]), "y": _num(start[1]), "depth": _num(max(0.0, -start[2])),
        "heading": _num(heading), "speed": _num(v.speed_mps), "max_speed": _num(max_speed),
        "speed_steps": str(int(max_speed * 10) + 1),
        "speed_factor": _num(50.0 / v.speed_mps),
        "max_depth": _num(max_depth), "depth_steps": str(int(max_depth * 2) + 1),
        "home": f"pts={{{_num(home[0])},{_num(home[1])}}}",
        "capture": _num(CAPTURE_RADIUS_M), "slip": _num(SLIP_RADIUS_M),
        "mode_var": m.MODE_VAR, "arrived_var": m.ARRIVED_VAR, "leg_end": m.LEG_END_VAR,
        "wpt_update": m.WPT_UPDATE_VAR, "return_update": m.RETURN_UPDATE_VAR,
        "depth_update": m.DEPTH_UPDATE_VAR,
    }


def render_moos(problem: Problem, vehicle_index: int, warp: float, port: int,
                frame: LocalFrame = LocalFrame(),
                origin_latlon: tuple[float, float] = DEFAULT_ORIGIN_LATLON,
                engaged: bool = True, bhv_path: str | None = None) -> str:
    """The ``.moos`` text of vehicle ``vehicle_index`` (pure); its helm reads ``bhv_path``
    (default ``<vehicle id>.bhv``, relative to the directory the helm is started in)."""
    if not (math.isfinite(warp) and warp > 0):
        raise ValueError(f"warp must be positive, got {warp}")
    if not 1 <= int(port) <= 65535:
        raise ValueError(f"port out of range: {port}")
    f = _fields(problem, vehicle_index, frame)
    lat, lon = origin_latlon
    return MOOS_TEMPLATE.substitute(f, port=int(port), warp=_num(warp), lat=f"{lat:.7f}",
                                    lon=f"{lon:.7f}", engaged="true" if engaged else "false",
                                    bhv_path=bhv_path or f"{f['vehicle']}.bhv")


def render_bhv(problem: Problem, vehicle_index: int, frame: LocalFrame = LocalFrame(),
               engaged: bool = True) -> str:
    """The ``.bhv`` text of vehicle ``vehicle_index`` (pure). ``engaged``: the helm drives
    from the start (emulation: it also releases the manual override pMarinePID waits for; on
    a vehicle the operator deploys it)."""
    deploy = "initialize MOOS_MANUAL_OVERRIDE = false\n" if engaged else ""
    return BHV_TEMPLATE.substitute(_fields(problem, vehicle_index, frame), deploy=deploy)


def write_moos_mission(problem: Problem, vehicle_index: int, run_dir: str | Path, warp: float,
                       port: int, frame: LocalFrame = LocalFrame(),
                       origin_latlon: tuple[float, float] = DEFAULT_ORIGIN_LATLON,
                       engaged: bool = True) -> Path:
    """Write vehicle ``vehicle_index``'s ``.moos`` and ``.bhv`` into ``run_dir``; the
    ``.moos`` path (its helm reads the ``.bhv`` by absolute path: start the apps anywhere)."""
    vid = vehicle_name(problem, vehicle_index)
    run = Path(run_dir).resolve()
    run.mkdir(parents=True, exist_ok=True)
    moos, bhv = run / f"{vid}.moos", run / f"{vid}.bhv"
    bhv.write_text(render_bhv(problem, vehicle_index, frame, engaged))
    moos.write_text(render_moos(problem, vehicle_index, warp, port, frame, origin_latlon,
                                engaged, str(bhv)))
    return moos


def write_example(folder: str | Path, seed: int = 1, first_port: int = 9001,
                  warp: float = 1.0) -> list[Path]:
    """The shipped mission folder: the paper preset's vehicles (drawn with ``seed``; only
    their stations and the spots' deepest depth reach the files), one MOOSDB port each from
    ``first_port``, ``.bhv`` paths relative (run pAntler in the folder), and the templates."""
    from reef_sim.scenarios.field import paper_preset_doc
    from hfc_core.formats.scenario import problem_from_dict

    problem = problem_from_dict(paper_preset_doc(seed))
    out = Path(folder)
    (out / "templates").mkdir(parents=True, exist_ok=True)
    written = []
    for i in range(len(problem.vehicles)):
        vid = vehicle_name(problem, i)
        moos, bhv = out / f"{vid}.moos", out / f"{vid}.bhv"
        moos.write_text(render_moos(problem, i, warp, first_port + i))
        bhv.write_text(render_bhv(problem, i))
        written += [moos, bhv]
    for name, tmpl in (("vehicle.moos.tmpl", MOOS_TEMPLATE), ("vehicle.bhv.tmpl", BHV_TEMPLATE)):
        (out / "templates" / name).write_text(tmpl.template)
        written.append(out / "templates" / name)
    return written


def main(argv: list[str] | None = None) -> int:
    import argparse
    import json

    from hfc_core.formats.scenario import problem_from_dict

    ap = argparse.ArgumentParser(description="write MOOS-IvP missions for a scenario")
    ap.add_argument("--scenario", help="scenario JSON (one .moos/.bhv per vehicle)")
    ap.add_argument("--run-dir", required=True)
    ap.add_argument("--warp", type=float, default=1.0)
    ap.add_argument("--first-port", type=int, default=9001)
    ap.add_argument("--on-board", action="store_true",
                    help="the helm waits for the operator to deploy it")
    args = ap.parse_args(argv)
    if not args.scenario:
        for p in write_example(args.run_dir, first_port=args.first_port, warp=args.warp):
            print(p)
        return 0
    with open(args.scenario) as f:
        problem = problem_from_dict(json.load(f))
    for i in range(len(problem.vehicles)):
        print(write_moos_mission(problem, i, args.run_dir, args.warp, args.first_port + i,
                                 engaged=not args.on_board))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
