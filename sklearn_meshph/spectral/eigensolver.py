"""Low eigenpairs of a Laplacian: shift-invert Lanczos on one factorization, or a dense
solve of small operators.

Eigenpairs come from a Lanczos run in shift-invert mode (:mod:`.lanczos`) with a small
negative shift, so that ``L - sigma M`` is positive definite and factored once
(:mod:`.factorization`), to a tolerance far below what any signature resolves. One more
eigenpair than asked places a shift ``tau`` between the last one and the next, and the
number of eigenvalues below ``tau`` (the inertia of ``L - tau M``) must equal the count
found: otherwise (a copy of a repeated eigenvalue missed, as a single Krylov sequence
does on symmetric shapes) ARPACK (:func:`scipy.sparse.linalg.eigsh`) solves again to
machine precision with a basis of twice the eigenpairs, which finds every copy. Small operators
(below a few hundred vertices or nodes: :data:`DENSE_MAX_VERTICES`,
:data:`DENSE_MAX_NODES`), requests of nearly every eigenpair and ``solver="dense"`` go
to LAPACK's dense symmetric eigensolver instead (:func:`dense_eigenpairs`). Both give
ascending eigenvalues and M-orthonormal eigenvectors under one sign rule
(:func:`fix_signs`).
"""

from __future__ import annotations

import warnings
from numbers import Integral

import numpy as np
import scipy.linalg
import scipy.sparse as sp
from scipy.sparse.linalg import ArpackError, eigsh

from .._param_validation import Interval, Options, validate_params
from .._threads import one_blas_thread
from ..graph.validation import Graph
from ..inputs import check_input
from ..mesh.cleaning import COMPONENT_POLICIES, describe, warn_if_lossy
from ._cholesky import SupernodalCholesky, negative_eigenvalues
from .factorization import SOLVERS, ShiftInvertOperator
from .lanczos import shift_invert_lanczos
from .laplacians import LAPLACIANS

__all__ = [
    "COMPONENTS",
    "DENSE_LIMIT",
    "DENSE_MAX_NODES",
    "DENSE_MAX_VERTICES",
    "dense_eigenpairs",
    "fix_signs",
    "generalized_eigenpairs",
    "laplacian_eigenfunctions",
]

#: The component policies of the eigen stage: cleaning's, and ``"all"``, which keeps
#: every connected component of a graph (isolated nodes included).
COMPONENTS = (*COMPONENT_POLICIES, "all")

#: Up to this many vertices ``solver="auto"`` solves a mesh's or a cloud's operator
#: densely: faster and simpler than ARPACK there.
DENSE_MAX_VERTICES = 200
#: Up to this many nodes ``solver="auto"`` solves a graph's operator densely (the
#: crossover measured by ``benchmarks/bench_graph_spectra.py``).
DENSE_MAX_NODES = 400
#: The dense solver holds two ``n x n`` float64 matrices: larger operators are refused.
DENSE_LIMIT = 12_000
# Up to this size a dense solve (seconds) replaces an ARPACK run that did not converge.
_DENSE_FALLBACK_VERTICES = 3000
# Shift of shift-invert, relative to the typical eigenvalue scale trace(L)/trace(M)/n.
_RELATIVE_SHIFT = 1e-2
# The Lanczos run stops when every Ritz pair's residual is below this share of its Ritz
# value (ARPACK's criterion): the eigenpairs then agree to rounding with ARPACK's to
# machine precision (measured in docs/scale.md), in at most _MAX_STEPS_RATIO times the
# eigenpairs solves (about 2.4 times are needed; 4.3 for the clustered spectra of two
# watertight_dev meshes at 48 eigenpairs) before ARPACK takes over.
_TOLERANCE = 1e-8
_MAX_STEPS_RATIO = 5
_MIN_BASIS = 20
# Whether the Lanczos run (with its inertia check) comes first, on our Cholesky factor
# (the "superlu" backend, a check, always goes to ARPACK); False: ARPACK alone, at
# machine precision, as before (benchmarks/bench_default_cost.py compares the two).
_LANCZOS = True
# tau is placed halfway between the last eigenvalue asked for and the next one; when
# they agree within this (relative), the boundary cuts through a repeated eigenvalue and
# ARPACK solves again.
_BOUNDARY_RTOL = 1e-6
# The constant is an eigenvector of eigenvalue 0 when every row of L sums to zero within
# this share of the row's absolute sum (rounding leaves about 1e-16).
_NULL_RTOL = 1e-12


