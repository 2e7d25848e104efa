"""Compiled exact bottleneck distance between two finite diagrams, and its matching.

Two algorithms, both exact: successive minimax augmenting paths for diagrams of up to a
few hundred points, and for larger ones a search over the candidate values with a
Hopcroft-Karp matching test on the pairs within each threshold.
"""

from __future__ import annotations

import numba
import numpy as np

from ._assignment import DIAGONAL, augment


@numba.njit(cache=True)
def _max_matching(adj_ptr, adj, n_left, n_right):
    """Hopcroft-Karp maximum matching of a bipartite graph in CSR form: its size and the
    partner of each left and right vertex (-1: unmatched)."""
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


@numba.njit(cache=True)
def _band(births, centre, reach):
    """Positions in sorted ``births`` within ``reach`` of ``centre`` (a superset: the
    bounds are widened by a few ulps, callers test the exact distance)."""
    slack = 1e-12 * (abs(centre) + reach) + 1e-300
    lo = np.searchsorted(births, centre - reach - slack, side="left")
    hi = np.searchsorted(births, centre + reach + slack, side="right")
    return lo, hi


@numba.njit(cache=True)
def _threshold_graph(a, b, by_birth, births, rows, t):
    """CSR graph from ``a[rows]`` to the points of ``b`` within L-infinity ``t``.

    ``by_birth`` sorts ``b`` by birth and ``births`` are those births: each row only
    looks at the band of births within ``t`` of its own (geometric pruning).
    """
    ptr = np.zeros(len(rows) + 1, np.int64)
    capacity = 4 * len(rows) + 16
    adj = np.empty(capacity, np.int64)
    k = 0
    for r in range(len(rows)):
        i = rows[r]
        lo, hi = _band(births, a[i, 0], t)
        if k + hi - lo > capacity:
            capacity = max(2 * capacity, k + hi - lo)
            grown = np.empty(capacity, np.int64)
            grown[:k] = adj[:k]
            adj = grown
        for s in range(lo, hi):
            j = by_birth[s]
            if max(abs(a[i, 0] - b[j, 0]), abs(a[i, 1] - b[j, 1])) <= t:
                adj[k] = j
                k += 1
        ptr[r + 1] = k
    return ptr, adj[:k]


@numba.njit(cache=True)
def _covers(a, b, by_birth, births, t):
    """Whether the points of ``a`` that cannot go to the diagonal at ``t`` can all be
    matched into ``b`` with L-infinity cost at most ``t``."""
    n_rows = 0
    for i in range(len(a)):
        if (a[i, 1] - a[i, 0]) / 2.0 > t:
            n_rows += 1
    if n_rows == 0:
        return True
    if n_rows > len(b):
        return False
    rows = np.empty(n_rows, np.int64)
    n_rows = 0
    for i in range(len(a)):
        if (a[i, 1] - a[i, 0]) / 2.0 > t:
            rows[n_rows] = i
            n_rows += 1
    ptr, adj = _threshold_graph(a, b, by_birth, births, rows, t)
    return _max_matching(ptr, adj, n_rows, len(b))[0] == n_rows


@numba.njit(cache=True)
def _feasible(a, b, sorted_a, sorted_b, t):
    """Whether some matching moves no point by more than ``t`` (L-infinity).

    Mendelsohn-Dulmage: a matching covering the points of ``a`` that cannot go to the
    diagonal and one covering those of ``b`` imply one covering both.
    """
    return _covers(a, b, sorted_b[0], sorted_b[1], t) and _covers(b, a, sorted_a[0], sorted_a[1], t)


@numba.njit(cache=True)
def _pair_values(a, b, by_birth, births, lo, hi, stride, out):
    """Count the pairwise distances d with ``lo < d < hi``; store every ``stride``-th in
    ``out`` (enumeration order) when ``stride > 0``."""
    count = 0
    stored = 0
    for i in range(len(a)):
        first, last = _band(births, a[i, 0], hi)
        for s in range(first, last):
            j = by_birth[s]
            d = max(abs(a[i, 0] - b[j, 0]), abs(a[i, 1] - b[j, 1]))
            if lo < d < hi:
                if stride > 0 and count % stride == 0 and stored < len(out):
                    out[stored] = d
                    stored += 1
                count += 1
    return count


@numba.njit(cache=True)
def _search(a, b, sorted_a, sorted_b, values, lo, hi, gallop):
    """Narrow the bracket (lo infeasible, hi feasible) to neighbours among ``values``.

    With ``gallop``, thresholds just above ``lo`` are tried first at exponentially
    growing steps (the answer is usually a few candidates above the lower bound), then
    the last gap is bisected.
    """
    values = np.unique(values)
    left = np.searchsorted(values, lo, side="right")
    right = np.searchsorted(values, hi, side="left")  # values[left:right] are inside
    step = 1
    while gallop and left < right:
        probe = min(left + step - 1, right - 1)
        if _feasible(a, b, sorted_a, sorted_b, values[probe]):
            hi = values[probe]
            right = probe
            break
        lo = values[probe]
        left = probe + 1
        step *= 2
    while left < right:
        mid = (left + right) // 2
        if _feasible(a, b, sorted_a, sorted_b, values[mid]):
            hi = values[mid]
            right = mid
        else:
            lo = values[mid]
            left = mid + 1
    return lo, hi


