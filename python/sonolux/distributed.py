"""Bakes spread over a Dask cluster (``dask.distributed``): from a laptop's cores to many machines.

:class:`DaskRunner` is the runner of :func:`sonolux.ranges.run_ranges` that traces ray ranges as
Dask tasks. The bake (a :class:`sonolux.ranges.RangeWork`: the scene's content, meshes included
as their triangles, and the settings; never a path) is sent to every worker once; each task
traces one range with one engine thread (a worker runs as many tasks at once as it has
threads) and returns its exact partial sum, which this process adds up as the tasks finish. A
worker lost mid-task is Dask's to handle: it runs the task again elsewhere, and since a range's
rays depend on (seed, source, ray) only, the sum has the same bits.

:func:`connect` turns ``--dask ADDRESS`` or ``--dask local`` into a client (``local``: a
``LocalCluster`` of worker processes on this machine). Real clusters: ``docs/distributed.md``.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Callable
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

from sonolux.errors import SonoluxError
from sonolux.ranges import Range, RangeWork, Tracker, split
from sonolux.version import __version__

#: Tasks per worker thread by default: enough to balance uneven ranges and to lose little when a
#: worker dies, few enough that the per-range cost (the field's allocation, its transfer) stays
#: small.
TASKS_PER_THREAD = 2
#: How often Dask runs a task again after an error before giving up (a lost worker's tasks are
#: rescheduled by the scheduler itself, up to its ``allowed-failures``).
RETRIES = 3


def _dask() -> Any:
    try:
        import distributed
    except ImportError as exc:
        raise SonoluxError(f"--dask needs the packages dask and distributed ({exc}); install "
                           "them with: pip install 'dask[distributed]'") from None
    return distributed


def trace_task(work: RangeWork, first: int, end: int, version: str) -> Any:
    """One task: rays first..end of ``work`` on this worker, one engine thread."""
    if version != __version__:
        raise SonoluxError(f"this Dask worker has sonolux {__version__}, the client "
                           f"{version}: install the same version on every worker")
    return work.trace(first, end, threads=1)


@dataclass
class DaskRunner:
    """Traces ranges as tasks of ``client``'s cluster: ``tasks`` of them (default 2 per worker
    thread), each retried up to ``retries`` times."""

    client: Any
    tasks: int | None = None
    retries: int = RETRIES

    def run(self, work: RangeWork, todo: list[Range], on_part: Callable[[Range, Any], None],
            tracker: Tracker) -> None:
        distributed = _dask()
        threads = sum(self.client.nthreads().values())
        if threads == 0:
            raise SonoluxError("the Dask cluster has no workers: start some (dask worker "
                               "SCHEDULER_ADDRESS) and run again")
        if self.tasks is not None and not (isinstance(self.tasks, int) and self.tasks >= 1):
            raise SonoluxError(f"tasks = {self.tasks!r} is not allowed: a whole number ≥ 1")
        pieces = split(todo, self.tasks or TASKS_PER_THREAD * threads)
        [shared] = self.client.scatter([work], broadcast=True, hash=False)
        futures = {self.client.submit(trace_task, shared, a, b, __version__, pure=False,
                                      retries=self.retries, key=f"sonolux-{work.kind}-{a}-{b}-"
                                      f"{work.fingerprint[:12]}-{os.getpid()}"): (a, b)
                   for a, b in pieces}
        try:
            for future in distributed.as_completed(futures):
                rng = futures[future]
                part = future.result()
                future.release()
                on_part(rng, part)
                tracker.finished(rng[1] - rng[0])
        finally:
            self.client.cancel(list(futures))


def local_cluster(workers: int | None = None) -> Any:
    """A LocalCluster of ``workers`` processes (default: this machine's cores), one thread
    each, the dashboard on a free port, quiet."""
    distributed = _dask()
    n = workers or os.cpu_count() or 1
    return distributed.LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                    dashboard_address=":0", silence_logs=logging.ERROR)


@contextmanager
def connect(address: str, workers: int | None = None, timeout_s: float = 20.0) -> Any:
    """A Dask client for ``address`` ("local": a process pool on this machine; else a
    scheduler such as ``tcp://host:8786``), closed on exit."""
    distributed = _dask()
    if workers is not None and not (isinstance(workers, int) and workers >= 1):
        raise SonoluxError(f"--dask-workers {workers!r} is not allowed: a whole number ≥ 1")
    if address == "local":
        with local_cluster(workers) as cluster, distributed.Client(cluster) as client:
            yield client
        return
    if workers is not None:
        raise SonoluxError("--dask-workers is for --dask local; a cluster's workers are "
                           "started with the cluster")
    try:
        client = distributed.Client(address, timeout=f"{timeout_s}s")
    except (OSError, TimeoutError, ValueError) as exc:
        raise SonoluxError(f"--dask {address}: cannot reach a Dask scheduler there ({exc}); "
                           "give its address as tcp://HOST:PORT, or 'local'") from None
    with client:
        yield client
