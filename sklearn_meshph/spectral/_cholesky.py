"""Supernodal multifrontal sparse Cholesky factorization, compiled with numba.

The factorization behind the eigensolver. A sparse symmetric positive definite matrix
``A``, permuted by a fill-reducing order (the geometric nested dissection of
:mod:`._ordering` on meshes), is factored as ``P A P^T = L L^T``:

1. symbolic analysis: the elimination tree (Liu's algorithm with path compression),
   renumbered in postorder (same fill, consecutive chains); the column counts of ``L``
   (one walk up the tree per row, O(nnz(L))); fundamental supernodes (chains of columns
   with nested structure) merged into relaxed supernodes when that adds few explicit
   zeros; and the row structure of every supernode;
2. numeric factorization, supernode by supernode in increasing order (children before
   parents): a dense frontal matrix gathers the supernode's columns of ``A`` and the
   update matrices of its children, then LAPACK's ``dpotrf``, BLAS ``dtrsm`` and ``dsyrk``
   (scipy's own BLAS, called from compiled code) factor its columns and form its update
   matrix for the parent;
3. solves: a forward and a backward sweep over the supernodal panels
   (:mod:`._triangular`).

The same numeric phase, without pivoting and with a signed diagonal (``C S C^T``, ``S``
of +-1), factors a symmetric indefinite matrix with few negative eigenvalues: their
count, by Sylvester's law of inertia, is :func:`negative_eigenvalues`, which the
eigensolver uses to check that no eigenvalue below a shift was missed.

Its speed against SuperLU, CHOLMOD and MKL PARDISO is measured by
``benchmarks/bench_factorization.py`` and recorded in ``docs/eigenfunctions.md``.
"""

from __future__ import annotations

import ctypes

import numba
import numpy as np
import scipy.sparse as sp
from numba.extending import get_cython_function_address

from .._threads import one_blas_thread
from ._triangular import BLAS, solve_panels

__all__ = ["SupernodalCholesky", "check_square_finite", "negative_eigenvalues"]

# Relaxed amalgamation (CHOLMOD's thresholds): a supernode and its parent merge when the
# merged panel has at most 4 columns, or at most 16 with below 80% explicit zeros, or at
# most 48 with below 10%, or any width with below 5%.
_RELAX = np.array([4, 16, 0.8, 48, 0.1, 0.05])

_P = ctypes.c_void_p
_dpotrf = ctypes.CFUNCTYPE(None, _P, _P, _P, _P, _P)(
    get_cython_function_address("scipy.linalg.cython_lapack", "dpotrf")
)
_dtrsm = ctypes.CFUNCTYPE(None, _P, _P, _P, _P, _P, _P, _P, _P, _P, _P, _P)(
    get_cython_function_address("scipy.linalg.cython_blas", "dtrsm")
)
_dsyrk = ctypes.CFUNCTYPE(None, _P, _P, _P, _P, _P, _P, _P, _P, _P, _P)(
    get_cython_function_address("scipy.linalg.cython_blas", "dsyrk")
)


@numba.njit(cache=True)
def _etree(n, indptr, indices):
    """Elimination tree of a symmetric pattern (both triangles stored): ``parent[j]``."""
    parent = np.full(n, -1, np.int64)
    ancestor = np.full(n, -1, np.int64)
    for i in range(n):
        for p in range(indptr[i], indptr[i + 1]):
            k = indices[p]
            while k != -1 and k < i:
                nxt = ancestor[k]
                ancestor[k] = i
                if nxt == -1:
                    parent[k] = i
                k = nxt
    return parent


@numba.njit(cache=True)
def _postorder(parent):
    """A postorder of the elimination forest (children in increasing order): numbering
    the columns in it keeps the fill and makes every chain of the tree consecutive, so
    that supernodes can form."""
    n = len(parent)
    head = np.full(n, -1, np.int64)  # first child
    sibling = np.full(n, -1, np.int64)  # next child of the same parent
    for j in range(n - 1, -1, -1):
        p = parent[j]
        if p != -1:
            sibling[j] = head[p]
            head[p] = j
    order = np.empty(n, np.int64)
    stack = np.empty(n, np.int64)
    k = 0
    for root in range(n):
        if parent[root] != -1:
            continue
        top = 0
        stack[0] = root
        while top >= 0:
            j = stack[top]
            child = head[j]
            if child == -1:
                order[k] = j
                k += 1
                top -= 1
            else:
                head[j] = sibling[child]  # visit the next child next time
                top += 1
                stack[top] = child
    return order


