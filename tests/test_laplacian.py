"""Laplacian matrices and eigenpairs against analytic results and independent solvers.

The factorization backends (``solver="cholesky"`` and ``"superlu"``) are checked through
the public functions only: against each other and the unit sphere's spectrum on meshes
of 41k vertices, and against dense solvers on meshes of 642 and 2,562 vertices.
"""

import re

import conftest
import numpy as np
import pytest
import scipy.linalg
import trimesh
from scipy.sparse.linalg import splu
from threadpoolctl import threadpool_info, threadpool_limits

from sklearn_meshph import (
    LaplacianEigenTransformer,
    cotangent_laplacian,
    graph_laplacian,
    laplacian_eigenfunctions,
)
from sklearn_meshph._param_validation import InvalidParameterError
from sklearn_meshph.spectral.eigensolver import generalized_eigenpairs
from sklearn_meshph.spectral.factorization import ShiftInvertOperator, fill_reducing_order

SOLVER_NAMES = ("auto", "cholesky", "superlu")


def irregular_ellipsoid(subdivisions=3, seed=0):
    """The shared irregular ellipsoid, its vertices numbered at random."""
    return conftest.irregular_ellipsoid(subdivisions, seed, shuffle=True)


def irregular_unit_sphere(subdivisions, seed=0):
    """An icosphere with vertices jittered by a fifth of the edge scale, put back on the
    unit sphere and numbered at random: the exact sphere, irregular triangles."""
    sphere = trimesh.creation.icosphere(subdivisions)
    rng = np.random.default_rng(seed)
    vertices = np.asarray(sphere.vertices)
    vertices = vertices + rng.normal(scale=0.2 * 2.0**-subdivisions, size=vertices.shape)
    vertices /= np.linalg.norm(vertices, axis=1, keepdims=True)
    shuffle = rng.permutation(len(vertices))
    return vertices[shuffle], np.argsort(shuffle)[np.asarray(sphere.faces)]


@pytest.fixture(autouse=True, scope="module")
def blas_on_one_thread():
    """BLAS on one thread unless a test sets otherwise, for the run time only: ARPACK's
    and the dense references' many small BLAS calls are several times slower on a
    threaded BLAS when the machine is busy (41k vertices: 1 s on one thread, 3 to 9 s on
    two; a 642-vertex dense eigh: 0.4 s against 13 s). Thread counts are tested in
    ``test_eigenpairs_do_not_depend_on_the_blas_thread_count``."""
    with threadpool_limits(limits=1, user_api="blas"):
        yield


