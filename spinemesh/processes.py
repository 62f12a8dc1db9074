"""Process hygiene: interruptions that clean up, and workers that end with their parent.

- :func:`exit_on_terminate` turns SIGTERM (and SIGHUP) into ``SystemExit``, so the cleanup of
  :mod:`spinemesh.fsutil` (temporary files removed) runs as it does for Ctrl-C.
- :func:`die_with_parent` is the initializer of every worker process: a watchdog thread ends
  the worker within a second of its re-parenting. A killed run leaves no workers behind.
- :func:`keep_buffers_on_heap` keeps a process that hands large work to others from paying a
  page fault per 4 KiB of every buffer it makes.
"""

from __future__ import annotations

import os
import signal
import threading
import time

def _terminate(signum, frame):
    raise SystemExit(128 + signum)


def exit_on_terminate() -> None:
    """Make SIGTERM and SIGHUP raise ``SystemExit(128 + signal)`` in the main thread."""
    for name in ("SIGTERM", "SIGHUP"):
        sig = getattr(signal, name, None)
        if sig is not None and signal.getsignal(sig) in (signal.SIG_DFL, None):
            signal.signal(sig, _terminate)


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
