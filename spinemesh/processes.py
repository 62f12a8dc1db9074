"""Process hygiene: interruptions that clean up, and workers that end with their parent.

- :func:`exit_on_terminate` makes Ctrl-C, SIGTERM and SIGHUP end the run once, cleanly: SIGTERM
  and SIGHUP become ``SystemExit``, so the cleanup of :mod:`spinemesh.files.atomic` (temporary
  files removed) runs as it does for Ctrl-C; a second signal during that cleanup is not raised
  into it; one that Python swallowed in a finalizer is raised again (:func:`interrupted`).
- :func:`die_with_parent` is the initializer of every worker process: a watchdog thread ends
  the worker within a second of its re-parenting. A killed run leaves no workers behind.
- :func:`keep_buffers_on_heap` keeps a process that hands large work to others from paying a
  page fault per 4 KiB of every buffer it makes.
"""

from __future__ import annotations

import _thread
import os
import signal
import sys
import threading
import time

#: The signal ending this run (SIGINT, SIGTERM, SIGHUP), 0 while none came; and when it came.
_ending = {"signal": 0, "at": 0.0, "hook": False}
#: Seconds after a signal during which another is not raised: the run is cleaning up (workers
#: get :data:`spinemesh.cluster.STOP_GRACE` to end), and an exception raised into that
#: cleanup would only cut it short with a traceback. A signal after this is raised again.
CLEANUP_SECONDS = 10.0
_default_unraisable = sys.unraisablehook


def _end_run(signum, frame):
    now = time.monotonic()
    if _ending["hook"]:  # inside the hook below, which would drop it too: a moment later
        _raise_later(signum)
        return
    if _ending["signal"] and now - _ending["at"] < CLEANUP_SECONDS:
        return
    _ending.update(signal=signum, at=now)
    if signum == signal.SIGINT:
        raise KeyboardInterrupt
    raise SystemExit(128 + signum)


def _raise_later(signum: int) -> None:
    """Have the main thread take ``signum`` again in a moment, from another thread (in the main
    thread, ``interrupt_main`` would run the handler at once, where it would be dropped again)."""
    timer = threading.Timer(0.005, _thread.interrupt_main, (signum,))
    timer.daemon = True
    timer.start()


def _unraisable(hook):
    """An interruption raised while Python ran a finalizer (``__del__``, a weakref callback) is
    printed as "Exception ignored" and dropped there, and the run would go on to end as if
    nothing came: it is raised again in the main thread, once the finalizer is over, instead."""
    if _ending["signal"] and isinstance(hook.exc_value, (KeyboardInterrupt, SystemExit)):
        _ending["hook"] = True
        try:
            signum = _ending["signal"]
            _ending.update(signal=0, at=0.0)
            _raise_later(signum)
        finally:
            _ending["hook"] = False
        return
    _default_unraisable(hook)


def interrupted() -> int:
    """The signal that is ending this run (``signal.SIGINT``, ``SIGTERM``, ``SIGHUP``), or 0."""
    return _ending["signal"]


def exit_on_terminate() -> None:
    """Make Ctrl-C raise ``KeyboardInterrupt`` and SIGTERM and SIGHUP ``SystemExit(128 + signal)``
    in the main thread, once per run (see :data:`CLEANUP_SECONDS`), never lost in a finalizer."""
    for name in ("SIGINT", "SIGTERM", "SIGHUP"):
        sig = getattr(signal, name, None)
        if sig is not None and signal.getsignal(sig) in (signal.SIG_DFL, None, signal.default_int_handler):
            signal.signal(sig, _end_run)
    sys.unraisablehook = _unraisable


def _watch_parent(parent: int) -> None:
    while True:
        if os.getppid() != parent:
            os._exit(1)
        time.sleep(1.0)


def die_with_parent() -> None:
    """Worker initializer: end this process when the process that started it dies.

    It imports nothing and starts no subprocess: a worker forked from a parent with threads
    could deadlock on a lock (the import lock) that another thread held at the fork.
    """
    parent = os.getppid()
    # A worker that inherited the parent's SIGTERM handler would raise inside the pool's
    # machinery; the parent cleans up, the worker just ends.
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    # Ctrl-C reaches the whole process group: the parent stops the pool, workers stay quiet.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    # Not prctl(PR_SET_PDEATHSIG): Linux sends that signal when the *thread* that forked the
    # worker ends, and a multiprocessing pool forks replacement workers (maxtasksperchild)
    # from its handler thread. Pool.terminate() ends that thread first; the kernel then killed
    # idle workers while they held the task queue's lock, and terminate() waited for that lock
    # for ever (a dataset run over the whole corpus hung at its very end).
    threading.Thread(target=_watch_parent, args=(parent,), daemon=True).start()


#: Size of the block :func:`keep_buffers_on_heap` allocates and frees: a 2048x2048 atlas page.
HEAP_BUFFER_BYTES = 16 << 20


def keep_buffers_on_heap() -> None:
    """Have the C allocator keep buffers up to :data:`HEAP_BUFFER_BYTES` on its heap from now on.

    glibc's ``malloc`` gives every block over its threshold (128 KiB at start) memory of its
    own, returned to the system when freed, and raises the threshold to the size of the largest
    such block freed. A process that decodes atlas pages frees 16 MB blocks, so its pickled
    tasks and crops (up to megabytes) reuse heap memory; one whose pages are decoded by its
    workers kept the low threshold, and each such buffer was new memory: in a library run of
    30 projects the parent's dispatcher thread took 500,000 more page faults, 1.2 s more CPU
    (``docs/benchmarks/speed.md``). Allocating and freeing one page-sized block, untouched,
    raises the threshold as decoding a page did. Elsewhere than glibc it costs nothing.
    """
    import numpy as np

    block = np.empty(HEAP_BUFFER_BYTES, np.uint8)  # numpy allocates it with malloc: never written
    del block
