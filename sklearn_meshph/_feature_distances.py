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


def _exponent(values) -> np.ndarray:
    """The power of two at or above each magnitude, as its exponent (0 for 0): scaling by
    it with ``np.ldexp`` is exact, also past 2**1023 where the power itself is inf."""
    values = np.asarray(values, dtype=np.float64)
    return np.where(values > 0, np.frexp(values)[1], 0)


def feature_distances(X, Y, metric, n_jobs=None) -> np.ndarray:
    """:func:`sklearn.metrics.pairwise_distances` of the rows of ``X`` and ``Y``, each
    pair's value independent of the other rows (the Euclidean distances by scipy, the
    cosine distances from each pair's own dot product of the normalized rows), at any
    scale float64 holds: the rows are scaled by powers of two first (exact), so that
    squares and norms of features near 1e308 or 1e-200 neither overflow nor vanish."""
    if isinstance(metric, str) and metric in _PER_PAIR:
        X, Y = np.asarray(X, dtype=np.float64), np.asarray(Y, dtype=np.float64)
        top = max(np.abs(X).max(initial=0.0), np.abs(Y).max(initial=0.0))
        exponent = int(_exponent(top))
        distances = cdist(np.ldexp(X, -exponent), np.ldexp(Y, -exponent), _PER_PAIR[metric])
        with np.errstate(over="ignore"):  # beyond float64: inf, refused by the caller
            return np.ldexp(distances, 2 * exponent if metric == "sqeuclidean" else exponent)
    if isinstance(metric, str) and metric == "cosine":

        def unit(rows):
            rows = np.asarray(rows, dtype=np.float64)
            exponent = _exponent(np.abs(rows).max(axis=1, initial=0.0))
            return normalize(np.ldexp(rows, -exponent[:, None]))

        similarity = np.einsum("id,jd->ij", unit(X), unit(Y))
        return np.clip(1.0 - similarity, 0.0, 2.0)
    return pairwise_distances(X, Y, metric=metric, n_jobs=n_jobs)
