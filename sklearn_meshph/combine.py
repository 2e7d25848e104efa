"""Precomputed distances beyond diagrams: between feature vectors such as Shape-DNA."""

from __future__ import annotations

from numbers import Integral

import numpy as np
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.metrics import pairwise_distances
from sklearn.utils.validation import check_is_fitted, validate_data

from ._param_validation import check_params

__all__ = ["FeatureDistance"]


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
