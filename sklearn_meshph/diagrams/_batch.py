"""Batched distances between packed samples: the compiled loop behind every matrix.

A sample is a tuple of diagrams compared position by position, as the typed disjoint
union of its diagrams: the bottleneck distance is the maximum of the per-diagram
distances, the q-Wasserstein distance the l_q norm of them, the sliced Wasserstein
distance their sum; essential points (death ``inf``) are matched among themselves by
sorted birth.
"""

from __future__ import annotations

import numba
import numpy as np

from ._bottleneck import SMALL_PAIRS, bottleneck_finite, bottleneck_small
from ._costs import power, power_of_two_above
from ._sliced import directions, project, sliced_pairs
from ._wasserstein import wasserstein_scaled
from .validation import Packed

__all__ = ["pack", "pack_one", "pack_sliced", "pair_distances", "split_diagram"]

BOTTLENECK, WASSERSTEIN, SLICED = 0, 1, 2


@numba.njit(cache=True, inline="always")
def _add_scaled(scale, total, s, t, order):
    """``(scale, total)`` standing for ``scale^q total``, plus ``s^q t``, rescaled to the
    larger scale so that nothing overflows."""
    if s == 0.0 or t == 0.0:
        return scale, total
    if s > scale:
        return s, total * power(scale / s, order) + t
    return scale, total + t * power(s / scale, order)


@numba.njit(cache=True, inline="always")
def _part(packed, sample, n_parts, part):
    """Finite points and sorted essential births of one diagram of a packed sample."""
    points, offsets, births, birth_offsets = packed
    d = sample * n_parts + part
    return points[offsets[d] : offsets[d + 1]], births[birth_offsets[d] : birth_offsets[d + 1]]


@numba.njit(cache=True)
def _bottleneck_sample(left, ia, right, ib, n_parts, limit):
    """Bottleneck distance of two packed samples: the largest over their parts.

    With an int ``limit``, NaN when a part has more point pairs than that (the caller
    then asks again with ``limit=None``). ``limit is None`` is decided when numba
    compiles, so the threshold search is compiled only if such a pair ever comes."""
    largest = 0.0
    for part in range(n_parts):
        a, essential_a = _part(left, ia, n_parts, part)
        b, essential_b = _part(right, ib, n_parts, part)
        if len(essential_a) != len(essential_b):
            return np.inf
        if limit is None:
            largest = max(largest, bottleneck_finite(a, b))
        elif len(a) * len(b) <= limit:
            largest = max(largest, bottleneck_small(a, b))
        else:
            return np.nan
        for k in range(len(essential_a)):
            largest = max(largest, abs(essential_a[k] - essential_b[k]))
    return largest


@numba.njit(cache=True)
def _bottleneck_pairs(left, right, rows, cols, n_parts, limit):
    out = np.empty(len(rows))
    for k in range(len(rows)):
        out[k] = _bottleneck_sample(left, rows[k], right, cols[k], n_parts, limit)
    return out


@numba.njit(cache=True)
def _wasserstein_pairs(left, right, rows, cols, n_parts, order, internal_p):
    """q-Wasserstein distances of sample pairs: the l_q norm over their parts, in the
    scaled form ``scale * total^(1/q)``."""
    out = np.empty(len(rows))
    for k in range(len(rows)):
        scale, total = 0.0, 0.0
        for part in range(n_parts):
            a, essential_a = _part(left, rows[k], n_parts, part)
            b, essential_b = _part(right, cols[k], n_parts, part)
            if len(essential_a) != len(essential_b):
                scale, total = np.inf, 1.0
                break
            s, t = wasserstein_scaled(a, b, order, internal_p)
            scale, total = _add_scaled(scale, total, s, t, order)
            for e in range(len(essential_a)):
                gap = abs(essential_a[e] - essential_b[e])
                if gap > 0.0:
                    s = power_of_two_above(gap)
                    scale, total = _add_scaled(scale, total, s, power(gap / s, order), order)
        out[k] = scale * total ** (1.0 / order)
    return out


def split_diagram(diagram: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The finite points of a validated diagram, and the sorted births of its essential
    points (matched among themselves by sorted birth)."""
    keep = np.isfinite(diagram[:, 1])
    return diagram[keep], np.sort(diagram[~keep, 0])


def pack_one(diagram: np.ndarray):
    """``pack([(diagram,)])`` without the lists, for the distance of a single pair."""
    points, births = split_diagram(diagram)
    return (
        np.ascontiguousarray(points),
        np.array([0, len(points)]),
        births,
        np.array([0, len(births)]),
    )


def pack(packed: Packed) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Packed samples (:class:`Packed`) as the compiled loops read them: four flat arrays.

    The finite points of every diagram (sample-major, part-minor) with their offsets,
    and the sorted births of the essential points with theirs.
    """
    points, offsets = packed.points, packed.offsets
    finite = np.isfinite(points[:, 1])
    if finite.all():
        return points, offsets, np.empty(0), np.zeros_like(offsets)
    n = len(offsets) - 1
    diagram = packed.diagram_of_rows()
    finite_offsets = np.zeros_like(offsets)
    np.cumsum(np.bincount(diagram[finite], minlength=n), out=finite_offsets[1:])
    births, owners = points[~finite, 0], diagram[~finite]
    birth_offsets = np.zeros_like(offsets)
    np.cumsum(np.bincount(owners, minlength=n), out=birth_offsets[1:])
    births = births[np.lexsort((births, owners))]
    return np.ascontiguousarray(points[finite]), finite_offsets, births, birth_offsets


def pack_sliced(packed, n_directions: int):
    """A :func:`pack` (or :func:`pack_one`) result as the sliced Wasserstein kernel reads
    it: each diagram's sorted projections on the ``n_directions`` lines and sorted
    diagonal projections (replacing the points) with their offsets, essential births and
    theirs."""
    points, offsets, births, birth_offsets = packed
    cos, sin = directions(n_directions)
    projected, diagonal, slots = project(points, offsets, cos, sin)
    return projected, diagonal, slots, births, birth_offsets


def pair_distances(left, right, rows, cols, n_parts, metric, order=2.0, internal_p=np.inf):
    """Distances of the sample pairs ``(rows[k], cols[k])`` of two packed sets.

    ``metric`` is a kernel code, ``BOTTLENECK``, ``WASSERSTEIN`` or ``SLICED`` (whose sets
    are packed by :func:`pack_sliced`). Each metric has its own compiled loop, and the
    bottleneck threshold search is only called (and compiled) for pairs of diagrams too
    large for the minimax algorithm: a first run compiles only what it uses.
    """
    rows = np.asarray(rows, dtype=np.int64)
    cols = np.asarray(cols, dtype=np.int64)
    if metric == SLICED:
        return sliced_pairs(left, right, rows, cols, n_parts)
    if metric == WASSERSTEIN:
        return _wasserstein_pairs(left, right, rows, cols, n_parts, float(order), float(internal_p))
    out = _bottleneck_pairs(left, right, rows, cols, n_parts, SMALL_PAIRS)
    large = np.flatnonzero(np.isnan(out))
    if len(large):
        out[large] = _bottleneck_pairs(left, right, rows[large], cols[large], n_parts, None)
    return out
