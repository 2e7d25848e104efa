"""Matrices between collections of diagrams: the one scheduler of blocks of pairs
(:func:`pair_matrix`, behind the distances and the kernels), the distance matrix, the
plans that put the matrices of several distances in one parallel call
(:func:`run_plans`), and the base of the transformers that return a matrix to their
fitted samples."""

from __future__ import annotations

from functools import partial
from math import comb
from numbers import Integral, Real

import numpy as np
from joblib import delayed, effective_n_jobs
from sklearn.base import ClassNamePrefixFeaturesOutMixin

from .._param_validation import N_JOBS, Interval, Options, validate_params
from .._progress import broadcast, parallel, track
from ._assignment import precedes
from ._batch import SLICED, pack, pack_sliced, pair_distances
from .distances import MAX_DIRECTIONS, METRICS, kernel_metric
from .estimator import DiagramTransformer
from .validation import Packed, pack_samples

__all__ = [
    "SLICED",
    "MatrixPlan",
    "PairRequest",
    "PairwiseTransformer",
    "as_packed",
    "distance_matrices",
    "distance_matrix",
    "distance_requests",
    "distance_stack",
    "fit_transform_plan",
    "pack_for_metric",
    "pair_distances",
    "pair_matrices",
    "pair_matrix",
    "pairwise_diagram_distances",
    "precedes",
    "run_plans",
    "sample_sizes",
    "transform_plan",
]


def as_packed(samples) -> Packed:
    """Validated samples (a :class:`Packed`, or tuples of diagrams) as a :class:`Packed`."""
    return samples if isinstance(samples, Packed) else Packed.from_checked(samples)


# Pairs per task at most: bounds the index arrays and results in flight (about 24 MB).
_MAX_TASK_PAIRS = 1_000_000
# Guided blocks: each block costs about the work not yet cut over this many times the
# workers, so the first blocks are large and the last ones small, and a call ends
# without a worker waiting long for another's block.
_GUIDED = 4
# The estimated cost of a pair of diagrams of a and b points is
# ``_PAIR_COST + (a + b) ** degree``: degree 2 for the optimal matchings (bottleneck,
# Wasserstein), 1 for the sliced Wasserstein distance. Only the blocks' boundaries and
# order depend on it, never a value.
_PAIR_COST = 80.0
# A block costs at least about this many pairs of small diagrams (some milliseconds of
# work): below, sending the task would cost more than computing it.
_MIN_TASK_COST = 10_000 * _PAIR_COST


def sample_sizes(packed: Packed) -> np.ndarray:
    """The points of each diagram of each sample, ``(n_samples, n_diagrams)``: what
    :class:`PairRequest` estimates the cost of a pair from."""
    return np.diff(packed.offsets).reshape(len(packed), packed.n_diagrams)


