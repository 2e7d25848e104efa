"""A few numbers per diagram: persistence entropy and summary statistics."""

from __future__ import annotations

import numpy as np

from .._param_validation import Numbers
from ._base import COMMON_CONSTRAINTS, PackedVectorizer, common_sections
from ._compiled import entropies, statistics

__all__ = ["DiagramStatistics", "PersistenceEntropy"]

_SECTIONS = common_sections()


class _Summary(PackedVectorizer):
    """Per-diagram numbers that need nothing learned but the ``infinite`` policy."""

    def _fit_positions(self, packed):
        pass

    def get_feature_names_out(self, input_features=None):
        """``d<k>_<number>``, per diagram position ``k``.

        Returns
        -------
        ndarray of str
        """
        return np.array(
            [f"d{k}_{name}" for k in range(self.n_diagrams_) for name in self._names()],
            dtype=object,
        )


class PersistenceEntropy(_Summary):
    __doc__ = f"""Persistence entropy: ``-sum_j p_j log p_j`` with ``p_j`` each point's share of the
    diagram's total persistence (Chintakunta et al. 2015; Atienza et al. 2020).

    One number per diagram: high when persistence is spread over many points, low when
    a few points hold it. A diagram without points (or of zero total persistence) gives
    0.

    Parameters
    ----------
    normalized : bool, default=False
        Divide by ``log n`` (``n`` points; 0 for ``n <= 1``), so that the value lies in
        [0, 1] whatever the number of points.
    {_SECTIONS}

    See Also
    --------
    EntropyCurve : The entropy summary function.

    Notes
    -----
    Equals ``gudhi.representations.Entropy(mode="scalar")`` on non-empty diagrams
    (tested); gudhi returns NaN for an empty one.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_meshph import PersistenceEntropy
    >>> PersistenceEntropy().fit_transform([np.array([[0.0, 1.0], [0.0, 1.0]])]).round(4)
    array([[0.6931]])
    """

    _parameter_constraints: dict = {**COMMON_CONSTRAINTS, "normalized": ["boolean"]}

    def __init__(
        self,
        normalized=False,
        infinite="drop",
        n_jobs=None,
        dtype="float64",
        essential="deprecated",
    ):
        self.normalized = normalized
        self.infinite, self.n_jobs, self.dtype = infinite, n_jobs, dtype
        self.essential = essential

    def _names(self):
        return ["entropy"]

    def _compute(self, k, packed, starts, stops):
        return entropies(packed.points, starts, stops, bool(self.normalized))


class DiagramStatistics(_Summary):
    __doc__ = f"""Summary statistics of each diagram's points.

    Per diagram: the number of points, the total, largest and mean persistence, the
    ``quantiles`` of the persistence, and the mean birth and death; an empty diagram
    gives zeros. Cheap, interpretable, and often a strong baseline with a tree model.

    Parameters
    ----------
    quantiles : tuple of float, default=(0.1, 0.25, 0.5, 0.75, 0.9)
        Quantiles of the persistence (linear interpolation).
    {_SECTIONS}

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_meshph import DiagramStatistics
    >>> stats = DiagramStatistics(quantiles=(0.5,)).fit([np.array([[0.0, 1.0], [0.0, 3.0]])])
    >>> list(stats.get_feature_names_out())
    ['d0_count', 'd0_total', 'd0_max', 'd0_mean', 'd0_q0.5', 'd0_mean_birth', 'd0_mean_death']
    >>> stats.transform([np.array([[0.0, 1.0], [0.0, 3.0]])])
    array([[2., 4., 3., 2., 2., 0., 2.]])
    """

    _parameter_constraints: dict = {**COMMON_CONSTRAINTS, "quantiles": [Numbers()]}

    def __init__(
        self,
        quantiles=(0.1, 0.25, 0.5, 0.75, 0.9),
        infinite="drop",
        n_jobs=None,
        dtype="float64",
        essential="deprecated",
    ):
        self.quantiles = quantiles
        self.infinite, self.n_jobs, self.dtype = infinite, n_jobs, dtype
        self.essential = essential

    def _check_params(self) -> None:
        super()._check_params()
        q = np.asarray(self.quantiles, dtype=float)
        if q.ndim != 1 or ((q < 0) | (q > 1) | np.isnan(q)).any():
            raise ValueError(f"quantiles must be numbers in [0, 1], got {self.quantiles!r}")

    def _names(self):
        return (
            ["count", "total", "max", "mean"]
            + [f"q{q:g}" for q in self.quantiles]
            + ["mean_birth", "mean_death"]
        )

    def _compute(self, k, packed, starts, stops):
        return statistics(
            packed.points, starts, stops, np.asarray(self.quantiles, dtype=np.float64)
        )
