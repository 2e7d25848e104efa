"""BLAS thread limits that are safe to nest and to enter from several threads at once.

threadpoolctl's limits on OpenBLAS (pthreads) and BLIS are process-global: a context that
sets BLAS to one thread and restores the previous count on exit would, entered by two
threads of a threading backend, restore the count while the other thread is still
inside, and make its BLAS calls threaded (results then differ in the last bits). Here
the first thread to enter sets those limits, the last to leave restores them, and the
caller's own limits are left as they were.

Two more things make that work whichever thread enters first or leaves last:

- threadpoolctl >= 3.8 lets only one thread, the first to set an OpenBLAS limit (the
  "controlling thread"), change the process-wide pool, and silently ignores the others
  (a limit not used as a context manager keeps control for as long as its thread
  lives). Our lock already orders the changes, so each change is made with that control
  released.
- The same versions limit MKL and OpenMP-threaded OpenBLAS for the calling thread only:
  every thread then sets and restores its own limit on those libraries.

A forked child keeps only the forking thread: it keeps that thread's entries, and gets
back the limits the other threads had set if none remain.
"""

from __future__ import annotations

import functools
import os
import threading
from contextlib import contextmanager

from threadpoolctl import OpenBLASController, ThreadpoolController

__all__ = ["one_blas_thread"]

# Only in threadpoolctl >= 3.8, the versions with a controlling thread and per-thread
# limits on MKL and OpenMP-threaded OpenBLAS.
_clear_controlling_thread = getattr(OpenBLASController, "clear_controlling_thread", None)

_lock = threading.Lock()
_holders = 0  # entries not yet left, all threads together
_shared = None  # the limiter of the process-wide libraries, while _holders > 0
_local = threading.local()  # depth: the entries of this thread not yet left


def _per_thread(lib) -> bool:
    """Whether threadpoolctl limits the library for the calling thread only."""
    if _clear_controlling_thread is None:
        return False
    if lib.internal_api == "mkl":
        return True
    return lib.internal_api == "openblas" and getattr(lib, "threading_layer", None) == "openmp"


@functools.cache
def _controllers():
    """The BLAS libraries whose limit is process-wide, and those limited per thread
    (each None if there is none).

    Made once per process: ``threadpool_limits`` looks up the loaded libraries at every
    call, which costs more than many of the solves it would wrap.
    """
    blas = ThreadpoolController().select(user_api="blas")
    paths = ([], [])
    for lib in blas.lib_controllers:
        paths[_per_thread(lib)].append(lib.filepath)
    return tuple(blas.select(filepath=p) if p else None for p in paths)


def _as_controlling_thread(change):
    """Make a change of the process-wide limits, with threadpoolctl's control released
    before (so that the change is not ignored) and after (so that no thread keeps it)."""
    if _clear_controlling_thread is None:
        return change()
    _clear_controlling_thread(force=True)
    try:
        return change()
    finally:
        _clear_controlling_thread(force=True)


@contextmanager
def one_blas_thread():
    """Limit BLAS to one thread for as long as any thread of the process is inside."""
    global _holders, _shared
    with _lock:
        shared, per_thread = _controllers()
        if _holders == 0 and shared is not None:
            _shared = _as_controlling_thread(lambda: shared.limit(limits=1, user_api="blas"))
        _holders += 1
    depth = getattr(_local, "depth", 0)
    _local.depth = depth + 1
    own = None
    try:
        if depth == 0 and per_thread is not None:
            own = per_thread.limit(limits=1, user_api="blas")
        yield
    finally:
        try:
            if own is not None:
                own.restore_original_limits()
        finally:
            _local.depth = depth
            with _lock:
                _holders -= 1
                if _holders == 0 and _shared is not None:
                    limiter, _shared = _shared, None
                    _as_controlling_thread(limiter.restore_original_limits)


def _after_fork_in_child():
    global _lock, _holders, _shared
    _lock = threading.Lock()
    _holders = getattr(_local, "depth", 0)  # the forking thread's entries live on
    if _holders == 0 and _shared is not None:
        limiter, _shared = _shared, None
        _as_controlling_thread(limiter.restore_original_limits)


if hasattr(os, "register_at_fork"):
    # Holding the lock across the fork: no limit change is half done in the child.
    os.register_at_fork(
        before=lambda: _lock.acquire(),
        after_in_parent=lambda: _lock.release(),
        after_in_child=_after_fork_in_child,
    )
