"""Compiled loops of the vectorizers over a block of diagrams, packed as one array of
points and the offsets of each diagram's rows."""

from __future__ import annotations

import math

import numba
import numpy as np

__all__ = ["betti_curves", "images", "landscapes", "pack_points", "silhouettes"]


def pack_points(diagrams) -> tuple[np.ndarray, np.ndarray]:
    """All rows of ``diagrams`` in one ``(N, 2)`` array, and ``offsets`` such that the
    rows of diagram ``i`` are ``offsets[i]:offsets[i + 1]``."""
    sizes = np.array([len(d) for d in diagrams], dtype=np.int64)
    offsets = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
    points = np.concatenate([np.asarray(d, np.float64) for d in diagrams] + [np.empty((0, 2))])
    return np.ascontiguousarray(points), offsets


@numba.njit(cache=True)
def _gaussian_factors(center, nodes, bandwidth, pixel, out):  # pragma: no cover - compiled
    """One axis of a separable Gaussian: its values at ``nodes`` or, for pixels, its
    mass between consecutive ``nodes`` (the pixel edges)."""
    if pixel:
        scale = bandwidth * math.sqrt(2.0)
        previous = 0.5 * math.erfc(-(nodes[0] - center) / scale)
        for j in range(len(out)):
            current = 0.5 * math.erfc(-(nodes[j + 1] - center) / scale)
            out[j] = current - previous
            previous = current
    else:
        two_var = 2.0 * bandwidth * bandwidth
        for j in range(len(out)):
            out[j] = math.exp(-((center - nodes[j]) ** 2) / two_var)


@numba.njit(cache=True)
def images(points, weights, offsets, xs, ys, bandwidth, pixel):  # pragma: no cover - compiled
    """Gaussian persistence images, one row per diagram (rows of the image: persistence,
    columns: birth), points in (birth, persistence) coordinates. ``pixel=False``: the
    density at the grid ``ys x xs``; ``pixel=True``: its mass in each pixel, ``xs`` and
    ``ys`` being the pixel edges. The Gaussian is separable, so each point costs one
    pass over each axis and one outer product."""
    rx = len(xs) - 1 if pixel else len(xs)
    ry = len(ys) - 1 if pixel else len(ys)
    n = len(offsets) - 1
    out = np.zeros((n, ry * rx))
    scale = 1.0 if pixel else 1.0 / (2.0 * np.pi * bandwidth * bandwidth)
    ex = np.empty(rx)
    ey = np.empty(ry)
    for d in range(n):
        for p in range(offsets[d], offsets[d + 1]):
            _gaussian_factors(points[p, 0], xs, bandwidth, pixel, ex)
            _gaussian_factors(points[p, 1], ys, bandwidth, pixel, ey)
            w = weights[p] * scale
            for i in range(ry):
                wy = w * ey[i]
                for j in range(rx):
                    out[d, i * rx + j] += wy * ex[j]
    return out


@numba.njit(cache=True)
def landscapes(points, offsets, grid, k):  # pragma: no cover - compiled
    """The ``k`` largest tent functions ``max(0, (d - b) / 2 - |x - (b + d) / 2|)`` at
    each grid point, landscape-major (``k`` blocks of ``len(grid)``), times ``sqrt 2``
    (the tents measured along the diagonal, as gudhi's)."""
    n, m = len(offsets) - 1, len(grid)
    out = np.zeros((n, k * m))
    top = np.empty(k)
    root2 = np.sqrt(2.0)
    for d in range(n):
        for g in range(m):
            x = grid[g]
            for t in range(k):
                top[t] = 0.0
            for p in range(offsets[d], offsets[d + 1]):
                b, e = points[p, 0], points[p, 1]
                value = 0.5 * (e - b) - abs(x - 0.5 * (b + e))
                if value > top[k - 1]:  # insert, keeping top sorted descending
                    t = k - 1
                    while t > 0 and top[t - 1] < value:
                        top[t] = top[t - 1]
                        t -= 1
                    top[t] = value
            for t in range(k):
                out[d, t * m + g] = root2 * top[t]
    return out


@numba.njit(cache=True)
def silhouettes(points, weights, offsets, grid):  # pragma: no cover - compiled
    """Weighted means of the tent functions at each grid point, times ``sqrt 2``; zero
    for a diagram of zero total weight."""
    n, m = len(offsets) - 1, len(grid)
    out = np.zeros((n, m))
    root2 = np.sqrt(2.0)
    for d in range(n):
        total = 0.0
        for p in range(offsets[d], offsets[d + 1]):
            total += weights[p]
        if total <= 0.0:
            continue
        for g in range(m):
            x = grid[g]
            acc = 0.0
            for p in range(offsets[d], offsets[d + 1]):
                b, e = points[p, 0], points[p, 1]
                value = 0.5 * (e - b) - abs(x - 0.5 * (b + e))
                if value > 0.0:
                    acc += weights[p] / total * value
            out[d, g] = root2 * acc
    return out


@numba.njit(cache=True)
def betti_curves(points, offsets, grid):  # pragma: no cover - compiled
    """The number of points with ``birth <= x < death`` at each (ascending) grid point."""
    n, m = len(offsets) - 1, len(grid)
    out = np.zeros((n, m))
    for d in range(n):
        for p in range(offsets[d], offsets[d + 1]):
            b, e = points[p, 0], points[p, 1]
            start = np.searchsorted(grid, b, side="left")
            stop = np.searchsorted(grid, e, side="left")
            for g in range(start, stop):
                out[d, g] += 1.0
    return out


@numba.njit(cache=True)
def entropy_curves(points, offsets, grid):  # pragma: no cover - compiled
    """The entropy summary function: ``-sum_j p_j log p_j`` over the points with
    ``birth <= x < death``, ``p_j`` the point's share of the diagram's total
    persistence."""
    n, m = len(offsets) - 1, len(grid)
    out = np.zeros((n, m))
    for d in range(n):
        total = 0.0
        for p in range(offsets[d], offsets[d + 1]):
            total += points[p, 1] - points[p, 0]
        if total <= 0.0:
            continue
        for p in range(offsets[d], offsets[d + 1]):
            b, e = points[p, 0], points[p, 1]
            share = (e - b) / total
            if share <= 0.0:
                continue
            term = -share * np.log(share)
            start = np.searchsorted(grid, b, side="left")
            stop = np.searchsorted(grid, e, side="left")
            for g in range(start, stop):
                out[d, g] += term
    return out