def blas_threads() -> int:
    """The thread count BLAS runs on now (the least over the loaded BLAS libraries)."""
    return min(i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas")


def relative_residuals(L, M, values, vectors):
    """``||L v - lambda M v|| / (||L|| ||v||)`` per eigenpair, in the max norm."""
    residual = L @ vectors - (M @ vectors) * values
    return np.abs(residual).max(axis=0) / (abs(L).sum(axis=1).max() * np.abs(vectors).max(axis=0))


@pytest.fixture(scope="module")
def ellipsoid_41k():
    vertices, faces = irregular_ellipsoid(6)
    assert len(vertices) == 40962
    return vertices, faces


def test_unit_sphere_spectrum_is_l_times_l_plus_1_at_41k_vertices():
    vertices, faces = irregular_unit_sphere(6)
    assert len(vertices) == 40962
    values, vectors = laplacian_eigenfunctions((vertices, faces), 9)
    assert abs(values[0]) < 1e-10
    # 0, then l (l + 1) with multiplicity 2 l + 1. Discretization error O(h^2): measured
    # at most 2.6e-5 (l = 1) and 1.3e-4 (l = 2) here, 3 times less than at 10k vertices.
    np.testing.assert_allclose(values[1:], [2, 2, 2, 6, 6, 6, 6, 6], rtol=3e-4)
    # The l = 1 eigenspace is spanned by the coordinate functions x, y, z.
    L, M = cotangent_laplacian(vertices, faces)
    mass = M.diagonal()
    gram = vertices.T @ (mass[:, None] * vertices)
    coordinates = vertices @ np.linalg.inv(np.linalg.cholesky(gram)).T  # M-orthonormal
    projection = coordinates.T @ (mass[:, None] * vectors[:, 1:4])
    np.testing.assert_allclose(np.linalg.norm(projection, axis=0), 1.0, atol=1e-6)
    # The Lanczos run stops at residuals of 1e-8 relative on the shift-inverted operator,
    # below 1e-10 here (measured 7e-11).
    assert relative_residuals(L, M, values, vectors).max() < 1e-9


def test_cholesky_and_superlu_eigenpairs_agree_at_41k_vertices(ellipsoid_41k):
    """The two backends through the public function, on an irregular mesh numbered at
    random (the Cholesky factor's solve is the Lanczos run, SuperLU's ARPACK to machine
    precision)."""
    by_cholesky = laplacian_eigenfunctions(ellipsoid_41k, 8, solver="cholesky")
    by_superlu = laplacian_eigenfunctions(ellipsoid_41k, 8, solver="superlu")
    values, vectors = by_cholesky
    np.testing.assert_allclose(by_superlu[0], values, rtol=1e-10, atol=1e-10 * values[-1])
    # Signs are fixed, so the vectors themselves agree.
    np.testing.assert_allclose(by_superlu[1], vectors, rtol=0, atol=1e-8)
    # An independent check of both: the residuals of the generalized problem.
    L, M = cotangent_laplacian(*ellipsoid_41k)
    for pairs in (by_cholesky, by_superlu):  # Lanczos: see the sphere's test above
        assert relative_residuals(L, M, *pairs).max() < 1e-9
    mass = M.diagonal()
    np.testing.assert_allclose(vectors.T @ (mass[:, None] * vectors), np.eye(8), atol=1e-10)


def test_public_eigenfunctions_match_dense_eigh_at_2562_vertices():
    vertices, faces = irregular_ellipsoid(4)
    L, M = cotangent_laplacian(vertices, faces)
    scale = 1.0 / np.sqrt(M.diagonal())  # M is diagonal: the standard form S = D L D
    ref_values, ref_vectors = scipy.linalg.eigh(
        scale[:, None] * L.toarray() * scale, subset_by_index=[0, 9], driver="evr"
    )
    ref_vectors = scale[:, None] * ref_vectors  # M-orthonormal eigenvectors of (L, M)
    for solver in SOLVER_NAMES:
        values, vectors = laplacian_eigenfunctions((vertices, faces), 10, solver=solver)
        np.testing.assert_allclose(values, ref_values, rtol=1e-10, atol=1e-10 * ref_values[-1])
        # Simple eigenvalues: each vector is the reference one up to its sign, within
        # the Lanczos run's stopping bound (eigensolver._TOLERANCE, 1e-8 relative:
        # with numpy 2.4 and numba 0.68 it stopped at 2.1e-9 here, 1e-9 before).
        signs = np.sign(np.einsum("i,ij,ij->j", M.diagonal(), vectors, ref_vectors))
        np.testing.assert_allclose(vectors, signs * ref_vectors, rtol=0, atol=1e-8)


@pytest.mark.parametrize("laplacian", ["cotangent", "graph"])
@pytest.mark.parametrize(
    "method", ["cholesky", "cholesky without points", "superlu", "superlu without points"]
)
def test_sparse_solver_matches_dense_eigh(laplacian, method):
    vertices, faces = irregular_ellipsoid(3)  # 642 vertices: the ARPACK path
    L, M = (
        cotangent_laplacian(vertices, faces)
        if laplacian == "cotangent"
        else graph_laplacian(faces, len(vertices))
    )
    points = None if method.endswith("without points") else vertices
    method = method.split()[0]
    values, vectors = generalized_eigenpairs(L, M, 10, points=points, solver=method)
    ref_values, ref_vectors = scipy.linalg.eigh(L.toarray(), M.toarray())
    scale = ref_values[9]
    np.testing.assert_allclose(values, ref_values[:10], atol=1e-8 * scale, rtol=1e-8)
    # Eigenspaces: the computed vectors lie in the span of the reference eigenspaces
    # (the last eigenvalue may belong to a multiplet cut by the count).
    span = ref_vectors[:, ref_values <= ref_values[9] * (1 + 1e-8)]
    mass = M.diagonal()
    projection = span.T @ (mass[:, None] * vectors)
    np.testing.assert_allclose(np.linalg.norm(projection, axis=0), 1.0, atol=1e-7)
    np.testing.assert_allclose(vectors.T @ (mass[:, None] * vectors), np.eye(10), atol=1e-9)


def test_eigenpairs_do_not_depend_on_the_blas_thread_count():
    vertices, faces = irregular_ellipsoid(5)  # 10,242 vertices
    with threadpool_limits(limits=2, user_api="blas"):
        if blas_threads() < 2:
            pytest.skip("BLAS cannot run on two threads here")
        two = laplacian_eigenfunctions((vertices, faces), 6)
    with threadpool_limits(limits=1, user_api="blas"):
        one = laplacian_eigenfunctions((vertices, faces), 6)
    np.testing.assert_array_equal(one[0], two[0])
    np.testing.assert_array_equal(one[1], two[1])


def test_cotangent_matrices_match_lapy():
    lapy = pytest.importorskip("lapy")
    vertices, faces = irregular_ellipsoid()
    L, M = cotangent_laplacian(vertices, faces)
    solver = lapy.Solver(lapy.TriaMesh(vertices, faces), lump=True)
    np.testing.assert_allclose(L.toarray(), solver.stiffness.toarray(), atol=1e-12)
    np.testing.assert_allclose(M.diagonal(), solver.mass.diagonal(), rtol=1e-12)


def test_cotangent_matrices_match_robust_laplacian_on_delaunay_mesh():
    robust_laplacian = pytest.importorskip("robust_laplacian")
    sphere = trimesh.creation.icosphere(3)
    vertices, faces = np.asarray(sphere.vertices), np.asarray(sphere.faces)
    L, M = cotangent_laplacian(vertices, faces)
    L_ref, M_ref = robust_laplacian.mesh_laplacian(vertices, faces)
    np.testing.assert_allclose(L.toarray(), L_ref.toarray(), atol=1e-10)
    np.testing.assert_allclose(M.diagonal(), M_ref.diagonal(), rtol=1e-10)


def test_eigenvalues_match_lapy_to_1e8():
    lapy = pytest.importorskip("lapy")
    vertices, faces = irregular_ellipsoid(4)
    values, vectors = laplacian_eigenfunctions((vertices, faces), 8)
    ref_values, ref_vectors = lapy.Solver(lapy.TriaMesh(vertices, faces), lump=True).eigs(8)
    np.testing.assert_allclose(values[1:], ref_values[1:], rtol=1e-8)
    assert abs(values[0]) < 1e-8
    _, M = cotangent_laplacian(vertices, faces)
    cosines = np.abs(np.einsum("i,ij,ij->j", M.diagonal(), vectors, ref_vectors))
    np.testing.assert_allclose(cosines[1:], 1.0, atol=1e-6)


def test_graph_laplacian_brute_force():
    sphere = trimesh.creation.icosphere(1)
    faces = np.asarray(sphere.faces)
    n = len(sphere.vertices)
    adjacency = np.zeros((n, n))
    for face in faces:
        for a in range(3):
            u, v = face[a], face[(a + 1) % 3]
            adjacency[u, v] = adjacency[v, u] = 1
    L, M = graph_laplacian(faces, n)
    np.testing.assert_array_equal(L.toarray(), np.diag(adjacency.sum(1)) - adjacency)
    np.testing.assert_array_equal(M.toarray(), np.eye(n))


def test_graph_eigenvectors_have_unit_norm():
    sphere = trimesh.creation.icosphere(3)
    _, vectors = laplacian_eigenfunctions(sphere, 4, laplacian="graph")
    np.testing.assert_allclose(np.linalg.norm(vectors, axis=0), 1.0)


@pytest.mark.parametrize("solver", ["cholesky", "superlu"])
def test_results_are_bitwise_reproducible_and_signs_fixed(solver):
    vertices, faces = irregular_ellipsoid(4)
    first = laplacian_eigenfunctions((vertices, faces), 6, solver=solver)
    second = laplacian_eigenfunctions((vertices, faces), 6, solver=solver)
    np.testing.assert_array_equal(first[0], second[0])
    np.testing.assert_array_equal(first[1], second[1])
    _, M = cotangent_laplacian(vertices, faces)
    other_seed = laplacian_eigenfunctions((vertices, faces), 6, random_state=123, solver=solver)
    # Another start vector changes rounding, never the sign.
    np.testing.assert_allclose(other_seed[1][:, 1:], first[1][:, 1:], atol=1e-6)
    skew = np.einsum("i,ij->j", M.diagonal(), first[1] ** 3)
    assert (skew[1:] > 0).all()


def test_tiny_mesh_uses_the_dense_path_and_checks_n_eigenpairs():
    vertices = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
    values, vectors = laplacian_eigenfunctions((vertices, [[0, 1, 2]]), 3)
    assert values.shape == (3,) and vectors.shape == (3, 3)
    assert np.isfinite(vectors).all()
    with pytest.raises(ValueError, match="n_eigenpairs must be between 1 and 3"):
        laplacian_eigenfunctions((vertices, [[0, 1, 2]]), 4)


@pytest.mark.parametrize(
    "sample, rows",
    [
        (trimesh.creation.icosphere(2), "162 (the kept vertices)"),
        (np.random.default_rng(0).random((300, 3)), "300 (the kept points)"),
    ],
)
def test_too_many_eigenpairs_is_refused_before_any_solve(monkeypatch, sample, rows):
    # The request was checked after the solve, which had been clipped to every
    # eigenpair: n_eigenpairs=10**6 on a large mesh meant a dense solve of all of them.
    from sklearn_meshph.spectral import solve

    def no_solve(*args, **kwargs):
        raise AssertionError("solved before refusing")

    monkeypatch.setattr(solve, "generalized_eigenpairs", no_solve)
    with pytest.raises(ValueError, match=rf"between 1 and {re.escape(rows)}, got 1000000"):
        laplacian_eigenfunctions(sample, 10**6)


def test_the_former_n_eigs_keyword_still_works_with_a_future_warning():
    vertices, faces = irregular_ellipsoid(2)
    with pytest.warns(FutureWarning, match="renamed n_eigenpairs"):
        old = laplacian_eigenfunctions((vertices, faces), n_eigs=4)
    new = laplacian_eigenfunctions((vertices, faces), n_eigenpairs=4)
    np.testing.assert_array_equal(old[0], new[0])
    with pytest.raises(TypeError, match="give n_eigenpairs only"):
        laplacian_eigenfunctions((vertices, faces), 4, n_eigs=4)
    with pytest.raises(TypeError, match="needs n_eigenpairs"):
        laplacian_eigenfunctions((vertices, faces))


@pytest.mark.parametrize("seed", [-1, 2**32, 1.5, "0"])
def test_invalid_seeds_are_refused_as_parameters(seed):
    with pytest.raises(ValueError, match="'random_state' parameter of laplacian_eigenfunctions"):
        laplacian_eigenfunctions(irregular_ellipsoid(1), 2, random_state=seed)


def test_degenerate_faces_do_not_change_the_spectrum():
    vertices, faces = irregular_ellipsoid(3)
    u, v = faces[0, 0], faces[0, 1]
    dirty_vertices = np.vstack([vertices, (vertices[u] + vertices[v]) / 2])
    extra = [[u, v, len(vertices)], [u, u, v]]
    dirty = (dirty_vertices, np.vstack([faces, extra]))
    np.testing.assert_allclose(
        laplacian_eigenfunctions(dirty, 6)[0],
        laplacian_eigenfunctions((vertices, faces), 6)[0],
        rtol=1e-10,
        atol=1e-10,
    )


def test_geometric_nested_dissection_is_a_fill_reducing_permutation():
    vertices, faces = irregular_ellipsoid(4)  # 2,562 vertices, numbered at random
    L, M = cotangent_laplacian(vertices, faces)
    A = (L + 1e-3 * M).tocsr()
    perm = fill_reducing_order(A, vertices)
    np.testing.assert_array_equal(np.sort(perm), np.arange(len(vertices)))
    options = {"diag_pivot_thresh": 0.0, "options": {"SymmetricMode": True}}
    ordered = splu(A[perm][:, perm].tocsc(), permc_spec="NATURAL", **options)
    natural = splu(A.tocsc(), permc_spec="NATURAL", **options)
    colamd = splu(A.tocsc(), permc_spec="COLAMD", **options)
    fill = ordered.L.nnz + ordered.U.nnz
    # Measured: 0.10 of the natural order's fill and 0.72 of COLAMD's.
    assert fill < 0.15 * (natural.L.nnz + natural.U.nnz)
    assert fill < 0.8 * (colamd.L.nnz + colamd.U.nnz)
    # The shift-invert operator on that order solves A y = x to rounding.
    x = np.random.default_rng(0).random(len(vertices))
    for solver in SOLVER_NAMES:
        y = ShiftInvertOperator(A, points=vertices, solver=solver).matvec(x)
        backward_error = np.abs(A @ y - x).max() / (abs(A).sum(axis=1).max() * np.abs(y).max())
        assert backward_error < 1e-14


def test_cholesky_and_lu_agree_and_indefinite_matrices_are_refused():
    vertices, faces = irregular_ellipsoid(4)
    L, M = cotangent_laplacian(vertices, faces)
    x = np.random.default_rng(1).random(len(vertices))
    A = L + 1e-2 * M
    by_cholesky = ShiftInvertOperator(A, points=vertices, solver="cholesky")
    by_lu = ShiftInvertOperator(A, points=vertices, solver="superlu")
    np.testing.assert_allclose(by_cholesky.matvec(x), by_lu.matvec(x), rtol=1e-9)
    with pytest.raises(ValueError, match="not positive definite"):
        ShiftInvertOperator(L - 10.0 * M, solver="cholesky")
    with pytest.raises(ValueError, match="solver must be"):
        ShiftInvertOperator(A, solver="qr")


@pytest.mark.parametrize("solver", SOLVER_NAMES)
def test_transformer_accepts_every_solver_and_gives_the_same_fields(solver):
    mesh = irregular_ellipsoid(4)
    reference = LaplacianEigenTransformer(solver="cholesky").fit_transform([mesh])[0]
    field = LaplacianEigenTransformer(solver=solver).fit_transform([mesh])[0]
    assert LaplacianEigenTransformer(solver=solver).get_params()["solver"] == solver
    np.testing.assert_array_equal(field.vertices, reference.vertices)
    np.testing.assert_array_equal(field.faces, reference.faces)
    assert field.values.shape == reference.values.shape == (len(mesh[0]), 3)
    if solver == "auto":  # documented: "auto" is the Cholesky backend
        np.testing.assert_array_equal(field.values, reference.values)
        np.testing.assert_array_equal(field.eigenvalues, reference.eigenvalues)
    np.testing.assert_allclose(field.eigenvalues, reference.eigenvalues, rtol=1e-10)
    np.testing.assert_allclose(field.values, reference.values, rtol=0, atol=1e-8)


@pytest.mark.parametrize("solver", ["qr", "Cholesky", "", None, 1, ("cholesky",)])
def test_an_unknown_solver_is_refused_with_a_clear_error(solver):
    mesh = irregular_ellipsoid(1)
    message = r"'solver' parameter of .* must be one of 'auto', 'cholesky', 'superlu'"
    with pytest.raises(InvalidParameterError, match=message) as error:
        LaplacianEigenTransformer(solver=solver).fit_transform([mesh])
    assert isinstance(error.value, ValueError)
    with pytest.raises(InvalidParameterError, match=message):
        LaplacianEigenTransformer(solver=solver).fit([mesh])
    with pytest.raises(InvalidParameterError, match=message):
        laplacian_eigenfunctions(mesh, 3, solver=solver)


def test_compiled_assembly_matches_a_dense_loop_and_is_canonical():
    """The counting-sort CSR against a plain per-face loop, with a right angle (a zero
    cotangent) and edges shared by faces in both directions."""
    vertices = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0.3], [0.4, 0.5, 1]])
    faces = np.array([[0, 1, 2], [1, 3, 2], [2, 3, 4], [0, 4, 1], [4, 3, 1], [0, 2, 4]])
    n = len(vertices)
    dense = np.zeros((n, n))
    for face in faces:
        for k in range(3):
            corner, a, b = vertices[face[k]], face[(k + 1) % 3], face[(k + 2) % 3]
            u, v = vertices[a] - corner, vertices[b] - corner
            half_cot = 0.5 * (u @ v) / np.linalg.norm(np.cross(u, v))
            dense[a, b] -= half_cot
            dense[b, a] -= half_cot
    dense -= np.diag(dense.sum(axis=1))
    L, _ = cotangent_laplacian(vertices, faces)
    assert L.has_canonical_format
    np.testing.assert_allclose(L.toarray(), dense, atol=1e-15)
    adjacency, _ = graph_laplacian(faces, n)
    assert adjacency.has_canonical_format and adjacency.nnz == n + 2 * 9  # 9 edges


