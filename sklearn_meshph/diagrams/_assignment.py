"""Pieces shared by the assignment and flow solvers: augmenting an alternating path, a
binary heap, a total order on diagrams that fixes the orientation of a pair, edge lists
(grown as they fill, transposed), the flow pushed along a path, and the collapse of
duplicated points into multiplicities."""

from __future__ import annotations

import numba
import numpy as np

DIAGONAL = -2  # a point assigned to the diagonal


@numba.njit(cache=True)
def augment(path, row4col, col4row, j, root):
    """Flip the alternating path that ends at free column ``j`` back to ``root``."""
    while True:
        r = path[j]
        row4col[j] = r
        previous = col4row[r]
        col4row[r] = j
        if r == root:
            return
        j = previous


@numba.njit(cache=True)
def settle_columns(v, dist, done, touched, n_touched, total):
    """End a shortest-path search that reached its sink at distance ``total``: lower
    the potential of each column it finished by ``total - dist`` (reduced costs stay
    non-negative, and 0 along the path), and clear its marks on the columns it
    touched."""
    for k in range(n_touched):
        j = touched[k]
        if done[j]:
            v[j] -= total - dist[j]
        dist[j] = np.inf
        done[j] = False


@numba.njit(cache=True)
def precedes(a, b):
    """A total order on diagrams (size, then values), to fix argument order."""
    if len(a) != len(b):
        return len(a) < len(b)
    for i in range(len(a)):
        for k in range(2):
            if a[i, k] != b[i, k]:
                return a[i, k] < b[i, k]
    return True


@numba.njit(cache=True)
def heap_push(keys, items, size, key, item):
    pos = size
    while pos > 0:
        parent = (pos - 1) >> 1
        if keys[parent] <= key:
            break
        keys[pos] = keys[parent]
        items[pos] = items[parent]
        pos = parent
    keys[pos] = key
    items[pos] = item
    return size + 1


@numba.njit(cache=True)
def heap_pop(keys, items, size):
    """Remove the root; return the new size (the root was read by the caller)."""
    size -= 1
    key, item = keys[size], items[size]
    pos = 0
    while True:
        child = 2 * pos + 1
        if child >= size:
            break
        if child + 1 < size and keys[child + 1] < keys[child]:
            child += 1
        if keys[child] >= key:
            break
        keys[pos] = keys[child]
        items[pos] = items[child]
        pos = child
    if size > 0:
        keys[pos] = key
        items[pos] = item
    return size


@numba.njit(cache=True)
def collapse(d):
    """The distinct points of ``d`` by increasing persistence (ties by birth, death),
    the index among them of each point of ``d``, and their multiplicities: diagrams with
    many exact duplicates (integer-valued functions, plateaus) are solved on these."""
    by_death = np.argsort(d[:, 1], kind="mergesort")
    by_birth = by_death[np.argsort(d[by_death, 0], kind="mergesort")]
    ranked = by_birth[np.argsort(d[by_birth, 1] - d[by_birth, 0], kind="mergesort")]
    of = np.empty(len(d), np.int64)
    distinct = np.empty((len(d), 2))
    count = np.zeros(len(d), np.int64)
    k = -1
    for r in range(len(d)):
        i = ranked[r]
        if k < 0 or d[i, 0] != distinct[k, 0] or d[i, 1] != distinct[k, 1]:
            k += 1
            distinct[k] = d[i]
        of[i] = k
        count[k] += 1
    return distinct[: k + 1].copy(), of, count[: k + 1].copy()


@numba.njit(cache=True)
def transpose(ptr, cols, n_cols):
    """The columns' side of a CSR edge list: ``(row_of, t_ptr, t_edge)``, the row of each
    edge and, for column ``j``, its edges ``t_edge[t_ptr[j]:t_ptr[j + 1]]`` in increasing
    order (so their rows are in increasing order too)."""
    n_edges = len(cols)
    row_of = np.empty(n_edges, np.int64)
    for r in range(len(ptr) - 1):
        row_of[ptr[r] : ptr[r + 1]] = r
    t_ptr = np.zeros(n_cols + 1, np.int64)
    for e in range(n_edges):
        t_ptr[cols[e] + 1] += 1
    for j in range(n_cols):
        t_ptr[j + 1] += t_ptr[j]
    t_edge = np.empty(n_edges, np.int64)
    fill = t_ptr[:-1].copy()
    for e in range(n_edges):
        t_edge[fill[cols[e]]] = e
        fill[cols[e]] += 1
    return row_of, t_ptr, t_edge


@numba.njit(cache=True)
def reserve(cols, costs, used, needed):
    """An edge list ``(cols, costs)`` with room for ``needed`` edges, its first ``used``
    kept: the arrays themselves when they have the room, else copies at least twice as
    long (a list filled edge by edge grows in amortized constant time)."""
    if needed <= len(cols):
        return cols, costs
    size = max(2 * len(cols), needed)
    grown_cols = np.empty(size, np.int64)
    grown_cols[:used] = cols[:used]
    grown_costs = np.empty(size)
    grown_costs[:used] = costs[:used]
    return grown_cols, grown_costs


@numba.njit(cache=True)
def path_room(via_col, via_row, row_of, cols, flow, end, amount):
    """What a flow can push along the path a search found back from column ``end``:
    ``amount`` at most, and no more than each edge it runs back along carries. The path
    reaches each column along the edge ``via_col[j]`` and each row back along the edge
    ``via_row[r]``, -1 at the row it starts from. Returns the amount and that row."""
    j = end
    while True:
        r = row_of[via_col[j]]
        back = via_row[r]
        if back < 0:
            return amount, r
        amount = min(amount, flow[back])
        j = cols[back]


@numba.njit(cache=True)
def rows_back(j, t_ptr, t_edge, row_of, flow, reached, via_row, out, n_out):
    """Extend a flow search back from column ``j``: each row not ``reached`` yet that
    sends flow into it is marked reached along that edge (``via_row``) and appended to
    ``out`` after its first ``n_out`` entries; returns the new count."""
    for k in range(t_ptr[j], t_ptr[j + 1]):
        e = t_edge[k]
        r = row_of[e]
        if flow[e] > 0 and not reached[r]:
            reached[r] = True
            via_row[r] = e
            out[n_out] = r
            n_out += 1
    return n_out


@numba.njit(cache=True)
def push_path(via_col, via_row, row_of, cols, flow, end, amount):
    """Push ``amount`` along the path of :func:`path_room`: forward along the edges that
    reach its columns, back along those that reach its rows."""
    j = end
    while True:
        e = via_col[j]
        flow[e] += amount
        back = via_row[row_of[e]]
        if back < 0:
            return
        flow[back] -= amount
        j = cols[back]
