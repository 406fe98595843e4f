"""Faults planned once (`cotsfleet.mission.fault_plan`): the schedule both backends carry out."""

from __future__ import annotations

from cotsfleet.mission.fault_plan import Step, awaited, carry_out, plan
from cotsfleet.mission.faults import ATTACK_SPACING_S, Fault, parse_faults


class Recorder:
    def __init__(self) -> None:
        self.done: list[tuple[str, str, float]] = []

    def apply(self, fault: Fault, now: float) -> None:
        self.done.append(("apply", fault.kind, now))

    def attack(self, fault: Fault, now: float) -> None:
        self.done.append(("attack", fault.kind, now))


def test_an_attack_is_its_start_then_one_step_per_frame() -> None:
    faults = parse_faults(aborts=["auv2@1200"], attacks=["forge@600*3"])
    steps = plan(faults)
    assert [(s.t_s, s.fault.kind, s.frame) for s in steps] == [
        (600.0, "forge", None), (601.0, "forge", 0), (601.0 + ATTACK_SPACING_S, "forge", 1),
        (601.0 + 2 * ATTACK_SPACING_S, "forge", 2), (1200.0, "abort", None)]


def test_steps_go_to_the_backend_as_apply_or_attack() -> None:
    r = Recorder()
    for s in plan(parse_faults(attacks=["phantom@100*2"], insider="auv1")):
        carry_out(s, r, s.t_s)
    assert [(a, t) for a, _, t in r.done] == [("apply", 100.0), ("attack", 101.0),
                                              ("attack", 101.0 + ATTACK_SPACING_S)]


def test_the_mission_waits_for_a_restart_or_an_abort_to_come() -> None:
    steps = plan(parse_faults(kills=["auv2@100"], restarts=["auv2@300"]))
    assert awaited(steps, 200.0) and not awaited(steps, 300.0)
    assert not awaited([Step(500.0, Fault("loss", 500.0, "", 0.1))], 0.0)
