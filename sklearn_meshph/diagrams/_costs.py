"""Scaled costs of matching two finite diagrams, and the pairs worth matching.

A pair's cost is ``(ground / s)^q`` for a scale ``s`` of the pair (see
:mod:`._wasserstein` for how it is chosen), capped; a point's cost to the diagonal is
that of its ground distance to its projection. Every solver reads its problem in the
same row form: each point of ``a`` a row, its pairs with the points of ``b`` as
reduced costs ``c - db``, then its private diagonal column.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from ._assignment import reserve
from ._kdtree import ground


@numba.njit(cache=True, inline="always")
def power_of_two_above(x):
    """The smallest power of two at least ``x > 0``: scaling by it is exact, so orders 1
    and 2 give the same bits as an unscaled computation that neither overflows nor
    underflows."""
    mantissa, exponent = math.frexp(x)
    return math.ldexp(1.0, exponent - 1) if mantissa == 0.5 else math.ldexp(1.0, exponent)


@numba.njit(cache=True, inline="always")
def power(g, order):
    """``g ** order``, with the common orders 1 and 2 without a call to ``pow``."""
    if order == 1.0:
        return g
    if order == 2.0:
        return g * g
    return g**order


@numba.njit(cache=True, inline="always")
def cost(g, order, inv_scale, cap):
    """``(ground / scale)^order``, capped: a capped cost is never part of an optimum."""
    return min(power(g * inv_scale, order), cap)


@numba.njit(cache=True, inline="always")
def pair_cost(a, i, b, j, order, internal_p, inv_scale, cap):
    """Scaled cost of matching point ``i`` of ``a`` with point ``j`` of ``b``."""
    g = ground(abs(a[i, 0] - b[j, 0]), abs(a[i, 1] - b[j, 1]), internal_p)
    return cost(g, order, inv_scale, cap)


@numba.njit(cache=True, inline="always")
def keep_pair(cols, costs, k, j, c, da_i, db_j, cap):
    """Write pair ``j`` of scaled cost ``c`` at ``k`` of the row being filled when it
    costs less than sending both points to the diagonal (and than the cap); returns the
    row's new end. Any matching that uses a pair left out costs no less after sending
    both of its points to the diagonal instead."""
    if c < min(da_i + db_j, cap):
        cols[k] = j
        costs[k] = c - db_j
        return k + 1
    return k


@numba.njit(cache=True, inline="always")
def diagonal_factor(internal_p):
    """Ground distance of ``(b, d)`` to the diagonal, per unit of ``(d - b) / 2``."""
    return 1.0 if internal_p == np.inf else 2.0 ** (1.0 / internal_p)


@numba.njit(cache=True)
def to_diagonal(d, order, internal_p, inv_scale, cap):
    """Scaled cost of moving each point of ``d`` to its projection on the diagonal."""
    factor = diagonal_factor(internal_p)
    out = np.empty(len(d))
    for i in range(len(d)):
        out[i] = cost((d[i, 1] - d[i, 0]) / 2.0 * factor, order, inv_scale, cap)
    return out


@numba.njit(cache=True)
def candidate_edges(a, b, da, db, order, internal_p, inv_scale, cap):
    """Pairs (i, j) worth matching: cost below sending both to the diagonal.

    Any matching that uses another pair costs no less after sending both of its points
    to the diagonal instead, so an optimal matching among these pairs is optimal. Points
    of ``b`` are scanned through a band of births around each point of ``a``.
    Returns CSR arrays (row pointers, columns, reduced costs ``c - db``): each row's pairs
    by increasing cost, then its private diagonal column ``m + i``.
    """
    n, m = len(a), len(b)
    by_birth = np.argsort(b[:, 0], kind="mergesort")
    births = b[by_birth, 0]
    widest = 0.0
    for j in range(m):
        widest = max(widest, b[j, 1] - b[j, 0])
    scale = diagonal_factor(internal_p)
    ptr = np.zeros(n + 1, np.int64)
    capacity = 4 * (n + m) + 16
    cols = np.empty(capacity, np.int64)
    costs = np.empty(capacity)
    k = 0
    for i in range(n):
        # ground >= |birth difference| and each diagonal cost <= (scale * half)^order.
        reach = scale * ((a[i, 1] - a[i, 0]) / 2.0 + widest / 2.0)
        lo = np.searchsorted(births, a[i, 0] - reach, side="left")
        hi = np.searchsorted(births, a[i, 0] + reach, side="right")
        cols, costs = reserve(cols, costs, k, k + (hi - lo) + 1)
        first = k
        for s in range(lo, hi):
            j = by_birth[s]
            c = pair_cost(a, i, b, j, order, internal_p, inv_scale, cap)
            k = keep_pair(cols, costs, k, j, c, da[i], db[j], cap)
        ascending = first + np.argsort(costs[first:k], kind="mergesort")
        cols[first:k] = cols[ascending]
        costs[first:k] = costs[ascending]
        cols[k] = m + i
        costs[k] = da[i]
        k += 1
        ptr[i + 1] = k
    return ptr, cols[:k], costs[:k]
