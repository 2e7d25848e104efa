"""Lanczos on a shift-inverted pencil: one run, no restart, partial reorthogonalization.

For ``L phi = lambda M phi`` (``M`` diagonal, positive) and a factorization of
``A = L - sigma M`` (:class:`._cholesky.SupernodalCholesky`), the symmetric operator
``C = M^1/2 A^-1 M^1/2`` has the eigenvalues ``theta = 1 / (lambda - sigma)``: the
eigenvalues nearest ``sigma`` become its largest. A single Krylov sequence of ``C`` (no
implicit restarts) is built one triangular solve at a time, in compiled code, in the
factor's order; each new vector is orthogonalized against the whole basis only when
Simon's recurrence estimates that its orthogonality has fallen to ``sqrt(eps)`` (and
once more at the next step), which keeps the basis semi-orthogonal: the Ritz values are
then as accurate as with full reorthogonalization, at a fraction of its cost (reading
the whole basis, bound by memory). Every few steps the Ritz pairs' residual bounds
decide convergence, as ARPACK's ``tol`` does. The Ritz vectors are formed in place in
the basis, whose unused rows are then released.

A null vector known in advance (the constant function of a Laplacian whose rows sum to
zero) is kept out of the Krylov space: the start vector is made orthogonal to it, and so
is each new vector, since rounding brings it back at every step amplified by its
``theta = -1 / sigma``, the largest of all. The run then seeks the eigenpairs after it
only, and the basis loses its orthogonality about a third less often.

A single Krylov sequence finds one vector of each eigenspace, the others only as
rounding brings them in: repeated eigenvalues must be checked by the caller (the
eigensolver counts the eigenvalues below a shift by the inertia of ``L - tau M``).
"""

from __future__ import annotations

import numba
import numpy as np
import scipy.linalg

from ._triangular import BLAS, solve_panels

__all__ = ["shift_invert_lanczos"]

_EPS = np.finfo(np.float64).eps
# Convergence is tested every this many steps from _FIRST_CHECK times the eigenpairs on
# (it takes about 2.4 times).
_CHECK_EVERY = 4
_FIRST_CHECK = 2
# The Ritz vectors are formed this many basis columns (vertices) at a time.
_CHUNK = 4096


@numba.njit(cache=True)
def _orthogonalize(basis, rows, w):
    """``w -= basis[:rows]^T (basis[:rows] w)`` (classical Gram-Schmidt, two BLAS
    matrix-vector products); returns the new norm of ``w``."""
    block = basis[:rows]
    w -= np.dot(np.dot(block, w), block)
    return np.sqrt(np.dot(w, w))


@numba.njit(cache=True, fastmath={"reassoc", "contract"})
def _steps(basis, start, stop, alpha, beta, omega, state, root, null, factor, scratch, blas):
    """Lanczos steps ``start .. stop - 1``: each writes ``alpha[j]``, ``beta[j]`` and the
    next vector ``basis[j + 1]``. ``omega`` (3 rows) holds the orthogonality estimates of
    the last three vectors, ``state`` the norm estimate, the rounding factor and whether
    the next vector must be reorthogonalized; ``null`` is a unit vector kept out of the
    basis (empty: none); ``factor`` is the factor's panels, in whose order the basis
    is. Returns False on a breakdown (an invariant subspace)."""
    first, rowptr, rowind, lptr, lx = factor
    x, work = scratch[0], scratch[1]
    n = len(root)
    eps = np.finfo(np.float64).eps
    for j in range(start, stop):
        v = basis[j]
        for i in range(n):
            x[i] = root[i] * v[i]
        solve_panels(x, first, rowptr, rowind, lptr, lx, work, blas)
        w = basis[j + 1]
        a = 0.0
        if j > 0:
            b = beta[j - 1]
            u = basis[j - 1]
            for i in range(n):
                w[i] = root[i] * x[i] - b * u[i]
                a += w[i] * v[i]
        else:
            for i in range(n):
                w[i] = root[i] * x[i]
                a += w[i] * v[i]
        for i in range(n):
            w[i] -= a * v[i]
        if len(null):
            w -= np.dot(null, w) * null
        norm = np.sqrt(np.dot(w, w))
        alpha[j] = a
        state[0] = max(state[0], abs(a) + norm + (beta[j - 1] if j > 0 else 0.0))
        rounding = state[1] * state[0]
        # Simon's recurrence for the inner products of w / norm with vectors 0 .. j, the
        # rounding term with the sign that makes each estimate larger.
        new, current, previous = omega[(j + 1) % 3], omega[j % 3], omega[(j + 2) % 3]
        largest = 0.0
        for k in range(j):
            t = beta[k] * current[k + 1] + (alpha[k] - a) * current[k]
            if k > 0:
                t += beta[k - 1] * current[k - 1]
            t -= beta[j - 1] * previous[k]
            t = (t + (rounding if t >= 0 else -rounding)) / norm
            new[k] = t
            largest = max(largest, abs(t))
        new[j] = rounding / norm
        new[j + 1] = 1.0
        if state[2] > 0 or max(largest, new[j]) > np.sqrt(eps):
            updated = _orthogonalize(basis, j + 1, w)
            if updated < 0.7 * norm:
                updated = _orthogonalize(basis, j + 1, w)
            norm = updated
            new[: j + 1] = eps
            state[2] = 0.0 if state[2] > 0 else 1.0
        if not norm > eps * abs(a) * n:  # breakdown (or NaN)
            return False
        beta[j] = norm
        for i in range(n):
            w[i] /= norm
    return True


