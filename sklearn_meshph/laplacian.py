"""Laplacians of triangle meshes and their low eigenpairs.

Two discretizations:

- ``"cotangent"``: the linear finite-element Laplace-Beltrami operator, cotangent
  stiffness matrix ``L`` with the barycentric lumped mass matrix ``M`` (one third of the
  area of every incident triangle per vertex, as in lapy, potpourri3d and
  robust-laplacian), solved as the generalized problem ``L phi = lambda M phi``.
- ``"graph"``: the combinatorial graph Laplacian ``D - A`` of the mesh edges, with
  ``M = I``. It ignores geometry and is not resolution invariant: its eigenvalues scale
  with the edge count, and unit-norm eigenvectors carry a factor ``1/sqrt(n)``.

Eigenpairs come from shift-invert Lanczos (ARPACK through :func:`scipy.sparse.linalg.eigsh`)
with a small negative shift and one sparse factorization of ``L - sigma M``: our
supernodal Cholesky (:mod:`._cholesky`) on a geometric nested-dissection order of the
vertices (fast to compute, near-linear fill).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg
import scipy.sparse as sp
from scipy.sparse.linalg import LinearOperator, eigsh, splu

from ._assembly import cotangent_weights, edge_matrix_csr
from ._cholesky import SupernodalCholesky
from ._mesh import check_faces, check_mesh, clean_mesh
from ._ordering import geometric_nested_dissection

__all__ = ["cotangent_laplacian", "graph_laplacian", "laplacian_eigenfunctions"]

LAPLACIANS = ("cotangent", "graph")

# Below this size a dense generalized eigensolver is faster and simpler than ARPACK.
_DENSE_MAX_VERTICES = 200
# Shift of shift-invert, relative to the typical eigenvalue scale trace(L)/trace(M)/n.
_RELATIVE_SHIFT = 1e-2


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

    Notes
    -----
    Barycentric and Voronoi lumping differ per vertex by up to 18% on irregular meshes
    and move eigenvalues in the fourth digit; barycentric lumping is positive on every
    mesh (Voronoi areas need a fix-up on obtuse triangles) and matches lapy, potpourri3d
    and robust-laplacian.

    Examples
    --------
    >>> import trimesh
    >>> from sklearn_meshph import cotangent_laplacian
    >>> sphere = trimesh.creation.icosphere(2)
    >>> L, M = cotangent_laplacian(sphere.vertices, sphere.faces)
    >>> bool(abs(L.sum()) < 1e-9), round(float(M.sum()), 2)
    (True, 12.33)
    """
    vertices = np.ascontiguousarray(vertices, dtype=np.float64)
    if vertices.ndim != 2 or vertices.shape[1] != 3:
        raise ValueError(f"vertices must have shape (n_vertices, 3), got {vertices.shape}")
    n = len(vertices)
    faces = check_faces(faces, n)
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
    from ._mesh import mesh_edges

    adjacency = mesh_edges(check_faces(faces, n_vertices), n_vertices)
    degree = np.asarray(adjacency.sum(axis=1)).ravel()
    return (sp.diags(degree) - adjacency).tocsr(), sp.identity(n_vertices, format="dia")


def build_laplacian(vertices, faces, laplacian: str):
    """Stiffness and mass matrices of the named discretization."""
    if laplacian == "cotangent":
        return cotangent_laplacian(vertices, faces)
    if laplacian == "graph":
        return graph_laplacian(faces, len(vertices))
    raise ValueError(f"laplacian must be one of {LAPLACIANS}, got {laplacian!r}")