@numba.njit(cache=True)
def _column_counts(n, indptr, indices, parent):
    """Number of non-zeros of every column of ``L``, the diagonal included."""
    counts = np.ones(n, np.int64)
    mark = np.full(n, -1, np.int64)
    for i in range(n):
        mark[i] = i
        for p in range(indptr[i], indptr[i + 1]):
            k = indices[p]
            if k >= i:
                continue
            while mark[k] != i:  # the path from k up to row i, in row i of L
                counts[k] += 1
                mark[k] = i
                k = parent[k]
    return counts


@numba.njit(cache=True)
def _supernodes(n, parent, counts, relax):
    """First column of each (relaxed) supernode, and its parent supernode.

    Fundamental supernodes first: column ``j + 1`` continues ``j``'s supernode when it is
    ``j``'s parent, its only child, and its column is ``j``'s minus the diagonal. Then a
    supernode is merged with the following one when that one is its parent and the merged
    panel has few explicit zeros for its width (the thresholds of CHOLMOD's relaxed
    amalgamation: any share up to 4 columns, 80% up to 16, 10% up to 48, 5% beyond):
    wider dense blocks make the BLAS calls efficient.
    """
    children = np.zeros(n, np.int64)
    for j in range(n):
        if parent[j] != -1:
            children[parent[j]] += 1
    starts = [0]
    for j in range(1, n):
        if not (parent[j - 1] == j and counts[j - 1] == counts[j] + 1 and children[j] == 1):
            starts.append(j)
    starts.append(n)
    first = np.array(starts, np.int64)
    ns = len(first) - 1
    # Relaxed merge of a supernode into the next one (its parent in the supernode tree).
    zeros = np.zeros(ns, np.int64)  # explicit zeros already in each supernode
    merged = [0]
    for s in range(1, ns + 1):
        if s == ns:
            merged.append(first[ns])
            break
        a0 = merged[-1]  # the current group holds columns a0 .. first[s] - 1
        a1 = first[s]
        b1 = first[s + 1]
        last_a = a1 - 1
        if parent[last_a] == a1:  # the next supernode is this group's parent
            na = a1 - a0
            nb = b1 - a1
            # Rows of the merged panel: the group's first column count covers the parent.
            rows = max(counts[a0], counts[a1] + na)
            added = (rows - counts[a0]) * na
            total = na + nb
            new_zeros = zeros[len(merged) - 1] + added
            size = total * rows
            fraction = new_zeros / size
            if (
                total <= relax[0]
                or (total <= relax[1] and fraction < relax[2])
                or (total <= relax[3] and fraction < relax[4])
                or fraction < relax[5]
            ):
                zeros[len(merged) - 1] = new_zeros
                counts[a0] = rows  # the merged group's column count
                for c in range(a0 + 1, b1):
                    counts[c] = rows - (c - a0)
                continue
        merged.append(first[s])
    first = np.array(merged, np.int64)
    ns = len(first) - 1
    column_super = np.empty(n, np.int64)
    for s in range(ns):
        column_super[first[s] : first[s + 1]] = s
    sparent = np.full(ns, -1, np.int64)
    for s in range(ns):
        p = parent[first[s + 1] - 1]
        if p != -1:
            sparent[s] = column_super[p]
    return first, sparent


@numba.njit(cache=True, inline="always")
def _add_rows(rows, last, s, mark, buffer, count):
    """Append to ``buffer[:count]`` the rows at or after ``last`` not yet marked ``s``."""
    for i in rows:
        if i >= last and mark[i] != s:
            mark[i] = s
            buffer[count] = i
            count += 1
    return count


@numba.njit(cache=True)
def _symbolic_rows(n, indptr, indices, first, sparent):
    """Row structure of every supernode: flat sorted rows, pointers, and children lists."""
    ns = len(first) - 1
    child_count = np.zeros(ns + 1, np.int64)
    for s in range(ns):
        if sparent[s] != -1:
            child_count[sparent[s] + 1] += 1
    child_ptr = np.cumsum(child_count)
    fill = child_ptr[:-1].copy()
    child = np.empty(max(child_ptr[-1], 1), np.int64)
    for s in range(ns):
        if sparent[s] != -1:
            child[fill[sparent[s]]] = s
            fill[sparent[s]] += 1
    mark = np.full(n, -1, np.int64)
    rowptr = np.zeros(ns + 1, np.int64)
    capacity = 4 * n
    rowind = np.empty(capacity, np.int64)
    buffer = np.empty(n, np.int64)
    for s in range(ns):
        f, last = first[s], first[s + 1]
        count = 0
        for c in range(f, last):
            mark[c] = s
            buffer[count] = c
            count += 1
        for c in range(f, last):  # the supernode's columns of A
            count = _add_rows(indices[indptr[c] : indptr[c + 1]], last, s, mark, buffer, count)
        for q in range(child_ptr[s], child_ptr[s + 1]):  # the children's rows
            ch = child[q]
            count = _add_rows(rowind[rowptr[ch] : rowptr[ch + 1]], last, s, mark, buffer, count)
        while rowptr[s] + count > capacity:
            capacity *= 2
            grown = np.empty(capacity, np.int64)
            grown[: rowptr[s]] = rowind[: rowptr[s]]
            rowind = grown
        rowind[rowptr[s] : rowptr[s] + count] = np.sort(buffer[:count])
        rowptr[s + 1] = rowptr[s] + count
    return rowptr, rowind[: rowptr[ns]].copy(), child_ptr, child


