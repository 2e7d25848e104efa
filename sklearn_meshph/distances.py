"""Exact bottleneck and Wasserstein distances between persistence diagrams."""

from __future__ import annotations

import numba
import numpy as np

from .diagrams import check_diagram

__all__ = ["bottleneck_distance", "wasserstein_distance"]


@numba.njit(cache=True)
def _max_matching(adj_ptr, adj, n_left, n_right):
    """Hopcroft-Karp maximum matching size of a bipartite graph in CSR form."""
    match_left = np.full(n_left, -1, np.int64)
    match_right = np.full(n_right, -1, np.int64)
    dist = np.empty(n_left, np.int64)
    queue = np.empty(n_left, np.int64)
    stack = np.empty(n_left + 1, np.int64)
    edge_pos = np.empty(n_left, np.int64)
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
            return size
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
def _covers(a, b, must_a, t):
    """Whether the points of ``a`` flagged ``must_a`` can all be matched into ``b``
    with L-infinity cost at most ``t``."""
    n_left = 0
    for i in range(len(a)):
        if must_a[i]:
            n_left += 1
    if n_left == 0:
        return True
    ptr = np.zeros(n_left + 1, np.int64)
    adj = np.empty(n_left * max(len(b), 1), np.int64)
    row = 0
    k = 0
    for i in range(len(a)):
        if not must_a[i]:
            continue
        for j in range(len(b)):
            d = max(abs(a[i, 0] - b[j, 0]), abs(a[i, 1] - b[j, 1]))
            if d <= t:
                adj[k] = j
                k += 1
        row += 1
        ptr[row] = k
    return _max_matching(ptr, adj, n_left, len(b)) == n_left


@numba.njit(cache=True)
def _bottleneck_finite(a, b):
    n, m = len(a), len(b)
    half_a = (a[:, 1] - a[:, 0]) / 2.0
    half_b = (b[:, 1] - b[:, 0]) / 2.0
    candidates = np.empty(n * m + n + m + 1, np.float64)
    k = 0
    for i in range(n):
        for j in range(m):
            candidates[k] = max(abs(a[i, 0] - b[j, 0]), abs(a[i, 1] - b[j, 1]))
            k += 1
    for i in range(n):
        candidates[k] = half_a[i]
        k += 1
    for j in range(m):
        candidates[k] = half_b[j]
        k += 1
    candidates[k] = 0.0
    values = np.unique(candidates)
    lo, hi = 0, len(values) - 1
    while lo < hi:
        mid = (lo + hi) // 2
        t = values[mid]
        # Mendelsohn-Dulmage: a matching covering the points that cannot go to the
        # diagonal on each side separately implies one covering both.
        if _covers(a, b, half_a > t, t) and _covers(b, a, half_b > t, t):
            hi = mid
        else:
            lo = mid + 1
    return values[lo]


@numba.njit(cache=True)
def assignment_cost(cost):
    """Minimum total cost of a perfect matching in a square cost matrix.

    Shortest augmenting paths with potentials (the Hungarian method, O(n^3)): exact.
    """
    n = cost.shape[0]
    u = np.zeros(n + 1)
    v = np.zeros(n + 1)
    match = np.zeros(n + 1, np.int64)  # row (1-based) matched to each column, 0: free
    way = np.zeros(n + 1, np.int64)
    slack = np.empty(n + 1)
    used = np.empty(n + 1, np.bool_)
    for i in range(1, n + 1):
        match[0] = i
        j0 = 0
        slack[:] = np.inf
        used[:] = False
        while True:
            used[j0] = True
            i0 = match[j0]
            delta = np.inf
            j1 = 0
            for j in range(1, n + 1):
                if not used[j]:
                    reduced = cost[i0 - 1, j - 1] - u[i0] - v[j]
                    if reduced < slack[j]:
                        slack[j] = reduced
                        way[j] = j0
                    if slack[j] < delta:
                        delta = slack[j]
                        j1 = j
            for j in range(n + 1):
                if used[j]:
                    u[match[j]] += delta
                    v[j] -= delta
                else:
                    slack[j] -= delta
            j0 = j1
            if match[j0] == 0:
                break
        while j0 != 0:
            j1 = way[j0]
            match[j0] = match[j1]
            j0 = j1
    total = 0.0
    for j in range(1, n + 1):
        total += cost[match[j] - 1, j - 1]
    return total


