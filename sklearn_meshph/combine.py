"""Precomputed distances beyond diagrams: between feature vectors such as Shape-DNA, and
weighted combinations of several distance matrices."""

from __future__ import annotations

from collections.abc import Mapping
from numbers import Integral

import numpy as np
from sklearn.base import BaseEstimator, TransformerMixin, clone
from sklearn.metrics import pairwise_distances
from sklearn.utils.validation import check_is_fitted, validate_data

from ._param_validation import check_params

__all__ = ["CombinedDistance", "FeatureDistance"]

NORMALIZATIONS = ("median", "none")


def _reusable(X):
    """``X`` itself when it can be read several times (arrays, lists...), else a list
    of it (a generator or another one-shot iterator)."""
    if isinstance(X, Mapping):
        raise TypeError(f"X must be a sequence of samples, got a {type(X).__name__}")
    return X if hasattr(X, "__len__") and hasattr(X, "__getitem__") else list(X)


class FeatureDistance(TransformerMixin, BaseEstimator):
    """Distances between feature vectors, as a precomputed-metric stage.

    The vector counterpart of :class:`DiagramDistance`: ``fit`` stores the rows of
    ``X``, ``transform(X)`` returns the ``(len(X), n_fitted)`` distances to them, ready
    for ``KNeighborsClassifier(metric="precomputed")`` or
    ``TSNE(metric="precomputed")``.

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

    See Also
    --------
    ShapeDNA : Spectra as feature vectors.
    DiagramDistance : Distances between persistence diagrams.

    Examples
    --------
    >>> from sklearn_meshph import FeatureDistance
    >>> FeatureDistance().fit_transform([[1.0, 2.0], [3.0, 2.0]])
    array([[0. , 0.5],
           [0.5, 0. ]])
    """

    _parameter_constraints: dict = {"metric": [str, callable], "n_jobs": [Integral, None]}

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
        check_params(self._parameter_constraints, self.get_params(deep=False), "FeatureDistance")
        self.features_ = validate_data(self, X, dtype=np.float64)
        return self

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
        return pairwise_distances(X, self.features_, metric=self.metric, n_jobs=self.n_jobs)


class CombinedDistance(TransformerMixin, BaseEstimator):
    """A weighted sum of the distance matrices of several parts, each normalized.

    Each part is a transformer (usually a :class:`~sklearn.pipeline.Pipeline`) that maps
    the same samples to a precomputed distance matrix: for example the diagrams of
    :class:`LowerStarPersistence` into :class:`DiagramDistance`, and :class:`ShapeDNA`
    into :class:`FeatureDistance`, both after one :class:`LaplacianEigenTransformer`
    (one eigensolve per mesh serves all parts). Like :class:`~sklearn.pipeline.FeatureUnion`,
    but the parts' outputs are added, not concatenated, so the result is again a
    distance matrix for ``KNeighborsClassifier(metric="precomputed")`` or
    ``TSNE(metric="precomputed")``.

    Parameters
    ----------
    transformer_list : list of (str, transformer)
        The named parts. Their parameters are reachable as ``<name>__<parameter>``, for
        ``set_params`` and grid searches.
    weights : dict of str to float, default=None
        Weight of each part (by name; missing parts weigh 1). ``None``: all 1.
    normalization : {"median", "none"}, default="median"
        ``"median"`` divides each part by the median of its finite off-diagonal
        distances on the fitted samples, learned by ``fit``: parts measured in different
        units (a bottleneck distance of unit-area eigenfunctions, a sum of relative
        eigenvalue differences) then weigh alike at weight 1, whatever their scales, and
        the median ignores the outliers that a maximum or a mean would follow. A part
        with no positive distance among the fitted samples is divided by 1.
        ``"none"`` adds the raw matrices.

    Attributes
    ----------
    scales_ : dict of str to float
        The divisor of each part (1 with ``normalization="none"``).

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

    def __init__(self, transformer_list, weights=None, normalization="median"):
        self.transformer_list = transformer_list
        self.weights = weights
        self.normalization = normalization

    def get_params(self, deep=True):
        """Parameters, with those of the parts as ``<name>__<parameter>`` when ``deep``."""
        params = super().get_params(deep=False)
        if deep:
            for name, part in self.transformer_list:
                params[name] = part
                params.update({f"{name}__{k}": v for k, v in part.get_params(deep=True).items()})
        return params

    def set_params(self, **params):
        """Set parameters, of the parts too (``<name>__<parameter>``, or ``<name>`` to
        replace a part)."""
        parts = dict(self.transformer_list)
        nested: dict = {}
        for key, value in params.items():
            name, _, rest = key.partition("__")
            if name in parts and rest:
                nested.setdefault(name, {})[rest] = value
            elif name in parts:
                parts[name] = value
            else:
                super().set_params(**{key: value})
                parts = dict(self.transformer_list)
        for name, values in nested.items():
            parts[name].set_params(**values)
        self.transformer_list = [(name, parts[name]) for name, _ in self.transformer_list]
        return self

    def _check(self) -> None:
        check_params(
            {"weights": [dict, None], "normalization": [str]},
            {"weights": self.weights, "normalization": self.normalization},
            "CombinedDistance",
        )
        if self.normalization not in NORMALIZATIONS:
            raise ValueError(
                f"normalization must be one of {NORMALIZATIONS}, got {self.normalization!r}"
            )
        names = [name for name, _ in self.transformer_list]
        if not names or len(set(names)) != len(names) or any("__" in n for n in names):
            raise ValueError(f"transformer_list needs distinct names without '__', got {names}")
        unknown = set(self.weights or ()) - set(names)
        if unknown:
            raise ValueError(f"weights name unknown parts {sorted(unknown)}; parts: {names}")

    def _combine(self, matrices):
        weights = self.weights or {}
        total = None
        for (name, _), matrix in zip(self.transformer_list, matrices, strict=True):
            term = float(weights.get(name, 1.0)) / self.scales_[name] * np.asarray(matrix, float)
            total = term if total is None else total + term
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
        self._check()
        X = _reusable(X)  # every part reads X: a generator is read once
        self.parts_ = [(name, clone(part)) for name, part in self.transformer_list]
        matrices = [part.fit_transform(X) for _, part in self.parts_]
        self.scales_ = {}
        for (name, _), matrix in zip(self.parts_, matrices, strict=True):
            self.scales_[name] = self._scale(np.asarray(matrix, float))
        return self._combine(matrices)

    def _scale(self, matrix) -> float:
        if self.normalization == "none":
            return 1.0
        off = matrix[~np.eye(*matrix.shape, dtype=bool)] if matrix.ndim == 2 else matrix
        finite = off[np.isfinite(off) & (off > 0)]
        # A part that tells no fitted pair apart (e.g. essential H1 on genus-0 shapes
        # only) adds nothing: any divisor will do.
        return float(np.median(finite)) if finite.size else 1.0

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
        return self._combine([part.transform(X) for _, part in self.parts_])

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.input_tags.two_d_array = False
        return tags
