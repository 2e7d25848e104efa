"""Matrices between collections of diagrams: the one scheduler of blocks of pairs
(:func:`pair_matrix`, behind the distances and the kernels), the distance matrix, and
the base of the transformers that return a matrix to their fitted samples."""

from __future__ import annotations

from functools import partial
from numbers import Integral, Real

import numpy as np
from joblib import delayed, effective_n_jobs
from sklearn.base import ClassNamePrefixFeaturesOutMixin

from .._param_validation import Interval, Options, validate_params
from .._progress import parallel, track
from ._assignment import precedes
from ._batch import SLICED, pack, pack_sliced, pair_distances
from .distances import METRICS, kernel_metric
from .estimator import DiagramTransformer
from .validation import Packed, pack_samples

__all__ = [
    "SLICED",
    "PairwiseTransformer",
    "as_packed",
    "distance_matrix",
    "distance_stack",
    "pack_for_metric",
    "pair_distances",
    "pair_matrix",
    "pairwise_diagram_distances",
    "precedes",
]


def as_packed(samples) -> Packed:
    """Validated samples (a :class:`Packed`, or tuples of diagrams) as a :class:`Packed`."""
    return samples if isinstance(samples, Packed) else Packed.from_checked(samples)


# Pairs per task at most: bounds the index arrays and results in flight (about 24 MB).
_MAX_TASK_PAIRS = 1_000_000


def _row_blocks(n_rows, pairs_per_row, n_tasks):
    """Boundaries of consecutive row blocks holding about equal numbers of pairs."""
    cumulative = np.concatenate([[0], np.cumsum(pairs_per_row)])
    targets = np.linspace(0, cumulative[-1], n_tasks + 1)
    bounds = np.unique(np.searchsorted(cumulative, targets, side="left"))
    bounds[0], bounds[-1] = 0, n_rows
    return np.unique(bounds)


class _Shared:
    """What every task of one call reads (packed samples: a tuple of arrays), in an
    object that joblib's dask backend sends to the cluster once per call instead of with
    every task: it scatters the arguments that are weakly referable and larger than a
    kilobyte by ``sizeof``, which a tuple is not."""

    def __init__(self, value):
        self.value = value
        self.nbytes = sum(getattr(array, "nbytes", 0) for array in value)

    def __sizeof__(self) -> int:
        return object.__sizeof__(self) + self.nbytes


def _block(function, left, right, start, stop, n_cols, symmetric, first):
    """``function`` on the pairs of rows ``start:stop``: with every column, or when
    symmetric with the columns from ``i + first`` on (``first`` 0: with the diagonal)."""
    left, right = left.value, right.value
    if symmetric:
        rows = np.concatenate([np.full(n_cols - i - first, i) for i in range(start, stop)])
        cols = np.concatenate([np.arange(i + first, n_cols) for i in range(start, stop)])
    else:
        rows, cols = np.divmod(np.arange(start * n_cols, stop * n_cols), n_cols)
    return function(left, right, rows, cols)