class PairRequest:
    """One ``(n, m)`` matrix of ``function(left, right, rows, cols)`` (the values of the
    pairs ``(rows[k], cols[k])``) for :func:`pair_matrices`.

    ``left`` and ``right`` are whatever ``function`` reads (packed samples); with
    ``right=None`` the matrix is symmetric (``m == n``), each unordered pair computed
    once and mirrored, and its diagonal is ``diagonal``, or computed if it is None.
    ``out`` receives the matrix (a new ``dtype`` array if None). ``sizes`` are the
    points of each diagram of the left and right samples (:func:`sample_sizes`; right
    None when symmetric), from which the cost of a pair is estimated as
    ``_PAIR_COST + (a + b) ** degree`` summed over the diagram positions; without them
    every pair costs the same.
    """

    def __init__(
        self,
        function,
        left,
        right,
        n,
        m,
        *,
        dtype=np.float64,
        out=None,
        diagonal=0.0,
        sizes=None,
        degree=2,
    ):
        self.function, self.left, self.right = function, left, right
        self.n, self.m = n, m
        self.symmetric = right is None
        self.first = 0 if self.symmetric and diagonal is None else 1
        self.diagonal = diagonal
        self.matrix = np.zeros((n, m), dtype=dtype) if out is None else out
        if sizes is None:
            sizes = (np.zeros((n, 1)), None if self.symmetric else np.zeros((m, 1)))
        self.row_costs = _row_costs(*sizes, self.first, degree)
        self.cost = float(self.row_costs.sum())
        if self.symmetric:
            self.row_pairs = np.arange(n - self.first, -self.first, -1)
        else:
            self.row_pairs = np.full(n, m)

    def write(self, a, b, values):
        """Store the values of the block of rows ``a:b``; a finite value that the
        matrix's dtype cannot hold (float32 past 3.4e38) is refused, naming its row."""
        matrix, n, m = self.matrix, self.n, self.m
        if matrix.dtype != values.dtype:
            with np.errstate(over="ignore"):
                lost = np.isinf(values.astype(matrix.dtype)) & np.isfinite(values)
            if lost.any():
                self._refuse(a, b, int(np.flatnonzero(lost)[0]))
        if self.symmetric:
            first, position = self.first, 0
            for i in range(a, b):
                row = values[position : position + n - i - first]
                matrix[i, i + first :] = row
                matrix[i + first :, i] = row
                position += n - i - first
        else:
            matrix[a:b] = values.reshape(b - a, m)

    def _refuse(self, a, b, position):
        if self.symmetric:  # rows a, a + 1... hold n - a - first, n - a - 1 - first... values
            ends = np.cumsum(self.n - np.arange(a, b) - self.first)
            k = int(np.searchsorted(ends, position, side="right"))
            row = a + k
            column = row + self.first + position - (int(ends[k - 1]) if k else 0)
            pair = f"samples {row} and {column}"
        else:
            row, column = a + position // self.m, position % self.m
            pair = f"sample {row} and fitted sample {column}"
        raise ValueError(
            f"{pair}: their distance overflows {self.matrix.dtype.name}; rescale the "
            "diagrams, or use dtype='float64'"
        )

    def finish(self):
        if self.symmetric and self.diagonal is not None:
            self.matrix[np.arange(self.n), np.arange(self.n)] = self.diagonal
        return self.matrix


def _row_costs(left_sizes, right_sizes, first, degree):
    """The estimated cost of the pairs of each row: ``sum_j sum_p _PAIR_COST + (a_ip +
    b_jp) ** degree`` over the row's columns ``j`` (when symmetric, from ``i + first``
    on) and the diagram positions ``p``."""
    symmetric = right_sizes is None
    a = np.asarray(left_sizes, dtype=float)
    b = a if symmetric else np.asarray(right_sizes, dtype=float)
    n = len(a)
    total = np.zeros(a.shape)
    for k in range(degree + 1):
        power = b**k
        if symmetric:  # sums over the columns from i + first on
            suffix = np.concatenate([np.cumsum(power[::-1], axis=0)[::-1], np.zeros_like(a[:1])])
            sums = suffix[np.minimum(np.arange(n) + first, n)]
        else:
            sums = power.sum(axis=0)
        total = total + comb(degree, k) * a ** (degree - k) * sums
        if k == 0:
            total = total + _PAIR_COST * sums
    return total.sum(axis=1)


def _guided_blocks(requests, workers):
    """``(request, start, stop, estimated cost)`` of consecutive blocks of rows of every
    request, the costliest first: each of about the cost not yet cut over ``_GUIDED *
    workers`` (none much under ``_MIN_TASK_COST``, a remainder under half a block
    joined to the block before), every request in one block with one worker; at most
    ``_MAX_TASK_PAIRS`` pairs each, or one row."""
    remaining = sum(r.cost for r in requests)
    tasks = []
    for r in sorted(requests, key=lambda r: -r.cost):
        cost = np.concatenate([[0.0], np.cumsum(r.row_costs)])
        pairs = np.concatenate([[0], np.cumsum(r.row_pairs)])
        a = 0
        while a < r.n:
            size = np.inf if workers == 1 else max(remaining / (_GUIDED * workers), _MIN_TASK_COST)
            b = min(int(np.searchsorted(cost, cost[a] + size)), r.n)
            if cost[-1] - cost[b] < size / 2:
                b = r.n
            fits = int(np.searchsorted(pairs, pairs[a] + _MAX_TASK_PAIRS, side="right")) - 1
            b = max(a + 1, min(b, fits))
            tasks.append((r, a, b, cost[b] - cost[a]))
            remaining -= cost[b] - cost[a]
            a = b
    tasks.sort(key=lambda task: -task[3])  # stable: ties keep their order
    return tasks


