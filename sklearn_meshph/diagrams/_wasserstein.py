"""Compiled exact q-Wasserstein distance between two finite diagrams: an optimal
assignment with a private diagonal column per point.

Costs are computed in a scaled form, ``(ground / s)^q`` for a scale ``s`` of the pair,
so that no order that float64 can carry underflows or overflows. Orders other than 1
and 2 use the bottleneck distance for ``s``, a lower bound of every q-Wasserstein
distance: the optimum is then at least 1, and never lost in the rounding of the dual
potentials. Orders 1 and 2 use the power of two just above the largest cost of a point
to the diagonal (every cost worth considering is then at most 2, and scaling by a power
of two is exact, so they give the bits of an unscaled computation), and fall back to the
bottleneck scale when the optimum comes out below 1e-250.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from ._assignment import DIAGONAL, augment, heap_pop, heap_push, precedes
from ._bottleneck import bottleneck_finite

# A scaled optimum below this is solved again at the scale of the bottleneck distance.
_TINY = 1e-250


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
def _ground(dx, dy, internal_p):
    """The L-p norm of ``(dx, dy)``, without overflow or underflow for large ``p``."""
    if internal_p == np.inf:
        return max(dx, dy)
    if internal_p == 2.0:
        return np.hypot(dx, dy)
    if internal_p == 1.0:
        return dx + dy
    big = max(dx, dy)
    if big == 0.0:
        return 0.0
    return big * ((dx / big) ** internal_p + (dy / big) ** internal_p) ** (1.0 / internal_p)


@numba.njit(cache=True, inline="always")
def _cost(ground, order, inv_scale, cap):
    """``(ground / scale)^order``, capped: a capped cost is never part of an optimum."""
    return min(power(ground * inv_scale, order), cap)


@numba.njit(cache=True, inline="always")
def _diagonal_factor(internal_p):
    """Ground distance of ``(b, d)`` to the diagonal, per unit of ``(d - b) / 2``."""
    return 1.0 if internal_p == np.inf else 2.0 ** (1.0 / internal_p)


@numba.njit(cache=True)
def _to_diagonal(d, order, internal_p, inv_scale, cap):
    """Scaled cost of moving each point of ``d`` to its projection on the diagonal."""
    factor = _diagonal_factor(internal_p)
    out = np.empty(len(d))
    for i in range(len(d)):
        out[i] = _cost((d[i, 1] - d[i, 0]) / 2.0 * factor, order, inv_scale, cap)
    return out


@numba.njit(cache=True)
def _candidate_edges(a, b, da, db, order, internal_p, inv_scale, cap):
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
    scale = _diagonal_factor(internal_p)
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
        if k + (hi - lo) + 1 > capacity:
            capacity = max(2 * capacity, k + (hi - lo) + 1)
            grown = np.empty(capacity, np.int64)
            grown[:k] = cols[:k]
            cols = grown
            grown_costs = np.empty(capacity)
            grown_costs[:k] = costs[:k]
            costs = grown_costs
        first = k
        for s in range(lo, hi):
            j = by_birth[s]
            g = _ground(abs(a[i, 0] - b[j, 0]), abs(a[i, 1] - b[j, 1]), internal_p)
            c = _cost(g, order, inv_scale, cap)
            if c < da[i] + db[j]:
                cols[k] = j
                costs[k] = c - db[j]
                k += 1
        ascending = first + np.argsort(costs[first:k], kind="mergesort")
        cols[first:k] = cols[ascending]
        costs[first:k] = costs[ascending]
        cols[k] = m + i
        costs[k] = da[i]
        k += 1
        ptr[i + 1] = k
    return ptr, cols[:k], costs[:k]


@numba.njit(cache=True)
def _optimal_transport(a, b, order, internal_p, inv_scale, cap):
    """Optimal matching of two finite diagrams for the cost ``sum (ground / s)^order``.

    Every point goes to a point of the other diagram or to the diagonal; the diagonal to
    itself is free. Writing the cost of a matching as ``sum_j db[j]`` plus, for each
    point i of ``a``, either ``c[i, j] - db[j]`` (matched to point j of ``b``) or
    ``da[i]`` (sent to the diagonal) turns the (n + m)-square assignment problem of the
    usual construction into an n x (m + n) one in which each row has a private diagonal
    column, and pairs that cost more than sending both points to the diagonal are
    dropped (``_candidate_edges``). It is solved exactly: Jonker-Volgenant row reduction
    for a start, then one shortest augmenting path per remaining row (Dijkstra with dual
    potentials and a binary heap). Rows go in order of increasing persistence, which
    keeps the augmenting paths short.

    ``inv_scale`` is ``1 / s``; costs above ``cap`` are replaced by ``cap``, which must
    exceed the optimum. Returns the optimal total cost and, for each point of ``a``, its
    partner in ``b`` or ``DIAGONAL``.
    """
    rows = np.argsort(a[:, 1] - a[:, 0], kind="mergesort")
    total, partner = _transport_rows(a[rows], b, order, internal_p, inv_scale, cap)
    out = np.empty_like(partner)
    out[rows] = partner
    return total, out


@numba.njit(cache=True)
def _transport_rows(a, b, order, internal_p, inv_scale, cap):
    n, m = len(a), len(b)
    da = _to_diagonal(a, order, internal_p, inv_scale, cap)
    db = _to_diagonal(b, order, internal_p, inv_scale, cap)
    ptr, cols, costs = _candidate_edges(a, b, da, db, order, internal_p, inv_scale, cap)
    n_cols = m + n
    u = np.zeros(n)
    v = np.zeros(n_cols)
    col4row = np.full(n, -1, np.int64)
    row4col = np.full(n_cols, -1, np.int64)
    dist = np.full(n_cols, np.inf)
    done = np.zeros(n_cols, np.bool_)
    path = np.empty(n_cols, np.int64)
    touched = np.empty(n_cols, np.int64)
    visited = np.empty(n, np.int64)
    keys = np.empty(len(cols) + 1)
    items = np.empty(len(cols) + 1, np.int64)
    free = _row_reduction(ptr, cols, costs, u, v, col4row, row4col, n)
    for root in free:
        n_touched = 0
        n_visited = 0
        size = 0
        i = root
        base = 0.0
        sink = -1
        # The search stops at the first free column it reaches, so a column no closer
        # than the closest free one seen so far is never reached: not queued.
        bound = np.inf
        while True:
            visited[n_visited] = i
            n_visited += 1
            ui = u[i]
            last = ptr[i + 1] - 1  # the private diagonal column, always free: first
            for f in range(ptr[i] - 1, last):
                e = last if f < ptr[i] else f
                j = cols[e]
                # Potentials of columns never rise above 0, so reduced costs are at
                # least base + cost - ui: past the bound, the rest of the row is too.
                if e != last and base + costs[e] - ui > bound:
                    break
                if done[j]:
                    continue
                reduced = base + costs[e] - ui - v[j]
                if reduced < dist[j] and reduced <= bound:
                    if dist[j] == np.inf:
                        touched[n_touched] = j
                        n_touched += 1
                    dist[j] = reduced
                    path[j] = i
                    if row4col[j] == -1:
                        bound = reduced
                    size = heap_push(keys, items, size, reduced, j)
            j = -1
            while size > 0:
                top, j = keys[0], items[0]
                size = heap_pop(keys, items, size)
                if not done[j] and top == dist[j]:
                    break
                j = -1
            # j == -1 cannot happen: the row's private diagonal column is always free.
            done[j] = True
            base = dist[j]
            if row4col[j] == -1:
                sink = j
                break
            i = row4col[j]
        min_value = base
        u[root] += min_value
        for k in range(1, n_visited):
            r = visited[k]
            u[r] += min_value - dist[col4row[r]]
        for k in range(n_touched):
            j = touched[k]
            if done[j]:
                v[j] -= min_value - dist[j]
            dist[j] = np.inf
            done[j] = False
        augment(path, row4col, col4row, sink, root)
    total = 0.0
    for j in range(m):
        if row4col[j] == -1:
            total += db[j]
    for i in range(n):
        j = col4row[i]
        if j >= m:
            total += da[i]
            col4row[i] = DIAGONAL
        else:
            g = _ground(abs(a[i, 0] - b[j, 0]), abs(a[i, 1] - b[j, 1]), internal_p)
            total += _cost(g, order, inv_scale, cap)
    return total, col4row


@numba.njit(cache=True)
def _row_reduction(ptr, cols, costs, u, v, col4row, row4col, n):
    """Jonker-Volgenant augmenting row reduction: a cheap start for most rows.

    Each free row takes its cheapest column (reduced by ``v``), lowering that column's
    potential to the second cheapest option so the duals stay feasible, and displacing
    the previous owner, which tries again. Returns the rows still free.
    """
    free = np.arange(n)
    n_free = n
    for _ in range(8):
        queue = free[:n_free].copy()
        n_queue = n_free
        n_free = 0
        k = 0
        steps = 0
        while k < n_queue:
            i = queue[k]
            k += 1
            steps += 1
            first = np.inf
            second = np.inf
            j1 = -1
            j2 = -1
            for e in range(ptr[i], ptr[i + 1]):
                h = costs[e] - v[cols[e]]
                if h < second:
                    if h < first:
                        second, j2 = first, j1
                        first, j1 = h, cols[e]
                    else:
                        second, j2 = h, cols[e]
            owner = row4col[j1]
            u[i] = first
            if j2 < 0:
                pass  # the private diagonal column is the row's only option
            elif first < second:
                v[j1] -= second - first
                u[i] = second
            elif owner >= 0:
                j1 = j2
                owner = row4col[j1]
            if owner >= 0:
                col4row[owner] = -1
            col4row[i] = j1
            row4col[j1] = i
            if owner >= 0:
                if first < second and steps < 4 * n:
                    k -= 1
                    queue[k] = owner
                else:
                    free[n_free] = owner
                    n_free += 1
    return free[:n_free].copy()


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
def transport(a, b, order, internal_p):
    """Optimal matching of two finite diagrams, in scaled form.

    Returns ``(s, total, partner)``: the distance is ``s * total^(1/order)`` and
    ``partner`` gives each point of ``a`` its partner in ``b`` or ``DIAGONAL``.
    """
    factor = _diagonal_factor(internal_p)
    largest = 0.0
    for d in (a, b):
        for i in range(len(d)):
            largest = max(largest, (d[i, 1] - d[i, 0]) / 2.0 * factor)
    if largest == 0.0:  # every point on the diagonal
        return 0.0, 0.0, np.full(len(a), DIAGONAL, np.int64)
    scale = power_of_two_above(largest)
    if order == 1.0 or order == 2.0:
        # Orders 1 and 2 keep the bits of the unscaled computation (scaling by a power
        # of two is exact) unless the optimum underflows.
        total, partner = _optimal_transport(a, b, order, internal_p, 1.0 / scale, np.inf)
        if total >= _TINY:
            return scale, total, partner
    # Other orders are always solved at the scale of the bottleneck distance: at the
    # scale of the largest persistence their optimum can be far below the costs that
    # the dual potentials carry (a distance far below the largest persistence, from
    # order ~10 on), lost in rounding, and a matching that is not optimal comes out.
    # The optimum is at least (bottleneck / s)^order; at s = the L-infinity bottleneck
    # distance it is at least 1 and at most n + m (internal_p = inf) or that times
    # 2^(order / internal_p), which callers keep within float64.
    bottleneck = bottleneck_finite(a, b)
    if bottleneck == 0.0:  # a matching of cost 0, found at any order
        return 0.0, 0.0, _optimal_transport(a, b, 1.0, internal_p, 1.0 / scale, np.inf)[1]
    scale = bottleneck
    bound = (len(a) + len(b)) * 2.0 ** (order / internal_p if internal_p != np.inf else 0.0)
    total, partner = _optimal_transport(a, b, order, internal_p, 1.0 / scale, 4.0 * bound)
    return scale, total, partner


@numba.njit(cache=True)
def wasserstein_scaled(a, b, order, internal_p):
    """``(s, total)`` with the q-Wasserstein distance ``s * total^(1/order)``.

    Equal diagrams give exactly 0: in floating point the solver's reduced costs cannot
    tell the identity matching from one that swaps two points 1e-16 apart.
    """
    if not precedes(a, b):  # so that d(a, b) == d(b, a) bit for bit
        a, b = b, a
    if _same_points(a, b):
        return 0.0, 0.0
    scale, total, _ = transport(a, b, order, internal_p)
    return scale, total
