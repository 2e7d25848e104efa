"""Repeated eigenvalues: how far a solve grows to see a requested eigenvalue's whole
multiplicity, and the warning that its eigenfunction is not unique."""

from __future__ import annotations

import warnings

import numpy as np

__all__ = ["RepeatedEigenvalueWarning", "solve_covering", "warn_if_repeated"]

# Eigenvalues closer than this (relative) count as one repeated eigenvalue.
_REPEATED_RTOL = 1e-3
# Eigenvalues below this share of the largest computed one are zeros: one per connected
# component of a graph kept whole (components="all").
_ZERO_RTOL = 1e-9
# A repeated eigenvalue that reaches the end of a solve makes it grow by at most this
# many blocks of eigenpairs, so that the warning can state the whole multiplicity:
# beyond it (a "book" of many triangles on one edge) the warning says "at least".
_MAX_GROWTH_BLOCKS = 4


class RepeatedEigenvalueWarning(UserWarning):
    """The requested eigenvalue is (nearly) repeated: its eigenfunction is not unique."""


def _repeats(values: np.ndarray, i: int) -> np.ndarray:
    """Indices of the eigenvalues that coincide with ``values[i]``: within a relative
    ``_REPEATED_RTOL``, or both zero (below ``_ZERO_RTOL`` times the largest)."""
    tolerance = max(_REPEATED_RTOL * abs(values[i]), _ZERO_RTOL * np.abs(values).max())
    return np.flatnonzero(np.abs(values - values[i]) <= tolerance)


def _reaches_end(values: np.ndarray, indices) -> bool:
    """Whether a requested repeated eigenvalue may go on past the last computed one."""
    last = len(values) - 1
    return any(0 < i <= last and _repeats(values, i)[-1] == last for i in indices)


def solve_covering(solve, n_eigenpairs: int, indices, block: int):
    """``solve(n)`` (returning ``(clean, values, vectors)``) for ``n_eigenpairs``, grown
    by ``block`` eigenpairs at a time while a repeated eigenvalue of ``indices`` reaches
    the last one computed, up to a limit. Returns the last result and whether it holds
    every eigenpair of the cleaned sample."""
    limit = n_eigenpairs + _MAX_GROWTH_BLOCKS * block
    while True:
        clean, values, vectors = solve(n_eigenpairs)
        n = len(clean.vertices)
        if n_eigenpairs >= min(n, limit) or not _reaches_end(values, indices):
            return (clean, values, vectors), len(values) == n
        n_eigenpairs = min(n_eigenpairs + block, limit)


def warn_if_repeated(values: np.ndarray, indices, sample: int, complete: bool) -> None:
    """Warn for each requested non-constant eigenvalue that is repeated, with its
    multiplicity ("at least" when it may go on past the last computed eigenvalue)."""
    for i in indices:
        if i == 0:
            continue
        close = _repeats(values, i)
        if len(close) < 2:
            continue
        open_ended = not complete and close[-1] == len(values) - 1
        lam = values[i]
        at_least = "at least " if open_ended else ""
        if close[0] == 0:  # zero, as the constant's: one per connected component
            warnings.warn(
                f"sample {sample}: eigenvalue {i} is 0, as are eigenvalues {close[0]}-"
                f"{close[-1]}: the sample has {at_least}{len(close)} connected components "
                "(components='all'), and its eigenfunction is an arbitrary combination of "
                "their indicator functions",
                RepeatedEigenvalueWarning,
                stacklevel=5,
            )
            continue
        others = np.delete(values, close)
        with np.errstate(divide="ignore", invalid="ignore"):  # lam = 0: a broken operator
            gap = np.min(np.abs(others - lam)) / abs(lam) if len(others) else np.inf
            spread = (values[close].max() - values[close].min()) / abs(lam)
        warnings.warn(
            f"sample {sample}: eigenvalue {i} ({lam:.6g}) is repeated with multiplicity "
            f"{at_least}{len(close)} (eigenvalues {close[0]}-"
            f"{close[-1]} agree within a relative {spread:.1e}; relative gap to the next "
            f"distinct one {gap:.2g}); its eigenfunction is not unique",
            RepeatedEigenvalueWarning,
            stacklevel=5,
        )