@numba.njit(cache=True)
def _precedes(a, b):
    """A total order on diagrams (size, then values), to fix argument order."""
    if len(a) != len(b):
        return len(a) < len(b)
    for i in range(len(a)):
        for k in range(2):
            if a[i, k] != b[i, k]:
                return a[i, k] < b[i, k]
    return True


@numba.njit(cache=True)
def _ground(dx, dy, internal_p):
    if np.isinf(internal_p):
        return max(dx, dy)
    return (dx**internal_p + dy**internal_p) ** (1.0 / internal_p)


@numba.njit(cache=True)
def _wasserstein_power(a, b, order, internal_p):
    """Optimal sum of cost^order over matchings of two finite diagrams."""
    if not _precedes(a, b):  # so that d(a, b) == d(b, a) bit for bit
        a, b = b, a
    if len(a) + len(b) == 0:
        return 0.0
    return assignment_cost(_augmented_costs(a, b, order, internal_p))


@numba.njit(cache=True)
def _augmented_costs(a, b, order, internal_p):
    """(n + m)-square costs: points to points, points to the diagonal, diagonal to itself."""
    n, m = len(a), len(b)
    diagonal = 1.0 if np.isinf(internal_p) else 2.0 ** (1.0 / internal_p)
    cost = np.zeros((n + m, n + m))
    for i in range(n):
        to_diagonal = ((a[i, 1] - a[i, 0]) / 2.0 * diagonal) ** order
        for j in range(m):
            dx = abs(a[i, 0] - b[j, 0])
            dy = abs(a[i, 1] - b[j, 1])
            cost[i, j] = _ground(dx, dy, internal_p) ** order
        for j in range(m, m + n):
            cost[i, j] = to_diagonal
    for j in range(m):
        to_diagonal = ((b[j, 1] - b[j, 0]) / 2.0 * diagonal) ** order
        for i in range(n, n + m):
            cost[i, j] = to_diagonal
    return cost


@numba.njit(cache=True)
def _sample_distance(pa, oa, ea, eoa, ia, pb, ob, eb, eob, ib, n_parts, metric, order, internal_p):
    """Distance between sample ``ia`` of one packed set and ``ib`` of another.

    Parts are compared position by position: the bottleneck distance is the maximum of
    the per-part distances, the Wasserstein distance the l_q norm of them.
    """
    total = 0.0
    for part in range(n_parts):
        da = ia * n_parts + part
        db = ib * n_parts + part
        a = pa[oa[da] : oa[da + 1]]
        b = pb[ob[db] : ob[db + 1]]
        essential_a = ea[eoa[da] : eoa[da + 1]]
        essential_b = eb[eob[db] : eob[db + 1]]
        if len(essential_a) != len(essential_b):
            return np.inf
        if metric == 0:
            d = _bottleneck_finite(a, b)
            for k in range(len(essential_a)):
                d = max(d, abs(essential_a[k] - essential_b[k]))
            total = max(total, d)
        else:
            total += _wasserstein_power(a, b, order, internal_p)
            for k in range(len(essential_a)):
                total += abs(essential_a[k] - essential_b[k]) ** order
    return total if metric == 0 else total ** (1.0 / order)


@numba.njit(cache=True)
def _pairs_kernel(left, right, rows, cols, n_parts, metric, order, internal_p):
    pa, oa, ea, eoa = left
    pb, ob, eb, eob = right
    out = np.empty(len(rows))
    for k in range(len(rows)):
        out[k] = _sample_distance(
            pa,
            oa,
            ea,
            eoa,
            rows[k],
            pb,
            ob,
            eb,
            eob,
            cols[k],
            n_parts,
            metric,
            order,
            internal_p,
        )
    return out


METRICS = {"bottleneck": 0, "wasserstein": 1}


