"""Where work runs: this process, local worker processes, or a Dask cluster.

``upgrade`` and ``dataset`` hand their work to a :class:`Workers` object and never care
which kind it is. Every kind runs the same pure function on the same inputs, so the
output does not depend on where (or in which order) tasks ran: the callers put results
back in a fixed order.

- ``jobs == 1``: tasks run in this process, at submission.
- ``jobs > 1``: worker processes, started once (forked where the platform allows, so they
  share the parent's imported modules) and fed one small task at a time.

A worker that dies (killed, out of memory) is noticed at once; its task runs once more in a
fresh worker, and if that worker dies too the task's future raises :class:`WorkerLost`
naming the reason: the caller reports that one task as failed and goes on. The same holds
on Dask (a lost worker's task is retried once by the scheduler, then fails).
- ``dask="local"`` or a scheduler address (``tcp://host:8786``) or a scheduler file
  (``dask scheduler --scheduler-file FILE``): tasks run on a Dask cluster through
  ``dask.distributed``. Dask is an optional dependency (``pip install 'spinemesh[cluster]'``).
"""

from __future__ import annotations

import functools
import multiprocessing
import os
import pickle
import signal
import sys
import threading
import time
from collections import deque
from concurrent.futures import Future, as_completed
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable, Iterator

from ..errors import SpineMeshError
from ..processes import die_with_parent

#: What pickle raises for an object it cannot write (a lambda, a lock) or read back (a class
#: the other side cannot import): such a task or answer fails alone, the worker goes on.
PICKLE_ERRORS = (pickle.PicklingError, pickle.UnpicklingError, TypeError, AttributeError, ImportError)


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


#: The interpreter's thread switch interval (s) while local workers run, instead of Python's
#: 5 ms. This process plans (pure Python, holding the GIL) while its dispatcher thread
#: feeds the workers; each wake of the dispatcher (an answer back, a task sent) waits for
#: the GIL up to the switch interval, so at 5 ms a worker waited about 14 ms per task for
#: its next one (200 tasks of 4 ms on 2 workers beside a busy thread: 1.8 s, 0.86 s at
#: 0.2 ms, 0.6 s with no busy thread). It bounds only that wait: a thread switches only when
#: another asks for the GIL, which the dispatcher does a few times per task.
DISPATCH_SWITCH_INTERVAL = 0.0002

#: Seconds a pool the system refused a worker process (``ulimit -n``, a container's pids limit) runs
#: on the workers it has before it tries to start one again: the descriptors or processes a moment
#: held (a stage's open files, another program) are often free again.
START_RETRY_SECONDS = 1.0


def _start_worker() -> None:
    """Worker start-up: end with the parent (no orphans after a kill)."""
    die_with_parent()


class Workers:
    """Runs ``fn(arg)`` tasks; subclasses decide where.

    ``submit`` returns a future (``.result()``); ``as_completed`` yields futures as they
    finish, so results stream back while other tasks still run. This class runs each task in
    this process as it is submitted; :class:`ProcessWorkers` and :class:`DaskWorkers` run
    them elsewhere. ``fn`` must be a module-level function (pickled by name) and ``arg``
    picklable, so that a task runs the same anywhere.

    Attributes
    ----------
    kind : str
        Where the tasks run, in words (``this process``).
    slots : int
        How many tasks run at once (callers keep about twice this many in flight).
    """

    kind = "this process"
    #: How many tasks run at once (callers keep about twice this many in flight).
    slots = 1

    def submit(self, fn: Callable[[Any], Any], arg: Any, first: bool = False) -> Future:
        """Run ``fn(arg)``; ``first``: ahead of the tasks already waiting (where tasks wait)."""
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


class WorkerLost(SpineMeshError):
    """A task whose worker process died under it twice (killed, out of memory, crashed).

    Raised by the task's future: the task was run again once in a fresh worker first.
    """


#: The signals that end a run (spinemesh.processes.exit_on_terminate), where the system has them.
RUN_SIGNALS = {getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, name)}