class ShiftInvertOperator(LinearOperator):
    """``x -> A^{-1} x`` for a symmetric positive definite ``A = L - sigma M``.

    ``method="cholesky"`` (and ``"auto"``) factors ``A`` with our supernodal multifrontal
    Cholesky (:class:`._cholesky.SupernodalCholesky`, dense kernels on scipy's BLAS) on a
    geometric nested-dissection order of ``points``, or on reverse Cuthill-McKee without
    points (more fill). ``method="lu"`` uses SuperLU with diagonal pivots (stable for a
    positive definite matrix) on the same nested-dissection order, or on SuperLU's COLAMD
    order without points: about twice the memory and the time, kept as an independent
    check.
    """

    def __init__(self, A: sp.spmatrix, points: np.ndarray | None = None, method: str = "auto"):
        A = sp.csr_matrix(A)
        super().__init__(dtype=np.float64, shape=A.shape)
        if method not in ("auto", "cholesky", "lu"):
            raise ValueError(f"method must be 'auto', 'cholesky' or 'lu', got {method!r}")
        self.method = "lu" if method == "lu" else "cholesky"
        self.perm = None
        if points is not None:
            graph = A.copy()
            graph.setdiag(0)
            graph.eliminate_zeros()
            self.perm = geometric_nested_dissection(
                np.ascontiguousarray(points, dtype=np.float64), graph.indptr, graph.indices
            )
        if self.method == "cholesky":
            self.cholesky = SupernodalCholesky(A, self.perm)
            return
        if self.perm is None:
            self.lu = splu(
                A.tocsc(),
                permc_spec="COLAMD",
                diag_pivot_thresh=0.0,
                options={"SymmetricMode": True},
            )
            return
        self.iperm = np.empty_like(self.perm)
        self.iperm[self.perm] = np.arange(len(self.perm))
        self.lu = splu(
            A[self.perm][:, self.perm].tocsc(),
            permc_spec="NATURAL",
            diag_pivot_thresh=0.0,
            options={"SymmetricMode": True},
        )

    def _matvec(self, x):
        x = np.asarray(x, dtype=np.float64).ravel()
        if self.method == "cholesky":
            return self.cholesky.solve(x)
        if self.perm is None:
            return self.lu.solve(x)
        return self.lu.solve(x[self.perm])[self.iperm]


def eigen_shift(L: sp.spmatrix, M: sp.spmatrix) -> float:
    """A negative shift well below the first non-zero eigenvalue, free of scale and size.

    ``trace(L) / trace(M) / n`` follows the first non-zero eigenvalue of a surface mesh
    under scaling and refinement (both grow like ``1 / area``), so a fixed fraction of it
    keeps ``L - sigma M`` equally well conditioned for every mesh.
    """
    n = L.shape[0]
    return -_RELATIVE_SHIFT * float(L.diagonal().sum()) / float(M.diagonal().sum()) / n


def fix_signs(vectors: np.ndarray, mass: np.ndarray) -> np.ndarray:
    """Flip each column so that its mass-weighted third moment is positive.

    The skewness ``sum_i m_i phi_i^3`` is a geometric quantity: it has the same sign on
    the same shape at any resolution, scale or pose. When it vanishes (relative to
    ``sum_i m_i |phi_i|^3``, below 1e-8: antisymmetric eigenfunctions of symmetric
    shapes), the entry of largest absolute value is made positive instead, the lowest
    index among entries within 1e-6 of that largest value (symmetric shapes have exact
    ties, which rounding would otherwise break one way or the other).
    """
    cubes = vectors * vectors * vectors  # not ** 3: pow() is ten times slower
    skew = mass @ cubes
    scale = mass @ np.abs(cubes)
    flip = skew < 0
    for j in np.flatnonzero(np.abs(skew) <= 1e-8 * scale):
        size = np.abs(vectors[:, j])
        flip[j] = vectors[np.flatnonzero(size >= size.max() * (1 - 1e-6))[0], j] < 0
    vectors = vectors * np.where(flip, -1.0, 1.0)
    return vectors


