"""Local triangulations of a point cloud: each point's surface neighbours, its tangent
frame, and the Delaunay triangles around it (compiled).

A change here changes the numbers a solve gives: bump
:data:`sklearn_meshph.spectral.cache.NUMERICS_VERSION` (a test checks).
"""

from __future__ import annotations

import numba
import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import breadth_first_order, minimum_spanning_tree
from scipy.spatial import cKDTree

from ..mesh import DEGENERATE_SINE
from ..mesh.graph import connected_components

__all__ = [
    "LOCAL_NEIGHBORS",
    "MAX_SLOPE",
    "MIN_NORMAL_COSINE",
    "NORMAL_NEIGHBORS",
    "SEED_NEIGHBORS",
    "SEED_SLOPE",
    "SHEET_OFFSET",
    "BLOCK",
    "local_delaunay_fans",
    "nearest",
    "orient_normals",
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

#: A point's first tangent plane is the plane through it and two of its this many
#: nearest neighbours that most of its ``2 * NORMAL_NEIGHBORS`` nearest lie flat on.
SEED_NEIGHBORS = 8

#: A neighbour lies flat on a candidate plane when its height is below this times its
#: distance (weighted down to zero at that slope).
SEED_SLOPE = 0.25

#: A neighbour is on another sheet when its height over the quadric fitted to the
#: point's kept neighbours exceeds this times the ``NORMAL_NEIGHBORS``-th neighbour's
#: distance (about half the sampling's spacing).
SHEET_OFFSET = 0.3

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


@numba.njit(cache=True)
def _consensus_normals(relative, candidates, voters, slope):
    """Unit normals ``(n, 3)`` of each point's best plane through it and two of its
    ``candidates`` nearest neighbours: the one its ``voters`` nearest lie flattest on
    (each adds ``1 - (height / (slope * distance))^2`` when positive). A point with no
    pair of candidates at a fair angle gets NaN."""
    n = relative.shape[0]
    out = np.full((n, 3), np.nan)
    for i in range(n):
        best = -1.0
        for a in range(candidates):
            ax, ay, az = relative[i, a, 0], relative[i, a, 1], relative[i, a, 2]
            for b in range(a + 1, candidates):
                bx, by, bz = relative[i, b, 0], relative[i, b, 1], relative[i, b, 2]
                nx, ny, nz = ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx
                norm = np.sqrt(nx * nx + ny * ny + nz * nz)
                lengths = np.sqrt((ax * ax + ay * ay + az * az) * (bx * bx + by * by + bz * bz))
                if norm <= 0.2 * lengths:  # the two directions within 12 degrees
                    continue
                nx, ny, nz = nx / norm, ny / norm, nz / norm
                score = 0.0
                for j in range(voters):
                    x, y, z = relative[i, j, 0], relative[i, j, 1], relative[i, j, 2]
                    t = abs(x * nx + y * ny + z * nz) / (slope * np.sqrt(x * x + y * y + z * z))
                    if t < 1.0:
                        score += 1.0 - t * t
                if score > best:
                    best = score
                    out[i, 0], out[i, 1], out[i, 2] = nx, ny, nz
    return out


def _first_normals(relative, first):
    """The consensus plane's normal (:func:`_consensus_normals`), or where no pair of
    neighbours gives one, the principal plane of the ``first`` nearest."""
    k = relative.shape[1]
    normal = _consensus_normals(
        relative, min(SEED_NEIGHBORS, k), min(2 * NORMAL_NEIGHBORS, k), SEED_SLOPE
    )
    missing = np.isnan(normal[:, 0])
    if missing.any():
        nearest_ones = np.zeros((1, k))
        nearest_ones[:, :first] = 1.0
        normal[missing] = _frames(relative[missing], nearest_ones)[0]
    return normal


@numba.njit(cache=True)
def _flip_along(order, predecessors, normal, sign):
    """Orient each point of a breadth-first ``order`` like its predecessor."""
    for v in order:
        p = predecessors[v]
        if p < 0:
            continue
        dot = sign[p] * (
            normal[v, 0] * normal[p, 0] + normal[v, 1] * normal[p, 1] + normal[v, 2] * normal[p, 2]
        )
        sign[v] = -1.0 if dot < 0 else 1.0


def orient_normals(points: np.ndarray, normal: np.ndarray, neighbors: np.ndarray) -> np.ndarray:
    """Signs ``(n,)`` that orient unit normals consistently along the surface.

    The orientation travels along the minimum spanning tree of the graph of each
    point's ``neighbors`` (``(n, m)`` indices), an edge costing ``1 - |cos|`` of the
    angle between its ends' normals plus its larger slope over their tangent planes:
    along a sheet, not across to a sheet nearby (a leg against a body, the other side
    of a thin part), which faces the other way.
    """
    n, m = neighbors.shape
    relative = points[neighbors] - points[:, None, :]
    distance = np.linalg.norm(relative, axis=2)
    slope = np.maximum(
        np.abs(_along(relative, normal)), np.abs((relative * normal[neighbors]).sum(axis=2))
    ) / np.maximum(distance, np.finfo(float).tiny)
    cosine = np.abs((normal[neighbors] * normal[:, None, :]).sum(axis=2))
    # Zero would be no edge for the sparse graph: the smallest cost is positive.
    cost = 1e-9 + (1.0 - cosine) + slope
    graph = sp.csr_matrix((cost.ravel(), (np.repeat(np.arange(n), m), neighbors.ravel())), (n, n))
    tree = minimum_spanning_tree(graph.maximum(graph.T))
    tree = (tree + tree.T).tocsr()
    sign = np.ones(n)
    labels = connected_components(n, np.column_stack(tree.nonzero()))[1]
    _, roots = np.unique(labels, return_index=True)
    for root in roots:
        order, predecessors = breadth_first_order(tree, root, directed=False)
        _flip_along(order, predecessors, normal, sign)
    return sign


def surface_neighbours(points: np.ndarray, n_neighbors: int = LOCAL_NEIGHBORS):
    """Each point's nearest neighbours, which of them are on its own sheet, and its frame.

    The ``n_neighbors`` nearest points may reach across a thin part (the other side of a
    finger) or to a part nearby (a leg against the body). In four steps:

    1. a first tangent plane is the plane through the point and two of its
       :data:`SEED_NEIGHBORS` nearest that its ``2 * NORMAL_NEIGHBORS`` nearest lie
       flattest on (:data:`SEED_SLOPE`): the principal plane of the nearest tilts
       towards a sheet a spacing or two away, whose points are few but high;
    2. the plane is fitted again to the neighbours low over the first plane for their
       distance (:data:`MAX_SLOPE`): as steady as a wide neighbourhood under noise;
    3. the normals are oriented along the surface (:func:`orient_normals`);
    4. the neighbours kept are those low over the plane for their distance
       (:data:`MAX_SLOPE`: not the far side of a thin part), near the quadric fitted to
       the kept ones (:data:`SHEET_OFFSET`: not a parallel sheet nearby), and whose
       oriented normal is within :data:`MIN_NORMAL_COSINE` of the point's (not a sheet
       facing the other way).

    Returns ``(neighbors, usable, normal, basis)``: indices ``(n, k)``, the mask of the
    neighbours kept ``(n, k)``, unit normals ``(n, 3)`` and tangent bases
    ``(n, 3, 2)``.
    """
    distances, neighbors = nearest(points, n_neighbors)
    n, k = neighbors.shape
    first = min(NORMAL_NEIGHBORS, k)
    reach = np.maximum(distances, distances[:, first - 1 : first])
    normal, basis = np.empty((n, 3)), np.empty((n, 3, 2))
    for block in _blocks(n):
        relative = _relative(points, neighbors, block)
        height = np.abs(_along(relative, _first_normals(relative, first)))
        flat = height <= MAX_SLOPE * reach[block]
        normal[block], basis[block] = _frames(relative, flat.astype(np.float64))
    sign = orient_normals(points, normal, neighbors[:, :first])
    normal *= sign[:, None]
    basis[:, :, 1] *= sign[:, None]  # right-handed frames
    usable = np.empty((n, k), dtype=bool)
    for block in _blocks(n):
        relative = _relative(points, neighbors, block)
        cosine = _along(normal[neighbors[block]], normal[block])
        kept = _flat(relative, normal[block], reach[block]) & (np.abs(cosine) >= MIN_NORMAL_COSINE)
        unit = distances[block, first - 1 : first]
        on_sheet = _on_sheet(relative, normal[block], basis[block], kept, unit)
        usable[block] = on_sheet & (cosine >= MIN_NORMAL_COSINE)
    return neighbors, usable, normal, basis


def _quadric(coords, height, usable, unit):
    """The quadric ``z = c0 + c1 x + c2 y + c3 x^2 + c4 x y + c5 y^2`` fitted by least
    squares to the point itself (at the origin) and its ``usable`` neighbours, in units
    of ``unit`` (n, 1): its terms at the neighbours ``(n, k, 6)`` and coefficients
    ``(n, 6)``."""
    x, y = coords[..., 0] / unit, coords[..., 1] / unit
    terms = np.stack([np.ones_like(x), x, y, x * x, x * y, y * y], axis=-1)
    weighted = (terms * usable[..., None]).transpose(0, 2, 1)
    gram = np.matmul(weighted, terms)
    gram[:, 0, 0] += 1.0  # the point itself, at height zero
    gram += 1e-6 * np.eye(6)
    moments = np.matmul(weighted, (height / unit)[..., None])
    return terms, np.linalg.solve(gram, moments)[..., 0]


def _on_sheet(relative, normal, basis, kept, unit):
    """Which ``kept`` neighbours lie within :data:`SHEET_OFFSET` times ``unit`` of the
    quadric fitted to the kept ones on the point's sheet (or 4 times their median offset
    if more: noise). Fitted twice, the second time without those off the first.
    A parallel sheet a spacing or two away is low for its distance (the slope test
    keeps it) but off the point's own sheet by that much."""
    coords = np.matmul(relative, basis)
    height = _along(relative, normal)
    on_sheet = kept
    rows = np.arange(len(kept))
    for _ in range(2):
        terms, coefficients = _quadric(coords, height, on_sheet, unit)
        off = np.abs(height / unit - _along(terms, coefficients))
        # Noise spreads the point's own sheet around the quadric: the limit grows with
        # the median offset of the kept (4 times: 2.7 standard deviations of a normal).
        ranked = np.sort(np.where(on_sheet, off, np.inf), axis=1)
        median = ranked[rows, np.maximum(on_sheet.sum(axis=1) - 1, 0) // 2][:, None]
        on_sheet = kept & (off <= np.maximum(SHEET_OFFSET, 4.0 * median))
    return on_sheet


def _heights(coords, height, usable, unit):
    """Heights of the neighbours over the point on the quadric fitted to the kept ones
    (:func:`_quadric`); a point with fewer than 8 samples keeps its tangent plane
    (heights zero). Returns the fitted heights of the neighbours minus the point's,
    ``(n, k)``: the surface's bend without the noise across it.
    """
    terms, coefficients = _quadric(coords, height, usable, unit)
    coefficients[usable.sum(axis=1) < 7] = 0.0
    return (_along(terms, coefficients) - coefficients[:, :1]) * unit


def tangent_fans(points: np.ndarray, n_neighbors: int = LOCAL_NEIGHBORS):
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
    dropped, and so are the triangles of a piece of fewer than ``LOCAL_NEIGHBORS``
    points. ``points`` must be distinct.
    """
    neighbors, usable, normal, basis = surface_neighbours(points, n_neighbors)
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
    triangles, a, b = (
        np.column_stack([i, neighbors[i, ja], neighbors[i, jb]])[keep],
        a[keep],
        b[keep],
    )
    # A piece of fewer points than a neighbourhood is no part of the surface the sampling
    # shows, but a few points whose neighbourhoods left out all the others.
    labels = connected_components(n, triangles)[1]
    keep = np.bincount(labels, minlength=n)[labels[triangles[:, 0]]] >= min(LOCAL_NEIGHBORS, n)
    return triangles[keep], a[keep], b[keep]


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
