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
    # Indices in the adjacency's integer type: int32 below 2**31 entries, which halves
    # the memory traffic of this cache-bound loop.
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
    roots = np.empty(n, dtype=order.dtype)
    n_roots = 0
    for r in range(n):
        v = order[r]
        if parent[v] == v:
            roots[n_roots] = v
            n_roots += 1
    return births[:n_pairs], deaths[:n_pairs], roots[:n_roots]


def edge_adjacency(faces: np.ndarray, n_vertices: int) -> sp.csr_matrix:
    """CSR vertex adjacency of the mesh edges, built once per mesh.

    Its ``indptr`` and ``indices`` share one integer type (scipy's choice: int32 unless
    the mesh is huge), which the union-find uses for all its arrays.
    """
    adjacency = mesh_edges(faces, n_vertices)
    index_type = np.promote_types(adjacency.indices.dtype, adjacency.indptr.dtype)
    adjacency.indices = adjacency.indices.astype(index_type, copy=False)
    adjacency.indptr = adjacency.indptr.astype(index_type, copy=False)
    return adjacency


def sublevel_h0(adjacency: sp.csr_matrix, values: np.ndarray):
    """Finite H0 pairs (n, 2) and essential births (c,) of the sublevel filtration."""
    order = np.argsort(values, kind="stable").astype(adjacency.indices.dtype, copy=False)
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
    if values.ndim != 1:
        raise ValueError(
            f"values must have shape ({len(vertices)},), got {values.shape}: for several "
            "functions on one mesh use LowerStarPersistence, which shares the adjacency"
        )
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


def function_diagrams(adjacency, values, *, filtration, essential, min_persistence, surface=None):
    """The diagrams of one function, as a list of (n, 2) arrays (see LowerStarPersistence).

    ``surface`` (from ``closed_surface_edges``, built once per mesh) enables the essential
    H1 diagram of ``"extended"``; without it that diagram is empty.
    """
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
            ext1 = np.empty((0, 2)) if surface is None else essential_h1_pairs(values, surface)
            diagrams = [sub, _reflect(sup), extremes, ext1[ext1[:, 0] < ext1[:, 1]]]
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


def closed_surface_edges(faces: np.ndarray, n_vertices: int):
    """Edges ``(e, 2)``, their two faces ``(e, 2)`` and the first Betti number.

    None unless every edge has exactly two faces (a closed surface).
    """
    half = np.sort(np.stack([faces, np.roll(faces, -1, axis=1)], axis=2).reshape(-1, 2), axis=1)
    if len(half) == 0 or (half[:, 0] == half[:, 1]).any():
        return None
    key = half[:, 0] * np.int64(n_vertices) + half[:, 1]
    order = np.argsort(key, kind="stable")
    key = key[order]
    if len(key) % 2 or (key[0::2] != key[1::2]).any() or (key[2::2] == key[1:-1:2]).any():
        return None
    face_of = order // 3
    edges = half[order[0::2]]
    edge_faces = np.column_stack([face_of[0::2], face_of[1::2]])
    # The first Betti number: edges left out of both the primal and the dual spanning
    # forests. Zero (spheres) means no essential H1 to compute.
    used = np.zeros(n_vertices, dtype=bool)
    used[edges.ravel()] = True
    primal = _n_components(edges, n_vertices) - (~used).sum()
    dual = _n_components(edge_faces, len(faces))
    betti_1 = len(edges) - (used.sum() - primal) - (len(faces) - dual)
    return edges, edge_faces, int(betti_1)


def _n_components(ends: np.ndarray, n_nodes: int) -> int:
    graph = sp.coo_matrix((np.ones(len(ends)), (ends[:, 0], ends[:, 1])), (n_nodes, n_nodes))
    return connected_components(graph, directed=False)[0]


@numba.njit(cache=True)
def _spanning_forest(n_nodes, ends, edge_order):
    """Edges kept by Kruskal's algorithm scanning ``edge_order``."""
    parent = np.arange(n_nodes)
    used = np.zeros(len(ends), dtype=np.bool_)
    for e in edge_order:
        a = _find(parent, ends[e, 0])
        b = _find(parent, ends[e, 1])
        if a != b:
            parent[a] = b
            used[e] = True
    return used


@numba.njit(cache=True)
def _rooted_forest(n_nodes, ends, used):
    """Parent node, parent edge and depth of every node of the forest of ``used`` edges."""
    degree = np.zeros(n_nodes + 1, dtype=np.int64)
    for e in range(len(ends)):
        if used[e]:
            degree[ends[e, 0] + 1] += 1
            degree[ends[e, 1] + 1] += 1
    indptr = np.cumsum(degree)
    fill = indptr[:-1].copy()
    incident = np.empty(indptr[-1], dtype=np.int64)
    for e in range(len(ends)):
        if used[e]:
            for a in (ends[e, 0], ends[e, 1]):
                incident[fill[a]] = e
                fill[a] += 1
    parent = np.full(n_nodes, -1, dtype=np.int64)
    parent_edge = np.full(n_nodes, -1, dtype=np.int64)
    depth = np.zeros(n_nodes, dtype=np.int64)
    queue = np.empty(n_nodes, dtype=np.int64)
    for root in range(n_nodes):
        if parent[root] != -1:
            continue
        parent[root] = root
        head, tail = 0, 1
        queue[0] = root
        while head < tail:
            a = queue[head]
            head += 1
            for k in range(indptr[a], indptr[a + 1]):
                e = incident[k]
                b = ends[e, 0] + ends[e, 1] - a
                if parent[b] == -1:
                    parent[b] = a
                    parent_edge[b] = e
                    depth[b] = depth[a] + 1
                    queue[tail] = b
                    tail += 1
    return parent, parent_edge, depth