def pack(samples) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Validated samples (tuples of diagrams) as four flat arrays for the kernels.

    Finite points of every diagram (sample-major, part-minor) with their offsets, and
    the sorted births of the essential points with theirs.
    """
    finite, essential = [], []
    for sample in samples:
        for diagram in sample:
            keep = np.isfinite(diagram[:, 1])
            finite.append(diagram[keep])
            essential.append(np.sort(diagram[~keep, 0]))
    offsets = np.concatenate([[0], np.cumsum([len(d) for d in finite])]).astype(np.int64)
    essential_offsets = np.concatenate([[0], np.cumsum([len(e) for e in essential])])
    points = np.ascontiguousarray(np.vstack(finite)) if finite else np.empty((0, 2))
    births = np.concatenate(essential) if essential else np.empty(0)
    return points, offsets, births.astype(np.float64), essential_offsets.astype(np.int64)


# Above this many points, scipy's C++ assignment solver beats the compiled Hungarian on
# the degenerate (tied) costs of the diagonal blocks.
_LARGE = 64


def _large_wasserstein(left, right, rows, cols, n_parts, order, internal_p):
    from scipy.optimize import linear_sum_assignment

    out = np.empty(len(rows))
    for k, (i, j) in enumerate(zip(rows, cols, strict=True)):
        total = 0.0
        for part in range(n_parts):
            da, db = i * n_parts + part, j * n_parts + part
            a = left[0][left[1][da] : left[1][da + 1]]
            b = right[0][right[1][db] : right[1][db + 1]]
            ea = left[2][left[3][da] : left[3][da + 1]]
            eb = right[2][right[3][db] : right[3][db + 1]]
            if len(ea) != len(eb):
                total = np.inf
                break
            if not _precedes(a, b):
                a, b = b, a
            cost = _augmented_costs(a, b, order, internal_p)
            r, c = linear_sum_assignment(cost)
            total += float(cost[r, c].sum()) + float(np.sum(np.abs(ea - eb) ** order))
        out[k] = total ** (1.0 / order)
    return out


def pair_distances(left, right, rows, cols, n_parts, metric, order=2.0, internal_p=np.inf):
    """Distances of the sample pairs ``(rows[k], cols[k])`` of two packed sets."""
    largest = max(np.diff(left[1]).max(initial=0), np.diff(right[1]).max(initial=0))
    if metric == "wasserstein" and largest > _LARGE:
        return _large_wasserstein(left, right, rows, cols, n_parts, float(order), float(internal_p))
    return _pairs_kernel(
        left,
        right,
        np.asarray(rows, dtype=np.int64),
        np.asarray(cols, dtype=np.int64),
        n_parts,
        METRICS[metric],
        float(order),
        float(internal_p),
    )


def _one_pair(a, b, metric, order=2.0, internal_p=np.inf) -> float:
    a, b = check_diagram(a, index=0), check_diagram(b, index=1)
    zero = np.zeros(1, dtype=np.int64)
    return float(
        pair_distances(pack([(a,)]), pack([(b,)]), zero, zero, 1, metric, order, internal_p)[0]
    )


def bottleneck_distance(a, b) -> float:
    """Exact bottleneck distance between two persistence diagrams (L-infinity ground).

    Parameters
    ----------
    a, b : array-like of shape (n, 2) and (m, 2)
        Rows (birth, death); death may be ``inf``. Empty diagrams, repeated points and
        points on the diagonal are valid.

    Returns
    -------
    float
        ``inf`` when the numbers of essential (infinite) points differ; otherwise the
        smallest ``t`` such that a matching of the points to each other or to the
        diagonal moves no point by more than ``t`` in the L-infinity norm (essential
        points matched among themselves by sorted birth).

    See Also
    --------
    wasserstein_distance, DiagramDistance

    Examples
    --------
    >>> from sklearn_meshph import bottleneck_distance
    >>> bottleneck_distance([[0.0, 1.0]], [[0.0, 1.25], [0.5, 0.75]])
    0.25
    >>> bottleneck_distance([], [[0.5, 1.0]])
    0.25
    """
    return _one_pair(a, b, "bottleneck")


def wasserstein_distance(a, b, order: float = 2.0, internal_p: float = np.inf) -> float:
    """Exact q-Wasserstein distance between two persistence diagrams.

    Parameters
    ----------
    a, b : array-like of shape (n, 2) and (m, 2)
    order : float, default=2.0
        The exponent q >= 1.
    internal_p : float, default=inf
        Ground metric between points: the L-p norm (``inf``: L-infinity, as in the
        paper). The distance of a point to the diagonal is that to its projection.

    Returns
    -------
    float
        ``(min over matchings of sum cost^q)^(1/q)``, solved exactly as an assignment
        problem (no approximation); ``inf`` when the numbers of essential points differ.

    See Also
    --------
    bottleneck_distance, DiagramDistance

    Examples
    --------
    >>> from sklearn_meshph import wasserstein_distance
    >>> wasserstein_distance([[0.0, 1.0]], [[0.0, 1.25], [0.5, 0.75]], order=1.0)
    0.375
    """
    if not order >= 1:
        raise ValueError(f"order must be at least 1, got {order}")
    if not internal_p >= 1:
        raise ValueError(f"internal_p must be at least 1, got {internal_p}")
    return _one_pair(a, b, "wasserstein", order, internal_p)
