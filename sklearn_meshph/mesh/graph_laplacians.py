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
    "adjacency_of",
    "combinatorial_laplacian",
    "from_combinatorial",
    "normalized_laplacian",
    "random_walk_laplacian",
]


def _degrees(adjacency: sp.spmatrix) -> np.ndarray:
    return np.asarray(adjacency.sum(axis=1), dtype=np.float64).ravel()


def combinatorial_laplacian(adjacency: sp.spmatrix) -> tuple[sp.csr_matrix, sp.dia_matrix]:
    """``L = D - A`` and ``M = I``."""
    n = adjacency.shape[0]
    L = (sp.diags(_degrees(adjacency)) - adjacency).tocsr()
    return L, sp.identity(n, format="dia")


def normalized_laplacian(adjacency: sp.spmatrix) -> tuple[sp.csr_matrix, sp.dia_matrix]:
    """``L = I - D^-1/2 A D^-1/2`` (``L_ii = 0`` at an isolated node) and ``M = I``."""
    n = adjacency.shape[0]
    degrees = _degrees(adjacency)
    connected = degrees > 0
    root = np.zeros(n)
    root[connected] = 1.0 / np.sqrt(degrees[connected])
    scaling = sp.diags(root)
    L = sp.diags(connected.astype(np.float64)) - scaling @ adjacency @ scaling
    return L.tocsr(), sp.identity(n, format="dia")


def random_walk_laplacian(adjacency: sp.spmatrix) -> tuple[sp.csr_matrix, sp.dia_matrix]:
    """``L = D - A`` and ``M = D`` (1 at an isolated node): ``I - D^-1 A`` as a
    symmetric generalized problem."""
    degrees = _degrees(adjacency)
    L = (sp.diags(degrees) - adjacency).tocsr()
    return L, sp.diags(np.where(degrees > 0, degrees, 1.0))


def adjacency_of(stiffness: sp.spmatrix) -> sp.csr_matrix:
    """The weighted adjacency ``A = diag(L) - L`` of a combinatorial Laplacian ``L``."""
    stiffness = sp.csr_matrix(stiffness)
    adjacency = sp.diags(stiffness.diagonal()) - stiffness
    adjacency.eliminate_zeros()
    return adjacency.tocsr()


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
