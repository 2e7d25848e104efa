"""Precomputed distances beyond diagrams: between feature vectors such as Shape-DNA, and
weighted combinations of several distance matrices."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from numbers import Real

import numpy as np
from scipy.sparse import issparse
from sklearn.base import BaseEstimator, ClassNamePrefixFeaturesOutMixin, TransformerMixin, clone
from sklearn.pipeline import Pipeline
from sklearn.utils import get_tags
from sklearn.utils.validation import check_is_fitted, validate_data

from ._base import median_scale
from ._feature_distances import check_metric, feature_distances
from ._param_validation import N_JOBS, Interval, Options, check_params
from .diagrams.pairwise import PairwiseTransformer, fit_transform_plan, run_plans, transform_plan
from .persistence import LowerStarPersistence

__all__ = ["CombinedDistance", "FeatureDistance"]

NORMALIZATIONS = ("median", "none")
_NON_NEGATIVE = Interval(Real, 0, None, closed="left")


def _reusable(X):
    """``X`` itself when it can be read several times (arrays, sparse matrices, lists...),
    else an array of it (an array-like) or a list of it (a generator or another one-shot
    iterator)."""
    if issparse(X):
        return X  # the parts accept it or refuse it by name
    if isinstance(X, Mapping):
        raise TypeError(f"X must be a sequence of samples, got a {type(X).__name__}")
    if hasattr(X, "__len__") and hasattr(X, "__getitem__"):
        return X
    return np.asarray(X) if hasattr(X, "__array__") else list(X)


def _plain(part) -> bool:
    """Whether ``part`` is a :class:`~sklearn.pipeline.Pipeline` whose steps may run
    apart (no memory, verbose or transform_input)."""
    plain = isinstance(part, Pipeline) and part.memory is None and not part.verbose
    return plain and getattr(part, "transform_input", None) is None


def _part_plan(part, X, fit: bool, first: int = 0):
    """``part.fit_transform(X)`` (``fit``) or ``part.transform(X)`` as a
    :class:`~sklearn_meshph.diagrams.pairwise.MatrixPlan`: the matrices of a diagram
    distance, alone or ending a :class:`~sklearn.pipeline.Pipeline` (without memory,
    verbose or transform_input, whose steps before it run now, fitted in place, from
    the ``first``: ``X`` is the output of those before), are left to the plan; any
    other part computes its output now."""
    step = part
    if _plain(part):
        step = part.steps[-1][1]
        if not isinstance(step, PairwiseTransformer):
            step = part
        else:  # the steps before it, as the pipeline runs them (a slice of it would
            # be a new Pipeline, not fitted in the eyes of check_is_fitted)
            for _, head in part.steps[first:-1]:
                if head is not None and head != "passthrough":
                    X = head.fit_transform(X) if fit else head.transform(X)
    return fit_transform_plan(step, X) if fit else transform_plan(step, X)


def _persistence_settings(part):
    """The settings, all but ``parts``, of the :class:`LowerStarPersistence` that starts
    ``part`` when its diagrams may come from a persistence shared with other parts (a
    plain Pipeline ending with a diagram distance); else None."""
    if not (_plain(part) and len(part.steps) > 1):
        return None
    first, last = part.steps[0][1], part.steps[-1][1]
    if type(first) is not LowerStarPersistence or not isinstance(last, PairwiseTransformer):
        return None
    return {k: v for k, v in first.get_params(deep=False).items() if k != "parts"}


def _persistence_groups(parts) -> list[list[int]]:
    """The positions of the parts that start with a :class:`LowerStarPersistence` of
    equal settings but ``parts``, per settings, where at least two share them."""
    groups: list[tuple[dict, list[int]]] = []
    for position, part in enumerate(parts):
        settings = _persistence_settings(part)
        if settings is None:
            continue
        group = next((g for s, g in groups if s == settings), None)
        if group is None:
            groups.append((settings, [position]))
        else:
            group.append(position)
    return [group for _, group in groups if len(group) > 1]


def _split(diagrams, positions, n_kept):
    """One part's diagrams of a sample out of those of the union of the parts' kinds
    (``n_kept`` per function, function-major): the union's ``positions`` of each
    function, one array alone or a tuple, as its own persistence makes them."""
    union = diagrams if isinstance(diagrams, tuple) else (diagrams,)
    own = [union[f + k] for f in range(0, len(union), n_kept) for k in positions]
    return own[0] if len(own) == 1 else tuple(own)


def _shared_diagrams(steps, X, fit: bool) -> list:
    """The output of each :class:`LowerStarPersistence` of ``steps`` (equal settings
    but ``parts``) on ``X``, from one persistence of the union of their diagrams: each
    function's diagrams are computed once for all (``fit``: each step is fitted on
    ``X`` first, as its own ``fit_transform`` would, and refuses its own ``parts``)."""
    if fit:
        for step in steps:
            step.fit(X)
    names = [step.diagram_names() for step in steps]
    union = clone(steps[0]).set_params(parts=None)
    union_names = [name for name in union.diagram_names() if any(name in n for n in names)]
    diagrams = union.set_params(parts=tuple(union_names)).transform(X)
    return [
        [
            _split(sample, [union_names.index(name) for name in own], len(union_names))
            for sample in diagrams
        ]
        for own in names
    ]


def _plans(parts, X, fit: bool) -> list:
    """The :class:`~sklearn_meshph.diagrams.pairwise.MatrixPlan` of every part on
    ``X``: those that start with a :class:`LowerStarPersistence` of equal settings but
    ``parts`` run one persistence for all of them, then their steps after it."""
    outputs = {}
    for group in _persistence_groups(parts):
        steps = [parts[position].steps[0][1] for position in group]
        outputs.update(zip(group, _shared_diagrams(steps, X, fit), strict=True))
    return [
        _part_plan(part, outputs[position], fit, first=1)
        if position in outputs
        else _part_plan(part, X, fit)
        for position, part in enumerate(parts)
    ]


class FeatureDistance(ClassNamePrefixFeaturesOutMixin, TransformerMixin, BaseEstimator):
    """Distances between feature vectors, as a precomputed-metric stage.

    The vector counterpart of :class:`DiagramDistance`: ``fit`` stores the rows of
    ``X``, ``transform(X)`` returns the ``(len(X), n_fitted)`` distances to them, ready
    for ``KNeighborsClassifier(metric="precomputed")`` or
    ``TSNE(metric="precomputed", init="random")``.

    Parameters
    ----------
    metric : str or callable, default="canberra"
        Any metric of :func:`sklearn.metrics.pairwise_distances`. The default,
        ``sum_k |a_k - b_k| / (|a_k| + |b_k|)``, compares Shape-DNA spectra by their
        differences relative to their sum: each eigenvalue counts for its relative
        change, not its size, so the many large eigenvalues do not drown the first.
    n_jobs : int, default=None
        ``None`` means 1 unless in a :func:`joblib.parallel_backend` context; ``-1``
        means all processors.

    Attributes
    ----------
    features_ : ndarray of shape (n_fitted, n_features)
        The fitted rows.
    n_features_in_ : int
    feature_names_in_ : ndarray of str
        The columns of a fitted DataFrame (only when fitted on one).

    See Also
    --------
    ShapeDNA : Spectra as feature vectors.
    DiagramDistance : Distances between persistence diagrams.

    Notes
    -----
    The output's columns are named ``featuredistance0``, ``featuredistance1``... after
    the fitted rows (:meth:`get_feature_names_out`, ``set_output(transform="pandas")``).

    Examples
    --------
    >>> from sklearn_meshph import FeatureDistance
    >>> FeatureDistance().fit_transform([[1.0, 2.0], [3.0, 2.0]])
    array([[0. , 0.5],
           [0.5, 0. ]])
    """

    _parameter_constraints: dict = {"metric": [str, callable], "n_jobs": N_JOBS}

    def __init__(self, metric="canberra", n_jobs=None):
        self.metric = metric
        self.n_jobs = n_jobs

    def fit(self, X, y=None):
        """Store the rows to measure distances to.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
        y : ignored

        Returns
        -------
        self
        """
        self._check_params()
        self.features_ = validate_data(self, X, dtype=np.float64)
        return self

    def _check_params(self) -> None:
        check_params(self._parameter_constraints, self.get_params(deep=False), "FeatureDistance")
        check_metric(self.metric, "FeatureDistance")

    def transform(self, X):
        """Distances from each row of ``X`` to each fitted row.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)

        Returns
        -------
        ndarray of shape (n_samples, n_fitted)
        """
        check_is_fitted(self)
        X = validate_data(self, X, dtype=np.float64, reset=False)
        with np.errstate(over="ignore", invalid="ignore"):
            distances = feature_distances(X, self.features_, self.metric, self.n_jobs)
        bad = ~np.isfinite(distances)
        if bad.any():
            i, j = np.argwhere(bad)[0]
            what = "NaN" if np.isnan(distances[i, j]) else "beyond float64"
            raise ValueError(
                f"sample {i}: its {self.metric} distance to fitted sample {j} is {what} "
                "(features constant or too large for that metric)"
            )
        return distances

    @property
    def _n_features_out(self):
        """The number of output columns: one per fitted row."""
        return len(self.features_)


class _Weights:
    """Constraint of ``CombinedDistance.weights``: finite non-negative numbers, by name
    or one per part."""

    def __call__(self, value) -> bool:
        if isinstance(value, Mapping):
            if not all(isinstance(name, str) for name in value):
                return False
            values = list(value.values())
        elif isinstance(value, Sequence | np.ndarray) and not isinstance(value, str):
            values = list(np.ravel(value)) if isinstance(value, np.ndarray) else list(value)
        else:
            return False
        return all(_NON_NEGATIVE(w) and math.isfinite(w) for w in values)

    def __str__(self) -> str:
        return (
            "a dict of part names to finite non-negative numbers, or a sequence of them "
            "(one per part)"
        )


class _NamedParts:
    """Constraint of ``CombinedDistance.transformer_list``."""

    @staticmethod
    def is_list_of_pairs(value) -> bool:
        return isinstance(value, list | tuple) and all(
            isinstance(pair, tuple | list) and len(pair) == 2 for pair in value
        )

    def __call__(self, value) -> bool:
        if not self.is_list_of_pairs(value) or not value:
            return False
        names = [name for name, _ in value]
        return (
            all(isinstance(name, str) and name and "__" not in name for name in names)
            and len(set(names)) == len(names)
            and all(
                hasattr(part, "fit_transform") and hasattr(part, "transform") for _, part in value
            )
        )

    def __str__(self) -> str:
        return "a non-empty list of (name, transformer) pairs with distinct names without '__'"


def _named(transformer_list) -> list:
    """The (name, part) pairs of ``transformer_list``; none when it is not a list of
    pairs (``fit`` refuses it by name; ``get_params`` must not fail before)."""
    if _NamedParts.is_list_of_pairs(transformer_list):
        return list(transformer_list)
    return []


class CombinedDistance(ClassNamePrefixFeaturesOutMixin, TransformerMixin, BaseEstimator):
    """A weighted sum of the distance matrices of several parts, each normalized.

    Each part is a transformer (usually a :class:`~sklearn.pipeline.Pipeline`) that maps
    the same samples to a precomputed distance matrix: for example the diagrams of
    :class:`LowerStarPersistence` into :class:`DiagramDistance`, and :class:`ShapeDNA`
    into :class:`FeatureDistance`, both after one :class:`LaplacianEigenTransformer`
    (one eigensolve per mesh serves all parts). Like :class:`~sklearn.pipeline.FeatureUnion`,
    but the parts' outputs are added, not concatenated, so the result is again a
    distance matrix for ``KNeighborsClassifier(metric="precomputed")`` or
    ``TSNE(metric="precomputed", init="random")``.

    Parameters
    ----------
    transformer_list : list of (str, transformer)
        The named parts. Their parameters are reachable as ``<name>__<parameter>``, for
        ``set_params`` and grid searches.
    weights : dict of str to float, sequence of float or None, default=None
        Weight of each part, finite and non-negative: by name (missing parts weigh 1;
        a name that is not a part's is refused by ``fit``), or one per part in the
        order of ``transformer_list``. ``None``: all 1. A part of weight 0 is left
        out: neither fitted nor computed (its infinite distances, and whatever it
        would refuse, with it), its scale 1; the weights are those of ``fit``, so a
        weight set after ``fit`` is ignored until the next one, like every parameter.
    normalization : {"median", "none"}, default="median"
        ``"median"`` divides each part by the median of its positive finite
        off-diagonal distances on the fitted samples, learned by ``fit``: parts measured
        in different units (a bottleneck distance of unit-area eigenfunctions, a sum of
        relative eigenvalue differences) then weigh alike at weight 1, whatever their
        scales, and the median ignores the outliers that a maximum or a mean would
        follow. A part with no positive distance among the fitted samples is divided by
        1. ``"none"`` adds the raw matrices.

    Attributes
    ----------
    parts_ : list of (str, transformer)
        The fitted clones of the parts; ``transform`` uses these, never the parts of
        ``transformer_list`` (which ``fit`` leaves unfitted).
    weights_ : dict of str to float
        The weight of each part at ``fit``.
    scales_ : dict of str to float
        The divisor of each part (1 with ``normalization="none"``).

    Notes
    -----
    ``transform`` reads the fitted state only: parameters set after ``fit`` (weights,
    parts, their parameters) take effect at the next ``fit``. ``set_params`` applies
    its arguments in a fixed order whatever the order of the keywords: a new
    ``transformer_list`` first, then parts replaced by name, then the other parameters
    and the parts' own (``<name>__<parameter>``), so that nested parameters reach the
    parts given in the same call. The parts' diagram distances (a
    :class:`DiagramDistance`, alone or ending a :class:`~sklearn.pipeline.Pipeline`)
    are computed together, in one parallel call after the steps before them. Parts
    that start with a :class:`LowerStarPersistence` of equal settings but ``parts``
    (Pipelines without memory or verbose) share one persistence per sample: each
    function's diagrams are computed once, and each part gets its own, as its
    persistence would have made them. The output's columns are named
    ``combineddistance0``, ``combineddistance1``... after the fitted samples
    (:meth:`get_feature_names_out`).

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn.preprocessing import FunctionTransformer
    >>> from sklearn_meshph import CombinedDistance
    >>> from scipy.spatial.distance import cdist
    >>> X = np.array([[0.0], [1.0], [3.0]])
    >>> absolute = FunctionTransformer(lambda A: cdist(A, X, "cityblock"))
    >>> combined = CombinedDistance([("a", absolute), ("b", absolute)], weights={"b": 3})
    >>> combined.fit_transform(X)  # (1 + 3) * |x - y| / median(1, 2, 3)
    array([[0., 2., 6.],
           [2., 0., 4.],
           [6., 4., 0.]])
    """

    _parameter_constraints: dict = {
        "transformer_list": [_NamedParts()],
        "weights": [_Weights(), None],
        "normalization": [Options(NORMALIZATIONS)],
    }

    def __init__(self, transformer_list, weights=None, normalization="median"):
        self.transformer_list = transformer_list
        self.weights = weights
        self.normalization = normalization

    def get_params(self, deep=True):
        """Parameters, with those of the parts as ``<name>__<parameter>`` when ``deep``.

        Parameters
        ----------
        deep : bool, default=True
            Whether to list the parts and their parameters too.

        Returns
        -------
        dict
        """
        params = super().get_params(deep=False)
        if deep:
            for name, part in _named(self.transformer_list):
                params[name] = part
                if hasattr(part, "get_params"):
                    nested = part.get_params(deep=True).items()
                    params.update({f"{name}__{key}": value for key, value in nested})
        return params

    def set_params(self, **params):
        """Set parameters, of the parts too, in an order that does not depend on the
        keywords': ``transformer_list``, then parts by name (``<name>``), then the rest
        (``weights``, ``normalization``, ``<name>__<parameter>``).

        Parameters
        ----------
        **params : dict

        Returns
        -------
        self
        """
        if "transformer_list" in params:
            self.transformer_list = params.pop("transformer_list")
        names = {name for name, _ in _named(self.transformer_list)}
        replaced = {key: params.pop(key) for key in list(params) if key in names}
        if replaced:
            self.transformer_list = [
                (name, replaced.get(name, part)) for name, part in self.transformer_list
            ]
        return super().set_params(**params)

    def _first_fitted(self):
        """The first part of positive weight (the others are not fitted)."""
        used = [part for name, part in self.parts_ if self.weights_[name] > 0]
        if not used:
            raise AttributeError("no part of positive weight was fitted")
        return used[0]

    @property
    def n_features_in_(self):
        """The number of features of the fitted samples, as the first part of positive
        weight saw them (when it counts them)."""
        return self._first_fitted().n_features_in_

    @property
    def feature_names_in_(self):
        """The columns of the fitted DataFrame, as the first part of positive weight
        saw them."""
        return self._first_fitted().feature_names_in_

    def _check_params(self) -> None:
        """The parameters' constraints, and the weights against the parts (by ``fit``, and
        by the main job before any sample is loaded)."""
        check_params(self._parameter_constraints, self.get_params(deep=False), "CombinedDistance")
        self._fitted_weights()

    def _fitted_weights(self) -> dict:
        """The weight of each part by name, checked against the parts: at least one
        positive (all 0 would make every distance 0)."""
        names = [name for name, _ in self.transformer_list]
        if self.weights is None:
            return dict.fromkeys(names, 1.0)
        if isinstance(self.weights, Mapping):
            unknown = set(self.weights) - set(names)
            if unknown:
                raise ValueError(f"weights name unknown parts {sorted(unknown)}; parts: {names}")
            fitted = {name: float(self.weights.get(name, 1.0)) for name in names}
        else:
            weights = np.ravel(self.weights)
            if len(weights) != len(names):
                raise ValueError(
                    f"weights holds {len(weights)} numbers for {len(names)} parts {names}"
                )
            fitted = {name: float(w) for name, w in zip(names, weights, strict=True)}
        if not any(w > 0 for w in fitted.values()):
            raise ValueError(
                f"weights are all 0 ({fitted}): every distance would be 0; give a part a "
                "positive weight"
            )
        return fitted

    def _matrices(self, parts, weights, X, n_fitted=None):
        """The matrices of the parts of positive weight on ``X`` (None for the others),
        as float arrays, each refused (naming the part) unless of shape ``(len(X),
        n_fitted)`` (``len(X)`` when fitting) and free of NaN; and that shape."""
        n = X.shape[0] if issparse(X) else len(X)
        shape = (n, n if n_fitted is None else n_fitted)
        used = [k for k, (name, _) in enumerate(parts) if weights[name] > 0]
        plans = _plans([parts[k][1] for k in used], X, fit=n_fitted is None)
        checked = [None] * len(parts)
        for k, matrix in zip(used, run_plans(plans) if used else [], strict=True):
            name = parts[k][0]
            matrix = np.asarray(matrix, dtype=float)
            if matrix.shape != shape:
                raise ValueError(
                    f"part {name!r} gave distances of shape {matrix.shape}; expected "
                    f"{shape} (one row per sample, one column per fitted sample)"
                )
            nan = np.isnan(matrix).any(axis=1)
            if nan.any():
                raise ValueError(
                    f"sample {int(np.flatnonzero(nan)[0])}: part {name!r} gave it a NaN distance"
                )
            checked[k] = matrix
        return checked, shape

    def _combine(self, matrices, shape):
        total = np.zeros(shape)
        finite = np.ones(total.shape, dtype=bool)  # where no part is infinite itself
        for (name, _), matrix in zip(self.parts_, matrices, strict=True):
            weight = self.weights_[name]
            if weight > 0:  # a weight-0 part is left out (0 * inf would be NaN)
                factor = weight / self.scales_[name]
                if not np.isfinite(factor):
                    raise ValueError(
                        f"weights: part {name!r}'s weight {weight!r} over its scale "
                        f"{self.scales_[name]:.3g} overflows float64; use smaller weights"
                    )
                matrix = np.asarray(matrix, float)
                with np.errstate(over="ignore"):
                    total += factor * matrix
                finite &= np.isfinite(matrix)
        if not np.isfinite(total[finite]).all():
            raise ValueError(
                "weights: the weighted sum of the parts' distances overflows float64; use "
                "smaller weights"
            )
        return total

    def fit_transform(self, X, y=None):
        """Fit every part and return the combined symmetric matrix of ``X``.

        Parameters
        ----------
        X : sequence of samples
            What every part takes (e.g. the fields of the eigen stage).
        y : ignored

        Returns
        -------
        ndarray of shape (n_samples, n_samples)
        """
        self._check_params()
        weights = self._fitted_weights()
        X = _reusable(X)  # every part reads X: a generator is read once
        parts = [(name, clone(part)) for name, part in self.transformer_list]
        # Every part's diagram distances are computed in one parallel call, after the
        # steps before them (one persistence for the parts that differ only by the
        # diagrams they keep): one wait for the last block, not one per part.
        matrices, shape = self._matrices(parts, weights, X)
        self.parts_, self.weights_ = parts, weights
        self.scales_ = {
            name: median_scale(matrix)
            if self.normalization == "median" and matrix is not None
            else 1.0
            for (name, _), matrix in zip(parts, matrices, strict=True)
        }
        combined = self._combine(matrices, shape)
        self._n_features_out = combined.shape[1]
        return combined

    def fit(self, X, y=None):
        """Fit every part on ``X`` and learn its normalization.

        Parameters
        ----------
        X : sequence of samples
            What every part takes, e.g. the fields of the eigen stage.
        y : ignored

        Returns
        -------
        self
        """
        self.fit_transform(X)
        return self

    def transform(self, X):
        """Combined distances from each sample of ``X`` to each fitted sample.

        Parameters
        ----------
        X : sequence of samples
            Of the kind the parts were fitted on.

        Returns
        -------
        ndarray of shape (len(X), n_fitted)
        """
        check_is_fitted(self, "parts_")
        X = _reusable(X)
        matrices, shape = self._matrices(self.parts_, self.weights_, X, self._n_features_out)
        return self._combine(matrices, shape)

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        parts = _named(self.transformer_list)
        tags.input_tags.two_d_array = bool(parts) and all(
            get_tags(part).input_tags.two_d_array for _, part in parts
        )
        return tags
