"""Laplacians of point clouds, one per entry of the mesh registry ``LAPLACIANS``.

- ``"cotangent"``: :func:`point_cloud_laplacian`, the cotangent Laplace-Beltrami
  operator of the union of local Delaunay triangulations of each point's neighbours on
  its own sheet of the surface, each point's triangles measured on the quadric fitted
  to its neighbourhood, each triangle's stiffness and mass shared among the corners
  that have a say on it (:func:`fan_shares`). It converges to
  the surface's operator under refinement, with uniform or uneven sampling and with
  noise below the sampling's spacing (measured against the unit sphere's spectrum in
  ``docs/point_clouds.md``).
- ``"graph"``: the combinatorial Laplacian ``D - A`` of the symmetric kNN graph that
  persistence filters (:mod:`.graph`), with ``M = I``, as ``"graph"`` is for meshes.

A change here changes the numbers a solve gives: bump
:data:`sklearn_meshph.spectral.cache.NUMERICS_VERSION` (a test checks).
"""

from __future__ import annotations

from numbers import Integral

import numba
import numpy as np
import scipy.sparse as sp

from .._param_validation import Interval, validate_params
from .._registry import Option, Registry
from ..mesh import unit_box_mass
from ..mesh.graph_laplacians import from_combinatorial, normalized_laplacian, random_walk_laplacian
from ..mesh.validation import check_vertices
from ._triangulation import LOCAL_NEIGHBORS, tangent_fans
from .graph import (
    GRAPH_NEIGHBORS,
    _knn_graph,
    cloud_unit_box,
    edge_adjacency,
    refuse_coincident,
    refuse_unresolved,
)
from .validation import MIN_POINTS

__all__ = [
    "CLOUD_LAPLACIANS",
    "LOCAL_NEIGHBORS",
    "cloud_operator",
    "fan_shares",
    "point_cloud_laplacian",
    "tangent_fans",
]