_SAMPLE = 256
_COLLECT = 1 << 15


@numba.njit(cache=True)
def _lower_bound(a, b, by_birth, births):
    """max over the points of ``a`` of the cheapest move (to ``b`` or the diagonal):
    no threshold below it is feasible, and it is a candidate value itself."""
    bound = 0.0
    for i in range(len(a)):
        best = (a[i, 1] - a[i, 0]) / 2.0
        first, last = _band(births, a[i, 0], best)
        for s in range(first, last):
            j = by_birth[s]
            best = min(best, max(abs(a[i, 0] - b[j, 0]), abs(a[i, 1] - b[j, 1])))
        bound = max(bound, best)
    return bound


@numba.njit(cache=True)
def _one_sided_bottleneck(a, b):
    """Smallest ``t`` at which every point of ``a`` goes to a point of ``b`` or to the
    diagonal within ``t``, points of ``b`` used at most once (the diagonal of ``b``
    is ignored: by Mendelsohn-Dulmage, the bottleneck distance is the larger of the two
    one-sided values).

    Successive minimax augmenting paths: each point of ``a`` in turn joins the matching
    along the alternating path whose largest edge is smallest (Dijkstra with ``max`` in
    place of ``+``), and ``t`` is the largest of these. Optimal at every step: a
    matching of the points so far within the optimum ``B`` contains, with the current
    one (all edges <= t <= B), an augmenting path from the new point within ``B``.
    O(n^2 m) at worst, microseconds for the diagrams of real meshes.
    """
    n, m = len(a), len(b)
    row4col = np.full(m, -1, np.int64)
    col4row = np.full(n, -1, np.int64)
    key = np.empty(m)
    path = np.empty(m, np.int64)
    done = np.empty(m, np.bool_)
    t = 0.0
    for root in range(n):
        key[:] = np.inf
        done[:] = False
        best_diagonal = np.inf
        diagonal_row = -1
        i = root
        reach = 0.0  # largest edge on the way to row i
        while True:
            to_diagonal = max(reach, (a[i, 1] - a[i, 0]) / 2.0)
            if to_diagonal < best_diagonal:
                best_diagonal = to_diagonal
                diagonal_row = i
            lowest = np.inf
            column = -1
            for j in range(m):
                if done[j]:
                    continue
                c = max(reach, max(abs(a[i, 0] - b[j, 0]), abs(a[i, 1] - b[j, 1])))
                if c < key[j]:
                    key[j] = c
                    path[j] = i
                if key[j] < lowest or (key[j] == lowest and row4col[j] == -1):
                    lowest = key[j]
                    column = j
            if best_diagonal <= lowest:
                t = max(t, best_diagonal)
                r = diagonal_row
                j = col4row[r]
                col4row[r] = DIAGONAL
                if r == root:
                    break
            else:
                done[column] = True
                if row4col[column] >= 0:
                    i = row4col[column]
                    reach = lowest
                    continue
                t = max(t, lowest)
                j = column
            augment(path, row4col, col4row, j, root)
            break
    return t


# Below this many point pairs (300 x 300) the minimax augmenting paths beat the threshold
# search (benchmarks/bench_distances.py; figures in docs/distances.md).
SMALL_PAIRS = 90_000


@numba.njit(cache=True)
def bottleneck_small(a, b):
    """Exact bottleneck distance of two finite diagrams by minimax augmenting paths, the
    faster algorithm up to ``SMALL_PAIRS`` point pairs. Kept apart from the threshold
    search so that a matrix of small diagrams never compiles the latter."""
    return max(_one_sided_bottleneck(a, b), _one_sided_bottleneck(b, a))


@numba.njit(cache=True)
def bottleneck_finite(a, b):
    """Exact bottleneck distance of two finite diagrams of any size."""
    if len(a) * len(b) <= SMALL_PAIRS:
        return bottleneck_small(a, b)
    return _threshold_bottleneck(a, b)


