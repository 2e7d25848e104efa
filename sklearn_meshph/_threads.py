"""BLAS thread limits that are safe to nest and to enter from several threads at once.

threadpoolctl's limits are process-global: a context that sets BLAS to one thread and
restores the previous count on exit would, entered by two threads of a threading
backend, restore the count while the other thread is still inside, and make its BLAS
calls threaded (results then differ in the last bits). Here the first thread to enter
sets the limit, the last to leave restores it, and the caller's own limits are left as
they were.
"""

from __future__ import annotations

import functools
import threading
from contextlib import contextmanager

from threadpoolctl import ThreadpoolController

__all__ = ["one_blas_thread"]

_lock = threading.Lock()
_holders = 0
_limiter = None


@functools.cache
def _controller() -> ThreadpoolController:
    # Made once per process: ``threadpool_limits`` looks up the loaded libraries at
    # every call, which costs more than many of the solves it would wrap.
    return ThreadpoolController()


@contextmanager
def one_blas_thread():
    """Limit BLAS to one thread for as long as any thread of the process is inside."""
    global _holders, _limiter
    with _lock:
        if _holders == 0:
            _limiter = _controller().limit(limits=1, user_api="blas")
        _holders += 1
    try:
        yield
    finally:
        with _lock:
            _holders -= 1
            if _holders == 0:
                _limiter.restore_original_limits()
                _limiter = None
