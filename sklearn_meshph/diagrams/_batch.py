"""Batched distances between packed samples: the compiled loop behind every matrix.

A sample is a tuple of diagrams compared position by position, as the typed disjoint
union of its diagrams: the bottleneck distance is the maximum of the per-diagram
distances, the q-Wasserstein distance the l_q norm of them, essential points (death
``inf``) matched among themselves by sorted birth.
"""

from __future__ import annotations

import numba
import numpy as np

from ._bottleneck import bottleneck_finite
from ._wasserstein import power, power_of_two_above, wasserstein_scaled

__all__ = ["pack", "pair_distances"]

BOTTLENECK, WASSERSTEIN = 0, 1


@numba.njit(cache=True, inline="always")
def _add_scaled(scale, total, s, t, order):
    """``(scale, total)`` standing for ``scale^q total``, plus ``s^q t``, rescaled to the
    larger scale so that nothing overflows."""
    if s == 0.0 or t == 0.0:
        return scale, total
    if s > scale:
        return s, total * power(scale / s, order) + t
    return scale, total + t * power(s / scale, order)


@numba.njit(cache=True)
def _sample_distance(pa, oa, ea, eoa, ia, pb, ob, eb, eob, ib, n_parts, metric, order, internal_p):
    """Distance between sample ``ia`` of one packed set and ``ib`` of another."""
    largest = 0.0
    scale, total = 0.0, 0.0
    for part in range(n_parts):
        da = ia * n_parts + part
        db = ib * n_parts + part
        a = pa[oa[da] : oa[da + 1]]
        b = pb[ob[db] : ob[db + 1]]
        essential_a = ea[eoa[da] : eoa[da + 1]]
        essential_b = eb[eob[db] : eob[db + 1]]
        if len(essential_a) != len(essential_b):
            return np.inf
        if metric == BOTTLENECK:
            largest = max(largest, bottleneck_finite(a, b))
            for k in range(len(essential_a)):
                largest = max(largest, abs(essential_a[k] - essential_b[k]))
        else:
            s, t = wasserstein_scaled(a, b, order, internal_p)
            scale, total = _add_scaled(scale, total, s, t, order)
            for k in range(len(essential_a)):
                gap = abs(essential_a[k] - essential_b[k])
                if gap > 0.0:
                    s = power_of_two_above(gap)
                    scale, total = _add_scaled(scale, total, s, power(gap / s, order), order)
    if metric == BOTTLENECK:
        return largest
    return scale * total ** (1.0 / order)


@numba.njit(cache=True)
def _pairs_kernel(left, right, rows, cols, n_parts, metric, order, internal_p):
    pa, oa, ea, eoa = left
    pb, ob, eb, eob = right
    out = np.empty(len(rows))
    for k in range(len(rows)):
        out[k] = _sample_distance(
            pa, oa, ea, eoa, rows[k], pb, ob, eb, eob, cols[k], n_parts, metric, order, internal_p
        )
    return out


def pack(samples) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Validated samples (tuples of diagrams) as four flat arrays for the kernels.

    Finite points of every diagram (sample-major, part-minor) with their offsets, and
    the sorted births of the essential points with theirs.
    """
    finite, essential = [], []
    for sample in samples:
        for diagram in sample:
            keep = np.isfinite(diagram[:, 1])
            finite.append(diagram[keep])
            essential.append(np.sort(diagram[~keep, 0]))
    offsets = np.concatenate([[0], np.cumsum([len(d) for d in finite])]).astype(np.int64)
    essential_offsets = np.concatenate([[0], np.cumsum([len(e) for e in essential])])
    points = np.ascontiguousarray(np.vstack(finite)) if finite else np.empty((0, 2))
    births = np.concatenate(essential) if essential else np.empty(0)
    return points, offsets, births.astype(np.float64), essential_offsets.astype(np.int64)


def pair_distances(left, right, rows, cols, n_parts, metric, order=2.0, internal_p=np.inf):
    """Distances of the sample pairs ``(rows[k], cols[k])`` of two packed sets.

    ``metric`` is a kernel code, ``BOTTLENECK`` or ``WASSERSTEIN``.
    """
    return _pairs_kernel(
        left,
        right,
        np.asarray(rows, dtype=np.int64),
        np.asarray(cols, dtype=np.int64),
        n_parts,
        metric,
        float(order),
        float(internal_p),
    )