def _unit_trace_factor(mass: np.ndarray) -> float:
    """The power of two that brings ``sum(mass)`` nearest to 1 on a log scale (1 for a
    unit-area mesh, or when the sum is not a positive finite number)."""
    total = float(np.sum(mass))
    if not (np.isfinite(total) and total > 0):
        return 1.0
    return float(np.ldexp(1.0, -round(np.log2(total))))


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
    # Each column scaled by a power of two to at most 1 in size first: exact, so the
    # decisions are those of the column itself, and the cubes of an eigenvector of
    # entries near 1e150 (a graph of weights near 1e-300, its mass D) do not overflow.
    exponents = np.frexp(np.abs(vectors).max(axis=0, initial=0.0))[1]
    unit = np.ldexp(vectors, -exponents[None, :])
    cubes = unit * unit * unit  # not ** 3: pow() is ten times slower
    skew = mass @ cubes
    scale = mass @ np.abs(cubes)
    flip = skew < 0
    for j in np.flatnonzero(np.abs(skew) <= 1e-8 * scale):
        size = np.abs(vectors[:, j])
        flip[j] = vectors[np.flatnonzero(size >= size.max() * (1 - 1e-6))[0], j] < 0
    vectors = vectors * np.where(flip, -1.0, 1.0)
    return vectors


def dense_eigenpairs(
    L: sp.spmatrix, mass: np.ndarray, n_eigenpairs: int
) -> tuple[np.ndarray, np.ndarray]:
    """The ``n_eigenpairs`` smallest eigenpairs of ``L phi = lambda diag(mass) phi`` by
    LAPACK, as the standard problem of ``M^-1/2 L M^-1/2`` (``mass`` positive): all of
    them by divide and conquer, fewer by relatively robust representations. Eigenvalues
    ascending, signs not fixed yet. Operators beyond :data:`DENSE_LIMIT` rows are refused
    with a ``ValueError`` (the matrices would not fit in memory)."""
    n = L.shape[0]
    if n > DENSE_LIMIT:
        gigabytes = 2 * 8 * n * n / 1e9
        raise ValueError(
            f"the dense eigensolver needs two {n} x {n} matrices ({gigabytes:.3g} GB), above "
            f"its limit of {DENSE_LIMIT} rows: ask for fewer eigenpairs than rows "
            "(n_eigenpairs), with solver='auto'"
        )
    A = L.toarray()
    # Masses spanning more than float64's range underflow to 0 once brought to a unit
    # trace, and their inverses overflow: refused below, not warned about.
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        inverse_root = 1.0 / np.sqrt(mass)
        A *= inverse_root[:, None]
        A *= inverse_root[None, :]
    if not np.isfinite(A).all():
        raise ValueError(
            "the operator scaled by the masses' inverse square roots leaves float64's range "
            f"(masses, scaled to sum to about 1, from {mass.min():.3g} to "
            f"{mass.max():.3g}; stiffness up to "
            f"{abs(L).max():.3g}): the weights span too wide a range; scale the small ones up"
        )
    if n_eigenpairs < n:
        values, vectors = scipy.linalg.eigh(
            A, subset_by_index=[0, n_eigenpairs - 1], driver="evr", overwrite_a=True
        )
    else:
        values, vectors = scipy.linalg.eigh(A, driver="evd", overwrite_a=True)
    return values, vectors * inverse_root[:, None]


def constant_null_vector(L: sp.spmatrix, mass: np.ndarray) -> np.ndarray | None:
    """The constant function, M-normalized, when it is an eigenvector of eigenvalue 0
    (the rows of ``L`` sum to zero up to rounding: the cotangent, combinatorial and
    random-walk Laplacians, not the normalized one); otherwise None."""
    rows = abs(L).sum(axis=1).A1
    if not np.all(np.abs(L.sum(axis=1).A1) <= _NULL_RTOL * rows):
        return None
    return np.full(L.shape[0], 1.0 / np.sqrt(mass.sum()))


