"""The graphs of a point cloud: the complex its lower-star filtration uses, and its
neighbourhood graph.

A point cloud has no edges of its own. Its vertex functions are filtered over the edges
of the local triangles its operator is made of (:func:`surface_graph`), the role the
mesh's edges play for a mesh: the complex joins what the operator couples and nothing
else, so it never crosses a thin part or the gap between parts nearby. The symmetric
k-nearest-neighbour graph (an edge wherever either point is among the other's
``GRAPH_NEIGHBORS`` nearest) is the ``"graph"`` Laplacian's; without its long edges, it
decides which points are far from the rest (:func:`neighbourhood_components`), and the
neighbourhood radii of its points which are outliers for the sampling around them
(:func:`sparse_outliers`).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..mesh import unit_box, within_tukey_fences
from ..mesh.graph import connected_components
from ._triangulation import nearest, tangent_fans
from .validation import MIN_POINTS

__all__ = [
    "FAR_BOX_RATIO",
    "FAR_EDGE_RATIO",
    "FAR_SHARE",
    "GRAPH_NEIGHBORS",
    "OUTLIER_RATIO",
    "canonical_order",
    "cloud_unit_box",
    "edge_adjacency",
    "knn_graph",
    "nearest",
    "neighbourhood_components",
    "refuse_coincident",
    "refuse_unresolved",
    "sparse_outliers",
    "surface_graph",
    "unique_edges",
    "unresolved_phrase",
    "within_fences",
]

#: Neighbours per point of the graph that lower-star persistence filters on a cloud.
GRAPH_NEIGHBORS = 10

#: An edge of the kNN graph longer than this many times the smaller neighbourhood radius
#: of its two ends joins points that are far apart for the cloud's own sampling.
FAR_EDGE_RATIO = 8.0

#: A point whose neighbourhood radius is more than this many times its neighbours' is
#: an outlier for the sampling around it (:func:`sparse_outliers`).
OUTLIER_RATIO = 3.0


def within_fences(points: np.ndarray) -> np.ndarray:
    """The points within Tukey's fences (three interquartile ranges beyond the
    quartiles, per coordinate), or all of them when fewer than ``MIN_POINTS`` are: far
    points are not dropped yet when the cloud is tested for lying on a line, and one
    outlier 1e15 times the shape's size away would make any shape a line."""
    return points[_inside_fences(points)]


def _inside_fences(points: np.ndarray) -> np.ndarray:
    inside = within_tukey_fences(points)
    return inside if np.count_nonzero(inside) >= MIN_POINTS else np.ones(len(points), bool)


#: A cloud whose box is this many times the box of its points within Tukey's fences is
#: put in the unit box of those points (see :func:`cloud_unit_box`).
FAR_BOX_RATIO = 1e6
#: ... and when at most this share of its points is outside those fences.
FAR_SHARE = 0.1
#: Otherwise the points within the fences are unresolved when float64's resolution in
#: the whole cloud's box is more than this fraction of their own box (a box over
#: 4.5e9 times smaller than the cloud's).
UNRESOLVED = 1e-6
# Unit-box coordinates of far points are clipped here (they are dropped as far points).
_FAR_CLIP = 1e12


def cloud_unit_box(points: np.ndarray) -> tuple[np.ndarray, float, np.ndarray]:
    """:func:`sklearn_meshph.mesh.unit_box` of a cloud, robust to far points.

    The unit box of every point, unless the box is more than ``FAR_BOX_RATIO`` times
    that of the points within Tukey's fences, which have some extent, and at most
    ``FAR_SHARE`` of the points are outside them. One outlier at 1e100 times the
    shape's size centred the whole box so far away that subtracting its centre
    cancelled every digit of the shape's coordinates. The box is then that of the
    points within the fences, and the far points' coordinates in it are clipped at
    ``_FAR_CLIP`` (they are dropped as far points; clipping keeps them finite and far).

    With more points outside the fences, which is the shape is a guess: a shape with
    many far points around it, or a cluster of near-copies of one point with the shape
    far around it (the fences are drawn around whichever holds most points). The whole
    cloud's box is kept, and the third value, a mask, says which points it leaves
    unresolved: those within the fences when float64 resolves their box only to more
    than ``UNRESOLVED`` of its size (they may merge into few points). Callers refuse
    or report them; the mask is empty of ``True`` otherwise.

    Returns ``(unit, scale, unresolved)``.
    """
    unit, scale = unit_box(points)
    none = np.zeros(len(points), dtype=bool)
    inside = _inside_fences(points)
    bulk = points[inside]
    outside = len(points) - len(bulk)
    if outside == 0:
        return unit, scale, none
    moved, bulk_scale = unit_box(points, bulk)
    if not (float(np.ptp(bulk, axis=0).max()) > 0.0 and bulk_scale * FAR_BOX_RATIO < scale):
        return unit, scale, none
    # Far points are few. When many points are outside, the fences may have been drawn
    # around a cluster of (near-)duplicates, not the shape: its box is not the shape's.
    if outside > FAR_SHARE * len(points):
        resolution = np.finfo(np.float64).eps * (scale / bulk_scale)
        return unit, scale, inside if resolution > UNRESOLVED else none
    return np.clip(moved, -_FAR_CLIP, _FAR_CLIP), bulk_scale, none


