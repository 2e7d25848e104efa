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

from ._assignment import (
    DIAGONAL,
    augment,
    collapse,
    heap_pop,
    heap_push,
    precedes,
    transpose,
)
from ._bottleneck import bottleneck_finite
from ._kdtree import STACK, box_gap, build, ground, nearest, node_maxima

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
def _cost(g, order, inv_scale, cap):
    """``(ground / scale)^order``, capped: a capped cost is never part of an optimum."""
    return min(power(g * inv_scale, order), cap)


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
            g = ground(abs(a[i, 0] - b[j, 0]), abs(a[i, 1] - b[j, 1]), internal_p)
            c = _cost(g, order, inv_scale, cap)
            if c < min(da[i] + db[j], cap):
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
    if len(a) * len(b) > DENSE_PAIRS:
        distinct_a, of_a, count_a = collapse(a)
        distinct_b, of_b, count_b = collapse(b)
        few = len(distinct_a) * len(distinct_b) <= DENSE_PAIRS
        if few and 2 * (len(distinct_a) + len(distinct_b)) <= len(a) + len(b):
            total, flows = _transport_distinct(
                distinct_a, count_a, distinct_b, count_b, order, internal_p, inv_scale, cap
            )
            return total, _partners_from_flows(flows, of_a, of_b, len(distinct_b))
    rows = np.argsort(a[:, 1] - a[:, 0], kind="mergesort")
    total, partner = _transport_rows(a[rows], b, order, internal_p, inv_scale, cap)
    out = np.empty_like(partner)
    out[rows] = partner
    return total, out


@numba.njit(cache=True)
def _transport_distinct(a, supply, b, capacity_b, order, internal_p, inv_scale, cap):
    """Optimal transport between distinct points with multiplicities (diagrams with
    many exact duplicates: integer-valued functions, plateaus): the same row form as
    :func:`_transport_rows` with row ``i`` sending ``supply[i]`` units and column ``j``
    taking at most ``capacity_b[j]``, solved by :func:`_min_cost_flow`. A matching of
    the expanded diagrams has the same cost as the flow, and every flow of integers
    splits into one, so the optimum is the same; the work depends on the number of
    distinct points. Returns the total and ``(ptr, cols, flow)`` per distinct row."""
    n, m = len(a), len(b)
    da = _to_diagonal(a, order, internal_p, inv_scale, cap)
    db = _to_diagonal(b, order, internal_p, inv_scale, cap)
    ptr, cols, costs = _candidate_edges(a, b, da, db, order, internal_p, inv_scale, cap)
    capacity = np.empty(m + n, np.int64)
    capacity[:m] = capacity_b
    capacity[m:] = supply
    flow = _min_cost_flow(ptr, cols, costs, supply, capacity, n)
    taken = np.zeros(m, np.int64)
    total = 0.0
    for i in range(n):
        for e in range(ptr[i], ptr[i + 1]):
            j = cols[e]
            if flow[e] > 0 and j < m:
                taken[j] += flow[e]
    for j in range(m):
        total += (capacity_b[j] - taken[j]) * db[j]
    for i in range(n):
        for e in range(ptr[i], ptr[i + 1]):
            j = cols[e]
            if flow[e] == 0:
                continue
            if j >= m:
                total += flow[e] * da[i]
            else:
                g = ground(abs(a[i, 0] - b[j, 0]), abs(a[i, 1] - b[j, 1]), internal_p)
                total += flow[e] * _cost(g, order, inv_scale, cap)
    return total, (ptr, cols, flow)