@validate_params({"n_neighbors": [Interval(Integral, 3, None, closed="left")]})
def point_cloud_laplacian(
    points: np.ndarray, n_neighbors: int = LOCAL_NEIGHBORS
) -> tuple[sp.csr_matrix, sp.dia_matrix]:
    """Cotangent stiffness and lumped mass of a point cloud's local triangulations.

    Parameters
    ----------
    points : ndarray of shape (n, 3) or trimesh.PointCloud
        Distinct, finite points sampling a surface.
    n_neighbors : int, default=30
        Neighbours per point that its local triangulation comes from. Its tangent plane
        and quadric are fitted to at most the 30 nearest of them (a wider fit misses
        the surface near the point). More neighbours still change the fans: a point
        whose near neighbours are left out (another sheet, a disagreeing plane) gets
        its cell closed by farther ones, so the area grows with the count. On a Sumner
        cat at 3,000 points the mass is 0.73, 0.78, 1.02 and 1.85 times the mesh's area
        with 20, 30, 100 and 500 neighbours; on a sphere 60 to 999 give the default's
        operator. Keep it near the default.

    Returns
    -------
    L : scipy.sparse.csr_matrix of shape (n, n)
        Symmetric positive semi-definite stiffness, rows summing to zero.
    M : scipy.sparse.dia_matrix of shape (n, n)
        Diagonal lumped mass; its sum estimates the surface's area. A point in no
        triangle (its neighbours on its own sheet too few or on a line) has zero mass
        and no stiffness.

    Raises
    ------
    ValueError
        Fewer than ``MIN_POINTS`` points, equal points, or areas float64 cannot hold at the points'
        scale (coordinates beyond about 1e154 or below 1e-154): the operator is built
        in the unit box and its mass scaled back, so any other scale gives the same
        stiffness and the mass times the scale squared.

    Notes
    -----
    Every point's neighbours on its own sheet of the surface
    (:func:`._triangulation.surface_neighbours`: not across a thin part, not on a part
    nearby) are projected onto its tangent plane and the Delaunay triangles at the
    point kept. Each triangle of a point's fan contributes the cotangent stiffness and
    barycentric mass (as in :func:`cotangent_laplacian`) of its shape on the quadric
    fitted to the point's neighbourhood (tangent coordinates and fitted heights),
    divided among the corners that have a say on it (:func:`fan_shares`): a triangle on
    which the neighbourhoods agree is in the fans of its three corners and counts once;
    neighbourhoods that disagree contribute each of their choices with its share; a
    corner whose fan leaves that side of it open (the sheet tests cut its neighbours
    there: a crease, the tip or rim of a thin part) has no say. Every triangle's
    stiffness is positive semi-definite, so the sum is too. Neighbours across a thin
    part would be folded into the fan by the projection, short-circuiting the surface
    (a stiffer operator, less area); the fitted heights keep the bend of a thin part
    and leave out the noise across the surface, which would otherwise add area at the
    sampling scale.
    This is the local triangulation of [1]_ (section 5.7) with an exact neighbour
    search, surface neighbourhoods, fitted geometry and without the tufted cover and
    intrinsic Delaunay flips, which on randomly sampled clouds lower the spectrum (the
    measurements are in ``docs/point_clouds.md``).

    References
    ----------
    .. [1] N. Sharp and K. Crane, "A Laplacian for Nonmanifold Triangle Meshes",
       Computer Graphics Forum 39(5), 2020.

    Examples
    --------
    >>> import numpy as np, trimesh
    >>> from sklearn_meshph import point_cloud_laplacian
    >>> points = np.asarray(trimesh.creation.icosphere(3).vertices)
    >>> L, M = point_cloud_laplacian(points)
    >>> round(float(M.sum()), 2)  # the area of the unit sphere, 4 pi = 12.57
    12.51
    """
    if not isinstance(points, np.ndarray) and hasattr(points, "vertices"):
        points = points.vertices  # a trimesh.PointCloud, as the estimators take it
    points = check_vertices(points, "points")
    if len(points) < MIN_POINTS:
        raise ValueError(
            f"points: a point cloud needs at least {MIN_POINTS} points, got {len(points)}"
        )
    refuse_coincident(points, "points")
    # In the unit box, as the eigen stage builds it: the same operator at any scale
    # (the stiffness is scale-free, the mass scaled back).
    unit, scale, unresolved = cloud_unit_box(points)
    refuse_unresolved(unresolved, "points")
    L, M, _ = cloud_operator(unit, n_neighbors)
    return L, sp.diags(unit_box_mass(M.diagonal(), scale, "point_cloud_laplacian"))


def cloud_operator(points: np.ndarray, n_neighbors: int = LOCAL_NEIGHBORS, *, knn=None):
    """:func:`point_cloud_laplacian` on checked points, and the triangles it sums.

    Returns ``(L, M, triangles)``, ``triangles`` an ``(m, 3)`` array of point indices:
    every local triangle of every point's fan (:func:`tangent_fans`), each as often as
    fans hold it. Their edges are a cloud's persistence complex, so the complex joins
    exactly the points the operator couples. ``knn``: the points' ``n_neighbors``
    nearest (:func:`._triangulation.nearest`), when the caller has them.
    """
    n = len(points)
    triangles, a, b = tangent_fans(points, n_neighbors, knn)
    # Weighted by three times the shares, then divided by three: a share of a third is
    # a weight of exactly 1.0, so closed fans give the plain sum's bits.
    indptr, indices, data, mass = _cotangent_csr(n, triangles, a, b, 3.0 * fan_shares(n, triangles))
    L = sp.csr_matrix((data / 3.0, indices, indptr), shape=(n, n))
    L.has_sorted_indices = True
    return L, sp.diags(mass / 3.0), triangles


