"""Where work runs: this process, local worker processes, or a Dask cluster.

``upgrade`` and ``dataset`` hand their work to a :class:`Workers` object and never care
which kind it is. Every kind runs the same pure function on the same inputs, so the
output does not depend on where (or in which order) tasks ran: the callers put results
back in a fixed order.

- ``jobs == 1``: tasks run in this process, at submission.
- ``jobs > 1``: a pool of worker processes, started once (forked where the platform
  allows, so they share the parent's imported modules) and fed one small task at a time.
- ``dask="local"`` or a scheduler address (``tcp://host:8786``) or a scheduler file
  (``dask scheduler --scheduler-file FILE``): tasks run on a Dask cluster through
  ``dask.distributed``. Dask is an optional dependency (``pip install 'spinemesh[cluster]'``).
"""

from __future__ import annotations

import multiprocessing
import os
from concurrent.futures import Future, as_completed
from pathlib import Path
from typing import Any, Callable, Iterable, Iterator

from ..errors import SpineMeshError
from ..processes import die_with_parent


def available_cores() -> int:
    """CPU cores this process may run on (its affinity mask, not the machine's count)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # macOS, Windows
        return max(1, os.cpu_count() or 1)


def _one_opencv_thread() -> int:
    """Make OpenCV single-threaded in this process; return the thread count it had.

    Called in the parent while its pool of workers lives, so that every worker, forked now or
    later (``max_tasks_per_child``), starts with one OpenCV thread: with as many processes as
    cores, OpenCV's own threads in each would only fight over the same cores (measured
    several times slower on a loaded 2-core machine). Workers must not resize OpenCV's pool
    themselves: a forked copy of the parent's running pool hung for ever in
    ``cv2.setNumThreads`` (``pthread_cond_destroy`` waiting for threads that do not exist in
    the child; seen in test_upgrade's jobs test under pytest).
    """
    import cv2

    threads = cv2.getNumThreads()
    cv2.setNumThreads(1)
    return threads


def _start_worker() -> None:
    """Worker start-up: end with the parent (no orphans after a kill)."""
    die_with_parent()


class Workers:
    """Runs ``fn(arg)`` tasks; subclasses decide where.

    ``submit`` returns a future (``.result()``); ``as_completed`` yields futures as they
    finish, so results stream back while other tasks still run.
    """

    kind = "this process"
    #: How many tasks run at once (callers keep about twice this many in flight).
    slots = 1

    def submit(self, fn: Callable[[Any], Any], arg: Any) -> Future:
        future: Future = Future()
        try:
            future.set_result(fn(arg))
        except Exception as e:  # raised again by .result(), exactly as a pool would
            future.set_exception(e)
        return future

    def as_completed(self, futures: Iterable) -> Iterator:
        return as_completed(list(futures))

    def close(self, finished: bool = True) -> None:
        """End the workers; ``finished`` is false when the run stopped on an error."""

    def __enter__(self) -> "Workers":
        return self

    def __exit__(self, exc_type, *exc) -> None:
        self.close(finished=exc_type is None)


class ProcessWorkers(Workers):
    """A pool of ``jobs`` worker processes, started once for the whole run.

    Parameters
    ----------
    jobs : int
        Worker processes.
    max_tasks_per_child : int, optional
        Replace a worker after this many tasks (bounds memory of long runs).
    """

    def __init__(self, jobs: int, max_tasks_per_child: int | None = None):
        methods = multiprocessing.get_all_start_methods()
        context = multiprocessing.get_context("fork" if "fork" in methods else None)
        self.kind = f"{jobs} local processes"
        self.slots = jobs
        self._opencv_threads = _one_opencv_thread()
        self._pool = context.Pool(jobs, initializer=_start_worker, maxtasksperchild=max_tasks_per_child)

    def submit(self, fn: Callable[[Any], Any], arg: Any) -> Future:
        future: Future = Future()
        # The pool's result thread completes the future the moment the worker answers.
        self._pool.apply_async(fn, (arg,), callback=future.set_result, error_callback=future.set_exception)
        return future

    def close(self, finished: bool = True) -> None:
        # After a run that finished, each worker takes its end-of-queue marker and exits on
        # its own: no signal. Terminating a pool whose workers are still starting (a library
        # with no project) once left a worker blocked on the queue's lock for ever.
        if finished:
            self._pool.close()
        else:
            self._pool.terminate()
        self._pool.join()
        import cv2

        cv2.setNumThreads(self._opencv_threads)


class DaskWorkers(Workers):
    """Tasks on a Dask cluster: a running scheduler, or a local cluster started here.

    Parameters
    ----------
    address : str
        ``"local"`` (a ``LocalCluster`` of ``jobs`` single-threaded worker processes), a
        scheduler address such as ``tcp://10.0.0.5:8786``, or the path of a scheduler file.
    jobs : int
        Workers of a local cluster; ignored for a running scheduler.
    """

    def __init__(self, address: str, jobs: int):
        try:
            from dask.distributed import Client, LocalCluster
        except ImportError:
            raise SpineMeshError("--dask needs Dask: pip install 'spinemesh[cluster]'") from None
        self._cluster = None
        if address == "local":
            self._cluster = LocalCluster(n_workers=jobs, threads_per_worker=1, processes=True,
                                         dashboard_address=None)
            self._client = Client(self._cluster)
        elif Path(address).is_file():
            self._client = Client(scheduler_file=address)
        else:
            try:
                # Waits as long as Dask's connect timeout (distributed.comm.timeouts.connect).
                self._client = Client(address)
            except (OSError, TimeoutError) as e:
                raise SpineMeshError(f"cannot reach the Dask scheduler at {address}: {e}") from None
        self.kind = f"Dask at {self._client.scheduler.address}"
        self.slots = max(1, sum(self._client.nthreads().values()))

    def submit(self, fn: Callable[[Any], Any], arg: Any):
        # pure=False: Dask would otherwise hash every argument to name the task.
        return self._client.submit(fn, arg, pure=False)

    def as_completed(self, futures: Iterable) -> Iterator:
        from dask.distributed import as_completed as dask_as_completed

        return iter(dask_as_completed(list(futures)))

    def close(self, finished: bool = True) -> None:
        self._client.close()
        if self._cluster is not None:
            self._cluster.close()


def open_workers(jobs: int = 1, dask: str | None = None, max_tasks_per_child: int | None = None) -> Workers:
    """The workers a command asked for (``--jobs``, ``--dask``); use it as a context manager."""
    if dask:
        return DaskWorkers(dask, jobs)
    if jobs > 1:
        return ProcessWorkers(jobs, max_tasks_per_child)
    return Workers()


__all__ = ["Workers", "ProcessWorkers", "DaskWorkers", "open_workers", "available_cores"]
