"""Sparse factorization backends of the eigensolver's shift-invert step.

A backend factors a symmetric positive definite ``A = L - sigma M`` once and then solves
``A x = b`` many times (once per Lanczos step). Each is a class built from
``(A, perm)``, ``perm`` a fill-reducing order or None, with a ``solve(b)`` method, and
one entry in :data:`SOLVERS`:

- ``"cholesky"``: our supernodal multifrontal Cholesky (:mod:`._cholesky`);
- ``"superlu"``: SciPy's SuperLU with diagonal pivots (stable on a positive definite
  matrix), twice the memory: an independent implementation to check against.

``"auto"`` takes the Cholesky factorization, the faster one at every size measured by
``benchmarks/bench_factorization.py`` (figures in ``docs/eigenfunctions.md``), and the
eigensolver solves small operators densely instead (the crossover measured by
``benchmarks/bench_graph_spectra.py``). ``"dense"`` factors nothing: the eigensolver
then always solves densely (:func:`.eigensolver.dense_eigenpairs`), every eigenpair at
once if asked.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import reverse_cuthill_mckee
from scipy.sparse.linalg import LinearOperator, splu

from .._registry import Option, Registry
from .._threads import one_blas_thread
from ._cholesky import SupernodalCholesky, check_square_finite
from ._ordering import geometric_nested_dissection

__all__ = ["SOLVERS", "ShiftInvertOperator", "factorize"]


class SuperLUFactor:
    """SuperLU of ``A`` with diagonal pivots, on the fill-reducing order ``perm``."""

    def __init__(self, A: sp.spmatrix, perm: np.ndarray):
        options = {"SymmetricMode": True}
        self.perm = perm
        self.iperm = np.empty_like(perm)
        self.iperm[perm] = np.arange(len(perm))
        B = A[perm][:, perm].tocsc()
        # One BLAS thread, as the Cholesky backend: SuperLU's results otherwise depend on
        # the caller's thread count with some BLAS builds (scipy 1.10's OpenBLAS 0.3.18).
        with one_blas_thread():
            self.lu = splu(B, "NATURAL", diag_pivot_thresh=0.0, options=options)

    def solve(self, b: np.ndarray) -> np.ndarray:
        """``A^{-1} b`` for a vector ``b`` of length n."""
        b = np.asarray(b, dtype=np.float64)
        if b.shape != self.perm.shape:
            raise ValueError(f"right-hand side must have shape ({len(self.perm)},), got {b.shape}")
        with one_blas_thread():
            return self.lu.solve(b[self.perm])[self.iperm]


SOLVERS = Registry(
    "solver",
    [
        Option(
            "auto",
            SupernodalCholesky,
            "the fastest: the dense eigensolver below a measured size, else 'cholesky'",
        ),
        Option(
            "cholesky",
            SupernodalCholesky,
            "our supernodal multifrontal Cholesky on scipy's BLAS and LAPACK",
        ),
        Option(
            "superlu",
            SuperLUFactor,
            "SciPy's SuperLU with diagonal pivots (independent check; twice the memory)",
        ),
        Option(
            "dense",
            None,
            "no factorization: LAPACK's dense symmetric eigensolver at every size (every "
            "eigenpair if asked; memory grows as the square of the size)",
        ),
    ],
)


def fill_reducing_order(A: sp.csr_matrix, points: np.ndarray | None) -> np.ndarray:
    """Geometric nested dissection of ``points``, or reverse Cuthill-McKee without."""
    if points is None:
        return reverse_cuthill_mckee(A, symmetric_mode=True).astype(np.int64)
    graph = A.copy()
    graph.setdiag(0)
    graph.eliminate_zeros()
    return geometric_nested_dissection(
        np.ascontiguousarray(points, dtype=np.float64), graph.indptr, graph.indices
    )


def factorize(A: sp.spmatrix, points: np.ndarray | None = None, solver: str = "auto"):
    """Factor a symmetric positive definite ``A`` with the named backend.

    ``points`` (vertex coordinates, one row per row of ``A``) give the geometric
    nested-dissection order; without them reverse Cuthill-McKee is used (more fill).
    """
    backend = SOLVERS[solver].value
    if backend is None:
        raise ValueError(f"the {solver!r} solver factors nothing: it is the dense eigensolver")
    A = check_square_finite(A)  # here, before the order is computed, for every backend
    n = A.shape[0]
    if points is not None:
        points = np.asarray(points, dtype=np.float64)
        if points.ndim != 2 or len(points) != n:
            raise ValueError(
                f"points must have one row per row of the matrix, ({n}, d); got {points.shape}"
            )
    return backend(A, fill_reducing_order(A, points))


class ShiftInvertOperator(LinearOperator):
    """``x -> A^{-1} x`` for ARPACK's shift-invert mode, from one factorization of ``A``."""

    def __init__(self, A: sp.spmatrix, points: np.ndarray | None = None, solver: str = "auto"):
        super().__init__(dtype=np.float64, shape=A.shape)
        self.factor = factorize(A, points, solver)

    def _matvec(self, x):
        return self.factor.solve(np.asarray(x, dtype=np.float64).ravel())