@numba.njit(cache=True)
def fan_shares(n, triangles):
    """Each fan triangle's share of its shape: one over the number of its corners that
    have a say on it.

    ``triangles`` are :func:`tangent_fans`'s ``(i, j, k)``, ``i`` the point whose fan
    holds it, each point's fan in turn, counter-clockwise around it. A point's fan is
    closed when its triangles chain around it (each one's ``k`` is another's ``j``); it
    is open where the sheet tests left its surface neighbours on one side (a crease,
    the tip or the rim of a thin part), and where a degenerate triangle was dropped.
    The fan's owner has a say on a triangle, and so has each other corner whose own fan
    is closed or reaches both of the triangle's other corners (it holds the triangle,
    or covers its side with other triangles: a rim point whose neighbourhood chose the
    other diagonal of a square). A triangle on which the neighbourhoods agree is held
    by its three corners (share 1/3 each, once in all); where they disagree, each
    choice counts with its share; a corner whose fan is open on that side has no say,
    so a triangle held by the two others counts once, not two thirds (there the
    operator would otherwise be cut, the heat held at the open fans).
    """
    m = triangles.shape[0]
    start = np.zeros(n + 1, np.int64)
    for t in range(m):
        start[triangles[t, 0] + 1] += 1
    for r in range(n):
        start[r + 1] += start[r]
    order = np.empty(m, np.int64)  # each point's triangles, in the order given
    fill = start[:-1].copy()
    for t in range(m):
        order[fill[triangles[t, 0]]] = t
        fill[triangles[t, 0]] += 1
    closed = np.zeros(n, np.bool_)
    for r in range(n):
        closed[r] = start[r + 1] - start[r] >= 3
        for s in range(start[r], start[r + 1]):
            chained = False
            for u in range(start[r], start[r + 1]):
                if triangles[order[u], 1] == triangles[order[s], 2]:
                    chained = True
                    break
            if not chained:
                closed[r] = False
                break
    shares = np.empty(m)
    for t in range(m):
        say = 1
        for c in range(1, 3):
            corner, other = triangles[t, c], triangles[t, 3 - c]
            if closed[corner]:
                say += 1
                continue
            reaches_owner = reaches_other = False
            for s in range(start[corner], start[corner + 1]):
                for q in range(1, 3):
                    reaches_owner |= triangles[order[s], q] == triangles[t, 0]
                    reaches_other |= triangles[order[s], q] == other
            if reaches_owner and reaches_other:
                say += 1
        shares[t] = 1.0 / say
    return shares