def refuse_unresolved(unresolved: np.ndarray, place: str) -> None:
    """A ``ValueError`` naming ``place`` when :func:`cloud_unit_box` left points
    unresolved: a function given the points themselves does not guess which are the
    shape."""
    if unresolved.any():
        raise ValueError(
            f"{place}: {unresolved_phrase(unresolved)}; drop the far points (or the cluster)"
        )


def unresolved_phrase(unresolved: np.ndarray) -> str:
    """What :func:`cloud_unit_box`'s ``unresolved`` mask means, in words."""
    n, kept = len(unresolved), int(np.count_nonzero(unresolved))
    return (
        f"{kept} of the point cloud's {n} points lie in a box over "
        f"{UNRESOLVED / np.finfo(np.float64).eps:.2g} times smaller than the cloud's, "
        f"which float64 resolves to worse than {UNRESOLVED:.0e} of their size at the "
        f"cloud's scale, and the {n - kept} others "
        f"(over {100 * FAR_SHARE:.3g}% of the points) are too many to drop as far points"
    )


def canonical_order(points: np.ndarray) -> np.ndarray:
    """The points' indices sorted by coordinates (x, then y, then z; ties by index).

    A cloud is a set: everything computed from it is computed in this order and mapped
    back, so that permuting the input permutes the output exactly (bit for bit).
    """
    return np.lexsort((points[:, 2], points[:, 1], points[:, 0]))