def test_public_laplacians_refuse_bad_faces_instead_of_reading_out_of_bounds():
    vertices = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]])
    with pytest.raises(ValueError, match=r"face 1 has index \[1, 2, 4\] out of range"):
        cotangent_laplacian(vertices, [[0, 1, 2], [1, 2, 4]])
    with pytest.raises(ValueError, match="out of range for 4 vertices"):
        graph_laplacian(np.array([[0, 1, -1]]), 4)
    with pytest.raises(ValueError, match=r"shape \(n_faces, 3\)"):
        cotangent_laplacian(vertices, [0, 1, 2])
    with pytest.raises(ValueError, match="face 1 has zero area"):
        cotangent_laplacian(vertices, [[0, 1, 2], [0, 1, 1]])
    with pytest.raises(ValueError, match="vertex 0 has a non-finite coordinate"):
        cotangent_laplacian(np.full((3, 3), np.nan), [[0, 1, 2]])


@pytest.mark.parametrize("scale", [1e-150, 1e-100, 1e100, 1e150])
def test_the_operators_hold_at_any_scale_float64_can_hold(scale):
    from sklearn_meshph import point_cloud_laplacian

    sphere = trimesh.creation.icosphere(2)
    L0, M0 = cotangent_laplacian(sphere.vertices, sphere.faces)
    L, M = cotangent_laplacian(np.asarray(sphere.vertices) * scale, sphere.faces)
    np.testing.assert_allclose(L.toarray(), L0.toarray(), atol=1e-12)
    np.testing.assert_allclose(M.diagonal() / scale**2, M0.diagonal(), rtol=1e-12)
    # A sampled cloud (no exactly cocircular neighbours) likewise.
    points = trimesh.sample.sample_surface(sphere, 800, seed=0)[0]
    C0, N0 = point_cloud_laplacian(points)
    C, N = point_cloud_laplacian(points * scale)
    np.testing.assert_allclose(C.toarray(), C0.toarray(), atol=1e-9)
    np.testing.assert_allclose(N.diagonal() / scale**2, N0.diagonal(), rtol=1e-9)


@pytest.mark.parametrize("scale", [1e-300, 1e-160, 1e160, 1e300])
def test_areas_beyond_float64_are_refused_not_zero_or_inf(scale):
    from sklearn_meshph import point_cloud_laplacian

    sphere = trimesh.creation.icosphere(2)
    with pytest.raises(ValueError, match="cotangent_laplacian: the areas do not fit"):
        cotangent_laplacian(np.asarray(sphere.vertices) * scale, sphere.faces)
    points = trimesh.sample.sample_surface(sphere, 800, seed=0)[0]
    with pytest.raises(ValueError, match="point_cloud_laplacian: the areas do not fit"):
        point_cloud_laplacian(points * scale)
