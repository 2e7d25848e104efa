"""Maximum matchings of bipartite graphs in CSR form, the tests of the bottleneck
distance's threshold search: Hopcroft-Karp for points taken once, and a maximum flow for
points with multiplicities."""

from __future__ import annotations

import numba
import numpy as np

from ._assignment import path_room, push_path, rows_back, transpose


@numba.njit(cache=True)
def max_matching(adj_ptr, adj, n_left, n_right, start):
    """Hopcroft-Karp maximum matching of a bipartite graph in CSR form: its size and the
    partner of each left and right vertex (-1: unmatched).

    ``start`` proposes a partner for each left vertex (-1: none); the proposals that are
    edges and do not collide are kept as the initial matching. The threshold search
    passes the matching of its previous test: thresholds close to each other have
    nearly the same maximum matching, so few phases are left."""
    # One allocation for all the work arrays: this runs millions of times on tiny graphs.
    work = np.empty(5 * n_left + n_right + 1, np.int64)
    match_left = work[:n_left]
    match_right = work[n_left : n_left + n_right]
    dist = work[n_left + n_right : 2 * n_left + n_right]
    queue = work[2 * n_left + n_right : 3 * n_left + n_right]
    edge_pos = work[3 * n_left + n_right : 4 * n_left + n_right]
    stack = work[4 * n_left + n_right :]
    match_left[:] = -1
    match_right[:] = -1
    size = 0
    for u in range(n_left):
        v = start[u]
        if v < 0 or match_right[v] >= 0:
            continue
        for k in range(adj_ptr[u], adj_ptr[u + 1]):
            if adj[k] == v:
                match_left[u] = v
                match_right[v] = u
                size += 1
                break
    inf = n_left + n_right + 1
    while True:
        head = tail = 0
        for u in range(n_left):
            if match_left[u] < 0:
                dist[u] = 0
                queue[tail] = u
                tail += 1
            else:
                dist[u] = inf
        found = inf
        while head < tail:
            u = queue[head]
            head += 1
            if dist[u] >= found:
                continue
            for k in range(adj_ptr[u], adj_ptr[u + 1]):
                w = match_right[adj[k]]
                if w < 0:
                    if found == inf:
                        found = dist[u] + 1
                elif dist[w] == inf:
                    dist[w] = dist[u] + 1
                    queue[tail] = w
                    tail += 1
        if found == inf:
            return size, match_left, match_right
        for u in range(n_left):
            edge_pos[u] = adj_ptr[u]
        for root in range(n_left):
            if match_left[root] >= 0:
                continue
            # Iterative DFS along layered edges.
            top = 0
            stack[0] = root
            while top >= 0:
                u = stack[top]
                advanced = False
                while edge_pos[u] < adj_ptr[u + 1]:
                    v = adj[edge_pos[u]]
                    w = match_right[v]
                    if w < 0:
                        if dist[u] + 1 == found:
                            # Augment along the stack.
                            for level in range(top, -1, -1):
                                x = stack[level]
                                y = adj[edge_pos[x]]
                                match_left[x] = y
                                match_right[y] = x
                            size += 1
                            top = -1
                            advanced = True
                            break
                        edge_pos[u] += 1
                    elif dist[w] == dist[u] + 1:
                        top += 1
                        stack[top] = w
                        advanced = True
                        break
                    else:
                        edge_pos[u] += 1
                if top < 0:
                    break
                if not advanced:
                    dist[u] = inf
                    top -= 1
                    if top >= 0:
                        edge_pos[stack[top]] += 1


@numba.njit(cache=True, inline="always")
def breadth_first(ptr, adj, queue, tail, seen, reach, state):
    """Breadth-first search of an alternating path: from the vertices ``queue[:tail]``
    along the edges ``(ptr, adj)`` to the vertices of the other side not ``seen`` yet.
    Each is marked seen and given to ``reach(x, e, y, queue, tail, state)`` (reached
    from ``x`` along edge ``e``), which returns whether the path ends there and the
    queue's new end (it queues the vertices to go on from). Returns the vertex the
    path ends at, or -1. Inlined into each caller, with its own ``reach``."""
    head = 0
    while head < tail:
        x = queue[head]
        head += 1
        for e in range(ptr[x], ptr[x + 1]):
            y = adj[e]
            if seen[y]:
                continue
            seen[y] = True
            found, tail = reach(x, e, y, queue, tail, state)
            if found:
                return y
    return -1


@numba.njit(cache=True)
def _column_with_room(r, e, j, queue, tail, state):
    """``max_flow``: column ``j`` reached along edge ``e`` ends the path when it has
    room; otherwise the search goes on back from it, to the rows that send it flow."""
    via_col, taken, capacity, t_ptr, t_edge, row_of, flow, seen_row, via_row = state
    via_col[j] = e
    if taken[j] < capacity[j]:
        return True, tail
    return False, rows_back(j, t_ptr, t_edge, row_of, flow, seen_row, via_row, queue, tail)


@numba.njit(cache=True)
def max_flow(ptr, adj, demand, capacity):
    """Largest flow from rows (each sending at most ``demand[r]``) along the edges
    ``(ptr, adj)`` into columns (each taking at most ``capacity[j]``): the matching test
    of points with multiplicities. A greedy start, then augmenting paths found by one
    breadth-first search from every row with demand left, back along edges that carry
    flow; each path carries as much as it can, so the number of searches depends on the
    distinct points, not on their copies."""
    n_rows, n_cols, n_edges = len(demand), len(capacity), len(adj)
    row_of, t_ptr, t_edge = transpose(ptr, adj, n_cols)
    flow = np.zeros(n_edges, np.int64)
    sent = np.zeros(n_rows, np.int64)
    taken = np.zeros(n_cols, np.int64)
    for r in range(n_rows):
        for e in range(ptr[r], ptr[r + 1]):
            push = min(demand[r] - sent[r], capacity[adj[e]] - taken[adj[e]])
            if push > 0:
                flow[e] += push
                sent[r] += push
                taken[adj[e]] += push
    total = sent.sum()
    via_col = np.empty(n_cols, np.int64)
    via_row = np.empty(n_rows, np.int64)
    seen_row = np.empty(n_rows, np.bool_)
    seen_col = np.empty(n_cols, np.bool_)
    queue = np.empty(n_rows, np.int64)
    while True:
        seen_row[:] = False
        seen_col[:] = False
        tail = 0
        for r in range(n_rows):
            if sent[r] < demand[r]:
                seen_row[r] = True
                via_row[r] = -1
                queue[tail] = r
                tail += 1
        state = (via_col, taken, capacity, t_ptr, t_edge, row_of, flow, seen_row, via_row)
        end = breadth_first(ptr, adj, queue, tail, seen_col, _column_with_room, state)
        if end < 0:
            return total
        amount, root = path_room(
            via_col, via_row, row_of, adj, flow, end, capacity[end] - taken[end]
        )
        amount = min(amount, demand[root] - sent[root])
        push_path(via_col, via_row, row_of, adj, flow, end, amount)
        sent[root] += amount
        taken[end] += amount
        total += amount
