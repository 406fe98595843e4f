"""Sweeps through Dask (`--scheduler`): a local cluster gives the aggregate of `--jobs 1`, a
named cluster is used and left running, Ctrl-C leaves no process behind."""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

import pytest

from cotsfleet.cli import main
from cotsfleet.mission.report_model import MissionReport, runs_from_list
from cotsfleet.reporting.sweep import machine_free
from cotsfleet.sweep.aggregate import comparable

pytest.importorskip("distributed")
pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")


def _cmdline(pid: int) -> str:
    try:
        with open(f"/proc/{pid}/cmdline", "rb") as fh:
            return fh.read().replace(b"\0", b" ").decode(errors="replace")
    except OSError:
        return ""


def descendants(pid: int) -> set[int]:
    """Running processes below ``pid`` (zombies have ended), but multiprocessing's resource
    tracker: one per interpreter, started on first use of a spawn context (here by Dask),
    ending with the interpreter; it runs no work."""
    children: dict[int, list[int]] = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                with open(f"/proc/{entry}/stat") as fh:
                    fields = fh.read().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if fields[0] != "Z" and "resource_tracker" not in _cmdline(int(entry)):
                children.setdefault(int(fields[1]), []).append(int(entry))
    out, todo = set(), [pid]
    while todo:
        for child in children.get(todo.pop(), []):
            out.add(child)
            todo.append(child)
    return out


