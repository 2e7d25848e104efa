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
    "local_delaunay_fans",
    "nearest",
    "nearest_within",
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


def nearest(points: np.ndarray, n_neighbors: int) -> tuple[np.ndarray, np.ndarray]:
    """Distances and indices ``(n, k)`` of each point's ``k`` nearest other points,
    nearest first, ties by the lower index (``k = min(n_neighbors, n - 1)``), by an
    exact k-d tree search: the same lists whatever else the cloud holds beyond them."""
    k = min(n_neighbors, len(points) - 1)
    if k < 1:  # one point (or none): no neighbours
        return np.empty((len(points), 0)), np.empty((len(points), 0), dtype=np.intp)
    return _ranked(cKDTree(points), points, np.arange(len(points)), k)


def _ranked(tree, queries, own, k):
    """The ``k`` nearest points of ``tree`` to each of ``queries`` but its ``own`` index,
    ranked by distance, then index.

    A k-d tree breaks ties between equal distances by its own build, which depends on
    every point it holds: on a grid, the lists of a cloud and of the same cloud with one
    twin more would differ where several points tie with the ``k``-th. So one more
    neighbour is asked for: where it ties with the ``k``-th, the row is searched again
    until the tie is whole; rows with ties are then ranked by index.
    """
    n = tree.n
    distances, indices = _without_own(tree, queries, own, min(k + 2, n))
    if distances.shape[1] > k:  # the (k + 1)-th: is it tied with the k-th?
        tied = np.flatnonzero(distances[:, k] == distances[:, k - 1])
        distances, indices = distances[:, :k].copy(), indices[:, :k].copy()
        count = k + 2
        while len(tied):  # searched again, wider each time, until the tie is whole
            count = min(count + 8 if count == k + 2 else 2 * count, n)
            found, near = _without_own(tree, queries[tied], own[tied], count)
            whole = (found[:, -1] > found[:, k - 1]) | (count == n)
            order = np.lexsort((near[whole], found[whole]))[:, :k]
            rows = tied[whole]
            distances[rows] = np.take_along_axis(found[whole], order, axis=1)
            indices[rows] = np.take_along_axis(near[whole], order, axis=1)
            tied = tied[~whole]
    ties = np.flatnonzero((distances[:, 1:] == distances[:, :-1]).any(axis=1))
    if len(ties):
        order = np.lexsort((indices[ties], distances[ties]))
        distances[ties] = np.take_along_axis(distances[ties], order, axis=1)
        indices[ties] = np.take_along_axis(indices[ties], order, axis=1)
    return distances, indices


def _without_own(tree, queries, own, count):
    """``tree.query(queries, count)`` without each query's ``own`` index (or, when a
    duplicate hides it beyond ``count``, without the last), ``count - 1`` columns."""
    distances, indices = tree.query(queries, count)
    distances = distances.reshape(len(queries), count)
    indices = indices.reshape(len(queries), count)
    itself = indices == own[:, None]
    itself[~itself.any(axis=1), -1] = True
    keep = ~itself
    return distances[keep].reshape(-1, count - 1), indices[keep].reshape(-1, count - 1)


def nearest_within(points, knn, keep, n_neighbors):
    """:func:`nearest` of ``points[keep]`` for ``n_neighbors``, from ``knn``, that of all
    the ``points`` for as many: a point none of whose nearest is dropped keeps them
    (renumbered: its ranking is the same among fewer points); only the others are
    searched again, among the kept points."""
    distances, indices = knn
    kept = np.flatnonzero(keep)
    k = min(n_neighbors, len(kept) - 1)
    if k != distances.shape[1]:  # fewer points than neighbours asked for
        return nearest(points[kept], n_neighbors)
    renumber = np.full(len(points), -1, dtype=np.int64)
    renumber[kept] = np.arange(len(kept))
    distances, indices = distances[kept], renumber[indices[kept]]
    stale = np.flatnonzero((indices < 0).any(axis=1))
    if len(stale):
        subset = points[kept]
        distances[stale], indices[stale] = _ranked(cKDTree(subset), subset[stale], stale, k)
    return distances, indices


