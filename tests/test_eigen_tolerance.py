"""The shift-invert solve: an unrestarted Lanczos run with partial reorthogonalization,
checked by an inertia count (the eigenvalues below a shift), and ARPACK at machine
precision where the check fails (a copy of a repeated eigenvalue missed)."""

import numpy as np
import pytest
import scipy.sparse as sp
import trimesh
from conftest import irregular_ellipsoid

from sklearn_meshph import laplacian_eigenfunctions
from sklearn_meshph.spectral import eigensolver
from sklearn_meshph.spectral._cholesky import SupernodalCholesky, negative_eigenvalues
from sklearn_meshph.spectral.eigensolver import dense_eigenpairs, generalized_eigenpairs
from sklearn_meshph.spectral.factorization import fill_reducing_order
from sklearn_meshph.spectral.lanczos import shift_invert_lanczos
from sklearn_meshph.spectral.laplacians import cotangent_laplacian


def operator(vertices, faces):
    L, M = cotangent_laplacian(np.asarray(vertices, dtype=float), np.asarray(faces))
    return L, M / M.diagonal().sum()


def counting_arpack(monkeypatch):
    """Record the size of every ARPACK solve of the eigensolver."""
    calls = []
    original = eigensolver.eigsh

    def eigsh(A, *args, **kwargs):
        calls.append(A.shape[0])
        return original(A, *args, **kwargs)

    monkeypatch.setattr(eigensolver, "eigsh", eigsh)
    return calls


def test_a_simple_spectrum_is_solved_by_lanczos_alone(monkeypatch):
    vertices, faces = irregular_ellipsoid(3, seed=1)
    L, M = operator(vertices, faces)
    calls = counting_arpack(monkeypatch)
    values, vectors = generalized_eigenpairs(L, M, 56, points=vertices)
    assert calls == []
    precise, precise_vectors = dense_eigenpairs(L, M.diagonal(), 56)
    np.testing.assert_allclose(values[1:], precise[1:], rtol=1e-10)
    mass = M.diagonal()
    np.testing.assert_allclose((vectors.T * mass) @ vectors, np.eye(56), atol=1e-10)
    # The heat kernel signature at the earliest time the default uses.
    t = 4 * np.log(10) / values[-1]
    hks = vectors**2 @ np.exp(-values * t)
    reference = precise_vectors**2 @ np.exp(-precise * t)
    np.testing.assert_allclose(hks, reference, rtol=1e-8)


def box(n=8):
    """A cube's surface, each face an n x n grid: a spectrum of repeated eigenvalues."""
    mesh = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    for _ in range(int(np.log2(n))):
        mesh = mesh.subdivide()
    return mesh


SYMMETRIC = {
    "icosphere": lambda: trimesh.creation.icosphere(3),
    "torus": lambda: trimesh.creation.torus(1.0, 0.4, major_sections=32, minor_sections=16),
    "box": box,
}


@pytest.mark.parametrize("n_eigenpairs", [24, 56])
@pytest.mark.parametrize("shape", sorted(SYMMETRIC))
def test_repeated_eigenvalues_of_symmetric_shapes_are_all_found(shape, n_eigenpairs):
    # A single Krylov sequence misses copies of repeated eigenvalues: the inertia count
    # sees it, and ARPACK to machine precision finds them all.
    mesh = SYMMETRIC[shape]()
    L, M = operator(mesh.vertices, mesh.faces)
    values, vectors = generalized_eigenpairs(L, M, n_eigenpairs, points=mesh.vertices)
    expected, expected_vectors = dense_eigenpairs(L, M.diagonal(), n_eigenpairs + 20)
    np.testing.assert_allclose(values[1:], expected[1:n_eigenpairs], rtol=1e-9)
    # The same eigenspaces: every computed vector lies in the span of the dense ones up
    # to the last eigenvalue's whole eigenspace (it may go on past the last one asked).
    span = expected_vectors[:, expected <= values[-1] * (1 + 1e-8)]
    mass = M.diagonal()
    overlap = (span.T * mass) @ vectors
    np.testing.assert_allclose(np.linalg.svd(overlap, compute_uv=False), 1.0, atol=1e-7)