def _lanczos(L, M, sigma, op, v0, n_eigenpairs):
    """The Lanczos run's eigenpairs, ascending, checked by the inertia of ``L - tau M``,
    or ``(None, None)`` when it does not converge or the check fails. The constant
    eigenfunction, when it is one, is kept out of the run and put first."""
    mass = M.diagonal()
    null = constant_null_vector(L, mass) if n_eigenpairs > 1 else None
    wanted = n_eigenpairs - (null is not None)
    found = shift_invert_lanczos(
        op.factor,
        mass,
        wanted,
        v0=v0,
        tol=_TOLERANCE,
        max_steps=max(_MAX_STEPS_RATIO * (wanted + 1), _MIN_BASIS),
        null=null,
    )
    if found is None:
        return None, None
    theta, vectors = found
    values = sigma + 1.0 / theta
    if null is not None:
        values = np.concatenate([[0.0], values])
        vectors = np.concatenate([null[None], vectors])
    last, following = values[-2], values[-1]
    if not following - last > _BOUNDARY_RTOL * abs(following):
        return None, None
    try:
        below = negative_eigenvalues(L - 0.5 * (last + following) * M, like=op.factor)
    except ValueError:  # a zero pivot: tau on an eigenvalue
        return None, None
    if below != n_eigenpairs:
        return None, None
    return values[:-1], vectors.T


def _shift_invert(L, M, sigma, op, v0, n_eigenpairs):
    """ARPACK's eigenpairs in shift-invert mode to machine precision, ascending, or
    ``(None, None)`` when it fails on an operator small enough for the dense solver."""
    n = L.shape[0]
    ncv, tol = min(n, max(2 * n_eigenpairs + 1, _MIN_BASIS)), 0.0
    # An eigenvalue of a multiplicity beyond the block (many triangles on one edge) can
    # stall ARPACK: no convergence, or error 3 ("no shifts could be applied"). A larger
    # Krylov space resolves it; failing that, a small mesh is solved densely.
    for attempt in range(3):
        try:
            values, vectors = eigsh(
                L,
                k=n_eigenpairs,
                M=M,
                sigma=sigma,
                which="LM",
                OPinv=op,
                v0=v0,
                ncv=ncv,
                tol=tol,
                maxiter=max(1000, 10 * n_eigenpairs),
            )
        except ArpackError as error:  # ArpackNoConvergence is one
            failure, arpack_error = None, error
        else:
            order = np.argsort(values, kind="stable")
            values, vectors = values[order], vectors[:, order]
            failure = _missed_eigenvalues(L, M, values, op)
            if failure is None:
                return values, vectors
        if ncv == n or attempt == 2:
            if n > _DENSE_FALLBACK_VERTICES:
                if failure is not None:
                    raise RuntimeError(f"ARPACK's shift-invert solve {failure}")
                raise arpack_error
            return None, None
        ncv = min(n, 2 * ncv + 20)


def _missed_eigenvalues(L, M, values, op) -> str | None:
    """What ARPACK's ascending ``values`` miss, or ``None``: below ``tau``, between the
    last cluster of ``values`` and the one before, the pencil must have as many
    eigenvalues as ``values`` (Sylvester's inertia of ``L - tau M``). ARPACK can lose a
    copy of a repeated eigenvalue (the fivefold l(l + 1) = 6 of a sphere of size
    1e-30 with scipy 1.17). Checked when the factor is the supernodal Cholesky (its
    analysis is reused); a single cluster or a zero pivot cannot be checked."""
    if not isinstance(op.factor, SupernodalCholesky):
        return None
    edge = values[-1] - _BOUNDARY_RTOL * abs(values[-1])
    below = int(np.count_nonzero(values < edge))
    if below == 0:
        return None
    tau = 0.5 * (values[below - 1] + values[below])
    try:
        count = negative_eigenvalues(L - tau * M, like=op.factor)
    except ValueError:
        return None
    if count == below:
        return None
    return f"found {below} eigenvalues below {tau:.6g}, the pencil has {count}"