def _mask_run_signals(how) -> None:
    """Block or unblock :data:`RUN_SIGNALS` in this thread (nothing where threads have no masks)."""
    if hasattr(signal, "pthread_sigmask"):
        signal.pthread_sigmask(how, RUN_SIGNALS)


def _death_reason(exitcode: int | None) -> str:
    """Words for how a worker process ended (``Process.exitcode``)."""
    if exitcode is not None and exitcode < 0:
        try:
            name = signal.Signals(-exitcode).name
        except ValueError:
            name = f"signal {-exitcode}"
        hint = " (out of memory?)" if -exitcode == signal.SIGKILL else ""
        return f"worker process was killed by {name}{hint}"
    return f"worker process exited with status {exitcode}"


def _worker_main(conn, max_tasks: int | None) -> None:
    """A worker process: run ``(fn, arg)`` tasks from ``conn``, send back ``(ok, value)``.

    Ends quietly when the parent is gone (a closed pipe is no reason for a traceback), when
    told to (``None``), or after ``max_tasks`` tasks (the parent starts a fresh one).
    """
    die_with_parent()
    _mask_run_signals(getattr(signal, "SIG_UNBLOCK", None))  # blocked by the thread that forked it
    done = 0
    try:
        while max_tasks is None or done < max_tasks:
            try:
                message = conn.recv()
            except MemoryError as e:  # no memory to read the task: it fails as out of memory
                conn.send((False, e))
                done += 1
                continue
            if message is None:
                break
            fn, arg = message
            try:
                answer = (True, fn(arg))
            except Exception as e:  # raised again by the future's .result(), as a pool would
                answer = (False, e)
            try:
                conn.send(answer)
            except PICKLE_ERRORS as e:  # an answer that does not pickle
                conn.send((False, SpineMeshError(f"worker could not send its answer back: {e}")))
            except MemoryError as e:  # no memory to pickle it: said as such (spinemesh.memory)
                answer = None
                conn.send((False, e))
            else:
                if isinstance(answer[1], SharedArray):
                    answer[1].send_memory(conn)
            done += 1
    except (OSError, EOFError, KeyboardInterrupt, SystemExit):
        pass  # the parent ended or stopped the run: nothing to say
    finally:
        conn.close()
        os._exit(0)  # no atexit handlers or flushes inherited from the parent


class SharedArray:
    """A worker's answer array handed to the parent through shared memory, not through the pipe.

    Made in the worker by :func:`shared_array`: the texels are written once into an anonymous
    memory file (Linux ``memfd_create``), whose descriptor follows the pickled answer over the
    worker's socket. The parent maps that memory (:class:`_Mapping`) and closes the descriptor
    at once, so the memory has no name anywhere (nothing in ``/dev/shm``, nothing for a
    resource tracker to clean up): it is freed when the last array over it is dropped, and by
    the kernel whichever way either process ends. The parent's future gets a read-only ``ndarray``.

    Through the pipe, a 16 MB page cost the parent about 17 ms of CPU (every byte read from the
    socket in chunks, joined, then copied again by unpickling, in the dispatcher thread, which
    holds the GIL the planning needs); mapped, about 1 to 3 ms, page faults included
    (``docs/benchmarks/speed.md``). Reading it into the parent's own memory instead cost 28 ms.
    """

    def __init__(self, array):
        import numpy as np

        array = np.ascontiguousarray(array)
        self.shape, self.dtype = array.shape, array.dtype.str
        self._fd: int | None = os.memfd_create("spinemesh-array", os.MFD_CLOEXEC)
        try:
            view = memoryview(array).cast("B")
            while view:  # os.write may write less than asked
                view = view[os.write(self._fd, view):]
        except BaseException:
            self.close()
            raise

    def __getstate__(self):  # the descriptor travels beside the pickle (send_memory)
        return {"shape": self.shape, "dtype": self.dtype, "_fd": None}

    def send_memory(self, conn) -> None:
        """Worker side, after the pickled answer: pass the memory's descriptor, then close ours."""
        from multiprocessing.reduction import send_handle

        try:
            send_handle(conn, self._fd, None)
        finally:
            self.close()

    def close(self) -> None:
        """Close the memory's descriptor here (the memory lives on while the other side holds it)."""
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None

    __del__ = close  # an answer that was never sent leaves no descriptor open

    def receive(self, conn):
        """Parent side: the array in the memory whose descriptor comes next on ``conn`` (read-only).

        Raises
        ------
        OSError, EOFError
            The connection is gone.
        SpineMeshError
            This answer alone could not be read.
        """
        from multiprocessing.reduction import recv_handle

        import numpy as np

        try:
            fd = recv_handle(conn)
        except RuntimeError as e:  # no descriptor in the message (this process has too many open)
            raise SpineMeshError(f"worker answer could not be read: {e}") from None
        try:
            nbytes = int(np.prod(self.shape, dtype=np.int64)) * np.dtype(self.dtype).itemsize
            memory = _Mapping(fd, nbytes)
        except OSError as e:
            raise SpineMeshError(f"worker answer could not be mapped: {e}") from None
        finally:
            os.close(fd)
        return np.asarray(memory).view(self.dtype).reshape(self.shape)  # read-only (_Mapping says so)