@numba.njit(cache=True)
def _min_cost_flow(ptr, cols, costs, supply, capacity, n):
    """Integer min-cost flow in the row form: row ``i`` sends ``supply[i]`` along its
    edges, column ``j`` takes at most ``capacity[j]``; returns the flow of each edge.

    Successive shortest paths with dual potentials, the assignment solver's scheme with
    capacities: a Dijkstra search from a row with supply left runs over the edges
    (reduced cost ``costs - u - v >= 0``) and back along edges that carry flow
    (reduced cost 0), to the nearest column with room, then pushes as much as the
    path allows (the root's supply, the column's room, the flows it runs back along).
    As in the assignment, columns only lose potential once full, and stay full.
    """
    n_edges = len(cols)
    n_cols = len(capacity)
    row_of, t_ptr, t_edge = transpose(ptr, cols, n_cols)
    flow = np.zeros(n_edges, np.int64)
    inflow = np.zeros(n_cols, np.int64)
    remaining = supply.copy()
    u = np.zeros(n)
    v = np.zeros(n_cols)
    dist_col = np.full(n_cols, np.inf)
    dist_row = np.full(n, np.inf)
    done = np.zeros(n_cols, np.bool_)
    reach_col = np.empty(n_cols, np.int64)  # the edge a column was reached along
    reach_row = np.empty(n, np.int64)  # the flow edge a row was reached back along
    touched = np.empty(n_cols, np.int64)
    visited = np.empty(n, np.int64)
    pending = np.empty(n, np.int64)
    keys = np.empty(n_edges + 1)
    items = np.empty(n_edges + 1, np.int64)
    for root in range(n):
        while remaining[root] > 0:
            n_touched = 0
            n_visited = 1
            visited[0] = root
            dist_row[root] = 0.0
            pending[0] = root
            n_pending = 1
            size = 0
            sink = -1
            while sink < 0:
                while n_pending > 0:  # rows reached at the current distance: scan them
                    n_pending -= 1
                    r = pending[n_pending]
                    base = dist_row[r]
                    for e in range(ptr[r], ptr[r + 1]):
                        j = cols[e]
                        if done[j]:
                            continue
                        reduced = base + costs[e] - u[r] - v[j]
                        if reduced < dist_col[j]:
                            if dist_col[j] == np.inf:
                                touched[n_touched] = j
                                n_touched += 1
                            dist_col[j] = reduced
                            reach_col[j] = e
                            size = heap_push(keys, items, size, reduced, j)
                # The heap cannot run dry: the root's private column has room.
                while size > 0:
                    top, j = keys[0], items[0]
                    size = heap_pop(keys, items, size)
                    if done[j] or top != dist_col[j]:
                        continue
                    done[j] = True
                    if inflow[j] < capacity[j]:
                        sink = j
                        break
                    for k in range(t_ptr[j], t_ptr[j + 1]):
                        e = t_edge[k]
                        r = row_of[e]
                        if flow[e] > 0 and dist_row[r] == np.inf:
                            dist_row[r] = top
                            reach_row[r] = e
                            visited[n_visited] = r
                            n_visited += 1
                            pending[n_pending] = r
                            n_pending += 1
                    if n_pending > 0:
                        break
            # The private diagonal column of a row with supply left always has room.
            total = dist_col[sink]
            for k in range(n_visited):
                w = visited[k]
                u[w] += total - dist_row[w]
                dist_row[w] = np.inf
            for k in range(n_touched):
                j = touched[k]
                if done[j]:
                    v[j] -= total - dist_col[j]
                dist_col[j] = np.inf
                done[j] = False
            amount = min(remaining[root], capacity[sink] - inflow[sink])
            j = sink
            while True:
                e = reach_col[j]
                w = row_of[e]
                if w == root:
                    break
                back = reach_row[w]
                amount = min(amount, flow[back])
                j = cols[back]
            j = sink
            while True:
                e = reach_col[j]
                flow[e] += amount
                w = row_of[e]
                if w == root:
                    break
                back = reach_row[w]
                flow[back] -= amount
                j = cols[back]
            inflow[sink] += amount
            remaining[root] -= amount
    return flow