def generalized_eigenpairs(
    L: sp.spmatrix,
    M: sp.spmatrix,
    n_eigs: int,
    *,
    seed: int = 0,
    points: np.ndarray | None = None,
    method: str = "auto",
) -> tuple[np.ndarray, np.ndarray]:
    """The ``n_eigs`` smallest eigenpairs of ``L phi = lambda M phi``.

    Eigenvectors are M-orthonormal (``phi^T M phi = 1``) with signs fixed by
    :func:`fix_signs`; eigenvalues are ascending. ARPACK's start vector is drawn from
    ``numpy.random.default_rng(seed)``, so results are bitwise reproducible.
    ``points`` (vertex coordinates) and ``method`` choose the factorization, see
    :class:`ShiftInvertOperator`.
    """
    n = L.shape[0]
    mass = M.diagonal()
    if n <= _DENSE_MAX_VERTICES or n_eigs >= n - 1:
        values, vectors = scipy.linalg.eigh(L.toarray(), np.diag(mass))
        values, vectors = values[:n_eigs], vectors[:, :n_eigs]
    else:
        sigma = eigen_shift(L, M)
        op = ShiftInvertOperator(L - sigma * M, points=points, method=method)
        v0 = np.random.default_rng(seed).uniform(-1.0, 1.0, n)
        values, vectors = eigsh(L, k=n_eigs, M=M, sigma=sigma, which="LM", OPinv=op, v0=v0)
        order = np.argsort(values, kind="stable")
        values, vectors = values[order], vectors[:, order]
    # L is positive semi-definite: a negative eigenvalue can only be rounding.
    values = np.maximum(values, 0.0)
    vectors = vectors / np.sqrt(np.einsum("i,ij,ij->j", mass, vectors, vectors))
    return values, fix_signs(vectors, mass)


def laplacian_eigenfunctions(
    mesh,
    n_eigs: int,
    laplacian: str = "cotangent",
    *,
    components: str = "largest",
    random_state: int = 0,
) -> tuple[np.ndarray, np.ndarray]:
    """First eigenpairs of a mesh Laplacian, the constant one included.

    The mesh is used as given: no rescaling, so the unit sphere gives eigenvalues close to
    ``l (l + 1)``: 0, 2, 2, 2, 6, ... For scale- and resolution-free eigenfunctions use
    :class:`LaplacianEigenTransformer`, which normalizes to unit area.

    Parameters
    ----------
    mesh : trimesh.Trimesh, (vertices, faces) pair, str or os.PathLike
        See :func:`check_mesh`. The mesh is cleaned by :func:`clean_mesh`.
    n_eigs : int
        Number of eigenpairs, at least 1 and at most the number of kept vertices.
    laplacian : {"cotangent", "graph"}, default="cotangent"
        ``"cotangent"`` solves ``L phi = lambda M phi`` with the cotangent stiffness and
        lumped mass; ``"graph"`` uses the graph Laplacian and ``M = I``.
    components : {"largest", "error"}, default="largest"
        Connected-component policy of :func:`clean_mesh`.
    random_state : int, default=0
        Seed of ARPACK's start vector.

    Returns
    -------
    eigenvalues : ndarray of shape (n_eigs,)
        Ascending.
    eigenvectors : ndarray of shape (n_vertices, n_eigs)
        Rows follow the cleaned vertex set (the input's vertices when the mesh needs no
        cleaning). Columns are M-orthonormal for ``"cotangent"`` and of unit Euclidean
        norm for ``"graph"``; signs follow the rule of
        :class:`LaplacianEigenTransformer`.

    Examples
    --------
    >>> import trimesh
    >>> from sklearn_meshph import laplacian_eigenfunctions
    >>> sphere = trimesh.creation.icosphere(4)
    >>> values, vectors = laplacian_eigenfunctions(sphere, 5)
    >>> [round(float(v), 1) for v in values]
    [0.0, 2.0, 2.0, 2.0, 6.0]
    """
    vertices, faces = check_mesh(mesh)
    clean = clean_mesh(vertices, faces, components=components)
    n = len(clean.vertices)
    if not 1 <= n_eigs <= n:
        raise ValueError(f"n_eigs must be between 1 and {n} (the kept vertices), got {n_eigs}")
    L, M = build_laplacian(clean.vertices, clean.faces, laplacian)
    return generalized_eigenpairs(L, M, n_eigs, seed=random_state, points=clean.vertices)