def test_a_missed_eigenvalue_is_caught_by_the_inertia_count(monkeypatch):
    # A broken run that drops the 10th eigenpair (and so reports the 57th as the 56th):
    # each value is a true eigenvalue, no two are close, only the count can tell.
    vertices, faces = irregular_ellipsoid(3, seed=1)
    L, M = operator(vertices, faces)
    original = eigensolver.shift_invert_lanczos

    def missing_one(factor, mass, n_eigenpairs, **kwargs):
        theta, vectors = original(factor, mass, n_eigenpairs + 1, **kwargs)
        keep = np.delete(np.arange(n_eigenpairs + 2), 9)
        return theta[keep], vectors[keep[:-1]]

    monkeypatch.setattr(eigensolver, "shift_invert_lanczos", missing_one)
    calls = counting_arpack(monkeypatch)
    values, _ = generalized_eigenpairs(L, M, 56, points=vertices)
    assert len(calls) == 1
    expected, _ = dense_eigenpairs(L, M.diagonal(), 56)
    np.testing.assert_allclose(values[1:], expected[1:], rtol=1e-10)


def test_a_boundary_through_a_repeated_eigenvalue_goes_to_arpack(monkeypatch):
    # The last eigenpair asked for and the next one agree: no shift separates them.
    vertices, faces = irregular_ellipsoid(3, seed=1)
    L, M = operator(vertices, faces)
    original = eigensolver.shift_invert_lanczos

    def tied(*args, **kwargs):
        theta, vectors = original(*args, **kwargs)
        theta[-1] = theta[-2] * (1 - 1e-9)
        return theta, vectors

    monkeypatch.setattr(eigensolver, "shift_invert_lanczos", tied)
    calls = counting_arpack(monkeypatch)
    generalized_eigenpairs(L, M, 20, points=vertices)
    assert len(calls) == 1


def test_the_inertia_count_is_the_number_of_eigenvalues_below_the_shift():
    vertices, faces = irregular_ellipsoid(2, seed=3)
    L, M = operator(vertices, faces)
    values = np.linalg.eigvalsh(
        np.diag(M.diagonal() ** -0.5) @ L.toarray() @ np.diag(M.diagonal() ** -0.5)
    )
    perm = fill_reducing_order(L.tocsr(), vertices)
    for count in [0, 1, 2, 7, 30, 80, len(values) - 1]:
        tau = -1.0 if count == 0 else 0.5 * (values[count - 1] + values[count])
        assert negative_eigenvalues(L - tau * M, perm) == count
        assert negative_eigenvalues(L - tau * M) == count  # any order
    with pytest.raises(ValueError, match="zero pivot"):
        negative_eigenvalues(sp.csr_matrix(np.diag([1.0, 0.0, 2.0])))


def test_lanczos_finds_a_known_spectrum_under_a_dominant_eigenvalue():
    # As in shift-invert, theta_0 = 1 / |sigma| dominates the others. (Orthogonality
    # estimates that leave the operator's norm out of the rounding term let copies of
    # its eigenvector crowd out the eigenpairs asked for on real meshes: the ellipsoid
    # test above then falls back to ARPACK.)
    n = 600
    theta = np.concatenate([[1e3], 1.0 / np.arange(1, n)])
    rng = np.random.default_rng(0)
    Q = np.linalg.qr(rng.normal(size=(n, n)))[0]
    factor = SupernodalCholesky(sp.csr_matrix((Q / theta) @ Q.T))  # C = A^-1
    found = shift_invert_lanczos(
        factor, np.ones(n), 40, v0=rng.uniform(-1, 1, n), tol=1e-8, max_steps=164
    )
    assert found is not None
    np.testing.assert_allclose(found[0], theta[:41], rtol=1e-10)
    np.testing.assert_allclose(np.abs(found[1] @ Q[:, :40]), np.eye(40), atol=1e-7)


