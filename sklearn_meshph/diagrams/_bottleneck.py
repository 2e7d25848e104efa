"""Compiled exact bottleneck distance between two finite diagrams, and its matching.

Two algorithms, both exact: successive minimax augmenting paths for small diagrams, and
for larger ones a search over the candidate values, each tested by a maximum matching
(:mod:`._matching`) of the pairs within the threshold.
"""

from __future__ import annotations

import numba
import numpy as np

from ._assignment import DIAGONAL, augment, collapse, transpose
from ._kdtree import STACK, build, nearest, within
from ._matching import breadth_first, max_flow, max_matching


@numba.njit(cache=True)
def _threshold_graph(a, b, tree_b, rows, t):
    """CSR graph from ``a[rows]`` to the points of ``b`` within L-infinity ``t``, found
    through the 2-d tree of ``b`` (ties and clusters cost nothing more). Counted first,
    then filled: the graph is the only large allocation of a threshold test."""
    ptr = np.zeros(len(rows) + 1, np.int64)
    near = np.empty(len(b), np.int64)
    stack = np.empty(STACK, np.int64)
    for r in range(len(rows)):
        i = rows[r]
        ptr[r + 1] = ptr[r] + within(tree_b, b, a[i, 0], a[i, 1], t, near, stack)
    adj = np.empty(ptr[-1], np.int64)
    for r in range(len(rows)):
        i = rows[r]
        within(tree_b, b, a[i, 0], a[i, 1], t, adj[ptr[r] : ptr[r + 1]], stack)
    return ptr, adj


@numba.njit(cache=True)
def _covers(a, count_a, b, count_b, tree_b, t, guess):
    """Whether the points of ``a`` that cannot go to the diagonal at ``t`` can all be
    matched into ``b`` with L-infinity cost at most ``t``. Empty counts: every point
    once (Hopcroft-Karp, started from and updating ``guess``, the partner in ``b`` of
    each point of ``a`` at the previous test); otherwise points with multiplicities (a
    flow)."""
    rows = np.flatnonzero((a[:, 1] - a[:, 0]) / 2.0 > t)
    if len(rows) == 0:
        return True
    if len(count_a) == 0:
        if len(rows) > len(b):
            return False
        ptr, adj = _threshold_graph(a, b, tree_b, rows, t)
        size, match_left, _ = max_matching(ptr, adj, len(rows), len(b), guess[rows])
        guess[rows] = match_left
        return size == len(rows)
    demand = count_a[rows]
    if demand.sum() > count_b.sum():
        return False
    ptr, adj = _threshold_graph(a, b, tree_b, rows, t)
    return max_flow(ptr, adj, demand, count_b) == demand.sum()


@numba.njit(cache=True)
def _feasible(a, count_a, b, count_b, tree_a, tree_b, t, guess_a, guess_b):
    """Whether some matching moves no point by more than ``t`` (L-infinity).

    Mendelsohn-Dulmage: a matching covering the points of ``a`` that cannot go to the
    diagonal and one covering those of ``b`` imply one covering both (with
    multiplicities too: split each point into its copies).
    """
    return _covers(a, count_a, b, count_b, tree_b, t, guess_a) and _covers(
        b, count_b, a, count_a, tree_a, t, guess_b
    )


@numba.njit(cache=True)
def _pair_values(a, b, tree_b, lo, hi, stride, out):
    """Count the pairwise distances d with ``lo < d < hi``; store every ``stride``-th
    in ``out`` (enumeration order) when ``stride > 0``."""
    near = np.empty(len(b), np.int64)
    stack = np.empty(STACK, np.int64)
    count = 0
    stored = 0
    for i in range(len(a)):
        found = within(tree_b, b, a[i, 0], a[i, 1], hi, near, stack)
        for s in range(found):
            j = near[s]
            d = max(abs(a[i, 0] - b[j, 0]), abs(a[i, 1] - b[j, 1]))
            if lo < d < hi:
                if stride > 0 and count % stride == 0 and stored < len(out):
                    out[stored] = d
                    stored += 1
                count += 1
    return count


