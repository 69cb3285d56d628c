"""Where batch fits run: a dask.distributed local cluster, a running scheduler, or this process.

:func:`escfit.study.fit_many` hands its tasks to a :class:`Runner`; :class:`LazyClient` shares
one client between batches and starts it only when some unit is left to fit.  A local
cluster's workers share the cores out (:func:`worker_threads`) instead of each starting a
compiled-kernel thread per core.  dask is the ``study`` extra: :func:`require_distributed`
names it when it is missing.
"""

from __future__ import annotations

import math
import os
from typing import Callable

from ..core.errors import FitError, MissingDependency

__all__ = ["Runner", "LazyClient", "local_cluster", "worker_threads", "worker_environment", "require_distributed"]


class Runner:
    """Runs tasks on a dask client (local cluster or given address) or in this process."""

    def __init__(self, scheduler, workers: int | None):
        self.client = None
        self._cluster = None
        self._lazy = scheduler if isinstance(scheduler, LazyClient) else None
        self.local_fs = True
        if workers == 0 and scheduler is None:
            return
        require_distributed()
        from distributed import Client

        if scheduler is None:
            self._cluster = local_cluster(workers or _cpu_count())
            self.client = Client(self._cluster)
        elif isinstance(scheduler, str):
            self.client = Client(scheduler)
            self.local_fs = False
        elif isinstance(scheduler, Client):
            self.client = scheduler
            self.local_fs = False
        elif callable(scheduler):  # a factory, e.g. LazyClient: called only when there is work
            self.client = scheduler()
            self.local_fs = isinstance(scheduler, LazyClient) and not scheduler.address
        else:
            raise FitError(f"scheduler must be an address, a distributed.Client or a factory, got {scheduler!r}")

    @property
    def description(self) -> str:
        if self.client is None:
            return "in-process"
        cluster = self._cluster if self._cluster is not None else getattr(self._lazy, "_cluster", None)
        if cluster is not None:
            return f"LocalCluster({len(cluster.workers)} processes x 1 thread)"
        return f"scheduler {self.client.scheduler.address}"

    def run(self, fn: Callable, jobs: list[tuple], on_done: Callable[[int, dict], None]) -> None:
        if self.client is None:
            for i, args in enumerate(jobs):
                on_done(i, fn(*args))
            return
        from distributed import as_completed

        futures = [self.client.submit(fn, *args, pure=False, key=f"escfit-fit-{i}-{os.urandom(4).hex()}")
                   for i, args in enumerate(jobs)]
        index = {f.key: i for i, f in enumerate(futures)}
        for fut in as_completed(futures):
            i = index[fut.key]
            try:
                out = fut.result()
            except Exception as exc:  # noqa: BLE001 - a lost worker, a killed task ...
                out = {"status": "failed", "error": f"{type(exc).__name__}: {exc}", "seconds": math.nan}
            on_done(i, out)
            fut.release()

    def close(self) -> None:
        if self._cluster is not None:
            self.client.close()
            self._cluster.close()


def worker_threads(n_workers: int) -> int:
    """Compiled-kernel threads each of ``n_workers`` local worker processes may use.

    The CPUs available shared out between the workers, at least one: two workers on two
    cores get one thread each (a fit's parallel kernels would otherwise start a thread per
    core in every worker, and the workers would fight over the cores), a single worker keeps
    them all.
    """
    return max(1, _cpu_count() // max(1, n_workers))


def worker_environment(n_workers: int) -> dict[str, str]:
    """Environment variables of each local worker process: ``NUMBA_NUM_THREADS`` and
    ``OMP_NUM_THREADS`` set to :func:`worker_threads`.

    The nanny sets them in the worker process before the worker starts, so before escfit
    (and numba, which reads them once, when it is imported) is imported there; the driver's
    own environment is left alone.
    """
    threads = str(worker_threads(n_workers))
    return {"NUMBA_NUM_THREADS": threads, "OMP_NUM_THREADS": threads}


def local_cluster(n_workers: int):
    """A LocalCluster of ``n_workers`` processes, as batches use it: one task at a time per
    process, compiled kernels limited to :func:`worker_threads` threads."""
    import dask
    from distributed import LocalCluster

    # the statistical profiler samples every task's stack every 10 ms: pure overhead here
    with dask.config.set({"distributed.worker.profile.enabled": False}):
        return LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True, dashboard_address=None,
                            silence_logs=40, env=worker_environment(n_workers))


class LazyClient:
    """A dask Client started on first use and shared by the batches it is passed to.

    Pass it as ``scheduler`` to :func:`fit_many` (or :func:`fit_fleet`): a batch with nothing
    left to fit never starts a cluster.  ``address`` selects a running scheduler; otherwise a
    LocalCluster of ``workers`` processes is started.  Call :meth:`close` at the end.
    """

    def __init__(self, address: str | None = None, workers: int | None = None):
        self.address, self.workers = address, workers
        self._client = None
        self._cluster = None

    def __call__(self):
        if self._client is None:
            from distributed import Client

            if self.address:
                self._client = Client(self.address)
            else:
                self._cluster = local_cluster(self.workers or _cpu_count())
                self._client = Client(self._cluster)
        return self._client

    @property
    def started(self) -> bool:
        return self._client is not None

    def close(self) -> None:
        if self._client is not None:
            self._client.close()
        if self._cluster is not None:
            self._cluster.close()
        self._client = self._cluster = None


def require_distributed() -> None:
    """Import dask.distributed, or raise :class:`~escfit.core.errors.MissingDependency` naming the
    extra that installs it (``escfit[study]``)."""
    try:
        import dask  # noqa: F401
        import distributed  # noqa: F401
    except ImportError as exc:
        raise MissingDependency("dask.distributed", "study", "fit-many") from exc


def _cpu_count() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not Linux
        return os.cpu_count() or 1