def test_lanczos_keeps_a_known_null_vector_out_of_the_run():
    # The same operator with its dominant eigenvector given: the run finds the
    # eigenpairs after it, orthogonal to it (without it, the first one found is it).
    n = 600
    theta = np.concatenate([[1e3], 1.0 / np.arange(1, n)])
    rng = np.random.default_rng(0)
    Q = np.linalg.qr(rng.normal(size=(n, n)))[0]
    factor = SupernodalCholesky(sp.csr_matrix((Q / theta) @ Q.T))
    found = shift_invert_lanczos(
        factor, np.ones(n), 40, v0=rng.uniform(-1, 1, n), tol=1e-8, max_steps=164, null=Q[:, 0]
    )
    assert found is not None
    np.testing.assert_allclose(found[0], theta[1:42], rtol=1e-10)
    np.testing.assert_allclose(np.abs(found[1] @ Q[:, 1:41]), np.eye(40), atol=1e-7)
    assert np.abs(found[1] @ Q[:, 0]).max() < 1e-12


def test_the_constant_eigenfunction_is_known_in_advance_where_rows_sum_to_zero(monkeypatch):
    vertices, faces = irregular_ellipsoid(3, seed=1)
    L, M = operator(vertices, faces)
    mass = M.diagonal()
    null = eigensolver.constant_null_vector(L, mass)
    np.testing.assert_allclose(null, 1.0 / np.sqrt(mass.sum()))
    # A Laplacian whose rows do not sum to zero (a normalized one, a potential) has none.
    assert eigensolver.constant_null_vector(L + sp.diags(np.full(L.shape[0], 1e-6)), mass) is None
    kept_out = []
    original = eigensolver.shift_invert_lanczos

    def spy(factor, mass, n_eigenpairs, **kwargs):
        kept_out.append((n_eigenpairs, kwargs["null"] is not None))
        return original(factor, mass, n_eigenpairs, **kwargs)

    monkeypatch.setattr(eigensolver, "shift_invert_lanczos", spy)
    values, vectors = generalized_eigenpairs(L, M, 24, points=vertices)
    assert kept_out == [(23, True)]
    assert values[0] == 0.0
    np.testing.assert_allclose(vectors[:, 0], null, rtol=1e-14)
    expected, _ = dense_eigenpairs(L, mass, 24)
    np.testing.assert_allclose(values[1:], expected[1:], rtol=1e-10)
    np.testing.assert_allclose((vectors.T * mass) @ vectors, np.eye(24), atol=1e-10)


def test_the_inertia_count_reuses_the_factor_analysis_where_patterns_agree(monkeypatch):
    from sklearn_meshph.spectral import _cholesky

    vertices, faces = irregular_ellipsoid(2, seed=3)
    L, M = operator(vertices, faces)
    values = dense_eigenpairs(L, M.diagonal(), 40)[0]
    factor = SupernodalCholesky(L + 1e-2 * M, fill_reducing_order(L.tocsr(), vertices))
    analyses = []
    original = _cholesky._etree
    monkeypatch.setattr(_cholesky, "_etree", lambda *a: analyses.append(1) or original(*a))
    for count in [1, 7, 30, 39]:
        tau = 0.5 * (values[count - 1] + values[count])
        assert negative_eigenvalues(L - tau * M, like=factor) == count
    assert analyses == []
    # Another pattern (an edge's entries removed): analysed afresh, counted right.
    A = (L - 0.5 * (values[6] + values[7]) * M).tolil()
    i, j = L.nonzero()[0][1], L.nonzero()[1][1]
    A[i, j] = A[j, i] = 0.0
    A = A.tocsr()
    A.eliminate_zeros()
    expected = int(np.count_nonzero(np.linalg.eigvalsh(A.toarray()) < 0))
    assert negative_eigenvalues(A, like=factor) == expected
    assert analyses != []


