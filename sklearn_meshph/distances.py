"""Exact bottleneck and Wasserstein distances between persistence diagrams."""

from __future__ import annotations

import numba
import numpy as np
from scipy.optimize import linear_sum_assignment

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


def _split(diagram):
    finite = np.isfinite(diagram[:, 1])
    return diagram[finite], np.sort(diagram[~finite, 0])


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

    Examples
    --------
    >>> from sklearn_meshph import bottleneck_distance
    >>> bottleneck_distance([[0.0, 1.0]], [[0.0, 1.25], [0.5, 0.75]])
    0.25
    >>> bottleneck_distance([], [[0.5, 1.0]])
    0.25
    """
    a, b = check_diagram(a, index=0), check_diagram(b, index=1)
    return _bottleneck_checked(a, b)


def _bottleneck_checked(a, b) -> float:
    fa, ea = _split(a)
    fb, eb = _split(b)
    if len(ea) != len(eb):
        return np.inf
    essential = float(np.max(np.abs(ea - eb))) if len(ea) else 0.0
    return max(essential, float(_bottleneck_finite(fa, fb)))


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
    """
    a, b = check_diagram(a, index=0), check_diagram(b, index=1)
    return _wasserstein_checked(a, b, float(order), float(internal_p))


def _to_diagonal(points, internal_p):
    half = (points[:, 1] - points[:, 0]) / 2.0
    if np.isinf(internal_p):
        return half
    return half * 2.0 ** (1.0 / internal_p)


def _wasserstein_checked(a, b, order, internal_p) -> float:
    # Rounding in the assignment's sum depends on the argument order: fix one, so that
    # d(a, b) == d(b, a) bit for bit.
    if (len(a), a.tobytes()) > (len(b), b.tobytes()):
        a, b = b, a
    fa, ea = _split(a)
    fb, eb = _split(b)
    if len(ea) != len(eb):
        return np.inf
    total = float(np.sum(np.abs(ea - eb) ** order))
    n, m = len(fa), len(fb)
    if n + m:
        diff = np.abs(fa[:, None, :] - fb[None, :, :])
        if np.isinf(internal_p):
            ground = diff.max(axis=2)
        else:
            ground = (diff**internal_p).sum(axis=2) ** (1.0 / internal_p)
        cost = np.zeros((n + m, n + m))
        cost[:n, :m] = ground**order
        cost[:n, m:] = (_to_diagonal(fa, internal_p) ** order)[:, None]
        cost[n:, :m] = (_to_diagonal(fb, internal_p) ** order)[None, :]
        rows, cols = linear_sum_assignment(cost)
        total += float(cost[rows, cols].sum())
    return total ** (1.0 / order)