def generalized_eigenpairs(
    L: sp.spmatrix,
    M: sp.spmatrix,
    n_eigenpairs: int,
    *,
    seed: int = 0,
    points: np.ndarray | None = None,
    solver: str = "auto",
    dense_max: int = DENSE_MAX_VERTICES,
) -> tuple[np.ndarray, np.ndarray]:
    """The ``n_eigenpairs`` smallest eigenpairs of ``L phi = lambda M phi``.

    Eigenvectors are M-orthonormal (``phi^T M phi = 1``) with signs fixed by
    :func:`fix_signs`; eigenvalues are ascending. The start vector is drawn from
    ``numpy.random.default_rng(seed)``, so results are bitwise reproducible.
    ``points`` (vertex coordinates) give the factorization's fill-reducing order and
    ``solver`` its backend (:data:`.factorization.SOLVERS`); operators of at most
    ``dense_max`` rows, requests of all eigenpairs but one or none and
    ``solver="dense"`` are solved densely (:func:`dense_eigenpairs`).
    """
    n = L.shape[0]
    mass = M.diagonal()
    # One BLAS thread: ARPACK's and LAPACK's results then do not depend on the caller's
    # thread count (bitwise), and ARPACK's many small BLAS calls are not slowed down by
    # threads (several times slower on a busy machine).
    with one_blas_thread():
        # The pencil is solved with M at unit trace, scaled by a power of two (exact, so
        # the vectors are the same and the eigenvalues scale back exactly): ARPACK lost
        # copies of repeated eigenvalues with the masses of a mesh of size 1e-6.
        unit = _unit_trace_factor(mass)
        M = M * unit
        values = vectors = None
        sigma = eigen_shift(L, M)
        # sigma = 0: no edge at all, every eigenvalue 0, which Lanczos cannot separate.
        if solver != "dense" and n > dense_max and n_eigenpairs < n - 1 and sigma < 0:
            op = ShiftInvertOperator(L - sigma * M, points=points, solver=solver)
            v0 = np.random.default_rng(seed).uniform(-1.0, 1.0, n)
            if _LANCZOS and isinstance(op.factor, SupernodalCholesky):
                values, vectors = _lanczos(L, M, sigma, op, v0, n_eigenpairs)
            if values is None:
                values, vectors = _shift_invert(L, M, sigma, op, v0, n_eigenpairs)
        if values is None:
            values, vectors = dense_eigenpairs(L, M.diagonal(), n_eigenpairs)
    # L is positive semi-definite: a negative eigenvalue can only be rounding.
    values = np.maximum(values, 0.0) * unit
    vectors = vectors / np.sqrt(np.einsum("i,ij,ij->j", mass, vectors, vectors))
    # C order, as the cache stores them: a cached solve gives the same bits downstream.
    return values, np.ascontiguousarray(fix_signs(vectors, mass))