@numba.njit(cache=True, inline="always")
def _principal_frame(c, frame):
    """The eigenvectors of the symmetric 3 x 3 ``c`` into the columns of ``frame``,
    by increasing eigenvalue (cyclic Jacobi rotations; ``c`` is overwritten): column 0
    is the normal of the principal plane, columns 1 and 2 span the plane."""
    for r in range(3):
        for q in range(3):
            frame[r, q] = 1.0 if r == q else 0.0
    for _ in range(64):
        off = c[0, 1] * c[0, 1] + c[0, 2] * c[0, 2] + c[1, 2] * c[1, 2]
        scale = c[0, 0] * c[0, 0] + c[1, 1] * c[1, 1] + c[2, 2] * c[2, 2]
        if off <= 1e-32 * scale or off == 0.0:
            break
        for p, q in ((0, 1), (0, 2), (1, 2)):
            if c[p, q] == 0.0:
                continue
            theta = (c[q, q] - c[p, p]) / (2.0 * c[p, q])
            t = 1.0 / (abs(theta) + np.sqrt(theta * theta + 1.0))
            if theta < 0.0:
                t = -t
            cos = 1.0 / np.sqrt(t * t + 1.0)
            sin = t * cos
            for r in range(3):  # columns p and q of c, then rows p and q
                cp, cq = c[r, p], c[r, q]
                c[r, p], c[r, q] = cos * cp - sin * cq, sin * cp + cos * cq
            for r in range(3):
                cp, cq = c[p, r], c[q, r]
                c[p, r], c[q, r] = cos * cp - sin * cq, sin * cp + cos * cq
            for r in range(3):
                vp, vq = frame[r, p], frame[r, q]
                frame[r, p], frame[r, q] = cos * vp - sin * vq, sin * vp + cos * vq
    # Sort the columns by eigenvalue (on the diagonal of c; three: an insertion sort).
    for a in range(1, 3):
        b = a
        while b > 0 and c[b, b] < c[b - 1, b - 1]:
            c[b, b], c[b - 1, b - 1] = c[b - 1, b - 1], c[b, b]
            for r in range(3):
                frame[r, b], frame[r, b - 1] = frame[r, b - 1], frame[r, b]
            b -= 1


@numba.njit(cache=True, inline="always")
def _weighted_frame(points, neighbors, i, take, c, frame):
    """The principal frame of point ``i``'s neighbours where ``take`` (relative to it:
    the plane goes through the point); ``c`` is a 3 x 3 work array."""
    c[:, :] = 0.0
    for j in range(neighbors.shape[1]):
        if take[j]:
            m = neighbors[i, j]
            ux = points[m, 0] - points[i, 0]
            uy = points[m, 1] - points[i, 1]
            uz = points[m, 2] - points[i, 2]
            c[0, 0] += ux * ux
            c[0, 1] += ux * uy
            c[0, 2] += ux * uz
            c[1, 1] += uy * uy
            c[1, 2] += uy * uz
            c[2, 2] += uz * uz
    c[1, 0], c[2, 0], c[2, 1] = c[0, 1], c[0, 2], c[1, 2]
    _principal_frame(c, frame)


@numba.njit(cache=True)
def _sheet_frames(points, neighbors, reach, first, fitted, max_slope):
    """Normals ``(n, 3)`` and tangent bases ``(n, 3, 2)`` of :func:`surface_neighbours`:
    the principal plane of the ``first`` nearest, then of those of the ``fitted``
    nearest that are low over it."""
    n, k = neighbors.shape
    normal = np.empty((n, 3))
    basis = np.empty((n, 3, 2))
    frame = np.empty((3, 3))
    c = np.empty((3, 3))
    take = np.zeros(k, dtype=np.bool_)
    for i in range(n):
        for j in range(k):
            take[j] = j < first
        _weighted_frame(points, neighbors, i, take, c, frame)
        for j in range(k):
            m = neighbors[i, j]
            height = (
                (points[m, 0] - points[i, 0]) * frame[0, 0]
                + (points[m, 1] - points[i, 1]) * frame[1, 0]
                + (points[m, 2] - points[i, 2]) * frame[2, 0]
            )
            take[j] = j < fitted and abs(height) <= max_slope * reach[i, j]
        _weighted_frame(points, neighbors, i, take, c, frame)
        for r in range(3):
            normal[i, r] = frame[r, 0]
            basis[i, r, 0] = frame[r, 1]
            basis[i, r, 1] = frame[r, 2]
    return normal, basis


