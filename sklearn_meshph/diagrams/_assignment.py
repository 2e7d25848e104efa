"""Pieces shared by the assignment solvers: augmenting an alternating path, a binary
heap, and a total order on diagrams that fixes the orientation of a pair."""

from __future__ import annotations

import numba

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
