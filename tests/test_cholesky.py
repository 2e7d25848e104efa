"""The supernodal Cholesky factorization against dense references."""

import numpy as np
import pytest
import scipy.linalg
import scipy.sparse as sp
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

from sklearn_meshph.spectral._cholesky import SupernodalCholesky
from sklearn_meshph.spectral._ordering import geometric_nested_dissection
from sklearn_meshph.spectral.eigensolver import eigen_shift
from sklearn_meshph.spectral.laplacians import cotangent_laplacian


def dense_factor(chol: SupernodalCholesky) -> np.ndarray:
    """``L`` rebuilt from the supernodal panels."""
    n = chol.shape[0]
    L = np.zeros((n, n))
    for s in range(len(chol.first) - 1):
        f, nc = chol.first[s], chol.first[s + 1] - chol.first[s]
        rows = chol.rowind[chol.rowptr[s] : chol.rowptr[s + 1]]
        panel = chol.lx[chol.lptr[s] : chol.lptr[s + 1]]
        k = 0
        for c in range(nc):
            for d in range(c + 1):
                L[f + c, f + d] = panel[k]
                k += 1
        m = len(rows) - nc
        for c in range(nc):  # the block below, by columns
            L[rows[nc:], f + c] = panel[k + c * m : k + (c + 1) * m]
    return L


def random_spd(n: int, density: float, seed: int) -> sp.csr_matrix:
    """A random sparse graph Laplacian plus a positive diagonal (possibly disconnected)."""
    rng = np.random.default_rng(seed)
    W = sp.random(n, n, density=density, random_state=rng, data_rvs=rng.random)
    W = W + W.T
    W.setdiag(0)
    laplacian = sp.diags(np.asarray(W.sum(axis=1)).ravel()) - W
    return (laplacian + sp.diags(rng.uniform(0.01, 1.0, n))).tocsr()


def mesh_matrix(subdivisions: int = 3):
    mesh = trimesh.creation.icosphere(subdivisions)
    vertices = np.asarray(mesh.vertices) * [1.0, 1.4, 2.1]
    L, M = cotangent_laplacian(vertices, mesh.faces)
    A = (L - eigen_shift(L, M) * M).tocsr()
    graph = A.copy()
    graph.setdiag(0)
    graph.eliminate_zeros()
    return A, geometric_nested_dissection(vertices, graph.indptr, graph.indices)


@pytest.mark.parametrize(
    ("n", "density", "seed"),
    [(1, 1.0, 0), (2, 0.5, 1), (30, 0.02, 2), (60, 0.3, 3), (200, 0.01, 4)],
)
def test_factor_and_solve_match_dense_cholesky(n, density, seed):
    A = random_spd(n, density, seed)
    perm = np.random.default_rng(seed).permutation(n)
    chol = SupernodalCholesky(A, perm)
    B = A.toarray()[chol.perm][:, chol.perm]  # the order after postordering
    L = dense_factor(chol)
    np.testing.assert_allclose(L, np.linalg.cholesky(B), atol=1e-12 * np.abs(B).max())
    # Postordering the elimination tree renumbers columns without adding fill.
    given = np.linalg.cholesky(A.toarray()[perm][:, perm])
    assert np.count_nonzero(np.abs(given) > 1e-14) == np.count_nonzero(np.abs(L) > 1e-14)
    b = np.random.default_rng(seed).normal(size=n)
    np.testing.assert_allclose(chol.solve(b), scipy.linalg.solve(A.toarray(), b), rtol=1e-9)


def test_mesh_matrix_on_nested_dissection_and_default_order():
    A, perm = mesh_matrix()
    b = np.random.default_rng(0).normal(size=A.shape[0])
    reference = scipy.linalg.solve(A.toarray(), b, assume_a="pos")
    for order in (perm, None):
        chol = SupernodalCholesky(A, order)
        x = chol.solve(b)
        np.testing.assert_allclose(x, reference, rtol=1e-8, atol=1e-10 * np.abs(reference).max())
        assert np.abs(A @ x - b).max() < 1e-10 * np.abs(b).max()
    # Nested dissection fills in far less than the band order, and relaxed supernodes
    # group columns (fewer supernodes than columns).
    assert SupernodalCholesky(A, perm).nnz < SupernodalCholesky(A).nnz
    assert len(chol.first) - 1 < A.shape[0] // 2


def test_bitwise_reproducible():
    A, perm = mesh_matrix()
    b = np.random.default_rng(1).normal(size=A.shape[0])
    one, two = SupernodalCholesky(A, perm), SupernodalCholesky(A, perm)
    assert np.array_equal(one.lx, two.lx)
    assert np.array_equal(one.solve(b), two.solve(b))


def test_bad_input_is_refused():
    A = random_spd(20, 0.2, 5)
    with pytest.raises(ValueError, match="not positive definite"):
        SupernodalCholesky(A - 10.0 * sp.identity(20))
    with pytest.raises(ValueError, match="not positive definite"):
        SupernodalCholesky(sp.diags([1.0, 0.0, 1.0]))
    nan = A.copy()
    nan.data[0] = np.nan
    with pytest.raises(ValueError, match="non-finite"):
        SupernodalCholesky(nan)
    with pytest.raises(ValueError, match="square"):
        SupernodalCholesky(sp.random(3, 4, density=0.5))
    with pytest.raises(ValueError, match="permutation"):
        SupernodalCholesky(A, np.zeros(20, dtype=int))
    with pytest.raises(ValueError, match="right-hand side"):
        SupernodalCholesky(A).solve(np.ones(3))


@settings(max_examples=40, deadline=None)
@given(
    n=st.integers(1, 40),
    density=st.floats(0.0, 0.5),
    seed=st.integers(0, 2**16),
)
def test_any_sparse_spd_matrix_and_order(n, density, seed):
    """Random patterns (forests, dense blocks, isolated vertices) and random orders."""
    A = random_spd(n, density, seed)
    perm = np.random.default_rng(seed).permutation(n)
    chol = SupernodalCholesky(A, perm)
    L = dense_factor(chol)
    B = A.toarray()[chol.perm][:, chol.perm]  # the order after postordering
    np.testing.assert_allclose(L @ L.T, B, atol=1e-12 * np.abs(B).max())
    assert np.allclose(np.triu(L, 1), 0.0)


def test_independent_of_the_blas_thread_setting():
    """BLAS runs on one thread inside the factorization whatever the caller's setting."""
    from threadpoolctl import threadpool_limits

    A, perm = mesh_matrix(4)
    b = np.random.default_rng(2).normal(size=A.shape[0])
    with threadpool_limits(limits=1, user_api="blas"):
        one = SupernodalCholesky(A, perm)
        x_one = one.solve(b)
    with threadpool_limits(limits=2, user_api="blas"):
        two = SupernodalCholesky(A, perm)
        x_two = two.solve(b)
    assert np.array_equal(one.lx, two.lx)
    assert np.array_equal(x_one, x_two)