@numba.njit(cache=True)
def _kept_on_sheet(points, neighbors, reach, normal, max_slope, min_cosine):
    """``usable`` of :func:`surface_neighbours`: low over the point's plane, and a
    tangent plane within ``min_cosine`` of the point's."""
    n, k = neighbors.shape
    usable = np.empty((n, k), dtype=np.bool_)
    for i in range(n):
        for j in range(k):
            m = neighbors[i, j]
            height = 0.0
            cosine = 0.0
            for r in range(3):
                height += (points[m, r] - points[i, r]) * normal[i, r]
                cosine += normal[m, r] * normal[i, r]
            usable[i, j] = abs(height) <= max_slope * reach[i, j] and abs(cosine) >= min_cosine
    return usable


def surface_neighbours(points: np.ndarray, n_neighbors: int = LOCAL_NEIGHBORS, knn=None):
    """Each point's nearest neighbours, which of them are on its own sheet, and its frame.

    The ``n_neighbors`` nearest points may reach across a thin part (the other side of a
    finger) or to a part nearby (a leg against the body). A first tangent plane comes
    from the ``NORMAL_NEIGHBORS`` nearest; neighbours too high above it for their
    distance (:data:`MAX_SLOPE`) are left out, and the plane is fitted again to the rest
    of the ``LOCAL_NEIGHBORS`` nearest (as many as the surface gives: as steady as a
    wide neighbourhood under noise, and no wider: a plane, like a quadric, is local). The
    neighbours kept are those low over that plane and whose own normal is within
    :data:`MIN_NORMAL_COSINE` of the point's. Each plane goes through the point: the
    principal directions of its neighbours' positions relative to it (compiled, per
    point).

    Returns ``(neighbors, usable, normal, basis)``: indices ``(n, k)``, the mask of the
    neighbours kept ``(n, k)``, unit normals ``(n, 3)`` and tangent bases
    ``(n, 3, 2)``. ``knn``: :func:`nearest`'s result for these points and
    ``n_neighbors``, when the caller has it.
    """
    distances, neighbors = nearest(points, n_neighbors) if knn is None else knn
    k = neighbors.shape[1]
    first = min(NORMAL_NEIGHBORS, k)
    # A neighbour nearer than the first-th is measured against that one's distance.
    reach = np.maximum(distances, distances[:, first - 1 : first])
    points = np.ascontiguousarray(points, dtype=np.float64)
    neighbors = np.ascontiguousarray(neighbors, dtype=np.int64)
    fitted = min(LOCAL_NEIGHBORS, k)
    normal, basis = _sheet_frames(points, neighbors, reach, first, fitted, MAX_SLOPE)
    usable = _kept_on_sheet(points, neighbors, reach, normal, MAX_SLOPE, MIN_NORMAL_COSINE)
    return neighbors, usable, normal, basis


