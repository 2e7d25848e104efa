"""Compiled loops of the vectorizers: diagram ``d`` is rows ``starts[d]:stops[d]`` of one
packed ``(N, 2)`` array of (birth, death) points."""

from __future__ import annotations

import math

import numba
import numpy as np

__all__ = [
    "betti_curves",
    "entropies",
    "entropy_curves",
    "images",
    "landscapes",
    "silhouettes",
    "statistics",
]


@numba.njit(cache=True, nogil=True)
def _gaussian_at_nodes(center, nodes, bandwidth, out):  # pragma: no cover - compiled
    """``exp(-(center - nodes[j])^2 / (2 bandwidth^2))`` on evenly spaced ``nodes``.

    From the node nearest ``center`` outwards each value is the previous one times a
    ratio that itself shrinks by the constant ``exp(-h^2 / bandwidth^2)``: four
    exponentials per axis instead of one per node, the relative rounding growing by
    about one unit in the last place per node (values far in the tails underflow to 0
    as the direct formula's do).
    """
    m = len(out)
    two_var = 2.0 * bandwidth * bandwidth
    if m == 1:
        out[0] = math.exp(-((center - nodes[0]) ** 2) / two_var)
        return
    h = nodes[1] - nodes[0]
    if h == 0.0:
        for j in range(m):
            out[j] = math.exp(-((center - nodes[j]) ** 2) / two_var)
        return
    c = int(round((center - nodes[0]) / h))
    c = min(max(c, 0), m - 1)
    u = center - nodes[c]  # offset of the centre from node c
    out[c] = math.exp(-u * u / two_var)
    shrink = math.exp(-h * h / (bandwidth * bandwidth))
    # up: g(j+1) / g(j) = exp((2 u' h - h^2) / two_var) with u' = center - nodes[j]
    ratio = math.exp((2.0 * u * h - h * h) / two_var)
    for j in range(c + 1, m):
        out[j] = out[j - 1] * ratio
        ratio *= shrink
    ratio = math.exp((-2.0 * u * h - h * h) / two_var)
    for j in range(c - 1, -1, -1):
        out[j] = out[j + 1] * ratio
        ratio *= shrink


@numba.njit(cache=True, nogil=True)
def _gaussian_in_pixels(center, edges, bandwidth, out):  # pragma: no cover - compiled
    """The mass of a 1-D Gaussian between consecutive ``edges``."""
    scale = bandwidth * math.sqrt(2.0)
    previous = 0.5 * math.erfc(-(edges[0] - center) / scale)
    for j in range(len(out)):
        current = 0.5 * math.erfc(-(edges[j + 1] - center) / scale)
        out[j] = current - previous
        previous = current


@numba.njit(cache=True, nogil=True)
def images(points, weights, starts, stops, xs, ys, bandwidth, pixel):  # pragma: no cover
    """Gaussian persistence images, one row per diagram (rows of the image:
    persistence, columns: birth), points in (birth, persistence) coordinates.
    ``pixel=False``: the density at the grid ``ys x xs``; ``pixel=True``: its mass in
    each pixel, ``xs`` and ``ys`` being the pixel edges. The Gaussian is separable: one
    pass over each axis and one outer product per point."""
    rx = len(xs) - 1 if pixel else len(xs)
    ry = len(ys) - 1 if pixel else len(ys)
    n = len(starts)
    out = np.zeros((n, ry * rx))
    scale = 1.0 if pixel else 1.0 / (2.0 * np.pi * bandwidth * bandwidth)
    ex = np.empty(rx)
    ey = np.empty(ry)
    for d in range(n):
        row = out[d]
        for p in range(starts[d], stops[d]):
            if pixel:
                _gaussian_in_pixels(points[p, 0], xs, bandwidth, ex)
                _gaussian_in_pixels(points[p, 1], ys, bandwidth, ey)
            else:
                _gaussian_at_nodes(points[p, 0], xs, bandwidth, ex)
                _gaussian_at_nodes(points[p, 1], ys, bandwidth, ey)
            w = weights[p] * scale
            for i in range(ry):
                wy = w * ey[i]
                if wy == 0.0:
                    continue
                base = i * rx
                for j in range(rx):
                    row[base + j] += wy * ex[j]
    return out


@numba.njit(cache=True, nogil=True)
def _first_above(grid, x, strict):  # pragma: no cover - compiled
    """The first index ``g`` with ``grid[g] > x`` (``strict``) or ``grid[g] >= x``, on an
    ascending, evenly spaced grid: a guess from the spacing, corrected by comparisons."""
    m = len(grid)
    h = (grid[m - 1] - grid[0]) / (m - 1) if m > 1 else 0.0
    if h > 0.0:
        g = int(min(max((x - grid[0]) / h, -1.0), m))
        g = min(max(g, 0), m)
    else:
        g = 0
    while g > 0 and (grid[g - 1] > x if strict else grid[g - 1] >= x):
        g -= 1
    while g < m and (grid[g] <= x if strict else grid[g] < x):
        g += 1
    return g


@numba.njit(cache=True, nogil=True)
def _support(grid, b, e):  # pragma: no cover - compiled
    """Grid indices ``g`` with ``b < grid[g] < e`` (where a tent can be positive)."""
    return _first_above(grid, b, True), _first_above(grid, e, False)