@pytest.mark.parametrize("name", ["spring/261.off.gz", "spring/269.off.gz"])
def test_clustered_spectra_converge_without_arpack(watertight_dir, name, monkeypatch):
    # The default's 48 eigenpairs of these springs need 202 Lanczos steps (4.2 per eigenpair):
    # with room for 4 per eigenpair they fell back to ARPACK, four times the cost.
    from sklearn_meshph import clean_mesh
    from sklearn_meshph.inputs import check_input
    from sklearn_meshph.pipelines import _EIGENPAIRS

    mesh = clean_mesh(*check_input(watertight_dir / name))
    L, M = operator(mesh.vertices, mesh.faces)
    calls = counting_arpack(monkeypatch)
    values, _ = generalized_eigenpairs(L, M, _EIGENPAIRS, points=mesh.vertices)
    assert calls == []
    monkeypatch.setattr(eigensolver, "_LANCZOS", False)
    expected, _ = generalized_eigenpairs(L, M, _EIGENPAIRS, points=mesh.vertices)
    np.testing.assert_allclose(values[1:], expected[1:], rtol=1e-10)


@pytest.mark.parametrize("size", [1e-12, 1e-30, 1e30])
def test_the_spectrum_does_not_depend_on_the_mesh_size(size):
    # With the masses of a mesh of size 1e-12, ARPACK (where the inertia count sends
    # it) lost a copy of the threefold eigenvalue l(l + 1) = 2 of the sphere.
    mesh = trimesh.creation.icosphere(4)
    L, M = cotangent_laplacian(mesh.vertices, np.asarray(mesh.faces))
    reference, _ = generalized_eigenpairs(L, M, 10, points=mesh.vertices)
    L, M = cotangent_laplacian(mesh.vertices * size, np.asarray(mesh.faces))
    values, vectors = generalized_eigenpairs(L, M, 10, points=mesh.vertices * size)
    np.testing.assert_allclose(values[1:] * size**2, reference[1:], rtol=1e-9)
    np.testing.assert_allclose((vectors.T * M.diagonal()) @ vectors, np.eye(10), atol=1e-9)


@pytest.mark.parametrize("size", [1e-150, 1e-100, 1e100, 1e150])
def test_laplacian_eigenfunctions_at_any_size_float64_holds(size):
    # It built the operator on the mesh as given: at size 1e-100 the squared areas
    # underflowed and every face was refused as degenerate; at 1e100 the areas
    # overflowed and every eigenvalue came back 0.
    mesh = trimesh.creation.icosphere(2)
    faces = np.asarray(mesh.faces)
    reference, ref_vectors = laplacian_eigenfunctions((mesh.vertices, faces), 6)
    values, vectors = laplacian_eigenfunctions((mesh.vertices * size, faces), 6)
    np.testing.assert_allclose(values[1:] * size * size, reference[1:], rtol=1e-9)
    # M-orthonormal at the mesh's own scale: the vectors scale as 1 / size.
    np.testing.assert_allclose(np.abs(vectors[:, 0] * size), np.abs(ref_vectors[:, 0]), rtol=1e-9)


@pytest.mark.parametrize("size", [1e-160, 1e160])
def test_laplacian_eigenfunctions_beyond_float64_is_an_error(size):
    mesh = trimesh.creation.icosphere(2)
    with pytest.raises(ValueError, match="beyond float64's range"):
        laplacian_eigenfunctions((mesh.vertices * size, np.asarray(mesh.faces)), 6)


def test_a_lost_copy_of_a_repeated_eigenvalue_is_detected_by_inertia():
    # ARPACK once returned the sphere's 0, 2 (x3), 6 (x4 of 5), 12, 12 at size 1e-30:
    # the count of the pencil's eigenvalues below the last cluster must show it.
    from sklearn_meshph.spectral.eigensolver import _missed_eigenvalues, eigen_shift
    from sklearn_meshph.spectral.factorization import ShiftInvertOperator

    mesh = trimesh.creation.icosphere(4)
    L, M = cotangent_laplacian(mesh.vertices, np.asarray(mesh.faces))
    values, _ = generalized_eigenpairs(L, M, 11, points=mesh.vertices)
    op = ShiftInvertOperator(L - eigen_shift(L, M) * M, points=mesh.vertices)
    assert _missed_eigenvalues(L, M, values[:10], op) is None
    lost = np.concatenate([values[:8], values[9:11]])  # one 6 missing, two 12s
    assert "found 8 eigenvalues below" in _missed_eigenvalues(L, M, lost, op)
    assert "the pencil has 9" in _missed_eigenvalues(L, M, lost, op)