def _ritz_in_place(basis, steps, coefficients):
    """Rows ``0 .. k-1`` of ``basis`` become ``coefficients^T basis[:steps]`` (``k``
    columns of coefficients), a chunk of columns at a time; the rest is released."""
    k = coefficients.shape[1]
    n = basis.shape[1]
    for start in range(0, n, _CHUNK):
        block = basis[:steps, start : start + _CHUNK]
        block[:k] = coefficients.T @ block
    basis.resize((k, n), refcheck=False)  # frees the unused rows (realloc shrinks)
    return basis


def shift_invert_lanczos(factor, mass, n_eigenpairs, *, v0, tol, max_steps, null=None):
    """The ``n_eigenpairs`` largest eigenvalues ``theta`` of ``C`` (see the module) and
    the next one, in decreasing order, and the eigenvectors ``phi = M^-1/2 u`` of the
    first ``n_eigenpairs`` as rows of an ``(n_eigenpairs, n)`` array; ``None`` when the
    ``max_steps`` solves do not converge or the sequence breaks down (an invariant
    subspace). ``factor``: a :class:`._cholesky.SupernodalCholesky` of ``A``.
    ``null``: an eigenvector ``phi`` of the pencil known in advance (M-orthonormal), kept
    out of the run: the eigenpairs are then those after it. Convergence: every residual
    bound below ``tol`` times its ``theta``, ``sqrt(tol)`` for the next one (it only
    bounds the others)."""
    n = len(mass)
    perm = factor.perm
    root = np.sqrt(mass[perm])
    kept_out = np.empty(0)
    start = v0[perm]
    if null is not None:  # in C's coordinates: M^1/2 phi, of unit norm
        kept_out = root * null[perm]
        kept_out /= np.linalg.norm(kept_out)
        start = start - np.dot(kept_out, start) * kept_out
    max_steps = min(max_steps, n)
    basis = np.empty((max_steps + 1, n))  # pages are touched only as rows are written
    alpha = np.zeros(max_steps)
    beta = np.zeros(max_steps)
    omega = np.zeros((3, max_steps + 2))
    omega[0, 0] = 1.0
    state = np.array([0.0, 0.5 * _EPS * np.sqrt(n), 0.0])  # PROPACK's rounding factor
    scratch = np.empty((2, n))
    panels = (factor.first, factor.rowptr, factor.rowind, factor.lptr, factor.lx)
    basis[0] = start / np.linalg.norm(start)
    first = max(_FIRST_CHECK * n_eigenpairs, n_eigenpairs + 1)
    args = (alpha, beta, omega, state, root, kept_out, panels, scratch, BLAS)
    steps = 0
    while steps < max_steps:
        stop = first if steps < first else min(steps + _CHECK_EVERY, max_steps)
        if not _steps(basis, steps, stop, *args):
            return None
        steps = stop
        theta, vectors = scipy.linalg.eigh_tridiagonal(alpha[:steps], beta[: steps - 1])
        wanted = np.arange(steps - 1, steps - n_eigenpairs - 2, -1)  # the largest, decreasing
        bounds = np.abs(beta[steps - 1] * vectors[-1, wanted]) / np.abs(theta[wanted])
        if np.all(bounds[:-1] <= tol) and bounds[-1] <= np.sqrt(tol):
            ritz = _ritz_in_place(basis, steps, vectors[:, wanted[:-1]])
            ritz /= root
            out = np.empty_like(ritz)
            out[:, perm] = ritz
            return theta[wanted], out
    return None