@numba.njit(cache=True)
def _partners_from_flows(flows, of_a, of_b, m):
    """Split a flow between distinct points into a matching of the points themselves:
    ``DIAGONAL`` or the index in ``b`` for each point of ``a``."""
    ptr, cols, flow = flows
    n_distinct = len(ptr) - 1
    # The points of b behind each distinct point, in index order.
    b_ptr = np.zeros(m + 1, np.int64)
    for j in range(len(of_b)):
        b_ptr[of_b[j] + 1] += 1
    for k in range(m):
        b_ptr[k + 1] += b_ptr[k]
    b_points = np.empty(len(of_b), np.int64)
    fill = b_ptr[:-1].copy()
    for j in range(len(of_b)):
        b_points[fill[of_b[j]]] = j
        fill[of_b[j]] += 1
    next_b = b_ptr[:-1].copy()
    # What each distinct point of a sends, as a list of (column, units) to hand out.
    edge = ptr[:-1].copy()
    left = np.zeros(n_distinct, np.int64)
    out = np.empty(len(of_a), np.int64)
    for i in range(len(of_a)):
        k = of_a[i]
        while left[k] == 0:
            left[k] = flow[edge[k]]
            edge[k] += 1
        column = cols[edge[k] - 1]
        left[k] -= 1
        if column >= m:
            out[i] = DIAGONAL
        else:
            out[i] = b_points[next_b[column]]
            next_b[column] += 1
    return out


@numba.njit(cache=True)
def _transport_rows(a, b, order, internal_p, inv_scale, cap):
    n, m = len(a), len(b)
    da = _to_diagonal(a, order, internal_p, inv_scale, cap)
    db = _to_diagonal(b, order, internal_p, inv_scale, cap)
    if n * m <= DENSE_PAIRS:
        ptr, cols, costs = _candidate_edges(a, b, da, db, order, internal_p, inv_scale, cap)
        col4row = _solve(ptr, cols, costs, n, m + n)[2]
    else:
        col4row = _sparse_solve(a, b, da, db, order, internal_p, inv_scale, cap)
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
            g = ground(abs(a[i, 0] - b[j, 0]), abs(a[i, 1] - b[j, 1]), internal_p)
            total += _cost(g, order, inv_scale, cap)
    return total, col4row


@numba.njit(cache=True)
def _solve(ptr, cols, costs, n, n_cols):
    """Optimal assignment of ``n`` rows on the edges ``(ptr, cols, costs)`` (CSR, each
    row's edges by increasing cost, then its private column, always free at the start).

    Returns the dual potentials ``u`` (rows) and ``v`` (columns, never above 0, 0 on the
    free columns) and the assignment ``col4row``, ``row4col``: reduced costs
    ``costs - u - v`` are >= 0 on every edge (up to rounding) and 0 on the assigned ones.
    """
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
    return u, v, col4row, row4col


# Above this many point pairs, each point starts with its nearest neighbours only and
# the edges the optimum needs are added by pricing (benchmarks/bench_distances.py).
DENSE_PAIRS = 90_000
# Neighbours per point in the first sparse problem, and new edges per row per round.
NEIGHBOURS = 8
# Places on each side of the same rank along the persistence and the diagonal.
WINDOW = 2
# Priced edges per row per round.
PRICED = 4


@numba.njit(cache=True)
def _sorted_rows(ptr, cols, costs, n, m):
    """Sort each row's edges by cost and append its private diagonal column (filled in
    by the caller's ``costs`` at that slot): the layout :func:`_solve` reads."""
    for i in range(n):
        first, last = ptr[i], ptr[i + 1] - 1
        ascending = first + np.argsort(costs[first:last], kind="mergesort")
        cols[first:last] = cols[ascending]
        costs[first:last] = costs[ascending]
        cols[last] = m + i


@numba.njit(cache=True)
def _add_rank_window(b, key_a, key_b, top_aligned, width, chosen, count):
    """Append to each row of ``chosen`` the points of ``b`` within ``width`` places of
    the same rank when both diagrams are sorted by a key: ranks counted from the top
    (``top_aligned``: the least persistent points are the ones the diagonal takes, so a
    difference in size is absorbed at the bottom) or proportionally.

    Where the points lie along the key's line (births all equal, say) the optimal
    matching is the sorted one, and nearest neighbours can miss it: the two sorted
    sequences drift about sqrt(n) places apart. The window also holds the edges that
    pin the optimal potentials along the line (for convex costs on a line, feasibility
    on neighbouring ranks implies it everywhere), so pricing finds little to add.
    """
    n, m = len(key_a), len(key_b)
    by_a = np.argsort(key_a, kind="mergesort")
    by_b = np.argsort(key_b, kind="mergesort")
    for r in range(n):
        i = by_a[r]
        centre = r + m - n if top_aligned else (2 * r + 1) * m // (2 * n)
        for t in range(max(centre - width, 0), min(centre + width + 1, m)):
            j = by_b[t]
            new = True
            for f in range(count[i]):
                new = new and chosen[i, f] != j
            if new:
                chosen[i, count[i]] = j
                count[i] += 1