class _Shared:
    """What the blocks of one matrix read (packed samples: a tuple of arrays), in one
    object: :func:`broadcast` sends it to every worker of a dask cluster at once (a
    tuple would be scattered item by item), and should that not happen, joblib's dask
    backend still scatters it once per call (it scatters the arguments that are weakly
    referable and larger than a kilobyte by ``sizeof``, which a tuple is not)."""

    def __init__(self, value):
        self.value = value
        self.nbytes = sum(getattr(array, "nbytes", 0) for array in value)

    def __sizeof__(self) -> int:
        return object.__sizeof__(self) + self.nbytes


def _block(function, left, right, start, stop, n_cols, first):
    """``function`` on the pairs of rows ``start:stop``: with every column of ``right``,
    or when ``right`` is None (symmetric) with the columns from ``i + first`` on
    (``first`` 0: with the diagonal)."""
    if right is None:
        left = right = left.value
        rows = np.concatenate([np.full(n_cols - i - first, i) for i in range(start, stop)])
        cols = np.concatenate([np.arange(i + first, n_cols) for i in range(start, stop)])
    else:
        left, right = left.value, right.value
        rows, cols = np.divmod(np.arange(start * n_cols, stop * n_cols), n_cols)
    return function(left, right, rows, cols)


@validate_params(
    {
        "metric": [Options(METRICS)],
        "order": [Interval(Real, 1, None, closed="left")],
        "internal_p": [Interval(Real, 1, None, closed="left")],
        "n_jobs": N_JOBS,
        "verbose": [Interval(Integral, 0, None, closed="left")],
        "n_directions": [Interval(Integral, 1, MAX_DIRECTIONS, closed="both")],
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
    Rows are split into blocks of about equal estimated work (from the diagrams'
    sizes), several per worker and at most a million pairs each, every block one
    compiled loop, the costliest first (with ``per_diagram``, the blocks of every
    position in one parallel call); the pair indices are made inside the workers, so
    memory stays bounded whatever the number of samples.

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
    return distance_matrices(
        [(left, right)],
        metric,
        order,
        internal_p,
        n_jobs,
        dtype,
        None if out is None else [out],
        verbose=verbose,
        n_directions=n_directions,
    )[0]


def distance_matrices(
    sides, metric, order, internal_p, n_jobs, dtype, out=None, verbose=0, n_directions=10
) -> list:
    """The distance matrix of each ``(left, right)`` of ``sides`` (validated samples;
    ``right=None``: the symmetric matrix of ``left``), all in one parallel call
    (:func:`pair_matrices`); ``out``: None or one array per matrix."""
    requests = distance_requests(sides, metric, order, internal_p, dtype, out, n_directions)
    return pair_matrices(requests, n_jobs=n_jobs, verbose=verbose)


def distance_requests(
    sides, metric, order, internal_p, dtype, out=None, n_directions=10
) -> list[PairRequest]:
    """The :class:`PairRequest` of the distance matrix of each ``(left, right)`` of
    ``sides``, as :func:`distance_matrices` computes them."""
    code, order = kernel_metric(metric, order, internal_p)
    requests = []
    for k, (left, right) in enumerate(sides):
        left = as_packed(left)
        right = None if right is None else as_packed(right)
        function = partial(
            pair_distances,
            n_parts=left.n_diagrams,
            metric=code,
            order=order,
            internal_p=float(internal_p),
        )
        requests.append(
            PairRequest(
                function,
                pack_for_metric(left, code, n_directions),
                None if right is None else pack_for_metric(right, code, n_directions),
                len(left),
                len(left if right is None else right),
                dtype=dtype,
                out=None if out is None else out[k],
                sizes=(sample_sizes(left), None if right is None else sample_sizes(right)),
                degree=1 if code == SLICED else 2,
            )
        )
    return requests


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
    ``left`` again, each unordered pair computed once); every position in one parallel
    call."""
    left = as_packed(left)
    right = None if right is None else as_packed(right)
    n, m = len(left), len(left if right is None else right)
    stack = np.empty((n, m, left.n_diagrams), dtype=dtype) if out is None else out
    positions = range(left.n_diagrams)
    distance_matrices(
        [(left.only(k), None if right is None else right.only(k)) for k in positions],
        metric,
        order,
        internal_p,
        n_jobs,
        dtype,
        [stack[:, :, k] for k in positions],
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
    """The ``(n, m)`` matrix of ``function(left, right, rows, cols)``: one
    :class:`PairRequest` (see there) given to :func:`pair_matrices`."""
    request = PairRequest(function, left, right, n, m, dtype=dtype, out=out, diagonal=diagonal)
    return pair_matrices([request], n_jobs=n_jobs, verbose=verbose, desc=desc)[0]


def pair_matrices(requests, *, n_jobs=None, verbose=0, desc="distances") -> list:
    """The matrices of several :class:`PairRequest`, over blocks of rows, all in one
    parallel call.

    Every matrix is cut into consecutive row blocks by estimated cost, in guided
    sizes: each block about the work not yet cut over ``_GUIDED`` times the workers
    (a cheap matrix is one block; none much cheaper than ``_MIN_TASK_COST``), of at
    most a million pairs each; the blocks go costliest first, so the call ends on
    small ones and no worker waits long for another's. The samples the blocks read are
    sent to every worker of a dask cluster once per call. With one worker
    (``n_jobs=1``, under any backend) the blocks run here, one after the other. Each
    value is computed alone, so the matrices do not depend on the blocks: neither on
    ``n_jobs`` nor on the backend.
    """
    workers = effective_n_jobs(n_jobs)
    tasks = _guided_blocks(requests, workers)
    sides = {}
    for r in requests:
        sides[id(r)] = (_Shared(r.left), None if r.symmetric else _Shared(r.right))
    local = workers == 1 or len(tasks) <= 1
    scattered = False
    if not local:  # sent once to every worker of a dask cluster, themselves elsewhere
        held = [side for pair in sides.values() for side in pair if side is not None]
        shipped = broadcast(held)
        scattered = any(s is not h for s, h in zip(shipped, held, strict=True))
        sent = dict(zip(map(id, held), shipped, strict=True))
        sides = {k: tuple(sent.get(id(side)) for side in pair) for k, pair in sides.items()}
    run = _block if local else delayed(_block)
    calls = (run(r.function, *sides[id(r)], a, b, r.m, r.first) for r, a, b, _ in tasks)
    # Tasks that carry only futures all go to the dask scheduler at once, which gives
    # each to the first worker free: with joblib's two tasks in flight per worker, it
    # placed them unevenly and the workers waited between them.
    dispatch = "all" if scattered else "2 * n_jobs"
    blocks = calls if local else parallel(n_jobs, batch_size=1, pre_dispatch=dispatch)(calls)
    for (r, a, b, _), values in zip(
        tasks, track(blocks, total=len(tasks), desc=desc, verbose=verbose), strict=True
    ):
        r.write(a, b, values)
    return [r.finish() for r in requests]


class MatrixPlan:
    """An output made of matrices between diagrams, before they are computed: the
    :class:`PairRequest` of each matrix, and ``finish(matrices)``, which makes the output
    of them (in the requests' order). :func:`run_plans` computes the matrices of several
    plans in one parallel call: one wait for the last block instead of one per plan.
    ``n_jobs`` and ``verbose`` are those of the estimator that made the plan."""

    def __init__(self, requests=(), finish=None, *, n_jobs=None, verbose=0):
        self.requests = list(requests)
        self.finish = finish
        self.n_jobs, self.verbose = n_jobs, verbose

    @classmethod
    def ready(cls, output):
        """The plan of an output already computed."""
        return cls(finish=lambda _: output)


def run_plans(plans) -> list:
    """The output of each plan: the matrices of all the plans of one ``n_jobs`` in one
    call of :func:`pair_matrices` (the blocks of every matrix of every plan, the
    costliest first), then each plan's ``finish`` on its own. The values do not depend
    on which plans run together."""
    groups = {}
    for plan in plans:
        if plan.requests:
            groups.setdefault(plan.n_jobs, []).append(plan)
    matrices = {}
    for n_jobs, group in groups.items():
        requests = [r for plan in group for r in plan.requests]
        verbose = max(plan.verbose for plan in group)
        computed = iter(pair_matrices(requests, n_jobs=n_jobs, verbose=verbose))
        for plan in group:
            matrices[id(plan)] = [next(computed) for _ in plan.requests]
    return [plan.finish(matrices.get(id(plan), [])) for plan in plans]


def fit_transform_plan(estimator, X) -> MatrixPlan:
    """``estimator.fit_transform(X)`` as a :class:`MatrixPlan`: a
    :class:`PairwiseTransformer` is fitted now and leaves its matrices to the plan
    (:class:`DiagramDistance` does; the kernels compute theirs now), any other
    transformer computes its output now."""
    if isinstance(estimator, PairwiseTransformer):
        return estimator._fit_transform_plan(X)
    return MatrixPlan.ready(estimator.fit_transform(X))


def transform_plan(estimator, X) -> MatrixPlan:
    """``estimator.transform(X)`` as a :class:`MatrixPlan` (see
    :func:`fit_transform_plan`)."""
    if isinstance(estimator, PairwiseTransformer):
        return estimator._transform_plan(X)
    return MatrixPlan.ready(estimator.transform(X))


class PairwiseTransformer(ClassNamePrefixFeaturesOutMixin, DiagramTransformer):
    """Base of the transformers whose output is a matrix to their fitted samples: the
    distances and the kernels between diagrams.

    ``fit`` stores the samples (``diagrams_``), ``transform(X)`` returns the
    ``(len(X), n_fitted)`` matrix to them, ``fit_transform(X)`` the symmetric matrix of
    ``X``, each unordered pair computed once. The output's columns are named after the
    fitted samples, ``<class name>0``, ``<class name>1``... Subclasses define
    ``_fit(X)`` (store the samples; return the symmetric matrix if fitting computed it,
    else None), ``_validate(X)`` and ``_matrix(left, right)`` (``right=None``: the
    symmetric matrix of ``left``). Those that can leave their matrices to a
    :class:`MatrixPlan` (so that several run in one parallel call, :func:`run_plans`)
    override ``_fit_transform_plan(X)`` and ``_transform_plan(X)``, which compute the
    output now by default.
    """

    def _fit_transform_plan(self, X) -> MatrixPlan:
        return MatrixPlan.ready(self.fit_transform(X))

    def _transform_plan(self, X) -> MatrixPlan:
        return MatrixPlan.ready(self.transform(X))

    def _plan(self, requests, finish) -> MatrixPlan:
        """A plan of this estimator's ``n_jobs`` and ``verbose``."""
        return MatrixPlan(requests, finish, n_jobs=self.n_jobs, verbose=self.verbose)

    def _output(self, samples):
        return self._matrix(samples, self.diagrams_)

    def _fit_output(self, matrix):
        return self._matrix(self.diagrams_, None) if matrix is None else matrix

    @property
    def _n_features_out(self) -> int:
        return len(self.diagrams_)
