"""``--scheduler [ADDRESS]``: the sweep on a Dask cluster (`dask.distributed`).

``ADDRESS`` (e.g. ``tcp://host:8786``) names a running cluster: its workers run the seeds, and
they stay when the sweep ends (they are the cluster's). With no address a `LocalCluster` of
``--jobs`` worker processes (default: one per core) is started for the sweep and closed with
it, however the sweep ends: the same code path as a real cluster, on one machine.

Before any run, every worker is asked what it runs (Python, numpy, scipy, cotsfleet): the
same seed must give the same mission on every worker, so a worker that differs stops the
sweep with its address rather than quietly changing results. The spec is scattered once to
every worker rather than shipped with each of thousands of tasks.
"""

from __future__ import annotations

import logging
import os
import platform
import uuid
from importlib import metadata
from typing import Any, Iterator, Sequence

from cotsfleet.errors import UsageError
from cotsfleet.mission.report_model import FailedRun, RunResult
from cotsfleet.sweep.spec import SweepSpec
from cotsfleet.sweep.task import run_seed

CONNECT_TIMEOUT_S = 10.0
WORKERS_TIMEOUT_S = 60.0  # a named cluster with no worker yet: wait this long for one
INSTALL_HINT = "pip install 'cotsfleet[cluster]'"


def environment() -> dict[str, str]:
    """What decides a mission's outcome besides its inputs (run here and on every worker)."""
    out = {"python": ".".join(platform.python_version_tuple()[:2])}
    for package in ("numpy", "scipy", "cotsfleet"):
        try:
            out[package] = metadata.version(package)
        except metadata.PackageNotFoundError:
            out[package] = "missing"
    return out


class DaskPool:
    """``with DaskPool(None, jobs=2) as pool: for r in pool.results(spec, seeds): ...``."""

    def __init__(self, address: str | None, jobs: int | None = None) -> None:
        self.address, self.jobs = address, jobs
        self._cluster: Any = None
        self._client: Any = None
        self._futures: list[Any] = []
        self.workers = 0

    @property
    def where(self) -> str:
        kind = "a local Dask cluster" if self.address is None else f"Dask at {self.address}"
        return f"{kind} ({self.workers} worker{'s' if self.workers != 1 else ''})"

    def __enter__(self) -> "DaskPool":
        try:
            from distributed import Client, LocalCluster
        except ImportError:
            raise UsageError(f"--scheduler needs Dask's distributed: {INSTALL_HINT}") from None
        try:
            if self.address is None:
                import dask

                # One task per worker at a time (no second one queued on it): runs take
                # seconds, so nothing is lost, and a worker that dies takes down only the
                # seed it was running, as in `LocalPool`.
                with dask.config.set({"distributed.scheduler.worker-saturation": 1.0}):
                    self._cluster = LocalCluster(
                        n_workers=self.jobs or os.cpu_count() or 1, threads_per_worker=1,
                        processes=True, dashboard_address=None, silence_logs=logging.ERROR,
                        preload=["cotsfleet.sweep.dask_worker"])
                self._client = Client(self._cluster)
            else:
                self._client = self._connect(Client)
            self.workers = len(self._client.scheduler_info()["workers"])
            self._check_workers()
        except BaseException:
            self.close()
            raise
        return self

    def _connect(self, client_class: Any) -> Any:
        try:
            client = client_class(self.address, timeout=CONNECT_TIMEOUT_S)
        except (OSError, TimeoutError, ValueError) as exc:
            raise UsageError(f"cannot reach the Dask scheduler at {self.address}: {exc}") from None
        try:
            client.wait_for_workers(1, timeout=WORKERS_TIMEOUT_S)
        except TimeoutError:
            client.close()
            raise UsageError(f"the Dask scheduler at {self.address} has no worker "
                             f"(waited {WORKERS_TIMEOUT_S:g} s)") from None
        return client

    def _check_workers(self) -> None:
        here = environment()
        try:
            theirs = self._client.run(environment)
        except Exception as exc:  # e.g. cotsfleet not importable there
            raise UsageError(f"the Dask workers cannot run cotsfleet ({exc!r}); install the "
                             "same cotsfleet on every worker") from None
        wrong = [f"{addr}: {env}" for addr, env in sorted(theirs.items()) if env != here]
        if wrong:
            raise UsageError(f"Dask workers differ from this machine ({here}), so a seed "
                             f"would not give the same mission: {'; '.join(wrong)}")

    def results(self, spec: SweepSpec, seeds: Sequence[int]) -> Iterator[RunResult]:
        from distributed import as_completed

        client = self._client
        shared = client.scatter(spec, broadcast=True, hash=False)
        token = uuid.uuid4().hex[:8]  # keys unique to this sweep on a shared scheduler
        # One graph for every seed: the scheduler then sees the whole group at once and queues
        # it, handing a worker a seed when it has a thread free (see `__enter__`).
        futures = client.map(run_seed, [shared] * len(seeds), list(seeds),
                             key=[f"cotsfleet-sim-{token}-{seed}" for seed in seeds], pure=False)
        seed_of = dict(zip(futures, seeds))
        self._futures = [*seed_of, shared]
        for future in as_completed(list(seed_of)):
            seed = seed_of[future]
            if future.status == "finished":
                result = future.result()
            else:  # run_seed catches what a run raises: this is the worker or the cluster
                result = FailedRun(seed=seed, error="the Dask task of this seed failed: "
                                   f"{future.exception()!r}")
            future.release()  # the result is ours now; free the worker's copy
            yield result

    def close(self) -> None:
        """Cancel what is left of the sweep, disconnect, and stop a cluster we started."""
        client, cluster = self._client, self._cluster
        self._client = self._cluster = None
        if client is not None:
            try:
                if self._futures:
                    client.cancel(self._futures)
            finally:
                self._futures = []
                client.close()
        if cluster is not None:
            cluster.close()

    def __exit__(self, *exc: object) -> None:
        self.close()
