"""PerDiagramDistance: the distance matrix of each diagram position, cached, so that a
kernel made from them (:class:`DistanceKernel`) can be searched over its bandwidths
without computing the distances again."""

from __future__ import annotations

import os
from functools import partial
from numbers import Integral, Real

import numpy as np
from sklearn.utils.validation import check_is_fitted

from .._base import SampleTransformer, as_sample_list
from .._param_validation import N_JOBS, HasMethods, Interval, Options
from .._version import VERSION
from .distances import MAX_DIRECTIONS, METRICS, kernel_metric
from .estimator import DiagramTransformer
from .pairwise import as_packed, distance_stack
from .stack_cache import StackCache, stack_cache_of
from .validation import pack_samples

__all__ = ["PerDiagramDistance"]


class PerDiagramDistance(DiagramTransformer):
    """The distance matrix of each diagram position to the fitted samples, stacked:
    the first stage of a kernel whose bandwidths are searched.

    ``fit`` stores the samples, ``transform(X)`` returns the ``(len(X), n_fitted,
    n_diagrams)`` array whose ``[i, j, k]`` is the distance between diagram ``k`` of
    ``X[i]`` and of the fitted sample ``j``, and ``fit_transform(X)`` the symmetric
    stack of ``X``, each unordered pair computed once. :class:`DistanceKernel` turns it
    into a kernel (a bandwidth per position, a sum or a product of the positions'
    kernels); :class:`DiagramDistance` gives the positions' combined distance instead.

    Parameters
    ----------
    metric : {"sliced-wasserstein", "bottleneck", "wasserstein"}, default="sliced-wasserstein"
        As :class:`DiagramDistance`'s; the default is the distance of the sliced
        Wasserstein kernel, ``exp(-SW / (2 sigma^2))``.
    order : float, default=2.0
        The Wasserstein exponent q (``metric="wasserstein"`` only).
    internal_p : float, default=inf
        Ground metric between points, the L-p norm (bottleneck and Wasserstein).
    n_directions : int, default=10
        Number of lines of the sliced Wasserstein distance (ignored by the others).
    memory : str, path, joblib.Memory or None, default=None
        Where to cache the stacks that ``fit_transform`` and ``transform`` compute,
        keyed by the diagrams of both sides, the distance parameters and the package's
        version. A grid search over the parameters of the later stages (the kernel's
        bandwidths, the classifier's ``C``) then computes each fold's distances once,
        its training stack at the first candidate and its test stack at the first
        score, instead of once per candidate (a pipeline's own ``memory`` caches
        ``fit_transform`` only). A folder, or a ``joblib.Memory``'s location, holds
        each stack as one ``.npy`` file in its ``sklearn_meshph_distances`` folder
        (data only, checked on read; see :mod:`sklearn_meshph.diagrams.stack_cache`);
        another object with a ``cache`` method is used as joblib's would be.
        ``None``: no caching.
    n_jobs : int, default=None
        Number of parallel jobs (joblib). ``None`` means 1 unless in a
        :func:`joblib.parallel_backend` context; ``-1`` means all processors. Results
        are identical for any ``n_jobs`` (which is not part of the cache key).
    dtype : {"float64", "float32"}, default="float64"
        Of the returned stack (distances are computed in float64); ``"float32"`` halves
        the memory of large stacks.

    Attributes
    ----------
    diagrams_ : list of tuple of ndarray
        The fitted samples, validated.
    n_diagrams_ : int
        Number of diagrams per sample.

    See Also
    --------
    DistanceKernel : The kernel of the stacks, with a bandwidth per position.
    DiagramDistance : The combined distance of the positions.
    pairwise_diagram_distances : The same stack with ``per_diagram=True``.

    Notes
    -----
    The output is a 3-d array, not a table: it has no feature names, and it passes
    through ``set_output(transform="pandas")`` as it is. Each pair's distance does not
    depend on the blocks it is computed in, so ``transform`` of the fitted samples
    equals ``fit_transform`` bit for bit, and a precomputed stack of all the samples
    (:func:`pairwise_diagram_distances` with ``per_diagram=True``), sliced by a
    cross-validation, holds the same values as the folds' stacks.

    Examples
    --------
    A grid search over the bandwidth of a sum of sliced Wasserstein kernels, one per
    diagram position, computing the distances of each fold once:

    >>> import numpy as np
    >>> from sklearn.model_selection import GridSearchCV
    >>> from sklearn.pipeline import make_pipeline
    >>> from sklearn.svm import SVC
    >>> from sklearn_meshph import DistanceKernel, PerDiagramDistance
    >>> rng = np.random.default_rng(0)
    >>> def sample(label):
    ...     births = rng.random(4)
    ...     return tuple(np.column_stack([births, births + 0.1 + label * k]) for k in (1, 2))
    >>> X, y = [sample(i % 2) for i in range(12)], np.arange(12) % 2
    >>> model = make_pipeline(
    ...     PerDiagramDistance(memory=None),  # a folder caches the distances
    ...     DistanceKernel(combine="sum"),
    ...     SVC(kernel="precomputed"),
    ... )
    >>> search = GridSearchCV(model, {"distancekernel__bandwidth": [0.5, 1.0]}, cv=3)
    >>> search.fit(X, y).best_score_
    np.float64(1.0)
    """

    _parameter_constraints: dict = {
        "metric": [Options(METRICS)],
        "order": [Interval(Real, 1, None, closed="left")],
        "internal_p": [Interval(Real, 1, None, closed="left")],
        "n_directions": [Interval(Integral, 1, MAX_DIRECTIONS, closed="both")],
        "memory": [None, str, os.PathLike, HasMethods(["cache"])],
        "n_jobs": N_JOBS,
        "dtype": [Options(("float64", "float32"))],
    }

    def __init__(
        self,
        metric="sliced-wasserstein",
        order=2.0,
        internal_p=np.inf,
        n_directions=10,
        memory=None,
        n_jobs=None,
        dtype="float64",
    ):
        self.metric = metric
        self.order = order
        self.internal_p = internal_p
        self.n_directions = n_directions
        self.memory = memory
        self.n_jobs = n_jobs
        self.dtype = dtype

    def _check_params(self) -> None:
        super()._check_params()
        kernel_metric(self.metric, self.order, self.internal_p)  # refused now, not later

    def _fit(self, X):
        X = as_sample_list(X, "diagrams")  # read once: X may be a generator
        SampleTransformer.fit(self, X)
        packed = pack_samples(X)
        self.diagrams_ = packed.samples()
        self.n_diagrams_ = packed.n_diagrams
        return packed

    def _fit_output(self, packed):
        return self._stack(packed, None)

    def _validate(self, X):
        check_is_fitted(self, "n_diagrams_")
        self._check_params()
        return pack_samples(X, n_diagrams=self.n_diagrams_)

    def _output(self, packed):
        return self._stack(packed, as_packed(self.diagrams_))

    def _stack(self, left, right):
        settings = {
            "metric": self.metric,
            "order": float(self.order),
            "internal_p": float(self.internal_p),
            "n_directions": int(self.n_directions),
            "dtype": np.dtype(self.dtype),
        }
        args = (left, right, *settings.values())
        cache = stack_cache_of(self.memory)
        if cache is None:
            return distance_stack(*args, n_jobs=self.n_jobs)
        if not isinstance(cache, StackCache):  # the user's own caching object
            return cache.cache(_stack, ignore=["n_jobs"])(VERSION, *args, n_jobs=self.n_jobs)
        sides = (left,) if right is None else (left, right)
        key = cache.key(
            [array for side in sides for array in (side.points, side.offsets)],
            {**settings, "n_diagrams": left.n_diagrams, "symmetric": right is None},
        )
        shape = (len(left), len(sides[-1]), left.n_diagrams)
        compute = partial(distance_stack, *args, n_jobs=self.n_jobs)
        return cache.stack(key, shape, settings["dtype"], compute)


def _stack(version, left, right, *args, n_jobs=None):
    """:func:`distance_stack`, with the package's ``version`` in the key of the user's
    caching object: a stack cached by another release is computed again."""
    return distance_stack(left, right, *args, n_jobs=n_jobs)
