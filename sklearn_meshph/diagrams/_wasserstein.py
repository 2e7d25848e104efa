"""Compiled exact q-Wasserstein distance between two finite diagrams: an optimal
assignment with a private diagonal column per point.

Costs are computed in a scaled form, ``(ground / s)^q`` for a scale ``s`` of the pair,
so that no order that float64 can carry underflows or overflows. Orders other than 1
and 2 use the bottleneck distance for ``s``, a lower bound of every q-Wasserstein
distance: the optimum is then at least 1, and never lost in the rounding of the dual
potentials. Orders 1 and 2 use the power of two just above the largest cost of a point
to the diagonal (every cost worth considering is then at most 2, and scaling by a power
of two is exact, so they give the bits of an unscaled computation), and fall back to the
bottleneck scale when the optimum comes out so small that it may have underflowed
(below ``_TINY``).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from ._assignment import DIAGONAL, collapse, precedes
from ._assignment_solver import solve
from ._bottleneck import bottleneck_finite
from ._costs import candidate_edges, diagonal_factor, pair_cost, power_of_two_above, to_diagonal
from ._min_cost_flow import partners_from_flows, transport_distinct
from ._pricing import sparse_solve

# A scaled optimum below this is solved again at the scale of the bottleneck distance.
_TINY = 1e-250
# A scale below this (a subnormal persistence or bottleneck distance) is avoided by
# solving the diagrams magnified by at most ``2^_MAGNIFY`` (exact: see ``transport``).
_SMALLEST_SCALE = 2.0**-1000
_MAGNIFY = 1000
_SMALLEST_NORMAL = 2.0**-1022
# Above this many point pairs, each point starts with its nearest neighbours only and
# the edges the optimum needs are added by pricing (benchmarks/bench_distances.py).
DENSE_PAIRS = 90_000


@numba.njit(cache=True)
def _optimal_transport(a, b, order, internal_p, inv_scale, cap):
    """Optimal matching of two finite diagrams for the cost ``sum (ground / s)^order``.

    Every point goes to a point of the other diagram or to the diagonal; the diagonal to
    itself is free. Writing the cost of a matching as ``sum_j db[j]`` plus, for each
    point i of ``a``, either ``c[i, j] - db[j]`` (matched to point j of ``b``) or
    ``da[i]`` (sent to the diagonal) turns the (n + m)-square assignment problem of the
    usual construction into an n x (m + n) one in which each row has a private diagonal
    column, and pairs that cost more than sending both points to the diagonal are
    dropped (``candidate_edges``). It is solved exactly: Jonker-Volgenant row reduction
    for a start, then one shortest augmenting path per remaining row (Dijkstra with dual
    potentials and a binary heap). Rows go in order of increasing persistence, which
    keeps the augmenting paths short.

    ``inv_scale`` is ``1 / s``; costs above ``cap`` are replaced by ``cap``, which must
    exceed the optimum. Returns the optimal total cost and, for each point of ``a``, its
    partner in ``b`` or ``DIAGONAL``.
    """
    if len(a) * len(b) > DENSE_PAIRS:
        distinct_a, of_a, count_a = collapse(a)
        distinct_b, of_b, count_b = collapse(b)
        few = len(distinct_a) * len(distinct_b) <= DENSE_PAIRS
        if few and 2 * (len(distinct_a) + len(distinct_b)) <= len(a) + len(b):
            total, flows = transport_distinct(
                distinct_a, count_a, distinct_b, count_b, order, internal_p, inv_scale, cap
            )
            return total, partners_from_flows(flows, of_a, of_b, len(distinct_b))
    rows = np.argsort(a[:, 1] - a[:, 0], kind="mergesort")
    total, partner = _transport_rows(a[rows], b, order, internal_p, inv_scale, cap)
    out = np.empty_like(partner)
    out[rows] = partner
    return total, out


@numba.njit(cache=True)
def _transport_rows(a, b, order, internal_p, inv_scale, cap):
    n, m = len(a), len(b)
    da = to_diagonal(a, order, internal_p, inv_scale, cap)
    db = to_diagonal(b, order, internal_p, inv_scale, cap)
    if n * m <= DENSE_PAIRS:
        ptr, cols, costs = candidate_edges(a, b, da, db, order, internal_p, inv_scale, cap)
        col4row = solve(ptr, cols, costs, n, m + n)[2]
    else:
        col4row = sparse_solve(a, b, da, db, order, internal_p, inv_scale, cap)
    used = np.zeros(m, np.bool_)
    for i in range(n):
        if col4row[i] < m:
            used[col4row[i]] = True
    total = 0.0
    for j in range(m):
        if not used[j]:
            total += db[j]
    for i in range(n):
        j = col4row[i]
        if j >= m:
            total += da[i]
            col4row[i] = DIAGONAL
        else:
            total += pair_cost(a, i, b, j, order, internal_p, inv_scale, cap)
    return total, col4row


@numba.njit(cache=True)
def _lexicographic(d):
    """Rows of ``d`` sorted by birth, then death."""
    by_death = np.argsort(d[:, 1], kind="mergesort")
    return d[by_death[np.argsort(d[by_death, 0], kind="mergesort")]]


@numba.njit(cache=True)
def _same_points(a, b):
    """Whether two diagrams hold the same points (as multisets)."""
    if len(a) != len(b):
        return False
    sa, sb = _lexicographic(a), _lexicographic(b)
    for i in range(len(a)):
        if sa[i, 0] != sb[i, 0] or sa[i, 1] != sb[i, 1]:
            return False
    return True


@numba.njit(cache=True)
def _off_diagonal(d):
    """Indices of the points of ``d`` off the diagonal."""
    keep = np.empty(len(d), np.int64)
    n = 0
    for i in range(len(d)):
        if d[i, 1] != d[i, 0]:
            keep[n] = i
            n += 1
    return keep[:n]


@numba.njit(cache=True)
def _largest_to_diagonal(a, b, internal_p):
    """The largest ground distance of a point of ``a`` or ``b`` to the diagonal, and the
    largest persistence (which the halving cannot round to 0)."""
    factor = diagonal_factor(internal_p)
    largest = span = 0.0
    for d in (a, b):
        for i in range(len(d)):
            span = max(span, d[i, 1] - d[i, 0])
            largest = max(largest, (d[i, 1] - d[i, 0]) / 2.0 * factor)
    return largest, span


@numba.njit(cache=True)
def _largest_magnitude(d, keep):
    out = 0.0
    for i in keep:
        out = max(out, abs(d[i, 0]), abs(d[i, 1]))
    return out


@numba.njit(cache=True)
def transport(a, b, order, internal_p):
    """Optimal matching of two finite diagrams, in scaled form.

    Returns ``(s, total, partner)``: the distance is ``s * total^(1/order)`` and
    ``partner`` gives each point of ``a`` its partner in ``b`` or ``DIAGONAL``.

    A scale below ``_SMALLEST_SCALE`` (a subnormal persistence or bottleneck distance,
    where ``1 / s`` overflows) is avoided by solving the diagrams magnified by a power of
    two, ``2^k``, which is exact: points on the diagonal are left out first (sending them
    to the diagonal costs nothing, and no matching gains by using them: in every ``l_p``
    ground metric a point is at least as far from a diagonal point as from its own
    projection), and ``k`` is at most ``_MAGNIFY`` and keeps every coordinate below
    ``2^1020``. Where that is not enough (coordinates near 1e300 with a subnormal
    distance), the scale is held at the smallest normal float, finite.
    """
    scale, total, partner, small = _transport_scaled(a, b, order, internal_p, False)
    if not small:
        return scale, total, partner
    keep_a, keep_b = _off_diagonal(a), _off_diagonal(b)
    largest = max(_largest_magnitude(a, keep_a), _largest_magnitude(b, keep_b))
    k = min(_MAGNIFY, 1020 - math.frexp(largest)[1])
    if k <= 0:
        return _transport_scaled(a, b, order, internal_p, True)[:3]
    up = 2.0**k
    scale, total, kept_partner, _ = _transport_scaled(
        a[keep_a] * up, b[keep_b] * up, order, internal_p, True
    )
    partner = np.full(len(a), DIAGONAL, np.int64)
    for i in range(len(keep_a)):
        if kept_partner[i] != DIAGONAL:
            partner[keep_a[i]] = keep_b[kept_partner[i]]
    # One rounding into the subnormals: the distance itself, not its scale, is divided.
    distance = scale * total ** (1.0 / order)
    return (distance * 2.0**-k, 1.0, partner) if distance > 0.0 else (0.0, 0.0, partner)


@numba.njit(cache=True)
def _transport_scaled(a, b, order, internal_p, hold):
    """:func:`transport` at a scale whose inverse is finite: ``(s, total, partner,
    small)``, with ``small`` True (and nothing solved) when the scale would fall below
    ``_SMALLEST_SCALE``, unless ``hold``: then the scale is held at ``2^-1022``."""
    no_partner = np.full(len(a), DIAGONAL, np.int64)
    largest, span = _largest_to_diagonal(a, b, internal_p)
    if span == 0.0:  # every point on the diagonal
        return 0.0, 0.0, no_partner, False
    if not np.isfinite(largest):  # the checks refuse such values; never solve with them
        raise ValueError("a diagram's persistence overflows float64")
    if span < _SMALLEST_SCALE and not hold:
        return 0.0, 0.0, no_partner, True
    scale = power_of_two_above(max(largest, _SMALLEST_NORMAL))
    if order == 1.0 or order == 2.0:
        # Orders 1 and 2 keep the bits of the unscaled computation (scaling by a power
        # of two is exact) unless the optimum underflows.
        total, partner = _optimal_transport(a, b, order, internal_p, 1.0 / scale, np.inf)
        if total >= _TINY:
            return scale, total, partner, False
    # Other orders are always solved at the scale of the bottleneck distance: at the
    # scale of the largest persistence their optimum can be far below the costs that
    # the dual potentials carry (a distance far below the largest persistence, from
    # order ~10 on), lost in rounding, and a matching that is not optimal comes out.
    # The optimum is at least (bottleneck / s)^order; at s = the L-infinity bottleneck
    # distance it is at least 1 and at most n + m (internal_p = inf) or that times
    # 2^(order / internal_p), which callers keep within float64.
    bottleneck = bottleneck_finite(a, b)
    if bottleneck == 0.0:  # a matching of cost 0, found at any order
        partner = _optimal_transport(a, b, 1.0, internal_p, 1.0 / scale, np.inf)[1]
        return 0.0, 0.0, partner, False
    if bottleneck < _SMALLEST_SCALE and not hold:
        return 0.0, 0.0, no_partner, True
    scale = max(bottleneck, _SMALLEST_NORMAL)
    bound = (len(a) + len(b)) * 2.0 ** (order / internal_p if internal_p != np.inf else 0.0)
    total, partner = _optimal_transport(a, b, order, internal_p, 1.0 / scale, 4.0 * bound)
    return scale, total, partner, False


@numba.njit(cache=True)
def wasserstein_scaled(a, b, order, internal_p):
    """``(s, total)`` with the q-Wasserstein distance ``s * total^(1/order)``.

    Equal diagrams give exactly 0: in floating point the solver's reduced costs cannot
    tell the identity matching from one that swaps two points an ulp apart.
    """
    if not precedes(a, b):  # so that d(a, b) == d(b, a) bit for bit
        a, b = b, a
    if _same_points(a, b):
        return 0.0, 0.0
    scale, total, _ = transport(a, b, order, internal_p)
    return scale, total
