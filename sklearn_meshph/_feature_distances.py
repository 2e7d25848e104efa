"""Distances between feature vectors, each pair's independent of the other rows, at any
scale float64 holds (:func:`feature_distances`, for ``FeatureDistance`` and the index's
feature parts)."""

from __future__ import annotations

import warnings

import numpy as np
from scipy.spatial.distance import cdist
from sklearn.metrics import pairwise_distances
from sklearn.preprocessing import normalize

__all__ = ["check_metric", "feature_distances"]

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


def check_metric(metric, owner: str) -> None:
    """Refuse a named ``metric`` that :func:`feature_distances` cannot compute, tried on
    six rows against four (as ``transform`` calls it, ``Y`` given): an unknown name, or
    one that needs arguments (``"mahalanobis"``, ``"seuclidean"``), failed only at
    ``transform`` (the main job's status 1 after the eigen stage, not 2 before loading).
    A callable is the user's, not tried."""
    if not isinstance(metric, str):
        return
    rows = np.array([[0.0, 1, 2], [1, 0, 3], [2, 2, 1], [3, 1, 0], [1, 3, 2], [0, 2, 3]])
    try:
        with warnings.catch_warnings(), np.errstate(all="ignore"):
            warnings.simplefilter("ignore")
            feature_distances(rows[:4], rows, metric)
    except (ValueError, TypeError) as exc:
        reason = " ".join(str(exc).split())
        reason = reason if len(reason) <= 160 else reason[:160] + "..."
        raise ValueError(f"{owner}: metric {metric!r} cannot be computed: {reason}") from None
