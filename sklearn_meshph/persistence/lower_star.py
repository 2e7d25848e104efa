"""Lower-star persistence of vertex functions (H0, by union-find over the edges)."""

from __future__ import annotations

import numba
import numpy as np
import scipy.sparse as sp

from ..graph.validation import Graph
from ..inputs import check_input
from ..mesh.graph import find_root, mesh_edges
from ..mesh.validation import check_values
from ..pointcloud.graph import edge_adjacency, surface_graph

__all__ = ["elder_merge", "lower_star_persistence", "sublevel_h0"]


@numba.njit(cache=True, inline="always")
def elder_merge(parent, rank, root_u, root_v, v, births, deaths, n_pairs):
    """Join the components of roots ``root_u != root_v`` at vertex ``v`` by the elder
    rule: the root of larger ``rank`` dies at ``v``, recorded in ``births`` and
    ``deaths`` at ``n_pairs`` unless it is ``v`` itself (a pair of length zero).
    Returns the surviving root and the new pair count."""
    if rank[root_u] < rank[root_v]:
        older, younger = root_u, root_v
    else:
        older, younger = root_v, root_u
    if younger != v:
        births[n_pairs] = younger
        deaths[n_pairs] = v
        n_pairs += 1
    parent[younger] = older
    return older, n_pairs


@numba.njit(cache=True)
def _union_find_h0(values, order, indptr, indices):
    """Sublevel H0 pairs of a vertex function over a CSR adjacency.

    Vertices enter in ``order`` (a total order: ascending value, ties by index). Each
    component is represented by its root, the vertex of smallest rank in it; when two
    components meet at vertex ``v`` the younger one (larger rank of its root) dies at
    ``values[v]`` (elder rule). Returns finite pairs as (birth vertex, death vertex) and
    the roots of the surviving components.
    """
    n = len(values)
    # Indices in the adjacency's integer type (int32 below 2**31 entries): this loop is
    # bound by memory traffic.
    rank = np.empty(n, dtype=order.dtype)
    for r in range(n):
        rank[order[r]] = r
    parent = np.arange(n).astype(order.dtype)
    births = np.empty(n, dtype=order.dtype)
    deaths = np.empty(n, dtype=order.dtype)
    n_pairs = 0
    for r in range(n):
        v = order[r]
        root_v = v
        for k in range(indptr[v], indptr[v + 1]):
            u = indices[k]
            if rank[u] > r:
                continue
            root_u = find_root(parent, u)
            if root_u != root_v:
                root_v, n_pairs = elder_merge(
                    parent, rank, root_u, root_v, v, births, deaths, n_pairs
                )
    roots = np.empty(n, dtype=order.dtype)
    n_roots = 0
    for r in range(n):
        v = order[r]
        if parent[v] == v:
            roots[n_roots] = v
            n_roots += 1
    return births[:n_pairs], deaths[:n_pairs], roots[:n_roots]


def sublevel_h0(adjacency: sp.csr_matrix, values: np.ndarray):
    """Finite H0 pairs ``(n, 2)``, essential births ``(c,)`` and the component roots.

    ``adjacency`` is :func:`sklearn_meshph.mesh.graph.mesh_edges` of the mesh; ``values`` a finite
    contiguous float64 vector.
    """
    order = np.argsort(values, kind="stable").astype(adjacency.indices.dtype, copy=False)
    births, deaths, roots = _union_find_h0(values, order, adjacency.indptr, adjacency.indices)
    pairs = np.column_stack([values[births], values[deaths]])
    pairs = pairs[pairs[:, 1] > pairs[:, 0]]
    return pairs, values[roots], roots


def lower_star_persistence(mesh, values) -> np.ndarray:
    """H0 persistence diagram of the lower-star filtration of a vertex function.

    Parameters
    ----------
    mesh : trimesh.Trimesh, (vertices, faces) pair, str, os.PathLike, point cloud or graph
        The simplicial complex: vertices, edges and triangles of the mesh as given (no
        cleaning: an unreferenced vertex is a component of its own). A point cloud (an
        ``(n, 3)`` array, a ``trimesh.PointCloud`` or a file of points) is filtered on
        the edges of its local triangles
        (:func:`sklearn_meshph.pointcloud.graph.surface_graph`), a graph (a
        :class:`~sklearn_meshph.graph.Graph`, an ``(n_nodes, edges)`` pair, a sparse
        adjacency or a networkx graph) on its nodes and edges.
    values : array-like of shape (n_vertices,)
        The function, finite (on a graph, one value per node).

    Returns
    -------
    diagram : ndarray of shape (n_pairs, 2)
        Rows (birth, death), float64 and exact (no rounding to float32): finite pairs by
        the elder rule with ties broken by vertex index, zero-persistence pairs dropped,
        then one essential class (death ``inf``) per connected component, born at its
        minimum.

    See Also
    --------
    LowerStarPersistence : Diagrams of many samples, superlevel and extended persistence.
    extended_persistence : The four extended diagrams of a function on a graph.

    Notes
    -----
    Vertices are sorted by value (stable: ties broken by vertex index, a total order) and
    added one at a time to a union-find over the edge adjacency; when a vertex joins
    components, all but the oldest (the one with the earliest minimum) die at its value.
    Triangles do not change H0, so only edges are used. The result equals the H0 diagram
    of the lower-star filtration computed by gudhi's ``SimplexTree``, bit for bit.

    References
    ----------
    .. [1] H. Edelsbrunner and J. Harer, "Computational Topology: An Introduction",
       AMS, 2010, section VII.1 (union-find for 0-dimensional persistence).

    Examples
    --------
    >>> import numpy as np
    >>> vertices = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], dtype=float)
    >>> faces = np.array([[0, 1, 2], [1, 3, 2]])
    >>> lower_star_persistence((vertices, faces), [0.0, 3.0, 2.0, 1.0])
    array([[ 1.,  2.],
           [ 0., inf]])
    """
    vertices, faces = check_input(mesh)
    n_vertices = vertices.n_nodes if isinstance(vertices, Graph) else len(vertices)
    values = check_values(values, n_vertices)
    if values.ndim != 1:
        raise ValueError(
            f"values must have shape ({n_vertices},), got {values.shape}: for several "
            "functions on one mesh use LowerStarPersistence, which shares the adjacency"
        )
    if isinstance(vertices, Graph):
        adjacency = edge_adjacency(vertices.edges, n_vertices)
    elif faces is None:
        adjacency = edge_adjacency(surface_graph(vertices, "point cloud"), n_vertices)
    else:
        adjacency = mesh_edges(faces, n_vertices)
    pairs, essential, _ = sublevel_h0(adjacency, values)
    return np.vstack([pairs, np.column_stack([essential, np.full(len(essential), np.inf)])])