class _Mapping:
    """Memory of a descriptor mapped into this process, unmapped when the last array over it goes.

    Not Python's ``mmap``: that keeps a descriptor of its own open per mapping, and a project of
    hundreds of small pages would run this process out of descriptors. Mapped copy-on-write
    and offered to NumPy read-only, so that even a write forced through would change only this
    process's copy, never crash it.
    """

    def __init__(self, fd: int, nbytes: int):
        import ctypes
        import mmap

        self._address = None
        libc = _libc()
        address = libc.mmap(None, nbytes, mmap.PROT_READ | mmap.PROT_WRITE, mmap.MAP_PRIVATE, fd, 0)
        if address is None or address == ctypes.c_void_p(-1).value:
            errno = ctypes.get_errno()
            raise OSError(errno, os.strerror(errno))
        self._unmap = libc.munmap
        self._address, self._nbytes = address, nbytes
        self.__array_interface__ = {"shape": (nbytes,), "typestr": "|u1", "data": (address, True), "version": 3}

    def __del__(self):
        if self._address is not None:
            self._unmap(self._address, self._nbytes)


@functools.lru_cache(maxsize=None)
def _libc():
    """The C library's ``mmap`` and ``munmap``, typed for ctypes."""
    import ctypes

    libc = ctypes.CDLL(None, use_errno=True)
    libc.mmap.restype = ctypes.c_void_p
    libc.mmap.argtypes = (ctypes.c_void_p, ctypes.c_size_t, ctypes.c_int, ctypes.c_int, ctypes.c_int, ctypes.c_long)
    libc.munmap.argtypes = (ctypes.c_void_p, ctypes.c_size_t)
    return libc


def shared_array(array):
    """``array`` as a worker answers it best: a :class:`SharedArray` where the system has
    anonymous memory files (Linux), else the array itself (pickled through the pipe).

    For local :class:`ProcessWorkers` only; large arrays only (a small one gains nothing).
    """
    if hasattr(os, "memfd_create") and array.nbytes > 0:
        return SharedArray(array)
    return array


@dataclass
class _Task:
    future: Future
    fn: Callable[[Any], Any]
    arg: Any
    lost: list[str] = field(default_factory=list)  # why each earlier attempt died


@dataclass
class _Worker:
    process: Any
    conn: Any
    task: _Task | None = None