@numba.njit(cache=True)
def _threshold_bottleneck(a, b):
    """Exact bottleneck distance of two finite diagrams, for large ones.

    The distance is one of the candidate values: 0, a half-persistence (point to the
    diagonal) or a pairwise L-infinity distance, and at least the largest cheapest move
    of a single point, which is often the answer and is tried first. Otherwise a binary
    search over the n + m diagonal candidates brackets it, and the pairwise candidates
    inside the bracket are narrowed by deterministic strided samples until few enough
    remain to sort, so memory stays O(n + m + 32k) instead of the n * m of a full
    candidate list. Every test of a threshold is a Hopcroft-Karp matching on the pairs
    within it, found through a band of births (geometric pruning).
    """
    n, m = len(a), len(b)
    order_a = np.argsort(a[:, 0], kind="mergesort")
    order_b = np.argsort(b[:, 0], kind="mergesort")
    sorted_a = (order_a, a[order_a, 0].copy())
    sorted_b = (order_b, b[order_b, 0].copy())
    lo = max(_lower_bound(a, b, *sorted_b), _lower_bound(b, a, *sorted_a))
    if _feasible(a, b, sorted_a, sorted_b, lo):
        return lo
    diagonal = np.empty(n + m)
    diagonal[:n] = (a[:, 1] - a[:, 0]) / 2.0
    diagonal[n:] = (b[:, 1] - b[:, 0]) / 2.0
    # Sending everything to the diagonal is feasible at the largest half-persistence.
    hi = diagonal.max()
    count = _pair_values(a, b, order_b, sorted_b[1], lo, hi, 0, diagonal[:0])
    if count > _COLLECT:
        lo, hi = _search(a, b, sorted_a, sorted_b, diagonal, lo, hi, False)
        count = _pair_values(a, b, order_b, sorted_b[1], lo, hi, 0, diagonal[:0])
    sample = np.empty(_SAMPLE)
    while count > _COLLECT:
        _pair_values(a, b, order_b, sorted_b[1], lo, hi, count // _SAMPLE, sample)
        lo, hi = _search(a, b, sorted_a, sorted_b, sample, lo, hi, False)
        count = _pair_values(a, b, order_b, sorted_b[1], lo, hi, 0, diagonal[:0])
    values = np.empty(count + n + m)
    _pair_values(a, b, order_b, sorted_b[1], lo, hi, 1, values)
    values[count:] = diagonal
    return _search(a, b, sorted_a, sorted_b, values, lo, hi, True)[1]


@numba.njit(cache=True)
def bottleneck_partners(a, b, t):
    """A matching of two finite diagrams that moves no point by more than ``t``.

    A maximum matching of the points of ``a`` that cannot go to the diagonal, then,
    for each such point of ``b`` left over, an alternating path that ends at a free
    point of ``a`` (augment) or at a matched point of ``b`` allowed on the diagonal
    (which gives up its partner). Neither step unmatches a point that needs a partner,
    and Mendelsohn-Dulmage guarantees the path exists when ``t`` is feasible.
    Returns the partner in ``b`` of each point of ``a`` (-1: the diagonal).
    """
    n, m = len(a), len(b)
    must_a = (a[:, 1] - a[:, 0]) / 2.0 > t
    must_b = (b[:, 1] - b[:, 0]) / 2.0 > t
    order_b = np.argsort(b[:, 0], kind="mergesort")
    births_b = b[order_b, 0].copy()
    every = np.arange(n)
    ptr, adj = _threshold_graph(a, b, order_b, births_b, every, t)
    # Hopcroft-Karp on the rows that must be matched.
    rows = np.flatnonzero(must_a)
    sub_ptr = np.zeros(len(rows) + 1, np.int64)
    for r in range(len(rows)):
        sub_ptr[r + 1] = sub_ptr[r] + ptr[rows[r] + 1] - ptr[rows[r]]
    sub_adj = np.empty(sub_ptr[-1], np.int64)
    for r in range(len(rows)):
        sub_adj[sub_ptr[r] : sub_ptr[r + 1]] = adj[ptr[rows[r]] : ptr[rows[r] + 1]]
    _, sub_left, _ = _max_matching(sub_ptr, sub_adj, len(rows), m)
    match_a = np.full(n, -1, np.int64)
    match_b = np.full(m, -1, np.int64)
    for r in range(len(rows)):
        if sub_left[r] >= 0:
            match_a[rows[r]] = sub_left[r]
            match_b[sub_left[r]] = rows[r]
    # Transpose: the points of a near each point of b.
    t_ptr = np.zeros(m + 1, np.int64)
    for e in range(len(adj)):
        t_ptr[adj[e] + 1] += 1
    for j in range(m):
        t_ptr[j + 1] += t_ptr[j]
    t_adj = np.empty(len(adj), np.int64)
    fill = t_ptr[:-1].copy()
    for i in range(n):
        for e in range(ptr[i], ptr[i + 1]):
            t_adj[fill[adj[e]]] = i
            fill[adj[e]] += 1
    seen = np.zeros(n, np.bool_)
    via = np.empty(n, np.int64)
    queue = np.empty(m, np.int64)
    for start in range(m):
        if not must_b[start] or match_b[start] >= 0:
            continue
        seen[:] = False
        head, tail = 0, 1
        queue[0] = start
        end = -1
        while head < tail and end < 0:
            j = queue[head]
            head += 1
            for e in range(t_ptr[j], t_ptr[j + 1]):
                i = t_adj[e]
                if seen[i]:
                    continue
                seen[i] = True
                via[i] = j
                mate = match_a[i]
                if mate < 0:
                    end = i
                    break
                if not must_b[mate]:
                    match_b[mate] = -1
                    end = i
                    break
                queue[tail] = mate
                tail += 1
        if end < 0:
            raise RuntimeError("no matching at the bottleneck threshold")
        i = end
        while True:
            j = via[i]
            previous = match_b[j]
            match_a[i] = j
            match_b[j] = i
            if j == start:
                break
            i = previous
    return match_a