@validate_params(
    {
        "n_eigenpairs": [Interval(Integral, 1, None, closed="left"), None],
        "n_eigs": [Interval(Integral, 1, None, closed="left"), None],
        "laplacian": [Options(LAPLACIANS)],
        "components": [Options(COMPONENTS)],
        "weld": ["boolean"],
        "random_state": [Interval(Integral, 0, 2**32 - 1, closed="both")],
        "solver": [Options(SOLVERS)],
    }
)
def laplacian_eigenfunctions(
    mesh,
    n_eigenpairs: int | None = None,
    laplacian: str = "cotangent",
    *,
    components: str = "largest",
    weld: bool = True,
    random_state: int = 0,
    solver: str = "auto",
    n_eigs: int | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """First eigenpairs of a mesh Laplacian, the constant one included.

    The eigenpairs are the mesh's at its own scale (no normalization), so the unit
    sphere gives eigenvalues close to ``l (l + 1)``: 0, 2, 2, 2, 6, ... The mesh is
    cleaned and solved in a unit box and the eigenpairs scaled back, so any size float64
    holds gives them (a mesh of size 1e-150 has eigenvalues near 1e300); where they are
    beyond float64's range (sizes below about 1e-154 or above 1e154) a ``ValueError``
    says so. For scale- and resolution-free eigenfunctions use
    :class:`LaplacianEigenTransformer`, which normalizes to unit area.

    Parameters
    ----------
    mesh : trimesh.Trimesh, (vertices, faces) pair, str, os.PathLike, point cloud or graph
        See :func:`check_mesh`. The mesh is cleaned by :func:`clean_mesh`. A point
        cloud (an ``(n, 3)`` array, a ``trimesh.PointCloud`` or a file of points, see
        :func:`check_point_cloud`) gets the point-cloud discretization of
        ``laplacian`` (:func:`point_cloud_laplacian` for ``"cotangent"``) after its own
        cleaning (coincident points merged, one component). A graph (see
        :func:`check_graph`) gets the graph discretization of ``laplacian`` on its
        edge weights (not ``"cotangent"``); its rows are the kept nodes.
    n_eigenpairs : int
        Number of eigenpairs, the constant one included: at least 1 and at most the
        number of kept vertices. ``None`` on a graph: every eigenpair.
    laplacian : {"cotangent", "graph", "normalized", "random_walk"}, default="cotangent"
        ``"cotangent"`` solves ``L phi = lambda M phi`` with the cotangent stiffness and
        lumped mass; ``"graph"`` uses the graph Laplacian and ``M = I``,
        ``"normalized"`` the symmetric normalized one and ``M = I``, ``"random_walk"``
        ``D - A`` and ``M = D`` (see :data:`LAPLACIANS`).
    components : {"largest", "error", "all"}, default="largest"
        Connected-component policy of :func:`clean_mesh`; a graph also takes ``"all"``,
        every component kept (see :class:`LaplacianEigenTransformer`).
    weld : bool, default=True
        Weld coincident vertices first (see :func:`clean_mesh`); ``False`` keeps the
        vertices as given.
    random_state : int, default=0
        Seed of ARPACK's start vector, in ``[0, 2**32 - 1]``.
    solver : {"auto", "cholesky", "superlu", "dense"}, default="auto"
        Factorization backend of the shift-invert step, or the dense eigensolver
        (:data:`SOLVERS`).
    n_eigs : int, optional
        The former name of ``n_eigenpairs`` (a ``FutureWarning``).

    Returns
    -------
    eigenvalues : ndarray of shape (n_eigenpairs,)
        Ascending.
    eigenvectors : ndarray of shape (n_vertices, n_eigenpairs)
        Rows follow the cleaned vertex set (the input's vertices when the mesh needs no
        cleaning). Columns are M-orthonormal: of unit Euclidean norm for ``"graph"`` and
        ``"normalized"``, D-orthonormal for ``"random_walk"``; signs follow the rule of
        :class:`LaplacianEigenTransformer`.

    Warns
    -----
    MeshCleaningWarning
        When cleaning drops more than 1% of the vertices or of the area.

    Examples
    --------
    >>> import trimesh
    >>> from sklearn_meshph import laplacian_eigenfunctions
    >>> sphere = trimesh.creation.icosphere(4)
    >>> values, vectors = laplacian_eigenfunctions(sphere, 5)
    >>> [round(float(v), 1) for v in values]
    [0.0, 2.0, 2.0, 2.0, 6.0]
    """
    if n_eigs is not None:
        if n_eigenpairs is not None:
            raise TypeError("give n_eigenpairs only (n_eigs is its former name)")
        warnings.warn(
            "laplacian_eigenfunctions(n_eigs=...) is renamed n_eigenpairs; n_eigs will be "
            "removed in a future release",
            FutureWarning,
            stacklevel=3,
        )
        n_eigenpairs = n_eigs
    vertices, faces = check_input(mesh)
    graph = isinstance(vertices, Graph)
    if n_eigenpairs is None and not graph:
        raise TypeError("laplacian_eigenfunctions() needs n_eigenpairs, the number of eigenpairs")
    # solve.py builds on this module
    from .solve import (
        SolveSettings,
        cloud_eigenpairs,
        graph_eigenpairs,
        mesh_eigenpairs,
        warn_graph_components,
    )

    settings = SolveSettings(laplacian, "none", components, solver, weld)
    # exact: more eigenpairs than the cleaned sample has rows is an error before the
    # solve (not a dense solve of all of them, then the error).
    if graph:
        clean, values, vectors = graph_eigenpairs(
            vertices,
            settings,
            n_eigenpairs or vertices.n_nodes,
            random_state,
            None,
            exact=n_eigenpairs is not None,
        )
        warn_graph_components(clean.report, "graph", stacklevel=3)
    elif faces is None:
        clean, values, vectors = cloud_eigenpairs(
            vertices, settings, n_eigenpairs, random_state, None, exact=True
        )
        warn_if_lossy(clean.report, describe(None, mesh), stacklevel=3)
    else:
        # In the unit box and scaled back (mesh_eigenpairs): a mesh of size 1e-150 or
        # 1e150 has the same functions, and eigenvalues beyond float64's range are an
        # error, not zeros or a refusal of faces whose areas underflow.
        clean, values, vectors = mesh_eigenpairs(
            vertices, faces, settings, n_eigenpairs, random_state, None, exact=True
        )
        warn_if_lossy(clean.report, describe(None, mesh), stacklevel=3)
    return values, vectors
