"""Sweeps (`cotsfleet.sweep`): the mission of each seed is the single run's, results are the
same whatever runs them, a failed run is a row, and no worker outlives the sweep."""

from __future__ import annotations

import argparse
import gc
import json
import os
import signal
import weakref
from pathlib import Path

import msgspec
import numpy as np
import pytest

from cotsfleet.cli import main
from cotsfleet.commands.mission_args import mission_args
from cotsfleet.mission.faults import Fault
from cotsfleet.mission.report_model import FailedRun, MissionReport, RunResult, runs_from_list
from cotsfleet.reporting.sweep import machine_free
from cotsfleet.sweep import SweepSpec, build_mission, run_seed
from cotsfleet.sweep.aggregate import by_seed, comparable, summary_table, write_outputs
from cotsfleet.sweep.local import LocalPool, describe_exit
from cotsfleet.sweep.run import executor_for, run_sweep
from cotsfleet.sweep.serial import Serial
from fleet_agent.config import AgentConfig
from hfc_core.formats.scenario import problem_to_dict
from reef_sim.scenarios.field import GeneratorParams, generate_doc

SEEDS = range(3, 7)


def alive(pid: int) -> bool:
    """A process that still runs (a zombie has ended: only its exit status is left)."""
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


@pytest.fixture(scope="module")
def small_scenario(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """12 spots, 2 AUVs, 15 minutes: a mission simulates in about a second."""
    doc = generate_doc(GeneratorParams(name="small", n_tasks=12, n_vehicles=2, size_m=400.0,
                                       battery_s=900.0), np.random.default_rng(0))
    path = tmp_path_factory.mktemp("sweep") / "small.json"
    path.write_text(json.dumps(doc), encoding="utf-8")
    return path


def sim_args(*argv: str) -> argparse.Namespace:
    from cotsfleet.cli import build_parser

    return build_parser().parse_args(["sim", *argv])


@pytest.fixture(scope="module")
def spec(small_scenario: Path) -> SweepSpec:
    return SweepSpec.from_args(sim_args("--scenario", str(small_scenario), "--kill",
                                        "auv2@300", "--loss", "0.1"))


@pytest.fixture(scope="module")
def serial_results(spec: SweepSpec) -> list[RunResult]:
    with Serial() as ex:
        return by_seed(ex.results(spec, SEEDS))


def assert_same_aggregate(a: list[RunResult], b: list[RunResult]) -> None:
    assert [comparable(r) for r in by_seed(a)] == [comparable(r) for r in by_seed(b)]


# -- the mission of a seed ---------------------------------------------------------------------


@pytest.mark.parametrize("argv", [
    [],
    ["--vehicles", "4", "--abort", "auv3@900", "--loss", "0.2"],
    ["--kill", "auv2@1200", "--restart", "auv2@1500", "--partition", "auv1@600+120"],
])
def test_a_seed_builds_the_mission_a_single_run_builds(argv: list[str]) -> None:
    args = sim_args(*argv)
    spec = SweepSpec.from_args(args)
    for seed in (0, 5):
        want, got = mission_args(args, seed=seed), build_mission(spec, seed)
        assert problem_to_dict(got.problem) == problem_to_dict(want.problem)
        assert (got.scenario, got.seed, got.config, got.faults, got.loss) == (
            want.scenario, want.seed, want.config, want.faults, want.loss)


def test_a_scenario_file_and_config_are_read_once_and_shipped(small_scenario: Path,
                                                              tmp_path: Path) -> None:
    config = tmp_path / "agent.toml"
    config.write_text("slot_s = 3.0\nreplan_iterations = 40\n", encoding="utf-8")
    args = sim_args("--scenario", str(small_scenario), "--config", str(config))
    spec = SweepSpec.from_args(args)
    assert spec.scenario == json.loads(small_scenario.read_text())
    assert spec.config.slot_s == 3.0 and spec.config.replan_iterations == 40
    small_scenario_copy = dict(spec.scenario)
    want, got = mission_args(args, seed=9), build_mission(spec, 9)
    assert problem_to_dict(got.problem) == problem_to_dict(want.problem)
    assert got.config == want.config and spec.scenario == small_scenario_copy


def test_bad_arguments_stop_the_sweep_before_any_run(capsys: pytest.CaptureFixture) -> None:
    assert main(["sim", "--runs", "3", "--jobs", "2", "--kill", "auv9@100"]) == 2
    assert "auv9" in capsys.readouterr().err


# -- one run -------------------------------------------------------------------------------


def test_a_run_gives_its_report_with_seed_and_wall_time(spec: SweepSpec,
                                                        serial_results: list[RunResult]) -> None:
    r = serial_results[0]
    assert isinstance(r, MissionReport)
    assert r.seed == SEEDS[0] and r.wall_s is not None and r.run_s is not None
    assert 0 < r.wall_s <= r.run_s
    assert r.oracle is not None and r.oracle.vid == "auv2"  # the spec's faults reached it
    assert comparable(run_seed(spec, SEEDS[0])) == comparable(r)  # deterministic


def test_a_worker_frees_the_last_runs_garbage_and_does_not_carry_it_along(
        spec: SweepSpec) -> None:
    # Garbage in the oldest generation, as a finished mission's cycles are when its worker
    # starts the next: the run must collect it, not freeze it with the live objects (it was
    # then thawed, frozen again by the next run and never freed: a worker grew by each run).
    class Cycle:
        pass

    freed: list[bool] = []
    junk = Cycle()
    junk.me = junk  # type: ignore[attr-defined]
    weakref.finalize(junk, freed.append, True)
    gc.collect()  # it survives, still referenced: now in the oldest generation
    del junk
    assert not freed
    assert isinstance(run_seed(spec, SEEDS[1]), MissionReport)
    assert freed == [True]
    assert not gc.get_freeze_count()  # and nothing is left frozen after the run


def test_a_run_that_raises_is_a_row_with_its_seed(spec: SweepSpec) -> None:
    bad = SweepSpec(spec.scenario, None, 0.0, AgentConfig(), (Fault("kill", 100.0, "auv9"),))
    r = run_seed(bad, 11)
    assert isinstance(r, FailedRun)
    assert r.seed == 11 and "auv9" in r.error and r.traceback and "FaultError" in r.traceback
    assert "fleet" not in r.to_dict()


# -- executors: the same aggregate, failures as rows, nothing left behind ---------------------


def test_local_workers_give_the_aggregate_of_one_process(spec: SweepSpec,
                                                         serial_results: list[RunResult]) -> None:
    with LocalPool(2) as pool:
        got = list(pool.results(spec, SEEDS))
        assert len(pool.pids) == 2 and all(alive(p) for p in pool.pids)
    assert sorted(r.seed for r in got) == list(SEEDS)
    assert_same_aggregate(got, serial_results)
    assert not any(alive(p) for p in pool.pids)


def _fail_some(monkeypatch: pytest.MonkeyPatch, raise_on: int, kill_on: int) -> None:
    """Seed ``raise_on`` raises in the simulation; seed ``kill_on`` kills its own process
    (as the OOM killer would). Workers are forked: they inherit the patch."""
    import cotsfleet.mission.inprocess as inprocess

    real = inprocess.simulate

    def simulate(problem, config, *, seed, **kw):
        if seed == raise_on:
            raise RuntimeError(f"boom {seed}")
        if seed == kill_on:
            os.kill(os.getpid(), signal.SIGKILL)
        return real(problem, config, seed=seed, **kw)

    monkeypatch.setattr(inprocess, "simulate", simulate)


@pytest.mark.skipif(not os.path.exists("/proc/self/stat"), reason="needs Linux (fork, /proc)")
def test_a_failed_run_and_a_dead_worker_cost_their_seed_only(
        spec: SweepSpec, serial_results: list[RunResult],
        monkeypatch: pytest.MonkeyPatch) -> None:
    _fail_some(monkeypatch, raise_on=4, kill_on=5)
    with LocalPool(2) as pool:
        got = by_seed(list(pool.results(spec, SEEDS)))
    assert [r.seed for r in got] == list(SEEDS)
    assert isinstance(got[1], FailedRun) and got[1].error == "RuntimeError('boom 4')"
    assert isinstance(got[2], FailedRun)
    assert "died: killed by signal 9 SIGKILL" in got[2].error
    assert len(pool.pids) == 3  # a fresh worker took the dead one's place
    ok = [r for r in got if isinstance(r, MissionReport)]
    assert_same_aggregate(ok, [r for r in serial_results if r.seed in (3, 6)])
    assert not any(alive(p) for p in pool.pids)


def test_an_exception_in_the_sweep_terminates_busy_workers(spec: SweepSpec) -> None:
    with pytest.raises(KeyboardInterrupt):
        with LocalPool(2) as pool:
            for _ in pool.results(spec, range(20)):
                raise KeyboardInterrupt  # as Ctrl-C would, with the other worker mid-run
    assert not any(alive(p) for p in pool.pids)


def test_describe_exit_names_the_signal() -> None:
    assert describe_exit(-15) == "killed by signal 15 SIGTERM"
    assert describe_exit(3) == "exit code 3"


def test_executor_choice() -> None:
    assert isinstance(executor_for(5, None, None), Serial)
    assert isinstance(executor_for(5, 1, None), Serial)
    assert executor_for(3, 8, None).jobs == 3  # never more workers than runs
    from cotsfleet.errors import UsageError
    with pytest.raises(UsageError):
        executor_for(5, 0, None)


# -- outputs ---------------------------------------------------------------------------------


def test_outputs_sorted_by_seed_and_only_wall_times_depend_on_the_machine(
        serial_results: list[RunResult], tmp_path: Path) -> None:
    failed = FailedRun(seed=2, error="RuntimeError('x')", traceback="...")
    shuffled = [serial_results[2], failed, *serial_results[:2], serial_results[3]]
    md = write_outputs(shuffled, tmp_path / "a" / "mine.json")
    assert md == tmp_path / "a" / "mine.md" and (tmp_path / "a" / "mine.csv").is_file()
    runs = json.loads((tmp_path / "a" / "mine.json").read_text())
    assert [r["seed"] for r in runs] == [2, 3, 4, 5, 6]
    assert all("wall_s" in r for r in runs[1:])  # the JSON keeps the machine's figures
    assert runs_from_list(runs) == by_seed(shuffled)  # and reads back as it was
    text = md.read_text()
    assert "Failed runs:** 1 of 5" in text
    for r in serial_results:  # the wall s column is filled (it was always "-")
        assert f"| {r.wall_s:,.2f} |" in text
    # Other wall times: the same summary but for them, the same CSV.
    slower = [r if isinstance(r, FailedRun) else msgspec.structs.replace(
        r, wall_s=r.wall_s * 7 + 1) for r in shuffled]
    md2 = write_outputs(slower[::-1], tmp_path / "b" / "mine.json")
    assert md2.read_text() != text
    assert machine_free(md2.read_text()) == machine_free(text)
    assert "wall" not in machine_free(text).split("## Per seed")[1].split("Columns:")[0]
    assert (tmp_path / "a" / "mine.csv").read_text() == (tmp_path / "b" / "mine.csv").read_text()


def test_terminal_table_has_quartiles_and_failures(serial_results: list[RunResult]) -> None:
    table = summary_table([*serial_results, FailedRun(seed=99, error="ValueError('v')")])
    lines = table.splitlines()
    assert [line.split()[0] for line in lines[1:7]] == ["median", "q1", "q3", "mean", "min",
                                                        "max"]
    prios = sorted(r.fleet.priority for r in serial_results)
    median = float(lines[1].split()[2])
    assert median == pytest.approx(float(np.median(prios)), rel=1e-3)
    assert lines[-1].startswith("failed: 1 of 5") and "seed 99" in lines[-1]


def test_cli_sweep_same_files_with_one_or_two_jobs(small_scenario: Path, tmp_path: Path,
                                                   capsys: pytest.CaptureFixture) -> None:
    base = ["sim", "--scenario", str(small_scenario), "--runs", "3", "--seed", "1",
            "--kill", "auv1@200"]
    assert main([*base, "--out", str(tmp_path / "one")]) == 0
    assert main([*base, "--jobs", "2", "--out", str(tmp_path / "two")]) == 0
    out = capsys.readouterr().out
    assert "on this process" in out and "on 2 local worker processes" in out
    one, two = tmp_path / "one", tmp_path / "two"
    assert (one / "sweep.csv").read_text() == (two / "sweep.csv").read_text()
    assert machine_free((one / "sweep.md").read_text()) == \
        machine_free((two / "sweep.md").read_text())
    runs_one = runs_from_list(json.loads((one / "sweep.json").read_text()))
    runs_two = runs_from_list(json.loads((two / "sweep.json").read_text()))
    assert [r.seed for r in runs_two] == [1, 2, 3]
    assert [comparable(r) for r in runs_one] == [comparable(r) for r in runs_two]


def test_run_sweep_keeps_what_finished_when_interrupted(spec: SweepSpec) -> None:
    class Interrupting(Serial):
        def results(self, spec, seeds):
            yield from super().results(spec, seeds[:2])
            raise KeyboardInterrupt

    outcome = run_sweep(spec, range(10, 15), Interrupting())
    assert outcome.interrupted and [r.seed for r in outcome.results] == [10, 11]
    assert outcome.seeds == 5
