"""Laplacians of triangle meshes: the registry of discretizations.

Each discretization returns a stiffness matrix ``L`` and a diagonal mass matrix ``M``
for the generalized eigenproblem ``L phi = lambda M phi``:

- ``"cotangent"``: the linear finite-element Laplace-Beltrami operator, cotangent
  stiffness with the barycentric lumped mass (one third of the area of every incident
  triangle per vertex, as lapy with ``lump=True``, potpourri3d and robust-laplacian).
- ``"graph"``: the combinatorial graph Laplacian ``D - A`` of the mesh edges, with
  ``M = I``. It ignores geometry and is not resolution invariant: its eigenvalues scale
  with the edge count, and unit-norm eigenvectors carry a factor ``1/sqrt(n)``.
- ``"normalized"``: the symmetric normalized Laplacian ``I - D^-1/2 A D^-1/2`` of the
  same edges, ``M = I`` (PersLay's operator on graphs);
- ``"random_walk"``: ``I - D^-1 A``, solved as ``(D - A) phi = lambda D phi``.

The three graph Laplacians are those of :mod:`sklearn_meshph.mesh.graph_laplacians`.
A graph sample (:class:`sklearn_meshph.graph.validation.Graph`) takes them too, with
its own edge weights: :data:`GRAPH_LAPLACIANS` holds their discretization
``graph -> (L, M)``, under the same names; a Laplacian of the surface
(``"cotangent"``) has none.

A new discretization is a function ``(vertices, faces) -> (L, M)`` and one entry in
:data:`LAPLACIANS` (and, if it applies to graphs, one in :data:`GRAPH_LAPLACIANS`).
"""

from __future__ import annotations

from numbers import Integral

import numpy as np
import scipy.sparse as sp

from .._param_validation import Interval, validate_params
from .._registry import Option, Registry
from ..graph.validation import Graph
from ..mesh import unit_box, unit_box_mass
from ..mesh.graph import edge_matrix_csr, mesh_edges
from ..mesh.graph_laplacians import (
    OPERATORS,
    combinatorial_laplacian,
    edge_entries,
    from_combinatorial,
    normalized_laplacian,
    random_walk_laplacian,
)
from ..mesh.validation import check_faces, check_vertices
from ._assembly import cotangent_weights

__all__ = ["GRAPH_LAPLACIANS", "LAPLACIANS", "cotangent_laplacian", "graph_laplacian"]


def cotangent_laplacian(
    vertices: np.ndarray, faces: np.ndarray
) -> tuple[sp.csr_matrix, sp.dia_matrix]:
    """Cotangent stiffness matrix and barycentric lumped mass matrix.

    Parameters
    ----------
    vertices : ndarray of shape (n, 3)
    faces : ndarray of shape (m, 3)
        Non-degenerate triangles (see :func:`sklearn_meshph.clean_mesh`).

    Returns
    -------
    L : scipy.sparse.csr_matrix of shape (n, n)
        Symmetric positive semi-definite stiffness matrix,
        ``L[i, j] = -(cot alpha_ij + cot beta_ij) / 2`` for an edge ``ij`` and rows
        summing to zero.
    M : scipy.sparse.dia_matrix of shape (n, n)
        Diagonal lumped mass: a third of the area of the triangles around each vertex.

    Raises
    ------
    ValueError
        A face of zero area (or a non-finite vertex), or areas float64 cannot hold at
        the mesh's scale (coordinates beyond about 1e154 or below 1e-154): the operator
        is built in the unit box and its mass scaled back.

    Notes
    -----
    Barycentric and Voronoi lumping differ per vertex on irregular meshes but barely
    move the eigenvalues (measured in the eigenfunctions guide); barycentric lumping is
    positive on every mesh (Voronoi areas need a fix-up on obtuse triangles) and matches
    lapy, potpourri3d and robust-laplacian.

    Examples
    --------
    >>> import trimesh
    >>> from sklearn_meshph import cotangent_laplacian
    >>> sphere = trimesh.creation.icosphere(2)
    >>> L, M = cotangent_laplacian(sphere.vertices, sphere.faces)
    >>> bool(abs(L.sum()) < 1e-9), round(float(M.sum()), 2)
    (True, 12.33)
    """
    vertices = check_vertices(vertices)
    faces = check_faces(faces, len(vertices))
    # In the unit box: the weights are ratios of lengths, the same at any scale, and
    # the areas neither underflow nor overflow (at 1e-150 or 1e150 they did).
    unit, scale = unit_box(vertices)
    L, M = _cotangent(unit, faces)
    return L, sp.diags(unit_box_mass(M.diagonal(), scale, "cotangent_laplacian"))


