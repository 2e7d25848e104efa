"""The mesh as a graph: union-find, connected components, the edge adjacency and the
faces around each edge, each computed by one compiled routine that every stage shares."""

from __future__ import annotations

import numba
import numpy as np
import scipy.sparse as sp


@numba.njit(cache=True)
def find_root(parent, v):
    """Root of ``v`` in a union-find forest, halving the path on the way."""
    while parent[v] != v:
        parent[v] = parent[parent[v]]
        v = parent[v]
    return v


@numba.njit(cache=True)
def connected_components(n, groups):
    """Connected components of ``n`` nodes joined by the rows of ``groups``.

    Every row of ``groups`` (faces ``(m, 3)``, edges ``(e, 2)``) joins its nodes.
    Returns ``(n_components, labels)``: labels number the components in the order of
    their lowest node; a node in no row is a component of its own.
    """
    parent = np.arange(n)
    for f in range(groups.shape[0]):
        for k in range(1, groups.shape[1]):
            ra = find_root(parent, groups[f, 0])
            rb = find_root(parent, groups[f, k])
            if ra != rb:
                if ra < rb:
                    parent[rb] = ra
                else:
                    parent[ra] = rb
    labels = np.empty(n, np.int64)
    count = 0
    for v in range(n):
        r = find_root(parent, v)
        if r == v:  # roots are their component's lowest node
            labels[v] = count
            count += 1
        else:
            labels[v] = labels[r]
    return count, labels


@numba.njit(cache=True)
def edge_matrix_csr(n, faces, weights, laplacian):
    """CSR arrays ``(data, indices, indptr)`` of the symmetric matrix with
    ``-weights[f, k]`` on both entries of the edge opposite corner ``k`` of face ``f``,
    duplicates summed, columns sorted.

    With ``laplacian`` the diagonal is added, minus the sum of each row, so that rows sum
    to zero; without it the result is the adjacency of the edges with every value 1.
    Every row gets an entry per distinct neighbour, even one whose weights sum to zero.
    """
    m = faces.shape[0]
    start = np.zeros(n + 1, dtype=np.int64)
    for f in range(m):
        for k in range(3):
            start[faces[f, (k + 1) % 3] + 1] += 1
            start[faces[f, (k + 2) % 3] + 1] += 1
    for i in range(n):
        start[i + 1] += start[i]
    fill = start[:n].copy()
    cols = np.empty(start[n], dtype=np.int64)
    vals = np.empty(start[n])
    for f in range(m):
        for k in range(3):
            a = faces[f, (k + 1) % 3]
            b = faces[f, (k + 2) % 3]
            w = -weights[f, k]
            cols[fill[a]] = b
            vals[fill[a]] = w
            fill[a] += 1
            cols[fill[b]] = a
            vals[fill[b]] = w
            fill[b] += 1
    extra = n if laplacian else 0
    indptr = np.zeros(n + 1, dtype=np.int64)
    indices = np.empty(start[n] + extra, dtype=np.int64)
    data = np.empty(start[n] + extra)
    pos = 0
    for r in range(n):
        lo, hi = start[r], start[r + 1]
        for p in range(lo + 1, hi):  # insertion sort: a row holds a dozen entries
            c, v = cols[p], vals[p]
            q = p - 1
            while q >= lo and cols[q] > c:
                cols[q + 1] = cols[q]
                vals[q + 1] = vals[q]
                q -= 1
            cols[q + 1] = c
            vals[q + 1] = v
        diagonal_at = -1
        total = 0.0
        p = lo
        while p < hi:
            c = cols[p]
            v = vals[p]
            p += 1
            while p < hi and cols[p] == c:
                v += vals[p]
                p += 1
            if laplacian and diagonal_at < 0 and c > r:
                diagonal_at = pos
                indices[pos] = r
                pos += 1
            indices[pos] = c
            data[pos] = v if laplacian else 1.0
            total += v
            pos += 1
        if laplacian:
            if diagonal_at < 0:
                diagonal_at = pos
                indices[pos] = r
                pos += 1
            data[diagonal_at] = -total
        indptr[r + 1] = pos
    return data[:pos], indices[:pos], indptr  # scipy's (data, indices, indptr) order


def mesh_edges(faces: np.ndarray, n_vertices: int) -> sp.csr_matrix:
    """Symmetric vertex adjacency (CSR, data 1, sorted columns) of the edges of ``faces``.

    Built by a counting sort on rows with duplicates merged per row (compiled), an order
    of magnitude faster than ``np.unique`` over edge rows on large meshes. ``indptr`` and
    ``indices`` share one integer type (int32 unless the mesh is huge), which halves the
    memory traffic of the loops that walk it.
    """
    faces = np.ascontiguousarray(faces, dtype=np.int64)
    data, indices, indptr = edge_matrix_csr(n_vertices, faces, np.ones(faces.shape), False)
    index_type = np.int32 if len(indices) < 2**31 - 1 else np.int64
    return sp.csr_matrix(
        (data, indices.astype(index_type), indptr.astype(index_type)),
        shape=(n_vertices, n_vertices),
    )


@numba.njit(cache=True)
def _edges_of_faces(faces, indptr, indices):
    """Each edge (once, ``a < b``), and the faces around it when there are exactly two.

    Returns ``(edges, edge_faces, closed)``; ``closed`` is False (and ``edge_faces``
    incomplete) when some edge does not have exactly two faces.
    """
    n = len(indptr) - 1
    edge_id = np.full(len(indices), -1, np.int64)
    n_edges = 0
    for a in range(n):
        for p in range(indptr[a], indptr[a + 1]):
            if indices[p] > a:
                edge_id[p] = n_edges
                n_edges += 1
    edges = np.empty((n_edges, 2), np.int64)
    for a in range(n):
        for p in range(indptr[a], indptr[a + 1]):
            if edge_id[p] >= 0:
                edges[edge_id[p], 0] = a
                edges[edge_id[p], 1] = indices[p]
    edge_faces = np.full((n_edges, 2), -1, np.int64)
    count = np.zeros(n_edges, np.int64)
    closed = True
    for f in range(faces.shape[0]):
        for k in range(3):
            a, b = faces[f, k], faces[f, (k + 1) % 3]
            if a == b:  # a face with a repeated vertex: not a surface
                closed = False
                continue
            if a > b:
                a, b = b, a
            p = indptr[a]
            while indices[p] != b:
                p += 1
            e = edge_id[p]
            if count[e] < 2:
                edge_faces[e, count[e]] = f
            else:
                closed = False
            count[e] += 1
    for e in range(n_edges):
        if count[e] != 2:
            closed = False
    return edges, edge_faces, closed


def closed_surface_edges(faces: np.ndarray, adjacency: sp.csr_matrix):
    """The edges ``(e, 2)`` of a closed surface and the two faces of each ``(e, 2)``.

    ``adjacency`` is :func:`mesh_edges` of the same faces. None unless every edge has
    exactly two faces.
    """
    edges, edge_faces, closed = _edges_of_faces(
        np.ascontiguousarray(faces, dtype=np.int64), adjacency.indptr, adjacency.indices
    )
    return (edges, edge_faces) if closed and len(edges) else None