@numba.njit(cache=True)
def _neighbour_edges(a, b, tree, da, db, order, internal_p, inv_scale, cap, k, width):
    """The first sparse problem: each point of ``a`` with its ``k`` nearest points of
    ``b`` and the rank windows along the persistence and along the diagonal (those
    cheaper than sending both to the diagonal), and its diagonal column."""
    n, m = len(a), len(b)
    slots = k + 3 * (2 * width + 1)
    chosen = np.empty((n, slots), np.int64)
    count = np.zeros(n, np.int64)
    best_g = np.empty(k)
    stack = np.empty(STACK, np.int64)
    for i in range(n):
        count[i] = nearest(tree, b, a[i, 0], a[i, 1], k, internal_p, best_g, chosen[i], stack)
    persistence_a, persistence_b = a[:, 1] - a[:, 0], b[:, 1] - b[:, 0]
    _add_rank_window(b, persistence_a, persistence_b, True, width, chosen, count)
    _add_rank_window(b, persistence_a, persistence_b, False, width, chosen, count)
    _add_rank_window(b, a[:, 1] + a[:, 0], b[:, 1] + b[:, 0], False, width, chosen, count)
    ptr = np.zeros(n + 1, np.int64)
    cols = np.empty(n * (slots + 1), np.int64)
    costs = np.empty(n * (slots + 1))
    e = 0
    for i in range(n):
        for f in range(count[i]):
            j = chosen[i, f]
            g = ground(abs(a[i, 0] - b[j, 0]), abs(a[i, 1] - b[j, 1]), internal_p)
            c = _cost(g, order, inv_scale, cap)
            if c < min(da[i] + db[j], cap):
                cols[e] = j
                costs[e] = c - db[j]
                e += 1
        costs[e] = da[i]
        e += 1
        ptr[i + 1] = e
    _sorted_rows(ptr, cols, costs, n, m)
    return ptr, cols[:e], costs[:e]


@numba.njit(cache=True)
def _price(a, b, tree, da, db, u, v, ptr, cols, order, internal_p, inv_scale, cap, k, tol):
    """Edges missing from the sparse problem whose reduced cost is below ``-tol``: for
    each row, its ``k`` most negative ones (none: the sparse optimum is optimal).

    A pair (i, j) costs ``c - db[j]`` in the row form, so it is violated when
    ``c < u[i] + w[j]`` with ``w = v + db``; boxes whose cost lower bound reaches the
    largest ``w`` inside them (or ``da[i]`` plus the largest ``db``) are skipped.
    """
    n, m = len(a), len(b)
    order_, start, stop, left, box = tree
    w_max = node_maxima(tree, v[:m] + db)
    db_max = node_maxima(tree, db)
    present = np.zeros(m, np.bool_)
    stack = np.empty(STACK, np.int64)
    found_j = np.empty(m, np.int64)
    found_r = np.empty(m)
    new_ptr = np.zeros(n + 1, np.int64)
    new_cols = np.empty(16, np.int64)
    new_costs = np.empty(16)
    e = 0
    for i in range(n):
        for f in range(ptr[i], ptr[i + 1] - 1):
            present[cols[f]] = True
        x, y = a[i, 0], a[i, 1]
        count = 0
        stack[0] = 0
        top = 1
        while top > 0:
            top -= 1
            node = stack[top]
            lower = _cost(box_gap(box, node, x, y), order, inv_scale, cap)
            if lower - u[i] - w_max[node] >= -tol or lower >= min(da[i] + db_max[node], cap):
                continue
            if left[node] >= 0:
                stack[top] = left[node]
                stack[top + 1] = left[node] + 1
                top += 2
                continue
            for r in range(start[node], stop[node]):
                j = order_[r]
                if present[j]:
                    continue
                g = ground(abs(x - b[j, 0]), abs(y - b[j, 1]), internal_p)
                c = _cost(g, order, inv_scale, cap)
                reduced = c - db[j] - u[i] - v[j]
                if reduced < -tol and c < min(da[i] + db[j], cap):
                    found_j[count] = j
                    found_r[count] = reduced
                    count += 1
        for f in range(ptr[i], ptr[i + 1] - 1):
            present[cols[f]] = False
        if count > k:
            chosen = np.argsort(found_r[:count], kind="mergesort")[:k]
            found_j[:k] = found_j[chosen]
            count = k
        if e + count > len(new_cols):
            size = max(2 * len(new_cols), e + count)
            grown = np.empty(size, np.int64)
            grown[:e] = new_cols[:e]
            new_cols = grown
            grown_costs = np.empty(size)
            grown_costs[:e] = new_costs[:e]
            new_costs = grown_costs
        for r in range(count):
            j = found_j[r]
            g = ground(abs(x - b[j, 0]), abs(y - b[j, 1]), internal_p)
            new_cols[e] = j
            new_costs[e] = _cost(g, order, inv_scale, cap) - db[j]
            e += 1
        new_ptr[i + 1] = e
    return new_ptr, new_cols[:e], new_costs[:e]


