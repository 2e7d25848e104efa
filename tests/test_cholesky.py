"""The supernodal Cholesky factorization as a backend, through its public surface only.

``SupernodalCholesky(A, perm).solve(b)`` and ``.nnz``, and
``factorization.factorize(A, points, solver)``: solves against dense solves and SuperLU
(on random sparse matrices and on mesh matrices of up to 41k vertices), refusal of bad
input, bitwise determinism (repeated factorizations, any BLAS thread count) and the size
of the factor. Nothing here reads the factor's internal layout.
"""

import conftest
import numpy as np
import pytest
import scipy.linalg
import scipy.sparse as sp
from hypothesis import given, settings
from hypothesis import strategies as st
from threadpoolctl import threadpool_info, threadpool_limits

from sklearn_meshph.spectral._cholesky import SupernodalCholesky
from sklearn_meshph.spectral.eigensolver import eigen_shift
from sklearn_meshph.spectral.factorization import factorize, fill_reducing_order
from sklearn_meshph.spectral.laplacians import cotangent_laplacian

BACKENDS = ("cholesky", "superlu")


def random_spd(n: int, density: float, seed: int) -> sp.csr_matrix:
    """A random sparse graph Laplacian plus a positive diagonal (possibly disconnected)."""
    rng = np.random.default_rng(seed)
    W = sp.random(n, n, density=density, random_state=rng, data_rvs=rng.random)
    W = W + W.T
    W = W - sp.diags(W.diagonal())  # not setdiag: no SparseEfficiencyWarning
    laplacian = sp.diags(np.asarray(W.sum(axis=1)).ravel()) - W
    return (laplacian + sp.diags(rng.uniform(0.01, 1.0, n))).tocsr()


def irregular_ellipsoid(subdivisions=3, seed=0):
    """The shared irregular ellipsoid, its vertices numbered at random."""
    return conftest.irregular_ellipsoid(subdivisions, seed, shuffle=True)


def shift_invert_matrix(subdivisions):
    """The eigensolver's ``A = L - sigma M`` on an irregular ellipsoid, ``M`` and the
    vertices."""
    vertices, faces = irregular_ellipsoid(subdivisions)
    L, M = cotangent_laplacian(vertices, faces)
    return (L - eigen_shift(L, M) * M).tocsr(), M, vertices


