"""Extended persistence of the essential H1 classes of a closed surface (Ext1).

The ``2g`` essential H1 classes of a closed genus-``g`` surface are paired over Z/2 from
a tree-cotree decomposition: intersection numbers with the dual loops of one sweep give
coordinates in which the sublevel and superlevel flags of H1 are compared.
"""

from __future__ import annotations

import numba
import numpy as np

from ..mesh.graph import closed_surface_edges, connected_components, find_root

__all__ = ["closed_surface", "essential_h1_pairs", "rooted_forest"]


def closed_surface(faces: np.ndarray, adjacency):
    """Edges ``(e, 2)``, their two faces ``(e, 2)`` and the first Betti number.

    None unless every edge has exactly two faces (a closed surface).
    """
    surface = closed_surface_edges(faces, adjacency)
    if surface is None:
        return None
    edges, edge_faces = surface
    n_vertices = adjacency.shape[0]
    # The first Betti number: edges left out of both the primal and the dual spanning
    # forests. Zero (spheres) means no essential H1 to compute.
    used = np.zeros(n_vertices, dtype=bool)
    used[edges.ravel()] = True
    primal = connected_components(n_vertices, edges)[0] - (~used).sum()
    dual = connected_components(len(faces), edge_faces)[0]
    betti_1 = len(edges) - (used.sum() - primal) - (len(faces) - dual)
    return edges, edge_faces, int(betti_1)


@numba.njit(cache=True)
def _spanning_forest(n_nodes, ends, edge_order):
    """Edges kept by Kruskal's algorithm scanning ``edge_order``."""
    parent = np.arange(n_nodes)
    used = np.zeros(len(ends), dtype=np.bool_)
    for e in edge_order:
        a = find_root(parent, ends[e, 0])
        b = find_root(parent, ends[e, 1])
        if a != b:
            parent[a] = b
            used[e] = True
    return used


@numba.njit(cache=True)
def rooted_forest(n_nodes, ends, used):
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
def _path_edges(a, b, parent, parent_edge, depth, out):
    """The forest edges on the path between nodes ``a`` and ``b``, written to ``out``;
    returns their number."""
    count = 0
    while a != b:
        if depth[a] < depth[b]:
            a, b = b, a
        out[count] = parent_edge[a]
        count += 1
        a = parent[a]
    return count


@numba.njit(cache=True)
def _xor_along_paths(pairs, parent, parent_edge, depth, labels, out):
    """``out[k] ^= labels[e]`` for every edge ``e`` on the forest path of ``pairs[k]``."""
    path = np.empty(len(parent), np.int64)
    for k in range(len(pairs)):
        for t in range(_path_edges(pairs[k, 0], pairs[k, 1], parent, parent_edge, depth, path)):
            out[k] ^= labels[path[t]]


@numba.njit(cache=True)
def _mark_dual_loops(pairs, parent, parent_edge, depth, marks, labels):
    """``labels[e] ^= marks[k]`` for every edge ``e`` on the forest path of ``pairs[k]``."""
    path = np.empty(len(parent), np.int64)
    for k in range(len(pairs)):
        for t in range(_path_edges(pairs[k, 0], pairs[k, 1], parent, parent_edge, depth, path)):
            labels[path[t]] ^= marks[k]


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

    ``surface`` is the output of :func:`closed_surface`. Rows (birth, death): birth
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
    parent, parent_edge, depth = rooted_forest(int(edge_faces.max()) + 1, edge_faces, up_cotree)
    marks = np.zeros((len(up), words), dtype=np.uint64)
    marks[np.arange(len(up)), np.arange(len(up)) // 64] = bits
    _mark_dual_loops(edge_faces[up], parent, parent_edge, depth, marks, labels)
    parent, parent_edge, depth = rooted_forest(n_vertices, edges, down_tree)
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
