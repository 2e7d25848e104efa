"""Progress bars for long work: tqdm when it is installed (the ``progress`` extra),
silence otherwise, and silence whenever ``verbose`` is 0."""

from __future__ import annotations

from collections.abc import Iterable, Iterator

__all__ = ["track"]


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
