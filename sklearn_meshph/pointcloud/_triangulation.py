"""Local triangulations of a point cloud: each point's surface neighbours, its tangent
frame, and the Delaunay triangles around it (compiled).

A change here changes the numbers a solve gives: bump
:data:`sklearn_meshph.spectral.cache.NUMERICS_VERSION` (a test checks).
"""

from __future__ import annotations

import numba
import numpy as np
from scipy.spatial import cKDTree

from ..mesh import DEGENERATE_SINE

__all__ = [
    "LOCAL_NEIGHBORS",
    "MAX_SLOPE",
    "MIN_NORMAL_COSINE",
    "NORMAL_NEIGHBORS",
    "BLOCK",
    "local_delaunay_fans",
    "nearest",
    "surface_neighbours",
    "tangent_fans",
]

#: Neighbours per point from which its local triangulation is made.
LOCAL_NEIGHBORS = 30

#: Nearest neighbours whose principal plane is a point's first estimate of its tangent
#: plane: few enough to stay on one side of a thin part.
NORMAL_NEIGHBORS = 10

#: A neighbour is off the surface at a point when its height over the point's tangent
#: plane exceeds this times its distance (or, nearer than the ``NORMAL_NEIGHBORS``-th
#: neighbour, times that neighbour's distance): 0.7 is the chord of a cylinder between
#: points a quarter turn apart, so the far side of a thin part is cut off.
MAX_SLOPE = 0.7

#: Surface neighbours have tangent planes within 60 degrees of each other (unoriented
#: normals: the absolute cosine).
MIN_NORMAL_COSINE = 0.5

#: Points whose local frames are computed together.
BLOCK = 4096


def nearest(points: np.ndarray, n_neighbors: int) -> tuple[np.ndarray, np.ndarray]:
    """Distances and indices ``(n, k)`` of each point's ``k`` nearest other points,
    nearest first (``k = min(n_neighbors, n - 1)``), by an exact k-d tree search."""
    k = min(n_neighbors, len(points) - 1)
    distances, indices = cKDTree(points).query(points, k + 1)
    # The point itself comes first, unless a duplicate of it does: drop it wherever it is.
    itself = indices == np.arange(len(points))[:, None]
    itself[~itself.any(axis=1), -1] = True
    keep = ~itself
    return distances[keep].reshape(-1, k), indices[keep].reshape(-1, k)