@numba.njit(cache=True, nogil=True)
def landscapes(points, starts, stops, grid, k):  # pragma: no cover - compiled
    """The ``k`` largest tent functions ``max(0, (d - b) / 2 - |x - (b + d) / 2|)`` at
    each grid point, landscape-major (``k`` blocks of ``len(grid)``), times ``sqrt 2``
    (the tents measured along the diagonal, as gudhi's). Each tent visits only the grid
    points of its support."""
    n, m = len(starts), len(grid)
    out = np.zeros((n, k * m))
    top = np.zeros((m, k))
    root2 = math.sqrt(2.0)
    for d in range(n):
        top[:] = 0.0
        for p in range(starts[d], stops[d]):
            b, e = points[p, 0], points[p, 1]
            half, middle = 0.5 * (e - b), 0.5 * (b + e)
            lo, hi = _support(grid, b, e)
            for g in range(lo, hi):
                value = half - abs(grid[g] - middle)
                if value > top[g, k - 1]:  # insert, keeping the row sorted descending
                    t = k - 1
                    while t > 0 and top[g, t - 1] < value:
                        top[g, t] = top[g, t - 1]
                        t -= 1
                    top[g, t] = value
        for t in range(k):
            for g in range(m):
                out[d, t * m + g] = root2 * top[g, t]
    return out


@numba.njit(cache=True, nogil=True)
def silhouettes(points, weights, starts, stops, grid):  # pragma: no cover - compiled
    """Weighted means of the tent functions at each grid point, times ``sqrt 2``; zero
    for a diagram of zero total weight."""
    n, m = len(starts), len(grid)
    out = np.zeros((n, m))
    root2 = math.sqrt(2.0)
    for d in range(n):
        total = 0.0
        for p in range(starts[d], stops[d]):
            total += weights[p]
        if total <= 0.0:
            continue
        for p in range(starts[d], stops[d]):
            b, e = points[p, 0], points[p, 1]
            half, middle = 0.5 * (e - b), 0.5 * (b + e)
            share = weights[p] / total
            lo, hi = _support(grid, b, e)
            for g in range(lo, hi):
                value = half - abs(grid[g] - middle)
                if value > 0.0:
                    out[d, g] += share * value
        for g in range(m):
            out[d, g] *= root2
    return out


@numba.njit(cache=True, nogil=True)
def betti_curves(points, starts, stops, grid):  # pragma: no cover - compiled
    """The number of points with ``birth <= x < death`` at each (ascending) grid point."""
    n, m = len(starts), len(grid)
    out = np.zeros((n, m))
    for d in range(n):
        for p in range(starts[d], stops[d]):
            lo = _first_above(grid, points[p, 0], False)
            hi = _first_above(grid, points[p, 1], False)
            for g in range(lo, hi):
                out[d, g] += 1.0
    return out


@numba.njit(cache=True, nogil=True)
def entropy_curves(points, starts, stops, grid):  # pragma: no cover - compiled
    """The entropy summary function: ``-sum_j p_j log p_j`` over the points with
    ``birth <= x < death``, ``p_j`` the point's share of the diagram's total
    persistence."""
    n, m = len(starts), len(grid)
    out = np.zeros((n, m))
    for d in range(n):
        total = 0.0
        for p in range(starts[d], stops[d]):
            total += points[p, 1] - points[p, 0]
        if total <= 0.0:
            continue
        for p in range(starts[d], stops[d]):
            share = (points[p, 1] - points[p, 0]) / total
            if share <= 0.0:
                continue
            term = -share * math.log(share)
            lo = _first_above(grid, points[p, 0], False)
            hi = _first_above(grid, points[p, 1], False)
            for g in range(lo, hi):
                out[d, g] += term
    return out


@numba.njit(cache=True, nogil=True)
def entropies(points, starts, stops, normalized):  # pragma: no cover - compiled
    """Persistence entropy of each diagram (points of zero persistence ignored)."""
    n = len(starts)
    out = np.zeros((n, 1))
    for d in range(n):
        total = 0.0
        count = 0
        for p in range(starts[d], stops[d]):
            length = points[p, 1] - points[p, 0]
            if length > 0.0:
                total += length
                count += 1
        if total <= 0.0:
            continue
        entropy = 0.0
        for p in range(starts[d], stops[d]):
            length = points[p, 1] - points[p, 0]
            if length > 0.0:
                share = length / total
                entropy -= share * math.log(share)
        if normalized:
            entropy = entropy / math.log(count) if count > 1 else 0.0
        out[d, 0] = entropy
    return out


@numba.njit(cache=True, nogil=True)
def statistics(points, starts, stops, quantiles):  # pragma: no cover - compiled
    """Count, total, largest and mean persistence, persistence quantiles (linear
    interpolation, as numpy's default), mean birth and mean death of each diagram."""
    n, q = len(starts), len(quantiles)
    out = np.zeros((n, 6 + q))
    for d in range(n):
        count = stops[d] - starts[d]
        if count == 0:
            continue
        lengths = np.empty(count)
        births = 0.0
        deaths = 0.0
        for t in range(count):
            p = starts[d] + t
            lengths[t] = points[p, 1] - points[p, 0]
            births += points[p, 0]
            deaths += points[p, 1]
        lengths.sort()
        total = lengths.sum()
        out[d, 0] = count
        out[d, 1] = total
        out[d, 2] = lengths[count - 1]
        out[d, 3] = total / count
        for t in range(q):
            position = quantiles[t] * (count - 1)
            below = int(math.floor(position))
            above = min(below + 1, count - 1)
            fraction = position - below
            out[d, 4 + t] = lengths[below] + (lengths[above] - lengths[below]) * fraction
        out[d, 4 + q] = births / count
        out[d, 5 + q] = deaths / count
    return out
