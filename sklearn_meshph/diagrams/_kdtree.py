"""A compiled 2-d tree over the points of a diagram: nearest neighbours and pruned scans.

The exact distances of large diagrams look at a few neighbours of each point instead of
every pair. Neighbours are found through this tree rather than a band of sorted births,
because a band is everything when many points share a birth (diagrams of functions with
plateaus, integer values, Rips H0 diagrams whose births are all 0): the tree splits
each box across its wider side at the median index, so ties and clusters cost nothing
more than spread points. Boxes bound the L-infinity distance from below, and every
ground metric the solvers use (L-p, p >= 1) is at least that.
"""

from __future__ import annotations

import numba
import numpy as np

LEAF = 8


@numba.njit(cache=True)
def build(points):
    """The tree of ``points`` (m, 2): ``(order, start, stop, left, box)``.

    Node ``k`` holds ``order[start[k]:stop[k]]``; ``left[k]`` is its first child (the
    second is ``left[k] + 1``) or -1 for a leaf; ``box[k]`` is ``(x0, x1, y0, y1)``.
    Children come after their parent, so a backward pass over the nodes is bottom-up.
    """
    m = len(points)
    capacity = 4 * (m // LEAF) + 8
    order = np.arange(m)
    start = np.empty(capacity, np.int64)
    stop = np.empty(capacity, np.int64)
    left = np.full(capacity, -1, np.int64)
    box = np.empty((capacity, 4))
    start[0], stop[0] = 0, m
    n_nodes = 1
    pending = np.empty(capacity, np.int64)
    pending[0] = 0
    top = 1
    while top > 0:
        top -= 1
        k = pending[top]
        s, e = start[k], stop[k]
        x0 = y0 = np.inf
        x1 = y1 = -np.inf
        for r in range(s, e):
            p = order[r]
            x0, x1 = min(x0, points[p, 0]), max(x1, points[p, 0])
            y0, y1 = min(y0, points[p, 1]), max(y1, points[p, 1])
        box[k, 0], box[k, 1], box[k, 2], box[k, 3] = x0, x1, y0, y1
        if e - s <= LEAF:
            continue
        axis = 0 if x1 - x0 >= y1 - y0 else 1
        piece = order[s:e].copy()
        ranked = np.argsort(points[piece, axis], kind="mergesort")
        order[s:e] = piece[ranked]
        middle = (s + e) // 2
        left[k] = n_nodes
        start[n_nodes], stop[n_nodes] = s, middle
        start[n_nodes + 1], stop[n_nodes + 1] = middle, e
        pending[top] = n_nodes
        pending[top + 1] = n_nodes + 1
        top += 2
        n_nodes += 2
    return order, start[:n_nodes], stop[:n_nodes], left[:n_nodes], box[:n_nodes]


@numba.njit(cache=True, inline="always")
def ground(dx, dy, internal_p):
    """The L-p norm of ``(dx, dy)``, without overflow or underflow for large ``p``."""
    if internal_p == np.inf:
        return max(dx, dy)
    if internal_p == 2.0:
        return np.hypot(dx, dy)
    if internal_p == 1.0:
        return dx + dy
    big = max(dx, dy)
    if big == 0.0:
        return 0.0
    return big * ((dx / big) ** internal_p + (dy / big) ** internal_p) ** (1.0 / internal_p)


@numba.njit(cache=True, inline="always")
def box_gap(box, k, x, y):
    """L-infinity distance from ``(x, y)`` to node ``k``'s box (0 inside)."""
    dx = max(box[k, 0] - x, x - box[k, 1], 0.0)
    dy = max(box[k, 2] - y, y - box[k, 3], 0.0)
    return max(dx, dy)


@numba.njit(cache=True)
def node_maxima(tree, weights):
    """The largest of ``weights`` (one per point) in each node, bottom-up."""
    order, start, stop, left, _ = tree
    out = np.empty(len(start))
    for k in range(len(start) - 1, -1, -1):
        if left[k] < 0:
            best = -np.inf
            for r in range(start[k], stop[k]):
                best = max(best, weights[order[r]])
            out[k] = best
        else:
            out[k] = max(out[left[k]], out[left[k] + 1])
    return out


@numba.njit(cache=True, inline="always")
def depth_first(tree, stack, skip, first_child, leaf, state):
    """Visit the leaves of ``tree`` depth-first from the root.

    A node for which ``skip(box, node, count, state)`` holds is passed over with
    everything below it; of an inner node's children ``left`` and ``left + 1``, child
    ``left + first_child(box, left, state)`` is visited first; ``leaf(order, s, e,
    count, state)`` sees the points ``order[s:e]`` of each leaf reached and returns the
    new ``count`` (of the points it kept, from 0), which the descent returns. ``state``
    is the caller's (a tuple): what the three functions read and write. Inlined into
    each caller, which compiles it with its own functions.
    """
    order, start, stop, left, box = tree
    count = 0
    stack[0] = 0
    top = 1
    while top > 0:
        top -= 1
        node = stack[top]
        if skip(box, node, count, state):
            continue
        if left[node] >= 0:
            first = first_child(box, left[node], state)
            stack[top] = left[node] + 1 - first
            stack[top + 1] = left[node] + first
            top += 2
            continue
        count = leaf(order, start[node], stop[node], count, state)
    return count


@numba.njit(cache=True)
def _beyond_the_kth(box, node, count, state):
    """``nearest``: the node cannot hold a point nearer than the k-th found so far."""
    _, x, y, k, _, best_g, _ = state
    return count == k and box_gap(box, node, x, y) >= best_g[k - 1]


@numba.njit(cache=True)
def _nearer_child(box, first, state):
    """``nearest``: the child whose box is nearer first (the first one on a tie)."""
    x, y = state[1], state[2]
    return 1 if box_gap(box, first + 1, x, y) < box_gap(box, first, x, y) else 0


@numba.njit(cache=True)
def _keep_nearest(order, s, e, count, state):
    """``nearest``: insert the leaf's points among the k nearest found so far."""
    points, x, y, k, internal_p, best_g, best_j = state
    for r in range(s, e):
        j = order[r]
        g = ground(abs(x - points[j, 0]), abs(y - points[j, 1]), internal_p)
        if count == k and g >= best_g[k - 1]:
            continue
        pos = count if count < k else k - 1
        while pos > 0 and best_g[pos - 1] > g:
            best_g[pos] = best_g[pos - 1]
            best_j[pos] = best_j[pos - 1]
            pos -= 1
        best_g[pos] = g
        best_j[pos] = j
        count = min(count + 1, k)
    return count


@numba.njit(cache=True)
def nearest(tree, points, x, y, k, internal_p, best_g, best_j, stack):
    """The ``k`` points nearest to ``(x, y)`` in the L-``internal_p`` metric, by
    increasing distance (ties in the order the tree meets them) in ``best_g`` and
    ``best_j``; returns how many (fewer when there are fewer points)."""
    state = (points, x, y, k, internal_p, best_g, best_j)
    return depth_first(tree, stack, _beyond_the_kth, _nearer_child, _keep_nearest, state)


@numba.njit(cache=True)
def _beyond_reach(box, node, count, state):
    """``within``: the node's box is farther than the reach."""
    return box_gap(box, node, state[1], state[2]) > state[3]


@numba.njit(cache=True)
def left_first(box, first, state):
    """Children in the order of the tree: the left one first."""
    return 0


@numba.njit(cache=True)
def right_first(box, first, state):
    """Children in reverse order of the tree: the right one first."""
    return 1


@numba.njit(cache=True)
def _keep_within(order, s, e, count, state):
    """``within``: append the leaf's points within the reach."""
    points, x, y, reach, out = state
    for r in range(s, e):
        j = order[r]
        if max(abs(x - points[j, 0]), abs(y - points[j, 1])) <= reach:
            out[count] = j
            count += 1
    return count


@numba.njit(cache=True)
def within(tree, points, x, y, reach, out, stack):
    """The points at L-infinity distance at most ``reach`` from ``(x, y)``, in tree
    order, written to ``out``; returns how many."""
    state = (points, x, y, reach, out)
    return depth_first(tree, stack, _beyond_reach, left_first, _keep_within, state)


# Depth-first stacks never hold more than two nodes per level of a tree.
STACK = 256
