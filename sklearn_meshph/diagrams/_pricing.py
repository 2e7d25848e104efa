"""The optimal assignment of large diagrams in memory linear in their sizes: a sparse
problem of nearest neighbours and rank windows, solved, then priced against every
missing pair through a 2-d tree until no pair has a negative reduced cost."""

from __future__ import annotations

import numba
import numpy as np

from ._assignment import reserve
from ._assignment_solver import solve
from ._costs import cost, keep_pair, pair_cost
from ._kdtree import STACK, box_gap, build, depth_first, nearest, node_maxima, right_first

# Neighbours per point in the first sparse problem, and new edges per row per round.
NEIGHBOURS = 8
# Places on each side of the same rank along the persistence and the diagonal.
WINDOW = 2
# Priced edges per row per round.
PRICED = 4


@numba.njit(cache=True)
def sorted_rows(ptr, cols, costs, n, m):
    """Sort each row's edges by cost and append its private diagonal column (filled in
    by the caller's ``costs`` at that slot): the layout :func:`solve` reads."""
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
            c = pair_cost(a, i, b, j, order, internal_p, inv_scale, cap)
            e = keep_pair(cols, costs, e, j, c, da[i], db[j], cap)
        costs[e] = da[i]
        e += 1
        ptr[i + 1] = e
    sorted_rows(ptr, cols, costs, n, m)
    return ptr, cols[:e], costs[:e]


@numba.njit(cache=True)
def _cannot_violate(box, node, count, state):
    """``_price``: no pair of row ``i`` with a point in the node's box is violated (its
    cost's lower bound reaches the largest ``w`` inside, or sending both points to the
    diagonal costs no more)."""
    a, i, _, da, _, u, _, w_max, db_max, _, _, _, order, _, inv_scale, cap, tol = state
    lower = cost(box_gap(box, node, a[i, 0], a[i, 1]), order, inv_scale, cap)
    return lower - u[i] - w_max[node] >= -tol or lower >= min(da[i] + db_max[node], cap)


@numba.njit(cache=True)
def _violated(order_, s, e, count, state):
    """``_price``: append the violated pairs of row ``i`` with the leaf's points that
    the sparse problem does not hold, with their reduced costs."""
    a, i, b, da, db, u, v, _, _, present, found_j, found_r = state[0:12]
    order, internal_p, inv_scale, cap, tol = state[12:17]
    for r in range(s, e):
        j = order_[r]
        if present[j]:
            continue
        c = pair_cost(a, i, b, j, order, internal_p, inv_scale, cap)
        reduced = c - db[j] - u[i] - v[j]
        if reduced < -tol and c < min(da[i] + db[j], cap):
            found_j[count] = j
            found_r[count] = reduced
            count += 1
    return count


@numba.njit(cache=True)
def _price(a, b, tree, da, db, u, v, ptr, cols, order, internal_p, inv_scale, cap, k, tol):
    """Edges missing from the sparse problem whose reduced cost is below ``-tol``: for
    each row, its ``k`` most negative ones (none: the sparse optimum is optimal).

    A pair (i, j) costs ``c - db[j]`` in the row form, so it is violated when
    ``c < u[i] + w[j]`` with ``w = v + db``; boxes whose cost lower bound reaches the
    largest ``w`` inside them (or ``da[i]`` plus the largest ``db``) are skipped.
    """
    n, m = len(a), len(b)
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
        state = (a, i, b, da, db, u, v, w_max, db_max, present, found_j, found_r)
        settings = (order, internal_p, inv_scale, cap, tol)
        count = depth_first(tree, stack, _cannot_violate, right_first, _violated, state + settings)
        for f in range(ptr[i], ptr[i + 1] - 1):
            present[cols[f]] = False
        if count > k:
            chosen = np.argsort(found_r[:count], kind="mergesort")[:k]
            found_j[:k] = found_j[chosen]
            count = k
        new_cols, new_costs = reserve(new_cols, new_costs, e, e + count)
        for r in range(count):
            j = found_j[r]
            new_cols[e] = j
            new_costs[e] = pair_cost(a, i, b, j, order, internal_p, inv_scale, cap) - db[j]
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
    sorted_rows(out_ptr, out_cols, out_costs, n, m)
    return out_ptr, out_cols, out_costs


@numba.njit(cache=True)
def sparse_solve(a, b, da, db, order, internal_p, inv_scale, cap):
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
        u, v, col4row, _ = solve(ptr, cols, costs, n, m + n)
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
