"""Validation of persistence diagrams and of samples made of several diagrams."""

from __future__ import annotations

import numpy as np

from .._base import as_sample_list

__all__ = ["check_diagram", "check_sample", "check_samples"]


def check_diagram(diagram, *, index: int | None = None, part: int | None = None) -> np.ndarray:
    """Validate one diagram and return it as a float64 array of shape (n, 2).

    Rows are (birth, death) with a finite birth and ``death >= birth``; death may be
    ``+inf`` (an essential class). An empty diagram (no rows) is valid.

    Raises
    ------
    ValueError
        Naming the sample (and the diagram within it) and the problem: wrong shape,
        non-numeric, NaN, infinite birth, death below birth.
    """
    where = "diagram" if index is None else f"sample {index}"
    if part is not None:
        where += f", diagram {part}"
    try:
        array = np.asarray(diagram, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{where}: not a numeric (n, 2) array: {exc}") from exc
    if array.size == 0:
        return np.empty((0, 2))
    if array.ndim != 2 or array.shape[1] != 2:
        raise ValueError(f"{where}: a diagram must have shape (n, 2), got {array.shape}")
    if np.isnan(array).any():
        row = int(np.flatnonzero(np.isnan(array).any(axis=1))[0])
        raise ValueError(f"{where}: row {row} contains NaN")
    if not np.isfinite(array[:, 0]).all():
        row = int(np.flatnonzero(~np.isfinite(array[:, 0]))[0])
        raise ValueError(f"{where}: row {row} has an infinite birth")
    if (array[:, 1] < array[:, 0]).any():
        row = int(np.flatnonzero(array[:, 1] < array[:, 0])[0])
        raise ValueError(
            f"{where}: row {row} has death {array[row, 1]} below birth {array[row, 0]}"
        )
    return array


def check_sample(sample, index: int | None = None) -> tuple[np.ndarray, ...]:
    """A sample as a tuple of validated diagrams.

    A tuple is several diagrams; anything else (an array, a list of rows) is one.
    """
    if isinstance(sample, tuple):
        return tuple(check_diagram(d, index=index, part=k) for k, d in enumerate(sample))
    return (check_diagram(sample, index=index),)


def check_samples(samples, n_diagrams: int | None = None) -> list[tuple[np.ndarray, ...]]:
    """Validated samples, all with the same number of diagrams (``n_diagrams`` if given).

    Raises
    ------
    ValueError
        If a diagram is malformed (naming the sample), if the samples hold different
        numbers of diagrams, or if they do not hold ``n_diagrams``.
    """
    checked = [check_sample(s, i) for i, s in enumerate(as_sample_list(samples, "diagrams"))]
    counts = sorted({len(s) for s in checked})
    if len(counts) > 1:
        raise ValueError(f"samples have different numbers of diagrams: {counts}")
    if n_diagrams is not None and counts[0] != n_diagrams:
        raise ValueError(f"X has {counts[0]} diagrams per sample, the fitted data {n_diagrams}")
    return checked