@numba.njit(cache=True)
def _first_feasible(a, count_a, b, count_b, tree_a, tree_b, values, guess_a, guess_b):
    """The smallest of the sorted ``values`` that is feasible, the last one being so:
    thresholds just above the bracket's start are tried first at exponentially growing
    steps (the answer is usually among the first candidates), then the gap is bisected,
    so the matching tests stay on sparse graphs."""
    left, right = 0, len(values) - 1  # values[right] is feasible
    step = 1
    while left < right:
        probe = min(left + step - 1, right - 1)
        if _feasible(a, count_a, b, count_b, tree_a, tree_b, values[probe], guess_a, guess_b):
            right = probe
            break
        left = probe + 1
        step *= 2
    while left < right:
        middle = (left + right) // 2
        if _feasible(a, count_a, b, count_b, tree_a, tree_b, values[middle], guess_a, guess_b):
            right = middle
        else:
            left = middle + 1
    return values[right]


_SAMPLE = 256
_COLLECT = 1 << 15


@numba.njit(cache=True)
def _lower_bound(a, b, tree_b):
    """max over the points of ``a`` of the cheapest move (to ``b`` or the diagonal):
    no threshold below it is feasible, and it is a candidate value itself."""
    best_g = np.empty(1)
    best_j = np.empty(1, np.int64)
    stack = np.empty(STACK, np.int64)
    bound = 0.0
    for i in range(len(a)):
        best = (a[i, 1] - a[i, 0]) / 2.0
        if nearest(tree_b, b, a[i, 0], a[i, 1], 1, np.inf, best_g, best_j, stack):
            best = min(best, best_g[0])
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
    """Exact bottleneck distance of two large finite diagrams: on their distinct points
    with multiplicities when at least half of the points are copies, else as they are."""
    distinct_a, _, count_a = collapse(a)
    distinct_b, _, count_b = collapse(b)
    if 2 * (len(distinct_a) + len(distinct_b)) <= len(a) + len(b):
        return _threshold_search(distinct_a, count_a, distinct_b, count_b)
    none = np.empty(0, np.int64)
    return _threshold_search(a, none, b, none)