def _cotangent(vertices, faces):
    """:func:`cotangent_laplacian` of checked vertices as they are (the eigen stage's,
    already in the unit box)."""
    n = len(vertices)
    weights, double_area = cotangent_weights(vertices, faces)
    if not (double_area > 0).all():  # also catches NaN coordinates
        bad = int(np.flatnonzero(~(double_area > 0))[0])
        raise ValueError(
            f"face {bad} has zero area (or a non-finite vertex): the cotangent Laplacian "
            "needs non-degenerate triangles; clean the mesh with clean_mesh first"
        )
    L = sp.csr_matrix(edge_matrix_csr(n, faces, weights, True), shape=(n, n))
    mass = np.bincount(faces.ravel(), weights=np.repeat(double_area / 6.0, 3), minlength=n)
    return L, sp.diags(mass)


@validate_params({"n_vertices": [Interval(Integral, 1, None, closed="left")]})
def graph_laplacian(faces: np.ndarray, n_vertices: int) -> tuple[sp.csr_matrix, sp.dia_matrix]:
    """Combinatorial graph Laplacian ``D - A`` of the mesh edges, and the identity.

    Parameters
    ----------
    faces : ndarray of shape (m, 3)
    n_vertices : int

    Returns
    -------
    L : scipy.sparse.csr_matrix of shape (n, n)
    M : scipy.sparse.dia_matrix
        The identity, so that both Laplacians share one generalized-eigenproblem solver.
    """
    return combinatorial_laplacian(mesh_edges(check_faces(faces, n_vertices), n_vertices))


def _graph(vertices, faces):
    return graph_laplacian(faces, len(vertices))


def _of_graph(name: str):
    """The Laplacian ``name`` of a graph sample, from its edges and weights."""

    def discretization(graph: Graph):
        return OPERATORS[name](*edge_entries(graph.n_nodes, graph.edges, graph.weights))

    discretization.__doc__ = f"the {name!r} Laplacian of a graph sample"
    return discretization


_NORMALIZED = (
    "symmetric normalized graph Laplacian `I - D^-1/2 A D^-1/2` of the edges, `M = I` "
    "(eigenvalues in [0, 2]; an isolated node has `L_ii = 0`); PersLay's operator"
)
_RANDOM_WALK = (
    "random-walk graph Laplacian `I - D^-1 A` of the edges, solved as `(D - A) phi = "
    "lambda D phi` (`M = D`, D-orthonormal eigenvectors; the normalized Laplacian's "
    "eigenvalues)"
)


LAPLACIANS = Registry(
    "laplacian",
    [
        Option(
            "cotangent",
            _cotangent,
            "finite-element Laplace-Beltrami operator: cotangent stiffness `L`, barycentric "
            "lumped mass `M`, `L phi = lambda M phi`; depends on the surface, not on its "
            "triangulation (the default)",
        ),
        Option(
            "graph",
            _graph,
            "combinatorial graph Laplacian `D - A` of the edges, `M = I`; depends on the "
            "connectivity only, not resolution invariant (the paper's literal setting)",
        ),
        Option("normalized", from_combinatorial(normalized_laplacian, _graph), _NORMALIZED),
        Option("random_walk", from_combinatorial(random_walk_laplacian, _graph), _RANDOM_WALK),
    ],
)

#: The discretization ``graph -> (L, M)`` of each Laplacian of :data:`LAPLACIANS` that a
#: graph sample takes, by the same name, on the graph's weighted adjacency.
GRAPH_LAPLACIANS = Registry(
    "laplacian",
    [
        Option(
            "graph",
            _of_graph("graph"),
            "combinatorial graph Laplacian `D - A` of the weighted adjacency, `M = I`",
        ),
        Option("normalized", _of_graph("normalized"), _NORMALIZED),
        Option("random_walk", _of_graph("random_walk"), _RANDOM_WALK),
    ],
)