@numba.njit(cache=True)
def _lifted(points, neighbors, usable, normal, basis, first, fitted):
    """Tangent coordinates ``(n, k, 2)`` of each point's neighbours and their heights
    ``(n, k)`` on the quadric fitted to the kept ones.

    ``z = c0 + c1 x + c2 y + c3 x^2 + c4 x y + c5 y^2`` by least squares over the point
    itself (at the origin) and its kept neighbours among the ``fitted`` nearest (a
    quadric is local: over a wider neighbourhood it misses the surface near the point
    and inflates the areas there), in units of the ``first``-th
    neighbour's distance, with a ridge of 1e-6; a point with fewer than 7 kept
    neighbours keeps its tangent plane (heights zero). The heights returned are the
    fitted ones minus the point's: the surface's bend without the noise across it.
    """
    n, k = neighbors.shape
    coords = np.empty((n, k, 2))
    lift = np.zeros((n, k))
    terms = np.empty((k, 6))
    gram = np.empty((6, 6))
    moments = np.empty(6)
    for i in range(n):
        m = neighbors[i, first - 1]
        unit = 0.0
        for r in range(3):
            unit += (points[m, r] - points[i, r]) ** 2
        unit = np.sqrt(unit)
        kept = 0
        for r in range(6):
            moments[r] = 0.0
            for q in range(6):
                gram[r, q] = 1e-6 if r == q else 0.0
        gram[0, 0] += 1.0  # the point itself, at height zero
        for j in range(k):
            m = neighbors[i, j]
            ux = points[m, 0] - points[i, 0]
            uy = points[m, 1] - points[i, 1]
            uz = points[m, 2] - points[i, 2]
            x = ux * basis[i, 0, 0] + uy * basis[i, 1, 0] + uz * basis[i, 2, 0]
            y = ux * basis[i, 0, 1] + uy * basis[i, 1, 1] + uz * basis[i, 2, 1]
            z = ux * normal[i, 0] + uy * normal[i, 1] + uz * normal[i, 2]
            coords[i, j, 0] = x
            coords[i, j, 1] = y
            x, y, z = x / unit, y / unit, z / unit
            terms[j, 0], terms[j, 1], terms[j, 2] = 1.0, x, y
            terms[j, 3], terms[j, 4], terms[j, 5] = x * x, x * y, y * y
            if usable[i, j] and j < fitted:
                kept += 1
                for r in range(6):  # the lower triangle: all the Cholesky reads
                    moments[r] += terms[j, r] * z
                    for q in range(r + 1):
                        gram[r, q] += terms[j, r] * terms[j, q]
        if kept < 7:
            continue
        # Cholesky of the (ridged, positive definite) Gram matrix, then two solves.
        for r in range(6):
            for q in range(r + 1):
                total = gram[r, q]
                for m in range(q):
                    total -= gram[r, m] * gram[q, m]
                gram[r, q] = np.sqrt(total) if r == q else total / gram[q, q]
        for r in range(6):
            total = moments[r]
            for m in range(r):
                total -= gram[r, m] * moments[m]
            moments[r] = total / gram[r, r]
        for r in range(5, -1, -1):
            total = moments[r]
            for m in range(r + 1, 6):
                total -= gram[m, r] * moments[m]
            moments[r] = total / gram[r, r]
        for j in range(k):
            height = 0.0
            for r in range(1, 6):
                height += terms[j, r] * moments[r]
            lift[i, j] = height * unit
    return coords, lift


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
    points = np.ascontiguousarray(points, dtype=np.float64)
    first = min(NORMAL_NEIGHBORS, neighbors.shape[1])
    fitted = min(LOCAL_NEIGHBORS, neighbors.shape[1])
    coords, lift = _lifted(points, neighbors, usable, normal, basis, first, fitted)
    fans = local_delaunay_fans(coords, usable)
    return _measured(fans, coords, lift, neighbors, DEGENERATE_SINE)


@numba.njit(cache=True)
def _measured(fans, coords, lift, neighbors, min_sine):
    """:func:`tangent_fans`'s ``(triangles, a, b)`` from the fans ``(i, a, b)`` of
    :func:`local_delaunay_fans` (positions among the neighbours), the tangent
    coordinates and the fitted heights: the edge vectors in the frame of ``i``, the
    triangles numbered as points, the degenerate ones left out."""
    m = fans.shape[0]
    triangles = np.empty((m, 3), np.int64)
    a = np.empty((m, 3))
    b = np.empty((m, 3))
    count = 0
    for t in range(m):
        i, ja, jb = fans[t, 0], fans[t, 1], fans[t, 2]
        ax, ay, az = coords[i, ja, 0], coords[i, ja, 1], lift[i, ja]
        bx, by, bz = coords[i, jb, 0], coords[i, jb, 1], lift[i, jb]
        cx, cy, cz = ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx
        double_area = np.sqrt(cx * cx + cy * cy + cz * cz)
        dx, dy, dz = bx - ax, by - ay, bz - az
        longest = max(ax * ax + ay * ay + az * az, bx * bx + by * by + bz * bz)
        longest = max(longest, dx * dx + dy * dy + dz * dz)
        if double_area > min_sine * longest:
            triangles[count, 0] = i
            triangles[count, 1] = neighbors[i, ja]
            triangles[count, 2] = neighbors[i, jb]
            a[count, 0], a[count, 1], a[count, 2] = ax, ay, az
            b[count, 0], b[count, 1], b[count, 2] = bx, by, bz
            count += 1
    return triangles[:count].copy(), a[:count].copy(), b[:count].copy()


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