def blas_threads() -> int:
    """The thread count BLAS runs on now (the least over the loaded BLAS libraries)."""
    return min(i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas")


def backward_error(A, x, b) -> float:
    """``||A x - b|| / (||A|| ||x||)`` in the max norm: rounding-sized for a stable solve
    whatever the condition number."""
    return float(np.abs(A @ x - b).max() / (abs(A).sum(axis=1).max() * np.abs(x).max()))


def exact_fill(A, perm) -> int:
    """Entries of the Cholesky factor of ``A[perm][:, perm]``, diagonal included, by
    symbolic elimination on a dense boolean pattern (no cancellation, no supernodes)."""
    pattern = sp.csr_matrix(A)[perm][:, perm].toarray() != 0
    count = 0
    for k in range(len(perm)):
        below = k + 1 + np.flatnonzero(pattern[k + 1 :, k])
        count += 1 + len(below)
        pattern[np.ix_(below, below)] = True
    return count


@pytest.fixture(autouse=True, scope="module")
def blas_on_one_thread():
    """BLAS on one thread unless a test sets otherwise, for the run time of the dense
    references on a busy machine; thread counts are tested in
    ``test_bitwise_equal_repeated_and_under_any_blas_thread_count``."""
    with threadpool_limits(limits=1, user_api="blas"):
        yield


@pytest.fixture(scope="module")
def matrix_41k():
    A, M, vertices = shift_invert_matrix(6)
    assert A.shape == (40962, 40962)
    return A, M, vertices


@pytest.mark.parametrize(
    ("n", "density", "seed"),
    [(1, 1.0, 0), (2, 0.5, 1), (30, 0.02, 2), (60, 0.3, 3), (200, 0.01, 4), (300, 1.0, 5)],
)
def test_solve_matches_dense_solve_and_superlu(n, density, seed):
    A = random_spd(n, density, seed)
    rng = np.random.default_rng(seed)
    b = rng.normal(size=n)
    kept = b.copy()
    reference = scipy.linalg.solve(A.toarray(), b, assume_a="pos")
    by_superlu = factorize(A, solver="superlu").solve(b)
    for perm in (rng.permutation(n), None):
        x = SupernodalCholesky(A, perm).solve(b)
        assert backward_error(A, x, b) < 1e-15 * max(n, 10)
        np.testing.assert_allclose(x, reference, rtol=1e-9, atol=1e-12 * np.abs(x).max())
        np.testing.assert_allclose(x, by_superlu, rtol=1e-9, atol=1e-12 * np.abs(x).max())
    np.testing.assert_array_equal(b, kept)  # the right-hand side is left alone


@settings(max_examples=40, deadline=None)
@given(
    n=st.integers(1, 40),
    density=st.floats(0.0, 0.5),
    seed=st.integers(0, 2**16),
)
def test_any_sparse_spd_matrix_and_order(n, density, seed):
    """Random patterns (forests, dense blocks, isolated vertices) and random orders."""
    A = random_spd(n, density, seed)
    rng = np.random.default_rng(seed)
    perm = rng.permutation(n)
    b = rng.normal(size=n)
    chol = SupernodalCholesky(A, perm)
    x = chol.solve(b)
    assert backward_error(A, x, b) < 1e-14  # measured at most 3.5e-16
    reference = scipy.linalg.solve(A.toarray(), b, assume_a="pos")
    np.testing.assert_allclose(x, reference, rtol=1e-8, atol=1e-12 * np.abs(x).max())
    # The factor holds at least the fill of the given order (more: the explicit zeros of
    # relaxed supernodes), at most a dense triangle.
    assert exact_fill(A, perm) <= chol.nnz <= n * (n + 1) // 2


def test_explicit_zeros_duplicates_and_sparse_formats_do_not_matter():
    A = random_spd(50, 0.1, 6)
    b = np.random.default_rng(6).normal(size=50)
    x = SupernodalCholesky(A).solve(b)
    coo = A.tocoo()
    rows, cols = np.arange(10), np.arange(10, 20)  # explicit zeros at symmetric places
    duplicated = sp.coo_matrix(
        (
            np.concatenate([coo.data / 2, coo.data / 2, np.zeros(20)]),
            (
                np.concatenate([coo.row, coo.row, rows, cols]),
                np.concatenate([coo.col, coo.col, cols, rows]),
            ),
        ),
        shape=A.shape,
    )
    for same in (duplicated, duplicated.tocsr(), A.tocsc()):
        for solver in BACKENDS:
            y = factorize(same, solver=solver).solve(b)
            np.testing.assert_allclose(y, x, rtol=1e-12, atol=1e-14 * np.abs(x).max())
        y = SupernodalCholesky(same).solve(b)
        np.testing.assert_allclose(y, x, rtol=1e-12, atol=1e-14 * np.abs(x).max())


def test_factor_size_is_the_fill_of_the_given_order():
    """Postordering the elimination tree renumbers columns without adding fill: the
    factor's size is the exact fill of the order given, plus only the explicit zeros of
    relaxed supernodes (measured: 4% to 34% more). ``.nnz`` counts those zeros, hence
    the upper bound and not an equality; a renumbering that adds fill would multiply
    the size of the good orders (a random order fills 4 times as much as nested
    dissection here)."""
    A, _, vertices = shift_invert_matrix(3)  # 642 vertices
    n = A.shape[0]
    orders = {
        "nested dissection": fill_reducing_order(A, vertices),
        "reverse Cuthill-McKee": fill_reducing_order(A, None),
        "natural": np.arange(n),
        "random": np.random.default_rng(0).permutation(n),
    }
    for name, perm in orders.items():
        fill = exact_fill(A, perm)
        nnz = SupernodalCholesky(A, perm).nnz
        assert fill <= nnz <= 1.5 * fill, name
    for name in ("random", "natural"):  # the orders are worth what their fill says
        assert exact_fill(A, orders["nested dissection"]) < 0.5 * exact_fill(A, orders[name])


def test_nested_dissection_fills_less_than_the_band_orders():
    A, _, vertices = shift_invert_matrix(4)  # 2,562 vertices, numbered at random
    nested = factorize(A, vertices, "cholesky").nnz
    # Measured: 0.54 of reverse Cuthill-McKee's (without points) and 0.37 of the
    # (random) natural order's.
    assert nested < 0.65 * factorize(A, None, "cholesky").nnz
    assert nested < 0.45 * SupernodalCholesky(A).nnz


@pytest.mark.parametrize("points", ["nested dissection", "reverse Cuthill-McKee"])
def test_backends_match_a_dense_solve_at_2562_vertices(points):
    A, _, vertices = shift_invert_matrix(4)
    b = np.random.default_rng(0).normal(size=A.shape[0])
    reference = scipy.linalg.solve(A.toarray(), b, assume_a="pos")
    for solver in ("auto", *BACKENDS):
        x = factorize(A, vertices if points == "nested dissection" else None, solver).solve(b)
        assert backward_error(A, x, b) < 1e-14  # measured below 5e-16
        # Condition number 7e5: measured 1.3e-12 between the backends.
        assert np.abs(x - reference).max() < 1e-10 * np.abs(reference).max()


def test_backends_agree_at_41k_vertices(matrix_41k):
    """Both backends on the eigensolver's own matrix; measured: backward errors 5e-16,
    relative difference 7e-12 (condition number 1.1e7, so a first-order bound of 1e-8)."""
    A, M, vertices = matrix_41k
    rng = np.random.default_rng(1)
    rhs = [rng.normal(size=A.shape[0]), M @ rng.uniform(-1.0, 1.0, A.shape[0])]
    solutions = {}
    for solver in BACKENDS:
        factor = factorize(A, vertices, solver)
        solutions[solver] = [factor.solve(b) for b in rhs]
        for b, x in zip(rhs, solutions[solver], strict=True):
            assert backward_error(A, x, b) < 1e-14
    for x, y in zip(*solutions.values(), strict=True):
        assert np.abs(x - y).max() < 1e-10 * np.abs(y).max()


@pytest.mark.parametrize("solver", ["cholesky", "superlu"])
def test_bitwise_equal_repeated_and_under_any_blas_thread_count(matrix_41k, solver):
    """One BLAS thread or two, again and again: the same bits. Our factorization runs
    BLAS on one thread whatever the caller's setting."""
    A, _, vertices = matrix_41k
    b = np.random.default_rng(2).normal(size=A.shape[0])
    results, in_effect = [], []
    for threads in (2, 2, 1):
        with threadpool_limits(limits=threads, user_api="blas"):
            in_effect.append(blas_threads())
            factor = factorize(A, vertices, solver)
            results.append((getattr(factor, "nnz", None), factor.solve(b), factor.solve(b)))
    assert in_effect == [2, 2, 1] or max(in_effect) < 2  # the limits were applied
    first = results[0]
    for other in results:
        assert other[0] == first[0]
        np.testing.assert_array_equal(other[1], first[1])
        np.testing.assert_array_equal(other[2], first[1])


def test_bad_input_is_refused():
    A = random_spd(20, 0.2, 5)
    with pytest.raises(ValueError, match="not positive definite"):
        SupernodalCholesky(A - 10.0 * sp.identity(20))
    with pytest.raises(ValueError, match="not positive definite"):
        SupernodalCholesky(sp.diags([1.0, 0.0, 1.0]))
    with pytest.raises(ValueError, match="not positive definite"):
        SupernodalCholesky(-sp.identity(3))
    for bad in (np.nan, np.inf, -np.inf):
        broken = A.copy()
        broken.data[0] = bad
        with pytest.raises(ValueError, match="non-finite"):
            SupernodalCholesky(broken)
    with pytest.raises(ValueError, match="square"):
        SupernodalCholesky(sp.random(3, 4, density=0.5))
    for perm in (np.zeros(20, dtype=int), np.arange(19), np.arange(1, 21)):
        with pytest.raises(ValueError, match="permutation"):
            SupernodalCholesky(A, perm)
    chol = SupernodalCholesky(A)
    for b in (np.ones(3), np.ones(21), np.ones((20, 1))):
        with pytest.raises(ValueError, match="right-hand side"):
            chol.solve(b)


def test_the_cholesky_backend_refuses_indefinite_matrices():
    """The eigensolver's matrix with too large a shift is indefinite: refused, not solved
    (SuperLU, an LU factorization, accepts it)."""
    A, M, vertices = shift_invert_matrix(3)
    for points in (vertices, None):
        with pytest.raises(ValueError, match="not positive definite"):
            factorize(A - 10.0 * M, points, "cholesky")
    with pytest.raises(ValueError, match="not positive definite"):
        factorize(sp.diags([1.0, 0.0, 1.0]), None, "cholesky")


# Each bad input and the message that names its problem (not any ValueError from deeper).
FACTORIZATION_ERRORS = {
    "non-square": r"^the matrix must be square, got shape \(3, 4\)$",
    "non-square with points": r"^the matrix must be square, got shape \(3, 4\)$",
    "non-finite": r"^the matrix has a non-finite entry",
    "points of the wrong length": r"^points must have one row per row of the matrix.*got \(5, 3\)",
    "right-hand side of the wrong length": r"^right-hand side must have shape \(6,\), got \(7,\)",
}


@pytest.mark.parametrize("solver", BACKENDS)
@pytest.mark.parametrize("case", sorted(FACTORIZATION_ERRORS))
def test_factorize_refuses_bad_input_for_every_backend(case, solver):
    A = random_spd(6, 0.5, 7)
    points = np.random.default_rng(7).normal(size=(6, 3))
    rhs = np.ones(6)
    if case.startswith("non-square"):
        A = sp.random(3, 4, density=0.5, random_state=0, format="csr")
        points, rhs = (points[:3] if case.endswith("points") else None), np.ones(3)
    elif case == "non-finite":
        A.data[0] = np.nan
    elif case == "points of the wrong length":
        points = points[:5]
    else:
        rhs = np.ones(7)
    with pytest.raises(ValueError, match=FACTORIZATION_ERRORS[case]):
        factorize(A, points, solver).solve(rhs)
