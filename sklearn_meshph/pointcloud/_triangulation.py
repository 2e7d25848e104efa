"""Compiled local Delaunay triangulations: the triangles around each point of a cloud.

A change here changes the numbers a solve gives: bump
:data:`sklearn_meshph.spectral.cache.NUMERICS_VERSION` (a test checks).
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True)
def _clip(px, py, labels, m, ax, ay, c, j, qx, qy, qlabels):
    """Clip the convex polygon ``(px, py)[:m]`` by the half-plane ``x ax + y ay <= c``.

    ``labels[t]`` names what made the edge leaving vertex ``t`` (a neighbour's index, or
    -1 for the bounding box); the edge along the clipping line gets ``j``. Writes the
    result into ``q*`` and returns its vertex count.
    """
    count = 0
    for t in range(m):
        u = t + 1 if t + 1 < m else 0
        st = px[t] * ax + py[t] * ay - c
        su = px[u] * ax + py[u] * ay - c
        if st <= 0.0:
            qx[count], qy[count], qlabels[count] = px[t], py[t], labels[t]
            count += 1
            if su > 0.0:  # leaving: the clipping line starts an edge
                s = st / (st - su)
                qx[count] = px[t] + s * (px[u] - px[t])
                qy[count] = py[t] + s * (py[u] - py[t])
                qlabels[count] = j
                count += 1
        elif su <= 0.0:  # entering: the rest of edge t
            s = st / (st - su)
            qx[count] = px[t] + s * (px[u] - px[t])
            qy[count] = py[t] + s * (py[u] - py[t])
            qlabels[count] = labels[t]
            count += 1
    return count


@numba.njit(cache=True)
def local_delaunay_fans(coords):
    """The Delaunay triangles around each point, in its own tangent plane.

    ``coords[i, j]`` are the 2-D tangent coordinates of the ``j``-th nearest neighbour
    of point ``i`` relative to it (nearest first). The
    Voronoi cell of the origin among those neighbours is cut out of a box by the
    bisectors, nearest first (a bisector that cannot cut the cell is skipped); two
    consecutive cell edges made by neighbours ``a`` and ``b`` meet at the circumcentre
    of the Delaunay triangle ``(i, a, b)``. Edges of the box (a point on the boundary
    of its neighbourhood) make no triangle. Returns the triangles ``(m, 3)`` as
    ``(i, a, b)`` with ``a`` and ``b`` positions among the neighbours of ``i``,
    counter-clockwise in its tangent plane, each point's fan in turn.
    """
    n, k = coords.shape[0], coords.shape[1]
    capacity = 2 * k + 8  # a convex cell has at most k + 4 edges; clipping adds one
    px, py = np.empty(capacity), np.empty(capacity)
    qx, qy = np.empty(capacity), np.empty(capacity)
    labels = np.empty(capacity, np.int64)
    qlabels = np.empty(capacity, np.int64)
    out = np.empty((8 * n + 16, 3), np.int64)
    count = 0
    for i in range(n):
        reach = 0.0
        for j in range(k):
            reach = max(reach, abs(coords[i, j, 0]), abs(coords[i, j, 1]))
        # Far enough that every bounded cell vertex of a reasonable triangle is inside:
        # only slivers along the boundary of the neighbourhood are cut off.
        box = 16.0 * reach
        m = 4
        px[0], py[0], labels[0] = -box, -box, -1
        px[1], py[1], labels[1] = box, -box, -1
        px[2], py[2], labels[2] = box, box, -1
        px[3], py[3], labels[3] = -box, box, -1
        for j in range(k):
            ax, ay = coords[i, j, 0], coords[i, j, 1]
            c = 0.5 * (ax * ax + ay * ay)
            if c == 0.0:
                continue  # on top of the point in the tangent plane
            cuts = False
            for t in range(m):
                if px[t] * ax + py[t] * ay > c:
                    cuts = True
                    break
            if cuts:
                m = _clip(px, py, labels, m, ax, ay, c, j, qx, qy, qlabels)
                for t in range(m):
                    px[t], py[t], labels[t] = qx[t], qy[t], qlabels[t]
        for t in range(m):
            a = labels[t]
            b = labels[t + 1 if t + 1 < m else 0]
            if a < 0 or b < 0 or a == b:
                continue
            if count == len(out):
                grown = np.empty((2 * count, 3), np.int64)
                grown[:count] = out[:count]
                out = grown
            out[count, 0] = i
            out[count, 1] = a
            out[count, 2] = b
            count += 1
    return out[:count]