@pytest.fixture(scope="module")
def scenario(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("dask") / "small.json"
    assert main(["scenario", "--tasks", "12", "--vehicles", "2", "--size", "400",
                 "--battery-s", "900", "-o", str(path)]) == 0
    return path


def sweep(scenario: Path, out: Path, *extra: str) -> int:
    """Seeds 2-5 of the small scenario (``extra`` may ask for more runs: the last wins)."""
    return main(["sim", "--scenario", str(scenario), "--runs", "4", "--seed", "2", "--kill",
                 "auv2@300", "--loss", "0.1", "--out", str(out), *extra])


def test_a_local_cluster_gives_the_aggregate_of_one_process(scenario: Path, tmp_path: Path,
                                                           capsys: pytest.CaptureFixture) -> None:
    before = descendants(os.getpid())
    assert sweep(scenario, tmp_path / "dask", "--scheduler", "--jobs", "2") == 0
    assert descendants(os.getpid()) - before == set()  # the cluster went with the sweep
    assert sweep(scenario, tmp_path / "one") == 0
    out = capsys.readouterr().out
    assert "on a local Dask cluster (2 workers)" in out and "on this process" in out
    assert (tmp_path / "dask" / "sweep.csv").read_text() == \
        (tmp_path / "one" / "sweep.csv").read_text()
    assert machine_free((tmp_path / "dask" / "sweep.md").read_text()) == \
        machine_free((tmp_path / "one" / "sweep.md").read_text())
    dask = runs_from_list(json.loads((tmp_path / "dask" / "sweep.json").read_text()))
    one = runs_from_list(json.loads((tmp_path / "one" / "sweep.json").read_text()))
    assert [r.seed for r in dask] == [2, 3, 4, 5]
    assert [comparable(r) for r in dask] == [comparable(r) for r in one]
    assert all(isinstance(r, MissionReport) and r.oracle is not None and r.oracle.vid == "auv2"
               for r in dask)


def test_a_named_cluster_runs_the_sweep_and_stays(scenario: Path, tmp_path: Path,
                                                  capsys: pytest.CaptureFixture) -> None:
    from distributed import Client, LocalCluster

    # A cluster of its own (threads: quick to start); the sweep only knows its address.
    with LocalCluster(n_workers=1, processes=False, threads_per_worker=1,
                      dashboard_address=None) as cluster:
        assert sweep(scenario, tmp_path / "named", "--scheduler", cluster.scheduler_address,
                     "--jobs", "3") == 0
        with Client(cluster) as client:
            assert len(client.scheduler_info()["workers"]) == 1  # still there, still ours
            assert client.who_has() == {}  # the sweep took its results and left nothing
    captured = capsys.readouterr()
    assert f"on Dask at {cluster.scheduler_address} (1 worker)" in captured.out
    assert "--jobs sizes a local pool" in captured.err
    runs = json.loads((tmp_path / "named" / "sweep.json").read_text())
    assert [r["seed"] for r in runs] == [2, 3, 4, 5] and not any("error" in r for r in runs)


def test_an_unreachable_scheduler_is_one_line(monkeypatch: pytest.MonkeyPatch,
                                              capsys: pytest.CaptureFixture) -> None:
    import cotsfleet.sweep.cluster as cluster

    monkeypatch.setattr(cluster, "CONNECT_TIMEOUT_S", 1.0)
    assert main(["sim", "--runs", "2", "--scheduler", "tcp://127.0.0.1:9"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith("cotsfleet sim: error: cannot reach the Dask scheduler at "
                              "tcp://127.0.0.1:9")


def test_ctrl_c_stops_the_local_cluster(scenario: Path, tmp_path: Path) -> None:
    from tests.cotsfleet.test_sweep_processes import run_and_stop

    run_and_stop(scenario, tmp_path / "out", "ctrl-c", "--scheduler")


def run_or_die(spec, seed):
    """A run whose seed 3 kills its Dask worker (as the OOM killer would). Workers import
    this from here by name: it must live at module level."""
    import signal

    from cotsfleet.sweep.task import run_seed

    if seed == 3:
        os.kill(os.getpid(), signal.SIGKILL)
    return run_seed(spec, seed)


def test_a_seed_that_kills_its_worker_is_a_row_and_the_sweep_goes_on(
        scenario: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture) -> None:
    import dask

    import cotsfleet.sweep.cluster as cluster

    monkeypatch.setattr(cluster, "run_seed", run_or_die)
    before = descendants(os.getpid())
    # Dask reschedules a task whose worker died; after this many deaths it gives up on it
    # (default 3: a seed that kills every worker it meets costs 4 worker restarts). With
    # more seeds than twice the workers, Dask queues them and hands each worker one at a time
    # (worker-saturation 1.0, set by the sweep), so the death is charged to seed 3 alone.
    with dask.config.set({"distributed.scheduler.allowed-failures": 0}):
        assert sweep(scenario, tmp_path / "out", "--scheduler", "--jobs", "2",
                     "--runs", "8") == 1
    assert descendants(os.getpid()) - before == set()
    runs = json.loads((tmp_path / "out" / "sweep.json").read_text())
    assert [r["seed"] for r in runs] == list(range(2, 10))
    assert "KilledWorker" in runs[1]["error"] and "fleet" not in runs[1]
    assert all("error" not in r for r in (runs[0], *runs[2:]))
    assert "failed: 1 of 8 run(s): seed 3" in capsys.readouterr().out


def test_a_killed_sweep_leaves_no_local_cluster_behind(scenario: Path, tmp_path: Path) -> None:
    """SIGKILL: the sweep cannot close its cluster; the workers must end on their own."""
    from tests.cotsfleet.test_sweep_processes import start_sweep, wait_for_runs, wait_gone

    proc = start_sweep(scenario, tmp_path / "out", "--scheduler")
    try:
        wait_for_runs(proc, 1)
        proc.kill()
        proc.wait()
    finally:
        left = wait_gone(proc.pid, timeout_s=30.0)
        for line in left:
            os.kill(int(line.split()[0]), 9)
    assert left == []


def test_a_local_worker_drops_only_the_heartbeat_lost_to_the_closing_sweep() -> None:
    import logging
    import signal

    from cotsfleet.sweep import dask_worker

    def record(msg: str, level: int = logging.ERROR) -> logging.LogRecord:
        return logging.LogRecord("distributed.worker", level, __file__, 1, msg, None, None)

    logger = logging.getLogger("distributed.worker")
    seen: list[str] = []
    handler = logging.Handler()
    handler.emit = lambda r: seen.append(r.getMessage())  # type: ignore[method-assign]
    logger.addHandler(handler)
    sigint = signal.getsignal(signal.SIGINT)  # dask_setup ignores Ctrl-C, as a worker does
    try:
        dask_worker.dask_setup(worker=None)
        logger.handle(record("Failed to communicate with scheduler during heartbeat."))
        logger.handle(record("Unexpected exception during heartbeat. Closing worker."))
        logger.handle(record("Worker is at 95% memory usage.", logging.WARNING))
    finally:
        logger.removeHandler(handler)
        logger.removeFilter(dask_worker.closing_noise)
        signal.signal(signal.SIGINT, sigint)
    assert seen == ["Unexpected exception during heartbeat. Closing worker.",
                    "Worker is at 95% memory usage."]