@validate_params(
    {
        "metric": [Options(METRICS)],
        "order": [Interval(Real, 1, None, closed="left")],
        "internal_p": [Interval(Real, 1, None, closed="left")],
        "n_jobs": [Integral, None],
        "verbose": [Interval(Integral, 0, None, closed="left")],
        "n_directions": [Interval(Integral, 1, None, closed="left")],
        "per_diagram": ["boolean"],
    }
)
def pairwise_diagram_distances(
    X,
    Y=None,
    *,
    metric="bottleneck",
    order=2.0,
    internal_p=np.inf,
    n_jobs=None,
    dtype=np.float64,
    out=None,
    verbose=0,
    n_directions=10,
    per_diagram=False,
) -> np.ndarray:
    """Distance matrix between two collections of diagrams (or of tuples of diagrams).

    The function behind :class:`DiagramDistance`, for matrices that should not be held
    in memory twice: ``out`` (e.g. a :func:`numpy.lib.format.open_memmap` array)
    receives the matrix instead of a new array.

    Parameters
    ----------
    X : sequence of diagrams or of tuples of diagrams
        Each sample an ``(n, 2)`` array or a tuple of them (all samples with the same
        number of diagrams), as :class:`LowerStarPersistence` returns.
    Y : sequence of diagrams or of tuples of diagrams, optional
        The columns; ``None`` gives the symmetric matrix of ``X``, each unordered pair
        computed once.
    metric : {"bottleneck", "wasserstein", "sliced-wasserstein"}, default="bottleneck"
        See :class:`DiagramDistance`.
    order : float, default=2.0
        The Wasserstein exponent q.
    internal_p : float, default=inf
        Ground metric between points for the Wasserstein distance.
    n_jobs : int, default=None
        ``None`` means 1 unless in a :func:`joblib.parallel_backend` context; ``-1``
        means all processors. Results are identical for any ``n_jobs`` and backend.
    dtype : numpy dtype, default=float64
        Of the returned matrix (distances are computed in float64).
    out : ndarray of shape (len(X), len(Y)) or (len(X), len(Y), n_diagrams), optional
        Written in place and returned.
    verbose : int, default=0
        With ``verbose > 0``, a progress bar over the blocks of pairs on stderr (needs
        tqdm, the ``progress`` extra); nothing is printed at 0.
    n_directions : int, default=10
        Number of lines of the sliced Wasserstein distance (ignored by the others).
    per_diagram : bool, default=False
        Return the distance matrix of each diagram position, stacked on a last axis,
        instead of their combination: what :class:`DistanceKernel` turns into a kernel
        with a bandwidth per position, and what a grid search slices as a precomputed
        matrix (see :class:`PerDiagramDistance`).

    Returns
    -------
    ndarray of shape (len(X), len(Y)), or (len(X), len(Y), n_diagrams) with ``per_diagram``

    Notes
    -----
    Rows are split into blocks of about equal work, a few per worker and at most a
    million pairs each, every block one compiled loop; the pair indices are made inside
    the workers, so memory stays bounded whatever the number of samples.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_meshph import pairwise_diagram_distances
    >>> pairwise_diagram_distances([np.array([[0.0, 1.0]]), np.array([[0.0, 1.5]])])
    array([[0. , 0.5],
           [0.5, 0. ]])
    """
    left = pack_samples(X)
    right = None if Y is None else pack_samples(Y, n_diagrams=left.n_diagrams)
    shape = (len(left), len(left if right is None else right))
    shape += (left.n_diagrams,) if per_diagram else ()
    if out is not None and out.shape != shape:
        raise ValueError(f"out has shape {out.shape}, expected {shape}")
    if per_diagram:
        return distance_stack(
            left, right, metric, order, internal_p, n_directions, dtype, n_jobs, out, verbose
        )
    return distance_matrix(
        left,
        right,
        metric,
        order,
        internal_p,
        n_jobs,
        dtype,
        out,
        verbose=verbose,
        n_directions=n_directions,
    )


def pack_for_metric(packed: Packed, code: int, n_directions: int = 10):
    """Packed samples as :func:`pair_distances` reads them for the metric ``code``
    (``SLICED``: each diagram's sorted projections on ``n_directions`` lines)."""
    flat = pack(packed)
    return pack_sliced(flat, n_directions) if code == SLICED else flat


def distance_matrix(
    left, right, metric, order, internal_p, n_jobs, dtype, out, verbose=0, n_directions=10
):
    """:func:`pairwise_diagram_distances` on validated samples (:class:`Packed`, or
    lists of tuples of diagrams)."""
    code, order = kernel_metric(metric, order, internal_p)
    left = as_packed(left)
    right = None if right is None else as_packed(right)
    n_parts = left.n_diagrams
    n, m = len(left), len(left if right is None else right)
    packed_left = pack_for_metric(left, code, n_directions)
    packed_right = None if right is None else pack_for_metric(right, code, n_directions)
    function = partial(
        pair_distances,
        n_parts=n_parts,
        metric=code,
        order=order,
        internal_p=float(internal_p),
    )
    return pair_matrix(
        function,
        packed_left,
        packed_right,
        n,
        m,
        n_jobs=n_jobs,
        dtype=dtype,
        out=out,
        verbose=verbose,
    )


