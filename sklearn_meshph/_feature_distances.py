"""Distances between feature vectors, each pair's independent of the other rows, at any
scale float64 holds (:func:`feature_distances`, for ``FeatureDistance`` and the index's
feature parts)."""

from __future__ import annotations

import numpy as np
from scipy.spatial.distance import cdist
from sklearn.metrics import pairwise_distances
from sklearn.preprocessing import normalize

__all__ = ["feature_distances"]

#: scikit-learn's metrics computed through products of matrices: a pair's value then
#: depends on the other rows computed with it (a sample's distance to itself 0 in one
#: batch, 1.7e-7 in another). They are computed pair by pair here.
_PER_PAIR = {"euclidean": "euclidean", "l2": "euclidean", "sqeuclidean": "sqeuclidean"}


def _power_of_two(values) -> np.ndarray:
    """The power of two at or above each magnitude (1 for 0): dividing by it is exact."""
    exponent = np.frexp(np.asarray(values, dtype=np.float64))[1]
    return np.ldexp(1.0, np.where(np.asarray(values) > 0, exponent, 0))


def feature_distances(X, Y, metric, n_jobs=None) -> np.ndarray:
    """:func:`sklearn.metrics.pairwise_distances` of the rows of ``X`` and ``Y``, each
    pair's value independent of the other rows (the Euclidean distances by scipy, the
    cosine distances from each pair's own dot product of the normalized rows), at any
    scale float64 holds: the rows are divided by powers of two first (exact), so that
    squares and norms of features near 1e200 or 1e-200 neither overflow nor vanish."""
    if isinstance(metric, str) and metric in _PER_PAIR:
        top = max(np.abs(X).max(initial=0.0), np.abs(Y).max(initial=0.0))
        scale = float(_power_of_two(top))
        distances = cdist(X / scale, Y / scale, _PER_PAIR[metric])
        with np.errstate(over="ignore"):
            return distances * (scale * scale if metric == "sqeuclidean" else scale)
    if isinstance(metric, str) and metric == "cosine":

        def unit(rows):
            rows = rows / _power_of_two(np.abs(rows).max(axis=1, initial=0.0))[:, None]
            return normalize(rows)

        similarity = np.einsum("id,jd->ij", unit(X), unit(Y))
        return np.clip(1.0 - similarity, 0.0, 2.0)
    return pairwise_distances(X, Y, metric=metric, n_jobs=n_jobs)
