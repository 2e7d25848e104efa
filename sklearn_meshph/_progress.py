"""Parallel work and its progress: joblib tasks returned as they finish, the one
scheduler of per-sample work (:func:`map_samples`, its blocks from
:func:`sample_blocks`), what every task of a call reads sent once to each worker of a
dask cluster (:func:`broadcast`), and tqdm bars when tqdm is installed (the
``progress`` extra), silence otherwise and whenever ``verbose`` is 0."""

from __future__ import annotations

from collections.abc import Iterable, Iterator

import numpy as np
from joblib import Parallel, delayed, effective_n_jobs
from joblib.parallel import get_active_backend

__all__ = ["broadcast", "map_samples", "parallel", "sample_blocks", "track"]

# Samples per block at most: bounds the memory of the results in flight.
_BLOCK = 2048


def parallel(n_jobs, prefer=None, batch_size="auto", pre_dispatch="2 * n_jobs") -> Parallel:
    """A joblib ``Parallel`` returning results in order as they finish, where the backend
    can (loky, threading, dask with joblib >= 1.4); others (multiprocessing) return
    them all at once. ``prefer="threads"`` is joblib's soft hint for work that releases
    the GIL (a ``parallel_backend`` context still decides); ``batch_size=1`` sends each
    task alone, for tasks already cut to a few per worker (joblib's automatic batching,
    learned on the fast tasks of earlier calls, would put several on one worker);
    ``pre_dispatch="all"`` hands every task to the backend at once (for tasks that carry
    only references, such as futures of a dask cluster)."""
    options = dict(n_jobs=n_jobs, prefer=prefer, batch_size=batch_size, pre_dispatch=pre_dispatch)
    try:
        return Parallel(return_as="generator", **options)
    except ValueError:  # "Backend ... does not support return_as=generator"
        return Parallel(**options)


def broadcast(values: list) -> list:
    """``values`` as the tasks of the next parallel call should receive them: under
    joblib's dask backend, futures of copies scattered to every worker of the cluster
    at once (so that any task runs on any worker without waiting for a transfer, and
    nothing travels with the tasks); under any other backend, the values themselves."""
    backend, _ = get_active_backend()
    client = getattr(backend, "client", None)
    if not values or client is None or type(backend).__name__ != "DaskDistributedBackend":
        return list(values)
    return client.scatter(list(values), broadcast=True, hash=False)


def track(items: Iterable, *, total: int, desc: str, verbose: int) -> Iterator:
    """``items``, with a progress bar of ``total`` steps labelled ``desc`` on stderr when
    ``verbose > 0`` and tqdm is importable."""
    if not verbose:
        return iter(items)
    try:
        from tqdm.auto import tqdm
    except ImportError:
        return iter(items)
    return iter(tqdm(items, total=total, desc=desc, unit="sample", leave=False))


def sample_blocks(n: int, n_jobs) -> list[tuple[int, int]]:
    """Consecutive ``(start, stop)`` blocks of ``n`` samples: a few per worker, each of
    at most ``_BLOCK`` samples."""
    n_blocks = max(-(-n // _BLOCK), min(n, 4 * effective_n_jobs(n_jobs)))
    bounds = np.linspace(0, n, n_blocks + 1).astype(int)
    return [(a, b) for a, b in zip(bounds[:-1], bounds[1:], strict=True) if b > a]


def map_samples(
    function, items, *, n_jobs=None, prefer=None, desc: str = "", verbose: int = 0
) -> list:
    """``[function(item) for item in items]``, in order, over joblib when there is more
    than one item and more than one worker, with a progress bar behind ``verbose``.

    The one scheduler of per-sample work: ``items`` are samples, or blocks of them
    (:func:`sample_blocks`). ``prefer="threads"`` suits functions that release the GIL.
    """
    items = list(items)
    if len(items) <= 1 or effective_n_jobs(n_jobs) == 1:
        results = map(function, items)
    else:
        results = parallel(n_jobs, prefer=prefer)(delayed(function)(item) for item in items)
    return list(track(results, total=len(items), desc=desc, verbose=verbose))
