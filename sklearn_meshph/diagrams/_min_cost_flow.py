"""Optimal transport between distinct points with multiplicities: an integer
min-cost flow in the row form, and the matching of the points behind it."""

from __future__ import annotations

import numba
import numpy as np

from ._assignment import (
    DIAGONAL,
    heap_pop,
    heap_push,
    path_room,
    push_path,
    rows_back,
    settle_columns,
    transpose,
)
from ._costs import candidate_edges, pair_cost, to_diagonal


@numba.njit(cache=True)
def transport_distinct(a, supply, b, capacity_b, order, internal_p, inv_scale, cap):
    """Optimal transport between distinct points with multiplicities (diagrams with
    many exact duplicates: integer-valued functions, plateaus): the row form of the
    assignment with row ``i`` sending ``supply[i]`` units and column ``j`` taking at
    most ``capacity_b[j]``, solved by :func:`min_cost_flow`. A matching of the expanded
    diagrams has the same cost as the flow, and every flow of integers splits into one,
    so the optimum is the same; the work depends on the number of distinct points.
    Returns the total and ``(ptr, cols, flow)`` per distinct row."""
    n, m = len(a), len(b)
    da = to_diagonal(a, order, internal_p, inv_scale, cap)
    db = to_diagonal(b, order, internal_p, inv_scale, cap)
    ptr, cols, costs = candidate_edges(a, b, da, db, order, internal_p, inv_scale, cap)
    capacity = np.empty(m + n, np.int64)
    capacity[:m] = capacity_b
    capacity[m:] = supply
    flow = min_cost_flow(ptr, cols, costs, supply, capacity, n)
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
                total += flow[e] * pair_cost(a, i, b, j, order, internal_p, inv_scale, cap)
    return total, (ptr, cols, flow)


@numba.njit(cache=True)
def min_cost_flow(ptr, cols, costs, supply, capacity, n):
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
    reached = np.zeros(n, np.bool_)  # the rows with a finite dist_row
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
            reached[root] = True
            reach_row[root] = -1  # where paths back end
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
                    first = n_pending
                    n_pending = rows_back(
                        j, t_ptr, t_edge, row_of, flow, reached, reach_row, pending, n_pending
                    )
                    for k in range(first, n_pending):
                        dist_row[pending[k]] = top
                        visited[n_visited] = pending[k]
                        n_visited += 1
                    if n_pending > 0:
                        break
            # The private diagonal column of a row with supply left always has room.
            total = dist_col[sink]
            for k in range(n_visited):
                w = visited[k]
                u[w] += total - dist_row[w]
                dist_row[w] = np.inf
                reached[w] = False
            settle_columns(v, dist_col, done, touched, n_touched, total)
            amount = min(remaining[root], capacity[sink] - inflow[sink])
            amount = path_room(reach_col, reach_row, row_of, cols, flow, sink, amount)[0]
            push_path(reach_col, reach_row, row_of, cols, flow, sink, amount)
            inflow[sink] += amount
            remaining[root] -= amount
    return flow


@numba.njit(cache=True)
def partners_from_flows(flows, of_a, of_b, m):
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
