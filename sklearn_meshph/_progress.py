"""Progress for long work: joblib tasks returned as they finish, and tqdm bars when
tqdm is installed (the ``progress`` extra), silence otherwise and whenever ``verbose``
is 0."""

from __future__ import annotations

from collections.abc import Iterable, Iterator

from joblib import Parallel

__all__ = ["parallel", "track"]


def parallel(n_jobs, prefer=None) -> Parallel:
    """A joblib ``Parallel`` returning results in order as they finish, where the backend
    can (loky, threading, dask with joblib >= 1.4); others (multiprocessing) return
    them all at once. ``prefer="threads"`` is joblib's soft hint for work that releases
    the GIL (a ``parallel_backend`` context still decides)."""
    try:
        return Parallel(n_jobs=n_jobs, return_as="generator", prefer=prefer)
    except ValueError:  # "Backend ... does not support return_as=generator"
        return Parallel(n_jobs=n_jobs, prefer=prefer)


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