@numba.njit(cache=True)
def _threshold_search(a, count_a, b, count_b):
    """Exact bottleneck distance of two finite diagrams, for large ones.

    The distance is one of the candidate values: 0, a half-persistence (point to the
    diagonal) or a pairwise L-infinity distance, and at least the largest cheapest move
    of a single point, which is often the answer and is tried first. Otherwise the
    thresholds ``lo * 2^k`` bracket it within a factor of two, and the candidates
    inside are narrowed by deterministic strided samples until few enough remain to
    sort. Every test of a threshold is a matching (Hopcroft-Karp, or a flow when
    ``count_a`` and ``count_b`` give multiplicities) on the pairs within it, found
    through 2-d trees, so the tests stay on graphs about as sparse as the answer's, and
    memory stays O(n + m + 32k) plus those graphs however the points tie or cluster.
    """
    tree_a, tree_b = build(a), build(b)
    guess_a = np.full(len(a), -1, np.int64)
    guess_b = np.full(len(b), -1, np.int64)
    lo = max(_lower_bound(a, b, tree_b), _lower_bound(b, a, tree_a))
    if _feasible(a, count_a, b, count_b, tree_a, tree_b, lo, guess_a, guess_b):
        return lo
    # Sending everything to the diagonal is feasible at the largest half-persistence.
    hi = max(np.max((a[:, 1] - a[:, 0]) / 2.0), np.max((b[:, 1] - b[:, 0]) / 2.0))
    # A feasible threshold within a factor 2 of an infeasible one.
    if lo == 0.0:  # every point has a copy across or lies on the diagonal
        start = hi * 2.0**-60
        if _feasible(a, count_a, b, count_b, tree_a, tree_b, start, guess_a, guess_b):
            hi = start
        else:
            lo = start
    if lo > 0.0:
        # Doubling, not faster: a feasible probe costs a graph as large as its
        # threshold's, so it should not overshoot the answer by more than 2.
        while 2.0 * lo < hi:
            if _feasible(a, count_a, b, count_b, tree_a, tree_b, 2.0 * lo, guess_a, guess_b):
                hi = 2.0 * lo
                break
            lo *= 2.0
    # The answer is the smallest feasible candidate in (lo, hi]: hi itself, or one of
    # the candidates strictly below it. Strided samples of those narrow the bracket
    # until few remain; excluding hi keeps ties (integer-valued diagrams, where many
    # pairs share each distance) from stalling the narrowing.
    diagonal = np.empty(len(a) + len(b))
    diagonal[: len(a)] = (a[:, 1] - a[:, 0]) / 2.0
    diagonal[len(a) :] = (b[:, 1] - b[:, 0]) / 2.0
    count = _pair_values(a, b, tree_b, lo, hi, 0, diagonal[:0])
    sample = np.empty(_SAMPLE + 1)
    while count > _COLLECT:
        _pair_values(a, b, tree_b, lo, hi, count // _SAMPLE, sample)
        sample[_SAMPLE] = hi
        values = np.unique(sample)
        found = _first_feasible(a, count_a, b, count_b, tree_a, tree_b, values, guess_a, guess_b)
        below = np.searchsorted(values, found) - 1
        if below >= 0:
            lo = values[below]
        hi = found
        count = _pair_values(a, b, tree_b, lo, hi, 0, diagonal[:0])
    diagonal = diagonal[(diagonal > lo) & (diagonal < hi)]
    values = np.empty(count + len(diagonal) + 1)
    _pair_values(a, b, tree_b, lo, hi, 1, values)
    values[count : count + len(diagonal)] = diagonal
    values[-1] = hi
    return _first_feasible(
        a, count_a, b, count_b, tree_a, tree_b, np.unique(values), guess_a, guess_b
    )


@numba.njit(cache=True)
def _free_or_optional(j, e, i, queue, tail, state):
    """``bottleneck_partners``: point ``i`` of ``a`` reached from point ``j`` of ``b``
    ends the path when it is free, or when its partner may go to the diagonal (which
    then gives it up); otherwise the search goes on from its partner."""
    via, match_a, match_b, must_b = state
    via[i] = j
    mate = match_a[i]
    if mate < 0:
        return True, tail
    if not must_b[mate]:
        match_b[mate] = -1
        return True, tail
    queue[tail] = mate
    return False, tail + 1


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
    ptr, adj = _threshold_graph(a, b, build(b), np.arange(n), t)
    # Hopcroft-Karp on the rows that must be matched.
    rows = np.flatnonzero(must_a)
    sub_ptr = np.zeros(len(rows) + 1, np.int64)
    for r in range(len(rows)):
        sub_ptr[r + 1] = sub_ptr[r] + ptr[rows[r] + 1] - ptr[rows[r]]
    sub_adj = np.empty(sub_ptr[-1], np.int64)
    for r in range(len(rows)):
        sub_adj[sub_ptr[r] : sub_ptr[r + 1]] = adj[ptr[rows[r]] : ptr[rows[r] + 1]]
    _, sub_left, _ = max_matching(sub_ptr, sub_adj, len(rows), m, np.full(len(rows), -1))
    match_a = np.full(n, -1, np.int64)
    match_b = np.full(m, -1, np.int64)
    for r in range(len(rows)):
        if sub_left[r] >= 0:
            match_a[rows[r]] = sub_left[r]
            match_b[sub_left[r]] = rows[r]
    # Transpose: the points of a near each point of b.
    row_of, t_ptr, t_edge = transpose(ptr, adj, m)
    t_adj = row_of[t_edge]
    seen = np.zeros(n, np.bool_)
    via = np.empty(n, np.int64)
    queue = np.empty(m, np.int64)
    for start in range(m):
        if not must_b[start] or match_b[start] >= 0:
            continue
        seen[:] = False
        queue[0] = start
        state = (via, match_a, match_b, must_b)
        end = breadth_first(t_ptr, t_adj, queue, 1, seen, _free_or_optional, state)
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