class ProcessWorkers(Workers):
    """``jobs`` worker processes, each fed one task at a time by a dispatcher thread.

    The dispatcher knows which task each worker holds, so a worker that dies (killed, out of
    memory, crashed in native code) is noticed at once by its process sentinel: its task is
    run once more in a fresh worker, and if that one dies too, the task's future raises
    :class:`WorkerLost` saying why. Every other task goes on.

    Parameters
    ----------
    jobs : int
        Worker processes.
    max_tasks_per_child : int, optional
        Replace a worker after this many tasks (bounds memory of long runs).
    """

    #: How many times a task whose worker died is run again (in a fresh worker).
    RETRIES = 1

    def __init__(self, jobs: int, max_tasks_per_child: int | None = None):
        methods = multiprocessing.get_all_start_methods()
        self._context = multiprocessing.get_context("fork" if "fork" in methods else None)
        self.kind = f"{jobs} local processes"
        self.slots = jobs
        self._max_tasks = max_tasks_per_child
        self._opencv_threads = _one_opencv_thread()
        self._switch_interval = sys.getswitchinterval()
        sys.setswitchinterval(min(self._switch_interval, DISPATCH_SWITCH_INTERVAL))
        self._queue: deque[_Task] = deque()
        self._first: deque[_Task] = deque()  # submitted with first=True: handed out before _queue
        self._workers: list[_Worker] = []
        self._lock = threading.Lock()
        self._closing = False
        self._refused_at: float | None = None  # when the system last refused a worker (START_RETRY_SECONDS)
        self._wake_read, self._wake_write = self._context.Pipe(duplex=False)
        self._dispatcher = threading.Thread(target=self._dispatch, name="spinemesh-workers", daemon=True)
        self._dispatcher.start()

    @property
    def pids(self) -> list[int]:
        """Process ids of the workers now running."""
        with self._lock:
            return [w.process.pid for w in self._workers]

    def submit(self, fn: Callable[[Any], Any], arg: Any, first: bool = False) -> Future:
        """Queue ``fn(arg)``; with ``first``, behind other such tasks but ahead of the rest
        (a page the planning will wait for goes before meshes nobody waits for yet)."""
        future: Future = Future()
        with self._lock:
            if self._closing:
                raise RuntimeError("workers are closed")
            (self._first if first else self._queue).append(_Task(future, fn, arg))
        self._wake()
        return future

    def _wake(self) -> None:
        try:
            self._wake_write.send_bytes(b"")
        except OSError:
            pass

    def _start_worker(self) -> _Worker:
        parent_end, child_end = self._context.Pipe()
        try:
            process = self._context.Process(target=_worker_main, args=(child_end, self._max_tasks), daemon=True)
            process.start()
        except BaseException:
            parent_end.close()
            raise
        finally:
            child_end.close()
        return _Worker(process, parent_end)

    def _refuse_queued(self, error: OSError) -> None:
        """Fail every queued task: no worker runs and the system refuses to start one."""
        refusal = SpineMeshError(f"cannot start a worker process: {error.strerror or error} (try fewer --jobs, or "
                                 "raise the limit: ulimit -n, ulimit -u)")
        while self._first or self._queue:
            task = (self._first or self._queue).popleft()
            if task.lost or task.future.set_running_or_notify_cancel():
                task.future.set_exception(refusal)

    def _hand_out(self) -> None:
        """Give queued tasks to idle workers, starting workers (up to ``jobs``) as needed."""
        with self._lock:
            while self._first or self._queue:
                idle = next((w for w in self._workers if w.task is None), None)
                if idle is None:
                    if len(self._workers) >= self.slots or (
                            self._refused_at is not None and time.monotonic() - self._refused_at < START_RETRY_SECONDS):
                        return
                    try:
                        idle = self._start_worker()
                    except OSError as e:
                        # the system refuses a process (too many open files under `ulimit -n`, no
                        # process left under a container's pids limit): this thread ended in a
                        # traceback and the run waited for ever. It goes on with the workers it
                        # has, and tries again a moment later (it ran the rest of the run on
                        # them, however many descriptors were freed); with none, the queued
                        # tasks fail, saying why
                        self._refused_at = time.monotonic()
                        if not self._workers:
                            self._refuse_queued(e)
                        return
                    self._refused_at = None
                    self._workers.append(idle)
                task = (self._first or self._queue).popleft()
                if not task.lost and not task.future.set_running_or_notify_cancel():
                    continue  # cancelled while queued (a retried task is running already)
                try:
                    idle.conn.send((task.fn, task.arg))
                except (OSError, EOFError):  # died before it got it: noticed by its sentinel
                    idle.task = task
                    continue
                except PICKLE_ERRORS + (MemoryError,) as e:  # a task that does not pickle, or no memory to
                    task.future.set_exception(e)                 # pickle it: that task fails, alone
                    continue
                idle.task = task

    def _answer(self, worker: _Worker) -> bool:
        """Take the worker's answer if it sent one; False when the pipe is closed."""
        try:
            ok, value = worker.conn.recv()
        except (OSError, EOFError):
            return False
        except PICKLE_ERRORS as e:  # an answer that does not unpickle
            ok, value = False, SpineMeshError(f"worker answer could not be read: {e}")
        except MemoryError as e:  # no memory to read it: the task fails as out of memory
            ok, value = False, e
        if isinstance(value, SharedArray):
            try:
                value = value.receive(worker.conn)
            except (OSError, EOFError):  # the worker died before its memory came: a lost task
                return False
            except SpineMeshError as e:  # this answer alone failed; the worker goes on
                ok, value = False, e
        task, worker.task = worker.task, None
        if task is not None:
            (task.future.set_result if ok else task.future.set_exception)(value)
        return True

    def _bury(self, worker: _Worker) -> None:
        """A worker process ended: put its task back once, or fail it."""
        while worker.conn.poll():  # it answered before it ended (max_tasks_per_child)
            if not self._answer(worker):
                break
        worker.process.join()
        worker.conn.close()
        with self._lock:
            self._workers.remove(worker)
            task, worker.task = worker.task, None
            if task is None:
                return
            task.lost.append(_death_reason(worker.process.exitcode))
            if len(task.lost) <= self.RETRIES and not self._closing:
                self._queue.appendleft(task)  # the next worker started is a fresh one
                return
        task.future.set_exception(WorkerLost(
            f"{task.lost[-1]} while running this task, {len(task.lost)} times; not run again"))

    def _dispatch(self) -> None:
        from multiprocessing.connection import wait

        # Workers are forked from this thread: with the run's signals blocked here, a worker
        # forked as Ctrl-C comes starts with them blocked, until it has set its own handlers
        # (_worker_main), instead of raising KeyboardInterrupt, with a traceback, in its start-up.
        # The main thread takes the signals.
        _mask_run_signals(getattr(signal, "SIG_BLOCK", None))

        while True:
            self._hand_out()
            with self._lock:
                workers = list(self._workers)
                if self._closing and not workers:
                    return
            ready = set(wait([self._wake_read] + [w.conn for w in workers if w.task is not None]
                             + [w.process.sentinel for w in workers], timeout=1.0))
            if self._wake_read in ready:
                while self._wake_read.poll():
                    self._wake_read.recv_bytes()
            for w in workers:
                if w.conn in ready and w.task is not None:
                    self._answer(w)
                if w.process.sentinel in ready or (w.conn in ready and w.task is not None):
                    if not w.process.is_alive():
                        self._bury(w)

    def close(self, finished: bool = True) -> None:
        """End the workers: after their current task when ``finished``, at once otherwise.

        Bounded either way: a worker that has not ended :data:`STOP_GRACE` seconds after it
        was told to (:data:`FINISH_GRACE` when ``finished``) is killed with SIGKILL, which
        also ends a stopped process (``kill -STOP``: a SIGTERM stays pending on it) or one
        hung in native code. An interruption while closing (a second Ctrl-C) still kills every
        worker before it goes on: no process outlives the run.
        """
        with self._lock:
            self._closing = True
            dropped = list(self._first) + list(self._queue)
            self._first.clear()
            self._queue.clear()
            workers = list(self._workers)
        for task in dropped:
            task.future.cancel()
        try:
            for w in workers:
                if finished:
                    try:
                        w.conn.send(None)
                    except (OSError, EOFError):
                        pass
                else:
                    w.process.terminate()
            self._wake()
            _end_within(workers, FINISH_GRACE if finished else STOP_GRACE)
        finally:
            for w in workers:
                w.process.kill()  # nothing where it has ended already
            self._wake()
            self._dispatcher.join()  # ends once it has buried every worker (a second at most)
            self._wake_read.close()
            self._wake_write.close()
            import cv2

            cv2.setNumThreads(self._opencv_threads)
            sys.setswitchinterval(self._switch_interval)


