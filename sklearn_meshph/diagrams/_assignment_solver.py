"""The exact assignment solver of the row form: Jonker-Volgenant row reduction for a
start, then one shortest augmenting path per remaining row (Dijkstra with dual
potentials and a binary heap), on sparse rows that end with a private column."""

from __future__ import annotations

import numba
import numpy as np

from ._assignment import augment, heap_pop, heap_push, settle_columns


@numba.njit(cache=True)
def solve(ptr, cols, costs, n, n_cols):
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
        settle_columns(v, dist, done, touched, n_touched, min_value)
        augment(path, row4col, col4row, sink, root)
    return u, v, col4row, row4col


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
