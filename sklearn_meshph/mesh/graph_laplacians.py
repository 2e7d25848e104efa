"""Laplacians of a weighted adjacency matrix: the graph operators of every input kind.

A mesh's edges, a point cloud's neighbourhood graph and a graph sample all reach the
eigensolver through these three operators of a symmetric adjacency ``A`` (non-negative
weights, no self-loops) with degrees ``d_i = sum_j A_ij``, each a stiffness ``L`` and a
diagonal mass ``M`` for ``L phi = lambda M phi``:

- :func:`combinatorial_laplacian`: ``L = D - A``, ``M = I``;
- :func:`normalized_laplacian`: the symmetric normalized ``L = I - D^-1/2 A D^-1/2``,
  ``M = I`` (eigenvalues in ``[0, 2]``); an isolated node has ``L_ii = 0``, as in
  F. Chung's definition, ``scipy.sparse.csgraph.laplacian(normed=True)`` and
  networkx: every connected component, isolated nodes included, then contributes one
  zero eigenvalue;
- :func:`random_walk_laplacian`: ``I - D^-1 A``, solved as ``(D - A) phi = lambda D phi``
  (``M = D``, eigenvectors D-orthonormal); its eigenvalues are the normalized
  Laplacian's and its eigenvectors ``D^-1/2`` times the normalized one's. An isolated
  node has mass 1 (``D`` would be singular): eigenvalue 0, its indicator function.

They live in the lowest layer so that the mesh, point-cloud and graph registries of
Laplacians share one implementation.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

__all__ = [
    "OPERATORS",
    "adjacency_of",
    "combinatorial_laplacian",
    "edge_entries",
    "from_combinatorial",
    "normalized_laplacian",
    "random_walk_laplacian",
]


def _entries(adjacency: sp.spmatrix):
    """``(n, rows, cols, weights)`` of the stored entries of ``adjacency``."""
    adjacency = sp.csr_matrix(adjacency)
    n = adjacency.shape[0]
    rows = np.repeat(np.arange(n), np.diff(adjacency.indptr))
    return n, rows, adjacency.indices, adjacency.data.astype(np.float64)


def edge_entries(n_nodes: int, edges: np.ndarray, weights: np.ndarray):
    """``(n, rows, cols, weights)`` of the adjacency of undirected ``edges`` (each once,
    no self-loop): the entries of both directions, without building the matrix."""
    rows = np.concatenate([edges[:, 0], edges[:, 1]])
    cols = np.concatenate([edges[:, 1], edges[:, 0]])
    return n_nodes, rows, cols, np.concatenate([weights, weights]).astype(np.float64)


def _operator(n, rows, cols, off_diagonal, diagonal) -> sp.csr_matrix:
    """The CSR matrix of ``off_diagonal`` at ``(rows, cols)`` (distinct, off the
    diagonal) and of ``diagonal``, built from the arrays at once: scipy's sparse
    arithmetic costs more than a small graph's whole solve."""
    nodes = np.arange(n)
    rows, cols = np.concatenate([rows, nodes]), np.concatenate([cols, nodes])
    order = np.lexsort((cols, rows))
    indptr = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(np.bincount(rows, minlength=n), out=indptr[1:])
    data = np.concatenate([off_diagonal, diagonal])[order]
    return sp.csr_matrix((data, cols[order], indptr), shape=(n, n))


def _diagonal(values: np.ndarray) -> sp.dia_matrix:
    return sp.dia_matrix((values[None, :], [0]), shape=(len(values), len(values)))


def _combinatorial(n, rows, cols, weights):
    degrees = np.bincount(rows, weights=weights, minlength=n)
    return _operator(n, rows, cols, -weights, degrees), _diagonal(np.ones(n))


def _normalized(n, rows, cols, weights):
    degrees = np.bincount(rows, weights=weights, minlength=n)
    connected = degrees > 0
    root = np.zeros(n)
    root[connected] = 1.0 / np.sqrt(degrees[connected])
    off_diagonal = -(root[rows] * weights * root[cols])
    L = _operator(n, rows, cols, off_diagonal, connected.astype(np.float64))
    return L, _diagonal(np.ones(n))


def _random_walk(n, rows, cols, weights):
    degrees = np.bincount(rows, weights=weights, minlength=n)
    mass = np.where(degrees > 0, degrees, 1.0)
    return _operator(n, rows, cols, -weights, degrees), _diagonal(mass)


#: The operators of entries ``(n, rows, cols, weights)`` (see :func:`edge_entries`), by
#: the names of the Laplacian registries.
OPERATORS = {"graph": _combinatorial, "normalized": _normalized, "random_walk": _random_walk}


def combinatorial_laplacian(adjacency: sp.spmatrix) -> tuple[sp.csr_matrix, sp.dia_matrix]:
    """``L = D - A`` and ``M = I``."""
    return _combinatorial(*_entries(adjacency))


def normalized_laplacian(adjacency: sp.spmatrix) -> tuple[sp.csr_matrix, sp.dia_matrix]:
    """``L = I - D^-1/2 A D^-1/2`` (``L_ii = 0`` at an isolated node) and ``M = I``."""
    return _normalized(*_entries(adjacency))


def random_walk_laplacian(adjacency: sp.spmatrix) -> tuple[sp.csr_matrix, sp.dia_matrix]:
    """``L = D - A`` and ``M = D`` (1 at an isolated node): ``I - D^-1 A`` as a
    symmetric generalized problem."""
    return _random_walk(*_entries(adjacency))


def adjacency_of(stiffness: sp.spmatrix) -> sp.csr_matrix:
    """The weighted adjacency ``A = diag(L) - L`` of a combinatorial Laplacian ``L``."""
    stiffness = sp.csr_matrix(stiffness, copy=True)
    stiffness.setdiag(0.0)
    stiffness.eliminate_zeros()
    return -stiffness


def from_combinatorial(operator, build):
    """The discretization that applies ``operator`` (one of the functions above) to the
    graph whose combinatorial Laplacian ``build`` returns: a function of ``build``'s
    arguments returning ``(L, M)``. The mesh and point-cloud registries make their
    normalized and random-walk Laplacians this way from their ``"graph"`` entry, so all
    three share one graph."""

    def discretization(*args):
        return operator(adjacency_of(build(*args)[0]))

    discretization.__doc__ = f"{operator.__name__} of the graph of {build.__name__}"
    return discretization