#: Seconds a worker has to end when a run stops (Ctrl-C, SIGTERM, an error) before SIGKILL.
STOP_GRACE = 2.0
#: Seconds a worker has to finish its task and end when a run is done, before SIGKILL.
FINISH_GRACE = 30.0


def _end_within(workers: list[_Worker], seconds: float) -> None:
    """Wait until every worker process has ended, at most ``seconds``; kill those still there.

    Waits on the processes' sentinels, never ``join``: the dispatcher thread reaps them."""
    import time
    from multiprocessing.connection import wait

    deadline = time.monotonic() + seconds
    waiting = {w.process.sentinel: w for w in workers}
    while waiting and (left := deadline - time.monotonic()) > 0:
        for sentinel in wait(list(waiting), timeout=left):
            waiting.pop(sentinel)
    for w in waiting.values():
        w.process.kill()


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
            import dask

            # A task whose worker dies is run once more, then fails (KilledWorker), as with
            # local processes; Dask's default would try it three times.
            dask.config.set({"distributed.scheduler.allowed-failures": ProcessWorkers.RETRIES})
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

    def submit(self, fn: Callable[[Any], Any], arg: Any, first: bool = False) -> Future:
        # pure=False: Dask would otherwise hash every argument to name the task.
        task = self._client.submit(fn, arg, pure=False)
        future: Future = Future()
        future.set_running_or_notify_cancel()
        task.add_done_callback(lambda done: _settle(future, done))
        return future

    def close(self, finished: bool = True) -> None:
        self._client.close()
        if self._cluster is not None:
            self._cluster.close()