@numba.njit(cache=True)
def _cotangent_csr(n, triangles, a, b, weights):
    """The cotangent stiffness of ``triangles``, each times its weight, as CSR arrays
    ``(indptr, indices, data)`` (sorted columns, entries that sum to exactly zero left
    out) and their lumped mass (a third of each triangle's weighted area at each
    corner).

    Each triangle ``(i, j, k)`` is measured by its edge vectors ``a = j - i`` and
    ``b = k - i`` in the frame of ``i``; an edge weighs half the cotangent of the
    corner opposite it, the cotangent of a corner being the dot product of its two
    edges over twice the area.
    """
    m = triangles.shape[0]
    start = np.zeros(n + 1, np.int64)
    for t in range(m):
        for c in range(3):
            start[triangles[t, c] + 1] += 2
    for r in range(n):
        start[r + 1] += start[r]
    fill = start[:-1].copy()
    columns = np.empty(6 * m, np.int64)
    entries = np.empty(6 * m)
    mass = np.zeros(n)
    for t in range(m):
        ax, ay, az = a[t, 0], a[t, 1], a[t, 2]
        bx, by, bz = b[t, 0], b[t, 1], b[t, 2]
        cx, cy, cz = ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx
        double_area = np.sqrt(cx * cx + cy * cy + cz * cz)
        at_i = (ax * bx + ay * by + az * bz) / double_area / 2.0 * weights[t]
        at_j = (ax * (ax - bx) + ay * (ay - by) + az * (az - bz)) / double_area / 2.0 * weights[t]
        at_k = (bx * (bx - ax) + by * (by - ay) + bz * (bz - az)) / double_area / 2.0 * weights[t]
        i, j, k = triangles[t, 0], triangles[t, 1], triangles[t, 2]
        # Edge (j, k) is opposite i, (i, k) opposite j, (i, j) opposite k.
        for p, q, w in ((j, k, at_i), (i, k, at_j), (i, j, at_k)):
            columns[fill[p]], entries[fill[p]] = q, w
            fill[p] += 1
            columns[fill[q]], entries[fill[q]] = p, w
            fill[q] += 1
        for c in range(3):
            mass[triangles[t, c]] += double_area / 6.0 * weights[t]
    # Each row's duplicates summed (in triangle order) through a slot per column,
    # then its distinct columns sorted (insertion sort: a few dozen), the diagonal (the
    # row's sum) in its place.
    indptr = np.zeros(n + 1, np.int64)
    indices = np.empty(6 * m + n, np.int64)
    data = np.empty(6 * m + n)
    seen = np.full(n, -1, np.int64)  # the last row that met each column
    slot = np.empty(n, np.int64)  # and where it went
    out = 0
    for r in range(n):
        first = out
        for s in range(start[r], start[r + 1]):
            col = columns[s]
            if seen[col] != r:
                seen[col], slot[col] = r, out
                indices[out], data[out] = col, entries[s]
                out += 1
            else:
                data[slot[col]] += entries[s]
        degree = 0.0
        kept = first
        for s in range(first, out):
            degree += data[s]
            if data[s] != 0.0:
                indices[kept], data[kept] = indices[s], -data[s]
                kept += 1
        out = kept
        if degree != 0.0:
            indices[out], data[out] = r, degree
            out += 1
        for s in range(first + 1, out):
            col, w = indices[s], data[s]
            u = s
            while u > first and indices[u - 1] > col:
                indices[u], data[u] = indices[u - 1], data[u - 1]
                u -= 1
            indices[u], data[u] = col, w
        indptr[r + 1] = out
    return indptr, indices[:out].copy(), data[:out].copy(), mass


def _graph(points):
    adjacency = edge_adjacency(_knn_graph(points, GRAPH_NEIGHBORS, refuse=False), len(points))
    degree = np.asarray(adjacency.sum(axis=1)).ravel()
    return (sp.diags(degree) - adjacency).tocsr(), sp.identity(len(points), format="dia")


def _with_fans(build):
    """``build``'s ``(L, M)`` and the local triangles of :func:`tangent_fans`: a cloud's
    complex is theirs whatever its operator."""

    def operator(points, *, knn=None):
        return (*build(points), tangent_fans(points, knn=knn)[0])

    # The operator alone, for cleaning to rebuild on the points it keeps (a graph
    # Laplacian restricted to some of its nodes is not theirs).
    operator.build = build
    return operator


#: The point-cloud discretization of each Laplacian of
#: :data:`sklearn_meshph.spectral.laplacians.LAPLACIANS`, by the same name. Each value
#: takes checked points (at least ``MIN_POINTS``; keyword ``knn``: their
#: ``LOCAL_NEIGHBORS`` nearest, if known) and returns ``(L, M, triangles)``: the
#: operator, and the local triangles whose edges are the cloud's persistence complex.
CLOUD_LAPLACIANS = Registry(
    "laplacian",
    [
        Option(
            "cotangent",
            cloud_operator,
            "cotangent Laplace-Beltrami operator of the local Delaunay triangulations "
            "of 30 neighbours, each in its tangent plane",
        ),
        Option(
            "graph",
            _with_fans(_graph),
            "combinatorial graph Laplacian `D - A` of the symmetric 10-nearest-neighbour "
            "graph, `M = I`",
        ),
        Option(
            "normalized",
            _with_fans(from_combinatorial(normalized_laplacian, _graph)),
            "symmetric normalized Laplacian `I - D^-1/2 A D^-1/2` of the graph of `graph`",
        ),
        Option(
            "random_walk",
            _with_fans(from_combinatorial(random_walk_laplacian, _graph)),
            "random-walk Laplacian `I - D^-1 A` of the graph of `graph`, `M = D`",
        ),
    ],
)