@numba.njit(cache=True)
def _xor_along_paths(pairs, parent, parent_edge, depth, labels, out):
    """``out[k] ^= labels[e]`` for every edge ``e`` of the forest path between ``pairs[k]``."""
    for k in range(len(pairs)):
        a, b = pairs[k, 0], pairs[k, 1]
        while a != b:
            if depth[a] < depth[b]:
                a, b = b, a
            out[k] ^= labels[parent_edge[a]]
            a = parent[a]


def _essential_cycles(values, edges, edge_faces, n_vertices):
    """Tree-cotree split of a closed surface for the lower-star order of ``values``.

    Returns the edges that create an H1 class which neither the sublevel sweep kills
    (they are not in the primal spanning forest, scanned upwards) nor is dual to an H0
    merge of the faces scanned downwards (the dual spanning forest): the ``2g`` births
    of essential H1, in filtration order, with both forests.
    """
    rank = np.empty(len(values), dtype=np.int64)
    rank[np.argsort(values, kind="stable")] = np.arange(len(values))
    ranks = rank[edges]
    order = np.argsort(ranks.max(axis=1) * np.int64(len(values)) + ranks.min(axis=1))
    tree = _spanning_forest(n_vertices, edges, order)
    cotree = _spanning_forest(int(edge_faces.max()) + 1, edge_faces, order[::-1])
    return order[~(tree | cotree)[order]], tree, cotree


def essential_h1_pairs(values: np.ndarray, surface) -> np.ndarray:
    """Extended persistence of the essential H1 classes of a closed surface (Ext1).

    ``surface`` is the output of ``closed_surface_edges``. Rows (birth, death): birth
    when the class appears in the sublevel sweep, death when it enters the image of a
    superlevel set's H1. Computed over Z/2 as the relative position of the two flags
    of H1 (classes born below a level, classes coming from above a level), in the
    coordinates given by intersection numbers with the dual loops of a tree-cotree
    decomposition.
    """
    edges, edge_faces, betti_1 = surface
    if betti_1 == 0:
        return np.empty((0, 2))
    n_vertices = len(values)
    up, _, up_cotree = _essential_cycles(values, edges, edge_faces, n_vertices)
    down, down_tree, _ = _essential_cycles(-values, edges, edge_faces, n_vertices)
    if len(up) == 0:
        return np.empty((0, 2))
    words = (len(up) + 63) // 64
    bits = np.uint64(1) << (np.arange(len(up)) % 64).astype(np.uint64)
    # labels[e] holds the dual loops (one per class born upwards) that cross edge e
    labels = np.zeros((len(edges), words), dtype=np.uint64)
    labels[up, np.arange(len(up)) // 64] = bits
    parent, parent_edge, depth = _rooted_forest(int(edge_faces.max()) + 1, edge_faces, up_cotree)
    marks = np.zeros((len(up), words), dtype=np.uint64)
    marks[np.arange(len(up)), np.arange(len(up)) // 64] = bits
    _mark_dual_loops(edge_faces[up], parent, parent_edge, depth, marks, labels)
    parent, parent_edge, depth = _rooted_forest(n_vertices, edges, down_tree)
    coordinates = labels[down].copy()
    _xor_along_paths(edges[down], parent, parent_edge, depth, labels, coordinates)
    pivots: dict[int, int] = {}
    pairs = []
    for j, row in enumerate(coordinates):
        vector = sum(int(w) << (64 * i) for i, w in enumerate(row))
        while vector and (vector.bit_length() - 1) in pivots:
            vector ^= pivots[vector.bit_length() - 1]
        low = vector.bit_length() - 1
        pivots[low] = vector
        pairs.append((values[edges[up[low]]].max(), values[edges[down[j]]].min()))
    return np.array(pairs, dtype=np.float64)


@numba.njit(cache=True)
def _mark_dual_loops(face_pairs, parent, parent_edge, depth, marks, labels):
    """``labels[e] ^= marks[k]`` for the cotree edges on the dual path of loop ``k``."""
    for k in range(len(face_pairs)):
        a, b = face_pairs[k, 0], face_pairs[k, 1]
        while a != b:
            if depth[a] < depth[b]:
                a, b = b, a
            labels[parent_edge[a]] ^= marks[k]
            a = parent[a]