def _frames(relative: np.ndarray, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit normals ``(n, 3)`` and tangent bases ``(n, 3, 2)``: the principal directions
    of the weighted neighbours, relative to each point (the plane goes through it)."""
    covariance = np.matmul((relative * weights[..., None]).transpose(0, 2, 1), relative)
    directions = np.linalg.eigh(covariance)[1]
    return directions[:, :, 0], directions[:, :, 1:]


def _along(vectors, directions):
    """``(n, k)`` components of ``vectors`` ``(n, k, 3)`` along ``directions`` ``(n, 3)``."""
    return np.matmul(vectors, directions[..., None])[..., 0]


def _flat(relative, normal, reach):
    """Neighbours whose height over the tangent plane is within ``MAX_SLOPE`` of their
    ``reach`` (distance, at least the ``NORMAL_NEIGHBORS``-th neighbour's)."""
    return np.abs(_along(relative, normal)) <= MAX_SLOPE * reach


def _blocks(n):
    """Slices of at most :data:`BLOCK` points: the local frames of a block are computed
    together, which bounds the temporary arrays (every point's result is the same)."""
    return (slice(start, min(start + BLOCK, n)) for start in range(0, n, BLOCK))


def _relative(points, neighbors, block):
    """Positions ``(b, k, 3)`` of the block's neighbours relative to each point."""
    return points[neighbors[block]] - points[block][:, None, :]


def surface_neighbours(points: np.ndarray, n_neighbors: int = LOCAL_NEIGHBORS, knn=None):
    """Each point's nearest neighbours, which of them are on its own sheet, and its frame.

    The ``n_neighbors`` nearest points may reach across a thin part (the other side of a
    finger) or to a part nearby (a leg against the body). A first tangent plane comes
    from the ``NORMAL_NEIGHBORS`` nearest; neighbours too high above it for their
    distance (:data:`MAX_SLOPE`) are left out, and the plane is fitted again to the rest
    (as many as the surface gives: as steady as a wide neighbourhood under noise). The
    neighbours kept are those low over that plane and whose own normal is within
    :data:`MIN_NORMAL_COSINE` of the point's.

    Returns ``(neighbors, usable, normal, basis)``: indices ``(n, k)``, the mask of the
    neighbours kept ``(n, k)``, unit normals ``(n, 3)`` and tangent bases
    ``(n, 3, 2)``. ``knn``: :func:`nearest`'s result for these points and
    ``n_neighbors``, when the caller has it.
    """
    distances, neighbors = nearest(points, n_neighbors) if knn is None else knn
    n, k = neighbors.shape
    first = min(NORMAL_NEIGHBORS, k)
    reach = np.maximum(distances, distances[:, first - 1 : first])
    nearest_ones = np.zeros((1, k))
    nearest_ones[:, :first] = 1.0
    normal, basis = np.empty((n, 3)), np.empty((n, 3, 2))
    for block in _blocks(n):
        relative = _relative(points, neighbors, block)
        flat = _flat(relative, _frames(relative, nearest_ones)[0], reach[block])
        normal[block], basis[block] = _frames(relative, flat.astype(np.float64))
    usable = np.empty((n, k), dtype=bool)
    for block in _blocks(n):
        agree = np.abs(_along(normal[neighbors[block]], normal[block])) >= MIN_NORMAL_COSINE
        flat = _flat(_relative(points, neighbors, block), normal[block], reach[block])
        usable[block] = flat & agree
    return neighbors, usable, normal, basis


def _heights(coords, height, usable, unit):
    """Heights of the neighbours over the point on the quadric fitted to the kept ones.

    ``z = c0 + c1 x + c2 y + c3 x^2 + c4 x y + c5 y^2`` by least squares over the point
    itself (at the origin) and its kept neighbours, in units of ``unit`` (n, 1); a point
    with fewer than 8 samples keeps its tangent plane (heights zero). Returns the fitted
    heights of the neighbours minus the point's, ``(n, k)``: the surface's bend without
    the noise across it.
    """
    x, y = coords[..., 0] / unit, coords[..., 1] / unit
    terms = np.stack([np.ones_like(x), x, y, x * x, x * y, y * y], axis=-1)
    weighted = (terms * usable[..., None]).transpose(0, 2, 1)
    gram = np.matmul(weighted, terms)
    gram[:, 0, 0] += 1.0  # the point itself, at height zero
    gram += 1e-6 * np.eye(6)
    moments = np.matmul(weighted, (height / unit)[..., None])
    coefficients = np.linalg.solve(gram, moments)[..., 0]
    coefficients[usable.sum(axis=1) < 7] = 0.0
    return (_along(terms, coefficients) - coefficients[:, :1]) * unit


def tangent_fans(points: np.ndarray, n_neighbors: int = LOCAL_NEIGHBORS, knn=None):
    """Every point's local Delaunay triangles among its surface neighbours.

    The neighbours kept by :func:`surface_neighbours` are projected onto the point's
    tangent plane and the Delaunay triangles at the point kept
    (:func:`local_delaunay_fans`). Each triangle is measured on the quadric fitted to
    the point's neighbourhood: tangent coordinates, and the fitted height (the bend of
    a thin part is kept, the noise across the surface is not). Returns
    ``(triangles, a, b)``: the triangles ``(m, 3)`` as point indices ``(i, j, k)``, and
    the edge vectors from ``i`` to ``j`` and to ``k`` in that frame, ``(m, 3)`` each.
    Degenerate triangles (twice the area at most
    :data:`sklearn_meshph.mesh.DEGENERATE_SINE` times the longest edge squared) are
    dropped. ``points`` must be distinct; ``knn`` as for :func:`surface_neighbours`.
    """
    neighbors, usable, normal, basis = surface_neighbours(points, n_neighbors, knn)
    n, k = neighbors.shape
    coords, lift = np.empty((n, k, 2)), np.empty((n, k))
    for block in _blocks(n):
        relative = _relative(points, neighbors, block)
        coords[block] = np.matmul(relative, basis[block])
        unit = np.linalg.norm(relative[:, min(NORMAL_NEIGHBORS, k) - 1], axis=1)[:, None]
        height = _along(relative, normal[block])
        lift[block] = _heights(coords[block], height, usable[block], unit)
    fans = local_delaunay_fans(coords, usable)
    i, ja, jb = fans[:, 0], fans[:, 1], fans[:, 2]
    a = np.column_stack([coords[i, ja], lift[i, ja]])
    b = np.column_stack([coords[i, jb], lift[i, jb]])
    double_area = np.linalg.norm(np.cross(a, b), axis=1)
    longest = np.maximum(np.maximum((a * a).sum(1), (b * b).sum(1)), ((b - a) ** 2).sum(1))
    keep = double_area > DEGENERATE_SINE * longest
    triangles = np.column_stack([i, neighbors[i, ja], neighbors[i, jb]])[keep]
    return triangles, a[keep], b[keep]


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
def local_delaunay_fans(coords, usable):
    """The Delaunay triangles around each point, in its own tangent plane.

    ``coords[i, j]`` are the 2-D tangent coordinates of the ``j``-th nearest neighbour
    of point ``i`` relative to it (nearest first), ``usable[i, j]`` whether it may be a
    corner (the others are ignored). The
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
            if usable[i, j]:
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
            if c == 0.0 or not usable[i, j]:
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
