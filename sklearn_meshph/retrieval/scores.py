"""The retrieval measures of the SHREC contests and the Princeton Shape Benchmark."""

from __future__ import annotations

import numpy as np
from scipy.sparse import issparse

__all__ = ["retrieval_scores"]


def retrieval_scores(D, y) -> dict[str, float]:
    """Nearest neighbour, first tier, second tier, DCG and mean average precision of a
    collection queried against itself.

    Each sample queries all the others, ranked by distance (equal distances by lowest
    index); with ``R`` the number of other samples of its class, the measures
    (Shilane et al. 2004, the Princeton Shape Benchmark, as SHREC reports them) are the
    means over the queries of:

    - ``nearest_neighbor``: whether the first result is of the query's class;
    - ``first_tier``, ``second_tier``: the share of the ``R`` samples of the class
      among the first ``R``, ``2 R`` results;
    - ``dcg``: the discounted cumulative gain ``G_1 + sum_{r >= 2} G_r / log2(r)``
      (``G_r`` 1 when result ``r`` is of the class) over its ideal value
      ``1 + sum_{r=2}^{R} 1 / log2(r)``;
    - ``mean_average_precision``: the mean over the class's samples of the precision
      of the results up to each of them.

    Parameters
    ----------
    D : array-like of shape (n_samples, n_samples)
        Distances between the samples (the diagonal is ignored), e.g.
        ``make_mesh_distance().fit_transform(meshes)``.
    y : array-like of shape (n_samples,)
        Their classes; every class needs at least two samples.

    Returns
    -------
    dict of str to float

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_meshph import retrieval_scores
    >>> D = np.array([[0, 1, 2, 3], [1, 0, 3, 1], [2, 3, 0, 1], [3, 1, 1, 0]])
    >>> retrieval_scores(D, [0, 0, 1, 1])["nearest_neighbor"]
    0.75
    """
    if issparse(D):
        raise TypeError("D must be a dense distance matrix, got a sparse one: pass D.toarray()")
    try:
        D = np.asarray(D, dtype=float)
    except (TypeError, ValueError) as error:
        raise ValueError(f"D must be a square matrix of numbers: {error}") from error
    given, y = y, np.asarray(y)
    if D.ndim != 2 or D.shape[0] != D.shape[1]:
        raise ValueError(f"D must be a square distance matrix, got shape {D.shape}")
    n = len(D)
    if y.shape != (n,):
        raise ValueError(f"y must hold one class per row of D ({n}), got shape {y.shape}")
    # Classes must sort: a None or a mixture of kinds does not (the values themselves:
    # as strings, 1 and "1" would be one class).
    try:
        sorted(set(given.tolist() if isinstance(given, np.ndarray) else list(given)))
    except TypeError as error:
        raise ValueError(f"y must hold classes of one sortable kind: {error}") from error
    if n < 2:
        raise ValueError(f"D has {n} samples: at least two are needed to query one another")
    if np.isnan(D).any():
        row = int(np.argwhere(np.isnan(D))[0, 0])
        raise ValueError(f"sample {row}: D holds NaN distances")
    classes, codes, sizes = np.unique(y, return_inverse=True, return_counts=True)
    if sizes.min() < 2:
        alone = classes[np.argmin(sizes)]
        raise ValueError(f"class {alone} has a single sample: no other can be retrieved")
    ranked = np.argsort(D, axis=1, kind="stable")
    ranked = ranked[ranked != np.arange(n)[:, None]].reshape(n, n - 1)
    relevant = codes[ranked] == codes[:, None]
    R = sizes[codes] - 1
    hits = np.cumsum(relevant, axis=1)
    ranks = np.arange(1, n)
    discount = np.concatenate([[1.0], 1.0 / np.log2(ranks[1:])])
    ideal = np.cumsum(discount)[R - 1]
    precision = np.where(relevant, hits / ranks, 0.0).sum(axis=1) / R
    rows = np.arange(n)
    return {
        "nearest_neighbor": float(np.mean(relevant[:, 0])),
        "first_tier": float(np.mean(hits[rows, R - 1] / R)),
        "second_tier": float(np.mean(hits[rows, np.minimum(2 * R, n - 1) - 1] / R)),
        "dcg": float(np.mean((relevant * discount).sum(axis=1) / ideal)),
        "mean_average_precision": float(np.mean(precision)),
    }