@numba.njit(cache=True)
def _merge(ptr, cols, costs, new_ptr, new_cols, new_costs, n, m):
    """Each row's edges with the priced ones, sorted again, private column last."""
    out_ptr = np.zeros(n + 1, np.int64)
    out_cols = np.empty(len(cols) + len(new_cols), np.int64)
    out_costs = np.empty(len(cols) + len(new_cols))
    e = 0
    for i in range(n):
        for f in range(ptr[i], ptr[i + 1] - 1):
            out_cols[e] = cols[f]
            out_costs[e] = costs[f]
            e += 1
        for f in range(new_ptr[i], new_ptr[i + 1]):
            out_cols[e] = new_cols[f]
            out_costs[e] = new_costs[f]
            e += 1
        out_costs[e] = costs[ptr[i + 1] - 1]
        e += 1
        out_ptr[i + 1] = e
    _sorted_rows(out_ptr, out_cols, out_costs, n, m)
    return out_ptr, out_cols, out_costs


@numba.njit(cache=True)
def _sparse_solve(a, b, da, db, order, internal_p, inv_scale, cap):
    """The optimal assignment of large diagrams in O((n + m) k) memory.

    Each point of ``a`` starts with its ``NEIGHBOURS`` nearest points of ``b`` (a 2-d
    tree: clusters and shared births cost nothing more than spread points) and its rank
    windows (:func:`_add_rank_window`); the sparse problem is solved, and every missing
    pair whose reduced cost under the optimal potentials is negative is priced in (the
    most negative ones per row first) and the problem solved again. When no pair is
    left with a negative reduced cost, the potentials are feasible for the full problem
    and the sparse optimum is the optimum (linear programming duality: the assignment
    polytope is integral). ``tol`` is a few hundred ulps of the largest potential: a
    pair violated by less cannot lower the total by more than rounding already does.
    """
    n, m = len(a), len(b)
    tree = build(b)
    ptr, cols, costs = _neighbour_edges(
        a, b, tree, da, db, order, internal_p, inv_scale, cap, NEIGHBOURS, WINDOW
    )
    priced = PRICED
    while True:
        u, v, col4row, _ = _solve(ptr, cols, costs, n, m + n)
        largest = 1.0
        for i in range(n):
            largest = max(largest, abs(u[i]))
        for j in range(m + n):
            largest = max(largest, abs(v[j]))
        tol = 256.0 * np.finfo(np.float64).eps * largest
        new_ptr, new_cols, new_costs = _price(
            a,
            b,
            tree,
            da,
            db,
            u,
            v,
            ptr,
            cols,
            order,
            internal_p,
            inv_scale,
            cap,
            priced,
            tol,
        )
        if len(new_cols) == 0:
            return col4row
        ptr, cols, costs = _merge(ptr, cols, costs, new_ptr, new_cols, new_costs, n, m)
        # Each round re-solves from scratch: let rounds grow geometrically in what
        # they add, so that a seed far from the optimum costs O(log) rounds.
        priced *= 2


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
