"""Vertex welding: one vertex per position, for triangle soups (STL) and split seams (OBJ).

STL stores every triangle with its own three vertices, and OBJ files with texture
coordinates repeat a vertex on each side of a UV seam; read with ``process=False`` such
a mesh falls apart into one component per triangle (or per chart). Welding maps every
vertex to the lowest-indexed vertex at the same position, before the rest of the
cleaning policy (:func:`sklearn_meshph.clean_mesh`).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from .graph import connected_components

__all__ = ["WELD_RTOL", "exact_representatives", "weld_groups", "weld_vertices"]

# Vertices closer than this times the bounding-box diagonal (in every coordinate) are
# welded. Far below any meaningful feature size, far above double rounding of a shared
# vertex written twice: ten-odd significant digits in a text file agree to it.
WELD_RTOL = 1e-10


def exact_representatives(vertices: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For each vertex, the lowest index of a vertex with exactly equal coordinates.

    Also returns those representatives in lexicographic order of their coordinates
    (``-0.0`` and ``0.0`` are equal).
    """
    n = len(vertices)
    # +0.0 turns -0.0 into 0.0, so that the two zeros (equal as numbers) compare equal.
    v = vertices + 0.0
    order = np.lexsort((v[:, 2], v[:, 1], v[:, 0]))  # stable: equal rows by index
    s = v[order]
    new_group = np.empty(n, dtype=bool)
    new_group[0] = True
    np.any(s[1:] != s[:-1], axis=1, out=new_group[1:])
    group = np.cumsum(new_group) - 1
    first = order[new_group]  # lowest index of each group: the sort is stable
    rep = np.empty(n, dtype=np.int64)
    rep[order] = first[group]
    return rep, first


def weld_vertices(vertices: np.ndarray, rtol: float = WELD_RTOL) -> np.ndarray:
    """Map every vertex to the vertex it is welded to.

    Two vertices are welded when every coordinate differs by at most
    ``rtol`` times the bounding-box diagonal; welding is transitive (chains of close
    vertices form one group) and each group is represented by its lowest index.

    Parameters
    ----------
    vertices : ndarray of shape (n, 3), float64
        Finite coordinates (as :func:`check_mesh` returns them).
    rtol : float, default=WELD_RTOL
        Tolerance relative to the bounding-box diagonal; ``0`` welds exactly equal
        coordinates only.

    Returns
    -------
    representative : ndarray of shape (n,), int64
        ``representative[i] <= i`` is the lowest index of the vertices welded with
        ``i``; ``representative[i] == i`` for every vertex of a mesh without
        coincident vertices.
    """
    if len(vertices) < 2:
        return np.arange(len(vertices), dtype=np.int64)
    return weld_groups(vertices, exact_representatives(vertices), rtol)


def weld_groups(vertices: np.ndarray, exact, rtol: float) -> np.ndarray:
    """:func:`weld_vertices` from ``exact``, the :func:`exact_representatives` of the
    same ``vertices`` (at least two), for a caller that has them already."""
    n = len(vertices)
    rep, first = exact
    diagonal = float(np.linalg.norm(vertices.max(axis=0) - vertices.min(axis=0)))
    tol = rtol * diagonal
    if tol > 0 and len(first) > 1:
        # Close vertices have close projections on any direction: in the order of the
        # projections, every gap between two close vertices is at most ``tol`` times
        # the direction's 1-norm (plus rounding). Only the runs of such gaps go to the
        # k-d tree, usually none. The direction is generic, so that the equal
        # coordinates of symmetric meshes do not make long runs.
        direction = np.array([0.5773502691896258, 0.6172133998483676, 0.5345224838248488])
        points = vertices[first]
        projection = points @ direction
        order = np.argsort(projection, kind="stable")
        margin = direction.sum() * (tol + 8 * np.finfo(float).eps * np.abs(points).max())
        close = np.diff(projection[order]) <= margin
        candidate = np.zeros(len(first), dtype=bool)
        candidate[order[:-1][close]] = True
        candidate[order[1:][close]] = True
        unique = np.sort(first[candidate])
        if len(unique) > 1:
            pairs = cKDTree(vertices[unique]).query_pairs(tol, p=np.inf, output_type="ndarray")
            if len(pairs):
                _, labels = connected_components(len(unique), pairs.astype(np.int64))
                # ``unique`` is ascending: the first member of a label is its lowest.
                _, lowest = np.unique(labels, return_index=True)
                target = np.arange(n, dtype=np.int64)
                target[unique] = unique[lowest[labels]]
                rep = target[rep]
    return rep
