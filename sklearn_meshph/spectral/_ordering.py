"""Geometric nested dissection: a fill-reducing order for sparse factorizations on meshes.

Recursively cut the vertex set by a plane through the median of its projection on one
direction, and number the shorter boundary of the cut (a vertex separator) last. Surface
meshes have separators of about sqrt(n) vertices along such planes, so the factor of a
mesh Laplacian ordered this way has near-linear fill, as with METIS, while the ordering
costs O(n log n) with no graph partitioner (timings in ``docs/eigenfunctions.md``).
"""

import numba
import numpy as np

__all__ = ["geometric_nested_dissection"]


@numba.njit(cache=True)
def _directions(points, ids, start, stop, all_directions):
    """Candidate cut directions: the longest side of the set's bounding box, or with
    ``all_directions`` the three coordinate axes."""
    if all_directions:
        return np.eye(3)
    low = np.full(3, np.inf)
    high = np.full(3, -np.inf)
    for k in range(start, stop):
        for axis in range(3):
            c = points[ids[k], axis]
            low[axis] = min(low[axis], c)
            high[axis] = max(high[axis], c)
    out = np.zeros((1, 3))
    out[0, np.argmax(high - low)] = 1.0
    return out


@numba.njit(cache=True)
def _split(points, ids, start, stop, direction, coords, label, left, right):
    """Label the set ``left`` / ``right`` of the median of its projection on
    ``direction`` (ties alternate, so both sides are non-empty)."""
    size = stop - start
    d0, d1, d2 = direction[0], direction[1], direction[2]
    for k in range(size):
        v = ids[start + k]
        coords[k] = points[v, 0] * d0 + points[v, 1] * d1 + points[v, 2] * d2
    median = np.median(coords[:size])
    tie = 0
    for k in range(size):
        c = coords[k]
        if c < median or (c == median and tie % 2 == 0):
            label[ids[start + k]] = left
        else:
            label[ids[start + k]] = right
        if c == median:
            tie += 1


@numba.njit(cache=True)
def _boundary(ids, start, stop, indptr, indices, label, side, other, out):
    """Number of vertices labelled ``side`` with a neighbour labelled ``other``; they are
    written to ``out`` unless it is empty."""
    count = 0
    for k in range(start, stop):
        v = ids[k]
        if label[v] != side:
            continue
        for e in range(indptr[v], indptr[v + 1]):
            if label[indices[e]] == other:
                if len(out):
                    out[count] = v
                count += 1
                break
    return count


@numba.njit(cache=True)
def geometric_nested_dissection(points, indptr, indices, leaf_size=16, try_all=4096):
    """Fill-reducing permutation of the vertices of a mesh graph.

    Parameters
    ----------
    points : ndarray of shape (n, 3)
        Vertex coordinates.
    indptr, indices : ndarray
        CSR adjacency of the graph (no self loops needed).
    leaf_size : int
        Sets this small are numbered as they come.
    try_all : int
        Sets larger than this try cuts across the three coordinate axes and keep the
        shortest; smaller ones cut across the longest side of their bounding box.

    Returns
    -------
    ndarray of shape (n,), int64
        ``perm[k]`` is the vertex numbered ``k``.
    """
    n = len(points)
    perm = np.empty(n, np.int64)
    ids = np.arange(n)
    label = np.zeros(n, np.int64)
    scratch = np.empty(n, np.int64)
    coords = np.empty(n)
    none = scratch[:0]  # _boundary only counts
    # Stack of sets: ids[start:stop], numbered from position lo, all labelled lab.
    stack = np.empty((2 * n + 2, 4), np.int64)
    stack[0] = (0, n, 0, 0)
    top = 1
    next_label = 1
    while top > 0:
        top -= 1
        start, stop, lo, lab = stack[top]
        size = stop - start
        if size <= leaf_size:
            perm[lo : lo + size] = ids[start:stop]
            continue
        left, right = next_label, next_label + 1
        next_label += 2
        directions = _directions(points, ids, start, stop, size > try_all)
        best, best_cut = 0, n + 1
        if len(directions) > 1:
            for d in range(len(directions)):
                _split(points, ids, start, stop, directions[d], coords, label, left, right)
                cut = min(
                    _boundary(ids, start, stop, indptr, indices, label, left, right, none),
                    _boundary(ids, start, stop, indptr, indices, label, right, left, none),
                )
                if cut < best_cut:
                    best, best_cut = d, cut
        _split(points, ids, start, stop, directions[best], coords, label, left, right)
        # The shorter boundary becomes the separator, numbered last.
        if _boundary(ids, start, stop, indptr, indices, label, left, right, none) < _boundary(
            ids, start, stop, indptr, indices, label, right, left, none
        ):
            cut, other = left, right
        else:
            cut, other = right, left
        n_sep = _boundary(ids, start, stop, indptr, indices, label, cut, other, scratch)
        for k in range(n_sep):
            perm[lo + size - 1 - k] = scratch[k]
            label[scratch[k]] = -1
        # Left vertices first, then the rest of the right ones.
        n_left = 0
        n_right = 0
        for k in range(start, stop):
            v = ids[k]
            if label[v] == left:
                ids[start + n_left] = v  # never ahead of the read position
                n_left += 1
            elif label[v] == right:
                scratch[n_right] = v
                n_right += 1
        ids[start + n_left : start + n_left + n_right] = scratch[:n_right]
        if n_left > 0:
            stack[top] = (start, start + n_left, lo, left)
            top += 1
        if n_right > 0:
            stack[top] = (start + n_left, start + n_left + n_right, lo + n_left, right)
            top += 1
    return perm