def unique_edges(a: np.ndarray, b: np.ndarray, n: int) -> np.ndarray:
    """The edges ``(m, 2)`` joining ``a[t]`` and ``b[t]`` (nodes below ``n``): ``a < b``,
    sorted, each once, loops left out. One integer per edge, sorted and masked (NumPy
    2's hashing ``np.unique`` took 30 times as long on a cloud's ~20 edges per point,
    ``np.unique(axis=0)`` longer still)."""
    low, high = np.minimum(a, b).astype(np.int64), np.maximum(a, b).astype(np.int64)
    n = max(int(n), 1)
    codes = np.sort((low * n + high)[low != high])
    if len(codes):
        codes = codes[np.concatenate([[True], codes[1:] != codes[:-1]])]
    return np.column_stack([codes // n, codes % n])


def knn_graph(points: np.ndarray, n_neighbors: int = GRAPH_NEIGHBORS) -> np.ndarray:
    """Edges ``(m, 2)`` (``a < b``, sorted, each once) of the symmetric kNN graph.

    Computed in :func:`cloud_unit_box` and in :func:`canonical_order`, then renumbered:
    the same graph at any scale float64 holds, far points or not, and a permuted cloud
    gives the permuted graph. Points that box leaves unresolved are refused.
    """
    return _knn_graph(points, n_neighbors, refuse=True)


def _knn_graph(points: np.ndarray, n_neighbors: int, *, refuse: bool) -> np.ndarray:
    """:func:`knn_graph`; without ``refuse``, in the plain unit box: the eigen stage's
    points, already cleaned (their far points dropped, unresolved ones reported)."""
    points = np.asarray(points, dtype=np.float64)
    n = len(points)
    if n < 2:
        return np.empty((0, 2), dtype=np.int64)
    order = canonical_order(points)
    if refuse:
        unit, _, unresolved = cloud_unit_box(points[order])
        refuse_unresolved(unresolved, "points")
    else:
        unit = unit_box(points[order])[0]
    _, indices = nearest(unit, n_neighbors)
    return unique_edges(np.repeat(order, indices.shape[1]), order[indices.ravel()], n)


def refuse_coincident(points: np.ndarray, place: str) -> None:
    """A ``ValueError`` naming the sample when some points are equal: the local
    triangulations need distinct points (the eigen stage merges them; a function given
    the points themselves does not choose which of two values a merged point keeps)."""
    n_equal = len(points) - len(np.unique(points + 0.0, axis=0))  # +0.0: -0.0 is 0.0
    if n_equal:
        raise ValueError(
            f"{place}: {n_equal} of the point cloud's points are equal to others; the "
            "local triangulations need distinct points (LaplacianEigenTransformer "
            "merges them into ScalarFields)"
        )


def surface_graph(points: np.ndarray, place: str = "point cloud") -> np.ndarray:
    """Edges ``(m, 2)`` (``a < b``, sorted, each once) of the cloud's local triangles.

    The triangles of :func:`._triangulation.tangent_fans` (those the ``"cotangent"``
    operator sums), computed in the unit box and in :func:`canonical_order`, then
    renumbered: the same edges at any scale float64 holds, and a permuted cloud gives
    the permuted edges. A point in no triangle (its neighbours on its own sheet too few
    or on a line) has no edge: it is a component of its own, as an unreferenced vertex
    of a mesh is. Equal points are refused (:func:`refuse_coincident`, naming
    ``place``).
    """
    points = np.asarray(points, dtype=np.float64)
    if len(points) < 3:
        return np.empty((0, 2), dtype=np.int64)
    refuse_coincident(points, place)
    order = canonical_order(points)
    unit, _, unresolved = cloud_unit_box(points[order])
    refuse_unresolved(unresolved, place)
    triangles = tangent_fans(unit)[0]
    a = order[triangles[:, [0, 1, 2]].ravel()]
    b = order[triangles[:, [1, 2, 0]].ravel()]
    return unique_edges(a, b, len(points))


def neighbourhood_components(points: np.ndarray, knn=None) -> tuple[int, np.ndarray]:
    """Connected components of the kNN graph without its long edges.

    The neighbourhood radius of a point is the distance to its ``GRAPH_NEIGHBORS``-th
    nearest neighbour. An edge ``(i, j)`` of the kNN graph is long when it is longer
    than :data:`FAR_EDGE_RATIO` times the smaller radius of its two ends. A stray point
    (or a small cluster) far from the surface has all its nearest neighbours far away:
    it joins the cloud only through such edges, longer than anything the sampling makes
    near the surface, and becomes a component of its own. The test compares lengths
    with lengths, so it holds at any scale and density; the radius of the point at the
    surface end decides, since the far end's radius is as long as the edge itself.

    Returns ``(n_components, labels)`` as
    :func:`sklearn_meshph.mesh.graph.connected_components` does (labels in the order
    of each component's lowest index). ``points`` must be distinct. ``knn``: the
    points' :func:`nearest` for at least ``GRAPH_NEIGHBORS`` neighbours, when known.
    """
    n = len(points)
    if n < 2:
        return n, np.zeros(n, dtype=np.int64)
    distances, indices = _nearest(points, knn)
    radius = distances[:, -1]
    a = np.repeat(np.arange(n), indices.shape[1])
    b = indices.ravel()
    short = distances.ravel() <= FAR_EDGE_RATIO * np.minimum(radius[a], radius[b])
    return connected_components(n, np.column_stack([a[short], b[short]]))


def _nearest(points, knn):
    """The ``GRAPH_NEIGHBORS`` nearest of each point: the first columns of ``knn`` (a
    :func:`nearest` for more neighbours) when given, else a search."""
    if knn is None:
        return nearest(points, GRAPH_NEIGHBORS)
    distances, indices = knn
    return distances[:, :GRAPH_NEIGHBORS], indices[:, :GRAPH_NEIGHBORS]


def sparse_outliers(points: np.ndarray, knn=None) -> np.ndarray:
    """The mask of the points standing alone off the surface, for the sampling around them.

    The neighbourhood radius of a point is the distance to its ``GRAPH_NEIGHBORS``-th
    nearest neighbour. A point off the surface by a few spacings (a stray point inside
    the shape's box, between two legs of a table) has its nearest neighbours on the
    surface below it, and a radius of about its height; theirs is the sampling's
    spacing. In two steps:

    1. a point is a *candidate* when its radius is more than :data:`OUTLIER_RATIO`
       times the median radius of its neighbours;
    2. a candidate is an *outlier* when its radius is more than :data:`OUTLIER_RATIO`
       times the radius of every neighbour that is not a candidate itself (and it has
       one).

    Step 2 keeps the points where the sampling changes: a point of a sparse region at
    its border with a dense one may have mostly dense neighbours (step 1), but also
    sparse ones whose radius is as long as its own. Two outliers near each other do
    not vouch for each other, as candidates do not count in step 2. Ratios of lengths
    only: the same at any scale and density. Fewer than ``GRAPH_NEIGHBORS + 1`` points
    have no neighbourhoods to compare: none is an outlier. ``points`` must be distinct;
    ``knn`` as for :func:`neighbourhood_components`.
    """
    n = len(points)
    if n <= GRAPH_NEIGHBORS:
        return np.zeros(n, dtype=bool)
    distances, indices = _nearest(points, knn)
    radius = distances[:, -1]
    around = radius[indices]
    candidate = radius > OUTLIER_RATIO * np.median(around, axis=1)
    vouching = np.where(candidate[indices], 0.0, around).max(axis=1)
    return candidate & (vouching > 0) & (radius > OUTLIER_RATIO * vouching)


def edge_adjacency(edges: np.ndarray, n_vertices: int) -> sp.csr_matrix:
    """Symmetric adjacency (CSR, data 1, sorted columns) of an edge list, in the layout
    of :func:`sklearn_meshph.mesh.graph.mesh_edges` (one integer type for ``indptr``
    and ``indices``, int32 unless huge), which the union-find loops walk."""
    edges = np.asarray(edges, dtype=np.int64).reshape(-1, 2)
    rows = np.concatenate([edges[:, 0], edges[:, 1]])
    cols = np.concatenate([edges[:, 1], edges[:, 0]])
    adjacency = sp.csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(n_vertices, n_vertices))
    adjacency.sum_duplicates()
    adjacency.data[:] = 1.0
    adjacency.sort_indices()
    index_type = np.int32 if adjacency.nnz < 2**31 - 1 else np.int64
    adjacency.indices = adjacency.indices.astype(index_type)
    adjacency.indptr = adjacency.indptr.astype(index_type)
    return adjacency