@numba.njit(cache=True)
def _signed_diagonal(front, nc, signs):
    """``front[:nc, :nc] = C S C^T`` (lower triangles) without pivoting: ``C`` overwrites
    it, ``S = diag(signs)`` gets the pivots' signs. Returns 0, or 1 + the column of a
    zero (or not finite) pivot."""
    for j in range(nc):
        d = front[j, j]
        for p in range(j):
            d -= front[j, p] * front[j, p] * signs[p]
        if not (d != 0.0 and np.isfinite(d)):
            return j + 1
        signs[j] = 1.0 if d > 0.0 else -1.0
        pivot = np.sqrt(abs(d))
        front[j, j] = pivot
        for i in range(j + 1, nc):
            value = front[i, j]
            for p in range(j):
                value -= front[i, p] * front[j, p] * signs[p]
            front[i, j] = value / (signs[j] * pivot)
    return 0


@numba.njit(cache=True)
def _numeric(n, indptr, indices, data, first, rowptr, rowind, child_ptr, child, lapack, signs):
    """Multifrontal numeric factorization; returns (panel offsets, panels, info).

    Panel ``s`` holds the supernode's columns of ``L``: its lower triangular diagonal
    block packed by rows (entry ``(c, d)``, ``d <= c``, at ``c (c + 1) / 2 + d``), then the
    ``(m, nc)`` block below it by columns (entry ``(t, c)`` at ``c m + t``, ``m = nr - nc``):
    the solves' inner loops then run along the long columns. ``info`` is 0, or 1 + the
    column where the matrix was found not positive definite. ``lapack`` holds the ctypes
    functions ``(dpotrf, dtrsm, dsyrk)``: passed as an argument rather than read as
    globals, so that numba can cache the compiled function.

    ``signs`` (length ``n``, or empty) asks for the factorization ``C S C^T`` of a
    symmetric indefinite matrix instead, ``S`` diagonal of +-1 written to ``signs``, with
    no pivoting (by Sylvester's law of inertia, the count of -1 is the number of negative
    eigenvalues); ``info`` then flags a zero pivot only.
    """
    dpotrf, dtrsm, dsyrk = lapack
    ns = len(first) - 1
    lptr = np.zeros(ns + 1, np.int64)
    max_rows = 0
    for s in range(ns):
        nr = rowptr[s + 1] - rowptr[s]
        nc = first[s + 1] - first[s]
        lptr[s + 1] = lptr[s] + nc * (nc + 1) // 2 + (nr - nc) * nc
        max_rows = max(max_rows, nr)
    lx = np.empty(lptr[ns])
    work = np.empty(max_rows * max_rows)
    pos = np.zeros(n, np.int64)
    relative = np.empty(max_rows, np.int64)
    updates = [np.empty((0, 0)) for _ in range(ns)]
    chars = np.array([ord("U"), ord("L"), ord("T"), ord("N")], np.uint8)
    ints = np.zeros(4, np.int32)
    scalars = np.array([1.0, -1.0])
    for s in range(ns):
        f = first[s]
        nc = first[s + 1] - f
        r0 = rowptr[s]
        nr = rowptr[s + 1] - r0
        for t in range(nr):
            pos[rowind[r0 + t]] = t
        front = work[: nr * nr].reshape((nr, nr))
        front[:] = 0.0
        # The supernode's columns of A, lower triangle (C order: front[row, col]).
        for c in range(nc):
            col = f + c
            for p in range(indptr[col], indptr[col + 1]):
                i = indices[p]
                if i >= col:
                    front[pos[i], c] += data[p]
        # Extend-add of the children's update matrices (lower triangles).
        for q in range(child_ptr[s], child_ptr[s + 1]):
            ch = child[q]
            update = updates[ch]
            nu = update.shape[0]
            offset = rowptr[ch + 1] - nu
            for a in range(nu):  # the child's rows in the front
                relative[a] = pos[rowind[offset + a]]
            for a in range(nu):
                ra = relative[a]
                for b in range(a + 1):
                    front[ra, relative[b]] += update[a, b]
            updates[ch] = np.empty((0, 0))
        # Fortran sees front^T: its upper triangle is our lower one.
        ints[0] = nc
        ints[1] = nr
        ints[2] = 0
        signed = len(signs) > 0
        if signed:
            ints[2] = _signed_diagonal(front, nc, signs[f:])
        else:
            dpotrf(
                chars[0:].ctypes, ints[0:].ctypes, front.ctypes, ints[1:].ctypes, ints[2:].ctypes
            )
        if ints[2] != 0:
            return lptr, lx, f + ints[2]
        m = nr - nc
        if m > 0:
            ints[3] = m
            below = front[nc:, :]  # rows nc.. in C order: Fortran's columns nc..
            # L21^T = L11^{-1} F21^T: in Fortran terms B <- U^{-T} B with U = L11^T.
            dtrsm(
                chars[1:].ctypes,  # side L
                chars[0:].ctypes,  # uplo U
                chars[2:].ctypes,  # trans T
                chars[3:].ctypes,  # diag N
                ints[0:].ctypes,  # m = nc
                ints[3:].ctypes,  # n = nr - nc
                scalars[0:].ctypes,
                front.ctypes,
                ints[1:].ctypes,
                below.ctypes,
                ints[1:].ctypes,
            )
            # F22 <- F22 - L21 L21^T: Fortran C <- C - B^T B, upper triangle.
            corner = front[nc:, nc:]
            dsyrk(
                chars[0:].ctypes,  # uplo U
                chars[2:].ctypes,  # trans T
                ints[3:].ctypes,  # n = nr - nc
                ints[0:].ctypes,  # k = nc
                scalars[1:].ctypes,  # alpha = -1
                below.ctypes,
                ints[1:].ctypes,
                scalars[0:].ctypes,  # beta = 1
                corner.ctypes,
                ints[1:].ctypes,
            )
            # Signed: W = F21 C11^{-T} above, F22 -= W S W^T (twice the negative columns'
            # rank-one terms back), and C21 = W S.
            for c in range(nc if signed else 0):
                if signs[f + c] < 0.0:
                    for a in range(m):
                        twice = 2.0 * below[a, c]
                        for b in range(a + 1):
                            corner[a, b] += twice * below[b, c]
                    for a in range(m):
                        below[a, c] = -below[a, c]
            update = np.empty((m, m))
            for a in range(m):
                for b in range(a + 1):
                    update[a, b] = front[nc + a, nc + b]
            updates[s] = update
        k = lptr[s]
        for c in range(nc):
            for d in range(c + 1):
                lx[k] = front[c, d]
                k += 1
        for c in range(nc):
            for t in range(nc, nr):
                lx[k] = front[t, c]
                k += 1
    return lptr, lx, 0


