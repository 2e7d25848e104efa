"""DiagramDistance: persistence diagrams to a precomputed distance matrix."""

from __future__ import annotations

from numbers import Integral, Real

import numpy as np
from sklearn.exceptions import NotFittedError
from sklearn.utils.validation import check_is_fitted

from .._base import SampleTransformer, as_sample_list, cast_output, median_scale
from .._param_validation import N_JOBS, Interval, Options
from .distances import MAX_DIRECTIONS, METRICS, kernel_metric
from .pairwise import PairwiseTransformer, distance_requests, run_plans
from .validation import check_samples

__all__ = ["DiagramDistance"]

# The parameters that define the distance: fit learns its scales under them.
_DISTANCE_PARAMS = ("metric", "order", "internal_p", "normalization", "n_directions")


class DiagramDistance(PairwiseTransformer):
    """Bottleneck, Wasserstein or sliced Wasserstein distances to the fitted persistence
    diagrams.

    The third stage of the mesh-learning pipeline, a precomputed-metric transformer:
    ``fit`` stores diagrams, ``transform(X)`` returns the ``(len(X), n_fitted)`` matrix of
    distances to them, ready for ``KNeighborsClassifier(metric="precomputed")``, and
    ``fit_transform(X)`` the symmetric ``(n, n)`` matrix, each unordered pair computed
    once, ready for ``TSNE(metric="precomputed", init="random")``.

    Parameters
    ----------
    metric : {"bottleneck", "wasserstein", "sliced-wasserstein"}, default="bottleneck"
        Exact bottleneck distance, exact q-Wasserstein distance (an optimal assignment,
        not an approximation), or the sliced Wasserstein distance of Carrière, Cuturi &
        Oudot (2017) as gudhi computes it (:func:`sliced_wasserstein_distance`): fast,
        ``O((n + m) n_directions)`` a pair after a sort of each diagram, and at most
        ``2 sqrt(2)`` times the 1-Wasserstein distance with the L-infinity ground metric
        (``order`` and ``internal_p`` are ignored).
    order : float, default=2.0
        The Wasserstein exponent q (ignored for the bottleneck distance).
    internal_p : float, default=inf
        Ground metric between points, the L-p norm; ``inf`` (L-infinity) as in the paper.
    n_jobs : int, default=None
        Number of parallel jobs. ``None`` means 1 unless in a
        :func:`joblib.parallel_backend` context; ``-1`` means all processors. Pairs are
        split into a few batches per worker; results are identical for any ``n_jobs``
        and joblib backend.
    dtype : {"float64", "float32"}, default="float64"
        Precision of the returned matrix. Distances are computed in float64 either way;
        ``"float32"`` halves the memory of very large matrices.
    verbose : int, default=0
        With ``verbose > 0``, a progress bar over the blocks of pairs on stderr (needs
        tqdm, the ``progress`` extra); nothing is printed at 0.
    normalization : {"none", "median"}, default="none"
        How the diagrams of a tuple weigh in the combined distance. ``"none"``: as
        they are (the typed disjoint union below). ``"median"``: each position's
        distance is first divided by its median over the fitted pairs (its positive
        finite off-diagonal distances; 1 if there is none), learned by ``fit``. Use it
        when the positions are functions on different scales, such as the heat kernel
        signature at several times: the persistence of ``log HKS`` shrinks with the
        time, and without it the earliest times decide every distance. ``fit`` then
        computes the fitted samples' distances (which ``fit_transform`` returns).
    n_directions : int, default=10
        Number of lines of the sliced Wasserstein distance (ignored by the other
        metrics): the angles ``-pi/2 + k pi / (n_directions + 1)``, ``k < n_directions``,
        gudhi's ``num_directions = n_directions + 1``.

    Attributes
    ----------
    diagrams_ : list of tuple of ndarray
        The fitted samples, validated.
    n_diagrams_ : int
        Number of diagrams per sample.
    scales_ : ndarray of shape (n_diagrams,)
        The divisor of each position (all 1 with ``normalization="none"``).
    distance_params_ : dict
        The parameters that define the distance (``metric``, ``order``, ``internal_p``,
        ``normalization``, ``n_directions``) as they were at ``fit``: ``scales_`` hold
        under them only, so ``transform`` refuses with :class:`NotFittedError` once one
        of them has changed (fit again). ``n_jobs``, ``dtype`` and ``verbose`` may
        change freely.

    See Also
    --------
    bottleneck_distance, wasserstein_distance : The distance between two diagrams.
    sliced_wasserstein_distance : Its approximation by projections on lines.
    LowerStarPersistence : The previous stage.

    Notes
    -----
    A sample is one ``(n, 2)`` diagram or a tuple of them (as produced by
    :class:`LowerStarPersistence`); tuples are compared position by position, as the
    typed disjoint union of their diagrams: the bottleneck distance is the maximum of the
    per-diagram distances, the q-Wasserstein distance the l_q norm of the per-diagram
    distances (their maximum at ``order=inf``, the bottleneck distance), the sliced
    Wasserstein distance their sum. Essential points (death ``inf``) are matched among
    themselves by sorted birth; when their numbers differ the distance is ``inf`` (else
    the sliced Wasserstein distance adds the L1 distance of their sorted births).
    gudhi's Wasserstein defaults to ``order=1`` and ``internal_p=inf``; hera's default
    ``delta`` allows a relative error; persim drops infinite points: pass matching
    settings when comparing. The output's columns are named ``diagramdistance0``,
    ``diagramdistance1``... after the fitted samples (:meth:`get_feature_names_out`,
    ``set_output(transform="pandas")``).

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_meshph import DiagramDistance
    >>> diagrams = [np.array([[0.0, 1.0]]), np.array([[0.0, 1.5]]), np.empty((0, 2))]
    >>> DiagramDistance().fit_transform(diagrams)
    array([[0.  , 0.5 , 0.5 ],
           [0.5 , 0.  , 0.75],
           [0.5 , 0.75, 0.  ]])
    """

    _sample_kind = "diagrams"
    _requires_fit = True
    _parameter_constraints: dict = {
        "metric": [Options(METRICS)],
        "order": [Interval(Real, 1, None, closed="left")],
        "internal_p": [Interval(Real, 1, None, closed="left")],
        "n_jobs": N_JOBS,
        "dtype": [Options(("float64", "float32"))],
        "verbose": [Interval(Integral, 0, None, closed="left")],
        "normalization": [Options(("none", "median"))],
        "n_directions": [Interval(Integral, 1, MAX_DIRECTIONS, closed="both")],
    }

    def __init__(
        self,
        metric="bottleneck",
        order=2.0,
        internal_p=np.inf,
        n_jobs=None,
        dtype="float64",
        verbose=0,
        normalization="none",
        n_directions=10,
    ):
        self.metric = metric
        self.order = order
        self.internal_p = internal_p
        self.n_jobs = n_jobs
        self.dtype = dtype
        self.verbose = verbose
        self.normalization = normalization
        self.n_directions = n_directions

    def _fit(self, X):
        """Fit; the fitted samples' symmetric matrix when it was computed, else None."""
        return run_plans([self._fit_plan(X)])[0]

    def _check_params(self) -> None:
        super()._check_params()
        # Settings the kernels cannot carry (order=inf with a finite internal_p), refused
        # with the others: by fit, and by the main job before any sample is loaded.
        kernel_metric(self.metric, self.order, self.internal_p)

    def _fit_plan(self, X):
        """Validate and store the samples now; what fitting computes as a plan: the
        median normalization's matrix of each position, whose finish learns the scales
        and returns the combined matrix (nothing, finishing to None, otherwise)."""
        X = as_sample_list(X, "diagrams")  # read once: X may be a generator
        SampleTransformer.fit(self, X)
        self.diagrams_ = check_samples(X)
        self.n_diagrams_ = len(self.diagrams_[0])
        self.distance_params_ = {name: getattr(self, name) for name in _DISTANCE_PARAMS}
        self.scales_ = np.ones(self.n_diagrams_)
        if self.normalization == "none":
            return self._plan([], lambda _: None)
        return self._plan(self._position_requests(self.diagrams_, None), self._learn_scales)

    def _learn_scales(self, parts):
        self.scales_ = np.array([median_scale(part) for part in parts])
        return self._combine(parts)

    def _fit_transform_plan(self, X):
        fit = self._fit_plan(X)
        return fit if fit.requests else self._matrix_plan(self.diagrams_, None)

    def _transform_plan(self, X):
        return self._matrix_plan(self._validate(X), self.diagrams_)

    def _kwargs(self, dtype=None):
        fitted = self.distance_params_
        return dict(
            metric=fitted["metric"],
            order=fitted["order"],
            internal_p=fitted["internal_p"],
            dtype=np.dtype(dtype or self.dtype),
            n_directions=fitted["n_directions"],
        )

    def _position_requests(self, left, right):
        """The requests of the float64 distance matrix of each position on its own."""
        sides = [
            ([s[k : k + 1] for s in left], None if right is None else [s[k : k + 1] for s in right])
            for k in range(self.n_diagrams_)
        ]
        return distance_requests(sides, **self._kwargs(dtype="float64"))

    def _combine(self, parts):
        """Per-position matrices divided by their scales, combined as the metric combines
        the diagrams of a tuple (maximum, l_q norm, or sum)."""
        scaled = [part / scale for part, scale in zip(parts, self.scales_, strict=True)]
        metric, q = self.distance_params_["metric"], float(self.distance_params_["order"])
        if metric == "bottleneck" or (metric == "wasserstein" and np.isinf(q)):
            total = np.maximum.reduce(scaled)
        elif metric == "sliced-wasserstein":
            total = sum(scaled)
        else:
            total = sum(part**q for part in scaled) ** (1.0 / q)
        return cast_output(total, self.dtype, "distances")

    def _matrix_plan(self, left, right):
        if self.distance_params_["normalization"] == "none":
            requests = distance_requests([(left, right)], **self._kwargs())
            return self._plan(requests, lambda matrices: matrices[0])
        return self._plan(self._position_requests(left, right), self._combine)

    def _matrix(self, left, right):
        return run_plans([self._matrix_plan(left, right)])[0]

    def _check_fitted(self) -> None:
        """Fitted, and under the distance parameters that ``scales_`` were learned with."""
        check_is_fitted(self)
        changed = [
            f"{name}={getattr(self, name)!r} (fitted with {value!r})"
            for name, value in self.distance_params_.items()
            if getattr(self, name) != value
        ]
        if changed:
            raise NotFittedError(
                "This DiagramDistance was fitted under other distance parameters: "
                f"{', '.join(changed)}; its scales hold under the fitted ones only: call "
                "fit again"
            )

    def _validate(self, X):
        self._check_fitted()
        return check_samples(X, n_diagrams=self.n_diagrams_)