def _settle(future: Future, done) -> None:
    """Copy a finished Dask future's outcome into ``future``; a lost worker becomes :class:`WorkerLost`."""
    try:
        future.set_result(done.result())
    except Exception as e:
        if type(e).__name__ in ("KilledWorker", "CancelledError", "FutureCancelledError"):
            e = WorkerLost(f"Dask lost the worker running this task ({e}); not run again")
        future.set_exception(e)


def open_workers(jobs: int = 1, dask: str | None = None, max_tasks_per_child: int | None = None) -> Workers:
    """The workers a command asked for (``--jobs``, ``--dask``); use it as a context manager.

    Parameters
    ----------
    jobs : int, default 1
        Worker processes on this machine; 1 runs every task in this process.
    dask : str, optional
        A Dask scheduler's address, or ``"local"`` for a local cluster of ``jobs`` workers
        (:class:`DaskWorkers`, the ``cluster`` extra); default: no Dask.
    max_tasks_per_child : int, optional
        Local processes only: a worker is replaced after this many tasks (bounds the memory
        of long runs); default: never.

    Returns
    -------
    Workers
        :class:`Workers` (this process), :class:`ProcessWorkers` or :class:`DaskWorkers`; the
        same tasks give the same results on any of them.

    Examples
    --------
    >>> with open_workers() as workers:
    ...     futures = [workers.submit(abs, n) for n in (-2, 3)]
    ...     sorted(f.result() for f in workers.as_completed(futures))
    [2, 3]
    """
    if dask:
        return DaskWorkers(dask, jobs)
    if jobs > 1:
        return ProcessWorkers(jobs, max_tasks_per_child)
    return Workers()


__all__ = ["Workers", "ProcessWorkers", "WorkerLost", "DaskWorkers", "open_workers", "available_cores",
           "SharedArray", "shared_array"]