def check_square_finite(A: sp.spmatrix) -> sp.csr_matrix:
    """``A`` as a float64 CSR matrix, refusing a non-square one or a non-finite entry."""
    A = sp.csr_matrix(A, dtype=np.float64)
    if A.shape[0] != A.shape[1]:
        raise ValueError(f"the matrix must be square, got shape {A.shape}")
    if not np.isfinite(A.data).all():
        raise ValueError("the matrix has a non-finite entry (NaN or inf)")
    return A


class SupernodalCholesky:
    """``A = P^T L L^T P`` for a sparse symmetric positive definite ``A``.

    Parameters
    ----------
    A : sparse matrix of shape (n, n)
        Symmetric positive definite with both triangles stored (only the lower one is
        read, so an unsymmetric ``A`` is not detected).
    perm : ndarray of shape (n,), optional
        Fill-reducing order: row ``k`` of ``P A P^T`` is row ``perm[k]`` of ``A`` (see
        :func:`.factorization.fill_reducing_order`). None keeps the natural order.

    Raises
    ------
    ValueError
        If ``A`` is not square, has a non-finite entry or is not positive definite, or
        ``perm`` is not a permutation.
    """

    def __init__(self, A: sp.spmatrix, perm: np.ndarray | None = None):
        info = self._factor(A, perm, np.empty(0))
        if info:
            raise ValueError(
                f"the matrix is not positive definite (zero or negative pivot at column "
                f"{int(self.perm[info - 1])})"
            )

    def _factor(self, A, perm, signs):
        """Analyse and factor ``A`` (``signs``: see :func:`_numeric`); returns ``info``."""
        A = check_square_finite(A)
        n = A.shape[0]
        if perm is None:
            perm = np.arange(n)
        self.perm = np.ascontiguousarray(perm, dtype=np.int64)
        if self.perm.shape != (n,) or not np.array_equal(
            np.bincount(self.perm, minlength=n), np.ones(n, dtype=np.int64)
        ):
            raise ValueError(f"perm must be a permutation of range({n})")
        self.shape = (n, n)
        B = A[self.perm][:, self.perm].tocsr()
        B.sum_duplicates()
        parent = _etree(n, B.indptr.astype(np.int64), B.indices.astype(np.int64))
        post = _postorder(parent)
        self.perm = self.perm[post]
        B = B[post][:, post].tocsr()
        B.sort_indices()
        indptr = B.indptr.astype(np.int64)
        indices = B.indices.astype(np.int64)
        parent = _etree(n, indptr, indices)
        counts = _column_counts(n, indptr, indices, parent)
        self.first, sparent = _supernodes(n, parent, counts, _RELAX)
        self.rowptr, self.rowind, child_ptr, child = _symbolic_rows(
            n, indptr, indices, self.first, sparent
        )
        self._pattern = (indptr, indices, child_ptr, child)
        return self._refactor(B.data, signs)

    def _refactor(self, data, signs):
        """The numeric factorization of the matrix of values ``data`` on the analysed
        pattern (``signs``: see :func:`_numeric`); returns ``info``."""
        indptr, indices, child_ptr, child = self._pattern
        # One BLAS thread: a threaded BLAS is far slower on thousands of small calls,
        # and its results depend on the thread count.
        with one_blas_thread():
            self.lptr, self.lx, info = _numeric(
                self.shape[0],
                indptr,
                indices,
                data,
                self.first,
                self.rowptr,
                self.rowind,
                child_ptr,
                child,
                (_dpotrf, _dtrsm, _dsyrk),
                signs,
            )
        return info

    def _same_pattern_values(self, A: sp.spmatrix) -> np.ndarray | None:
        """The values of ``P A P^T`` on this factor's pattern, or None when ``A``'s
        pattern differs (an entry cancelled to zero, for one)."""
        indptr, indices = self._pattern[:2]
        B = check_square_finite(A)[self.perm][:, self.perm].tocsr()
        B.sum_duplicates()
        B.sort_indices()
        if not (np.array_equal(B.indptr, indptr) and np.array_equal(B.indices, indices)):
            return None
        return B.data

    @property
    def nnz(self) -> int:
        """Stored entries of the factor (explicit zeros of relaxed supernodes included)."""
        return int(self.lptr[-1])

    def solve(self, b: np.ndarray) -> np.ndarray:
        """``A^{-1} b`` for a vector ``b`` of length n."""
        b = np.asarray(b, dtype=np.float64)
        if b.shape != (self.shape[0],):
            raise ValueError(f"right-hand side must have shape ({self.shape[0]},), got {b.shape}")
        x = b[self.perm]
        with one_blas_thread():
            solve_panels(
                x,
                self.first,
                self.rowptr,
                self.rowind,
                self.lptr,
                self.lx,
                np.empty(len(x)),
                BLAS,
            )
        out = np.empty_like(x)
        out[self.perm] = x
        return out


def negative_eigenvalues(
    A: sp.spmatrix, perm: np.ndarray | None = None, *, like: SupernodalCholesky | None = None
) -> int:
    """The number of negative eigenvalues of a sparse symmetric ``A``, nonsingular (both
    triangles stored), by Sylvester's law of inertia: the negative pivots of its
    factorization ``C S C^T`` on the fill-reducing order ``perm``, without pivoting, so
    meant for matrices with few negative eigenvalues (``L - tau M`` with ``tau`` low in
    the spectrum, between two eigenvalues). ``like``: a factor of a matrix of the same
    pattern, whose analysis (order, supernodes, rows) is reused when the patterns agree
    (``perm`` is then ignored). A zero pivot is a ``ValueError``."""
    factor = SupernodalCholesky.__new__(SupernodalCholesky)
    signs = np.ones(A.shape[0])
    data = like._same_pattern_values(A) if like is not None else None
    if data is not None:
        factor.__dict__.update(like.__dict__)  # the analysis; lptr and lx are replaced
        info = factor._refactor(data, signs)
    else:
        info = factor._factor(A, perm, signs)
    if info:
        raise ValueError("zero pivot: the matrix is singular or nearly so")
    return int(np.count_nonzero(signs < 0.0))
