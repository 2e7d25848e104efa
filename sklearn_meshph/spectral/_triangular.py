"""Triangular solves with the factor of :mod:`._cholesky`: a forward and a backward sweep
over its supernodal panels, BLAS (``dtpsv``, ``dgemv``) on the wide ones, compiled loops on
the many narrow ones."""

from __future__ import annotations

import ctypes

import numba
import numpy as np
from numba.extending import get_cython_function_address

__all__ = ["BLAS", "solve_panels"]

_P = ctypes.c_void_p
_dtpsv = ctypes.CFUNCTYPE(None, _P, _P, _P, _P, _P, _P, _P)(
    get_cython_function_address("scipy.linalg.cython_blas", "dtpsv")
)
_dgemv = ctypes.CFUNCTYPE(None, _P, _P, _P, _P, _P, _P, _P, _P, _P, _P, _P)(
    get_cython_function_address("scipy.linalg.cython_blas", "dgemv")
)
#: The BLAS functions :func:`solve_panels` takes.
BLAS = (_dtpsv, _dgemv)

# Supernodes of at least this many columns are solved with BLAS (dtpsv and dgemv); the
# many small ones with compiled loops, cheaper than a call.
_BLAS_SOLVE_COLUMNS = 8


@numba.njit(cache=True, inline="always")
def _panel(first, rowptr, lptr, s, ints):
    """Supernode ``s``: first column, columns ``nc``, start of the rows below its diagonal
    block in ``rowind``, their count ``m``, and the offsets of its diagonal block and of
    the block below in ``lx``. Sets ``ints[:2]`` to ``nc, m`` for the BLAS calls."""
    f = first[s]
    nc = first[s + 1] - f
    r0 = rowptr[s] + nc
    m = rowptr[s + 1] - r0
    base = lptr[s]
    ints[0] = nc
    ints[1] = m
    return f, nc, r0, m, base, base + nc * (nc + 1) // 2


@numba.njit(cache=True, inline="always")
def _tpsv(dtpsv, chars, ints, trans, ap, x):
    """``x <- U^{-T} x`` (``trans=1``) or ``U^{-1} x`` (``trans=2``) for the upper triangle
    ``U`` of order ``ints[0]`` packed by columns in ``ap``; ``chars`` is "UTN"."""
    dtpsv(
        chars[0:].ctypes,
        chars[trans:].ctypes,
        chars[2:].ctypes,
        ints[0:].ctypes,
        ap.ctypes,
        x.ctypes,
        ints[2:].ctypes,
    )


@numba.njit(cache=True, inline="always")
def _gemv(dgemv, chars, ints, scalars, trans, alpha, beta, a, x, y):
    """``y <- scalars[alpha] op(A) x + scalars[beta] y`` for the ``ints[1] x ints[0]``
    column-major ``A`` in ``a``; ``op`` is the transpose with ``trans=1``, none with 2."""
    dgemv(
        chars[trans:].ctypes,
        ints[1:].ctypes,
        ints[0:].ctypes,
        scalars[alpha:].ctypes,
        a.ctypes,
        ints[1:].ctypes,
        x.ctypes,
        ints[2:].ctypes,
        scalars[beta:].ctypes,
        y.ctypes,
        ints[2:].ctypes,
    )


# Reassociation lets the compiler vectorize the dot products (a fixed order for a given
# machine and build: results stay reproducible).
@numba.njit(cache=True, fastmath={"reassoc", "contract"})
def solve_panels(x, first, rowptr, rowind, lptr, lx, work, blas):
    """Overwrite ``x`` (permuted) with ``(L L^T)^{-1} x``; ``work`` has length >= n.

    ``blas`` holds the ctypes functions ``(dtpsv, dgemv)``. In Fortran's view a lower
    triangle packed by rows is the upper triangle ``U = L11^T`` packed by columns, and the
    block below, stored by columns, is ``L21`` with leading dimension ``m``.
    """
    dtpsv, dgemv = blas
    chars = np.array([ord("U"), ord("T"), ord("N")], np.uint8)
    ints = np.array([0, 0, 1], np.int32)  # nc, m, increment 1
    scalars = np.array([1.0, 0.0, -1.0])
    ns = len(first) - 1
    for s in range(ns):  # forward: L y = x
        f, nc, r0, m, base, below = _panel(first, rowptr, lptr, s, ints)
        use_blas = nc >= _BLAS_SOLVE_COLUMNS
        xs = x[f:]
        if use_blas:  # y = U^{-T} x_J
            _tpsv(dtpsv, chars, ints, 1, lx[base:], xs)
        else:
            for c in range(nc):
                value = x[f + c]
                row = base + c * (c + 1) // 2
                for d in range(c):
                    value -= lx[row + d] * x[f + d]
                x[f + c] = value / lx[row + c]
        if m == 0:
            continue
        if use_blas:  # work = L21 y
            _gemv(dgemv, chars, ints, scalars, 2, 0, 1, lx[below:], xs, work)
        else:
            work[:m] = 0.0
            for c in range(nc):
                yc = x[f + c]
                col = below + c * m
                for t in range(m):
                    work[t] += lx[col + t] * yc
        for t in range(m):
            x[rowind[r0 + t]] -= work[t]
    for s in range(ns - 1, -1, -1):  # backward: L^T x = y
        f, nc, r0, m, base, below = _panel(first, rowptr, lptr, s, ints)
        use_blas = nc >= _BLAS_SOLVE_COLUMNS
        xs = x[f:]
        if m > 0:
            for t in range(m):
                work[t] = x[rowind[r0 + t]]
            if use_blas:  # x_J -= L21^T work
                _gemv(dgemv, chars, ints, scalars, 1, 2, 0, lx[below:], work, xs)
            else:
                for c in range(nc):
                    col = below + c * m
                    value = 0.0
                    for t in range(m):
                        value += lx[col + t] * work[t]
                    x[f + c] -= value
        if use_blas:  # x_J = U^{-1} x_J
            _tpsv(dtpsv, chars, ints, 2, lx[base:], xs)
        else:
            for c in range(nc - 1, -1, -1):  # by rows of L: contiguous in the triangle
                row = base + c * (c + 1) // 2
                value = x[f + c] / lx[row + c]
                x[f + c] = value
                for d in range(c):
                    x[f + d] -= lx[row + d] * value