def distance_stack(
    left,
    right,
    metric,
    order,
    internal_p,
    n_directions,
    dtype=np.float64,
    n_jobs=None,
    out=None,
    verbose=0,
):
    """The distance matrix of each diagram position of validated samples
    (:class:`Packed`, or lists of tuples of diagrams), stacked: ``out[i, j, k]`` is the
    distance between diagram ``k`` of ``left[i]`` and of ``right[j]`` (``right=None``:
    ``left`` again, each unordered pair computed once)."""
    left = as_packed(left)
    right = None if right is None else as_packed(right)
    n, m = len(left), len(left if right is None else right)
    stack = np.empty((n, m, left.n_diagrams), dtype=dtype) if out is None else out
    for k in range(left.n_diagrams):
        distance_matrix(
            left.only(k),
            None if right is None else right.only(k),
            metric,
            order,
            internal_p,
            n_jobs,
            dtype,
            stack[:, :, k],
            verbose=verbose,
            n_directions=n_directions,
        )
    return stack


def pair_matrix(
    function,
    left,
    right,
    n,
    m,
    *,
    n_jobs=None,
    dtype=np.float64,
    out=None,
    verbose=0,
    diagonal=0.0,
    desc="distances",
):
    """The ``(n, m)`` matrix of ``function(left, right, rows, cols)`` (the values of the
    pairs ``(rows[k], cols[k])``), over blocks of rows in parallel.

    ``left`` and ``right`` are whatever ``function`` reads (packed samples); with
    ``right=None`` the matrix is symmetric (``m == n``), each unordered pair computed
    once and mirrored, and its diagonal is ``diagonal``, or computed if it is None.
    Blocks hold about equal numbers of pairs, a few per worker and at most a million
    each; results do not depend on the blocks, so neither on ``n_jobs`` nor the backend.
    """
    symmetric = right is None
    left = _Shared(left)
    right = left if symmetric else _Shared(right)
    first = 0 if symmetric and diagonal is None else 1
    pairs_per_row = np.arange(n - first, -first, -1) if symmetric else np.full(n, m)
    total = int(pairs_per_row.sum())
    n_tasks = max(1, min(n, max(4 * effective_n_jobs(n_jobs), -(-total // _MAX_TASK_PAIRS))))
    bounds = _row_blocks(n, pairs_per_row, n_tasks)
    matrix = np.zeros((n, m), dtype=dtype) if out is None else out
    tasks = parallel(n_jobs, batch_size=1)(
        delayed(_block)(function, left, right, a, b, m, symmetric, first)
        for a, b in zip(bounds[:-1], bounds[1:], strict=True)
    )
    blocks = track(tasks, total=len(bounds) - 1, desc=desc, verbose=verbose)
    for a, b, values in zip(bounds[:-1], bounds[1:], blocks, strict=True):
        if symmetric:
            position = 0
            for i in range(a, b):
                row = values[position : position + n - i - first]
                matrix[i, i + first :] = row
                matrix[i + first :, i] = row
                position += n - i - first
        else:
            matrix[a:b] = values.reshape(b - a, m)
    if symmetric and diagonal is not None:
        matrix[np.arange(n), np.arange(n)] = diagonal
    return matrix


class PairwiseTransformer(ClassNamePrefixFeaturesOutMixin, DiagramTransformer):
    """Base of the transformers whose output is a matrix to their fitted samples: the
    distances and the kernels between diagrams.

    ``fit`` stores the samples (``diagrams_``), ``transform(X)`` returns the
    ``(len(X), n_fitted)`` matrix to them, ``fit_transform(X)`` the symmetric matrix of
    ``X``, each unordered pair computed once. The output's columns are named after the
    fitted samples, ``<class name>0``, ``<class name>1``... Subclasses define
    ``_fit(X)`` (store the samples; return the symmetric matrix if fitting computed it,
    else None), ``_validate(X)`` and ``_matrix(left, right)`` (``right=None``: the
    symmetric matrix of ``left``).
    """

    def _output(self, samples):
        return self._matrix(samples, self.diagrams_)

    def _fit_output(self, matrix):
        return self._matrix(self.diagrams_, None) if matrix is None else matrix

    @property
    def _n_features_out(self) -> int:
        return len(self.diagrams_)
