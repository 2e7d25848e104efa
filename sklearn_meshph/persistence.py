"""Lower-star persistence of vertex functions on meshes (H0, by union-find)."""

from __future__ import annotations

import numba
import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from ._mesh import check_mesh, mesh_edges

__all__ = ["lower_star_persistence"]


@numba.njit(cache=True)
def _find(parent, x):
    root = x
    while parent[root] != root:
        root = parent[root]
    while parent[x] != root:
        parent[x], x = root, parent[x]
    return root


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
    rank = np.empty(n, dtype=np.int64)
    for r in range(n):
        rank[order[r]] = r
    parent = np.arange(n)
    births = np.empty(n, dtype=np.int64)
    deaths = np.empty(n, dtype=np.int64)
    n_pairs = 0
    for r in range(n):
        v = order[r]
        root_v = v
        for k in range(indptr[v], indptr[v + 1]):
            u = indices[k]
            if rank[u] > r:
                continue
            root_u = _find(parent, u)
            if root_u == root_v:
                continue
            if rank[root_u] < rank[root_v]:
                older, younger = root_u, root_v
            else:
                older, younger = root_v, root_u
            if younger != v:
                births[n_pairs] = younger
                deaths[n_pairs] = v
                n_pairs += 1
            parent[younger] = older
            root_v = older
    roots = np.empty(n, dtype=np.int64)
    n_roots = 0
    for r in range(n):
        v = order[r]
        if parent[v] == v:
            roots[n_roots] = v
            n_roots += 1
    return births[:n_pairs], deaths[:n_pairs], roots[:n_roots]


def edge_adjacency(faces: np.ndarray, n_vertices: int) -> sp.csr_matrix:
    """CSR vertex adjacency of the mesh edges, built once per mesh."""
    adjacency = mesh_edges(faces, n_vertices)
    adjacency.indices = adjacency.indices.astype(np.int64, copy=False)
    adjacency.indptr = adjacency.indptr.astype(np.int64, copy=False)
    return adjacency


def sublevel_h0(adjacency: sp.csr_matrix, values: np.ndarray):
    """Finite H0 pairs (n, 2) and essential births (c,) of the sublevel filtration."""
    order = np.argsort(values, kind="stable")
    births, deaths, roots = _union_find_h0(values, order, adjacency.indptr, adjacency.indices)
    pairs = np.column_stack([values[births], values[deaths]])
    pairs = pairs[pairs[:, 1] > pairs[:, 0]]
    return pairs, values[roots], roots


def lower_star_persistence(mesh, values) -> np.ndarray:
    """H0 persistence diagram of the lower-star filtration of a vertex function.

    Parameters
    ----------
    mesh : trimesh.Trimesh, (vertices, faces) pair, str or os.PathLike
        The simplicial complex: vertices, edges and triangles of the mesh as given (no
        cleaning: an unreferenced vertex is a component of its own).
    values : array-like of shape (n_vertices,)
        The function, finite.

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
    vertices, faces = check_mesh(mesh)
    values = check_values(values, len(vertices))
    pairs, essential, _ = sublevel_h0(edge_adjacency(faces, len(vertices)), values)
    return np.vstack([pairs, np.column_stack([essential, np.full(len(essential), np.inf)])])


def check_values(values, n_vertices: int, index: int | None = None) -> np.ndarray:
    """Vertex values as float64, shape ``(n_vertices,)`` or ``(n_vertices, k)``, finite."""
    where = "values" if index is None else f"sample {index}"
    values = np.asarray(values, dtype=np.float64)
    if values.ndim not in (1, 2) or values.shape[0] != n_vertices:
        raise ValueError(
            f"{where}: values must have shape ({n_vertices},) or ({n_vertices}, k) to match "
            f"the mesh's vertices, got {values.shape}"
        )
    if not np.isfinite(values).all():
        raise ValueError(f"{where}: values contain NaN or inf")
    return values


FILTRATIONS = ("symmetric", "sublevel", "superlevel", "extended")


def _reflect(diagram: np.ndarray) -> np.ndarray:
    """The pairs of ``-f`` from those of ``f``: (b, d) -> (-d, -b)."""
    return np.column_stack([-diagram[:, 1], -diagram[:, 0]])


def function_diagrams(adjacency, values, *, filtration, essential, min_persistence):
    """The diagrams of one function, as a list of (n, 2) arrays (see LowerStarPersistence)."""
    if filtration in ("sublevel", "superlevel"):
        if filtration == "superlevel":
            values = -values
        pairs, births, roots = sublevel_h0(adjacency, values)
        diagrams = [np.vstack([pairs, _essential(births, values, roots, adjacency, essential)])]
    else:
        sub, _, roots = sublevel_h0(adjacency, values)
        sup, _, _ = sublevel_h0(adjacency, -values)
        extremes = _component_extremes(values, roots, adjacency)
        if filtration == "extended":
            diagrams = [sub, _reflect(sup), extremes]
        else:
            diagrams = [np.vstack([sub, sup]), np.vstack([extremes, _reflect(extremes)])]
    # Also drops the (min, max) pair of a component where the function is constant.
    return [d[(d[:, 1] - d[:, 0]) > min_persistence] for d in diagrams]


def _component_extremes(values, roots, adjacency):
    """(min, max) of each connected component, in the order of the minima's ranks."""
    _, labels = connected_components(adjacency, directed=False)
    maxima = np.full(labels.max() + 1, -np.inf)
    np.maximum.at(maxima, labels, values)
    return np.column_stack([values[roots], maxima[labels[roots]]])


def _essential(births, values, roots, adjacency, policy):
    if policy == "drop":
        return np.empty((0, 2))
    if policy == "max":
        return _component_extremes(values, roots, adjacency)
    return np.column_stack([births, np.full(len(births), np.inf)])
