"""Functions of the filtration value sampled on a grid: persistence landscapes,
silhouettes, Betti curves and the entropy summary function."""

from __future__ import annotations

from numbers import Integral, Real

import numpy as np
from sklearn.utils.validation import check_is_fitted

from .._param_validation import Interval, Numbers
from ._base import (
    COMMON_CONSTRAINTS,
    PackedVectorizer,
    common_sections,
    resolve_range,
)
from ._compiled import betti_curves, entropy_curves, landscapes, silhouettes

__all__ = [
    "MAX_LANDSCAPE_VALUES",
    "MAX_RESOLUTION",
    "BettiCurve",
    "EntropyCurve",
    "PersistenceLandscape",
    "Silhouette",
]

#: Largest ``resolution`` of a grid function (values per diagram).
MAX_RESOLUTION = 2**20
#: Largest ``n_landscapes * resolution`` of :class:`PersistenceLandscape` (values per
#: diagram, 128 MiB per sample and diagram as float64).
MAX_LANDSCAPE_VALUES = 2**24


def _sample_grid(points, resolution, sample_range, keep_endpoints) -> np.ndarray:
    """``resolution`` evenly spaced values over ``sample_range``; a ``None`` or NaN end
    is the smallest birth or the largest death of ``points``, and, unless
    ``keep_endpoints``, that end itself is left out (every function here is 0 there):
    the grid has one more step per learned end, as gudhi's."""
    given = [None, None] if sample_range is None else list(sample_range)
    if len(given) != 2:
        raise ValueError(f"sample_range must have 2 entries, got {sample_range!r}")
    data = [points[:, 0].min(), points[:, 1].max()] if len(points) else [0.0, 0.0]
    lo, hi = resolve_range(given, data, "sample_range")
    learned = [g is None or np.isnan(g) for g in given]
    extra = 0 if keep_endpoints else sum(learned)
    n = resolution + extra
    grid = np.linspace(lo, hi, n) if lo != hi else np.full(n, lo)
    if not keep_endpoints:
        grid = grid[int(learned[0]) : n - int(learned[1])]
    return grid


_GRID_CONSTRAINTS: dict = {
    "resolution": [Interval(Integral, 1, MAX_RESOLUTION, closed="both")],
    "sample_range": [Numbers(2, none=True), None],
    "keep_endpoints": ["boolean"],
    **COMMON_CONSTRAINTS,
}

_GRID_PARAMETERS = f"""resolution : int, default=100
        Grid points.
    sample_range : tuple of 2 float, default=None
        ``(min, max)`` of the grid, increasing and finite; ``None`` or NaN ends are
        learned by ``fit``, per diagram position, as the smallest birth and the largest
        death of the fitted diagrams.
    keep_endpoints : bool, default=False
        Whether a learned end is itself a grid point (where the function is 0 or
        trivial); by default the grid is spread over ``resolution + 1`` (or ``+ 2``)
        points and the learned ends left out, as gudhi does.
    {
    common_sections('''grids_ : list of ndarray
        The grid of each diagram position.''')
}"""


class _GridFunction(PackedVectorizer):
    """A function of the filtration value sampled on a grid learned per position."""

    _parameter_constraints: dict = dict(_GRID_CONSTRAINTS)
    _feature = "value"

    def __init__(
        self,
        resolution=100,
        sample_range=None,
        keep_endpoints=False,
        infinite="drop",
        n_jobs=None,
        dtype="float64",
        essential="deprecated",
    ):
        self.resolution = resolution
        self.sample_range = sample_range
        self.keep_endpoints = keep_endpoints
        self.infinite, self.n_jobs, self.dtype = infinite, n_jobs, dtype
        self.essential = essential

    def _features_per_position(self) -> int:
        return self.resolution

    def _grid_size(self) -> int:
        """The fitted grids' points (``resolution`` as it was at ``fit``)."""
        check_is_fitted(self, "grids_")
        return len(self.grids_[0]) if self.grids_ else int(self.resolution)

    def _fit_positions(self, packed):
        self.grids_ = [
            _sample_grid(
                packed.only(k).points, self.resolution, self.sample_range, self.keep_endpoints
            )
            for k in range(packed.n_diagrams)
        ]

    def _compute(self, k, packed, starts, stops):
        return self._curves(packed.points, starts, stops, self.grids_[k])

    def _column_names(self) -> list[str]:
        return [f"{self._feature}_{g}" for g in range(self._grid_size())]

    def get_feature_names_out(self, input_features=None):
        """``d<k>_<feature>_<grid index>``, per diagram position ``k``.

        Returns
        -------
        ndarray of str
        """
        names = self._column_names()
        return np.array(
            [f"d{k}_{name}" for k in range(self.n_diagrams_) for name in names], dtype=object
        )


class PersistenceLandscape(_GridFunction):
    __doc__ = f"""Persistence landscapes: the ``n_landscapes`` largest tent functions.

    Each point ``(b, d)`` is the tent ``max(0, (d - b) / 2 - |x - (b + d) / 2|)``; the
    ``k``-th landscape is the ``k``-th largest tent at each ``x`` (Bubenik 2015),
    sampled on a grid and multiplied by ``sqrt 2`` (measured along the diagonal, as
    gudhi does). Output per diagram: landscape 1 on the whole grid, then landscape 2...

    Parameters
    ----------
    n_landscapes : int, default=5
        Landscapes per diagram.
    {_GRID_PARAMETERS}

    Notes
    -----
    Equals ``gudhi.representations.Landscape(num_landscapes, resolution, sample_range,
    keep_endpoints=...)`` on one diagram per sample (tested to 1e-10).

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_meshph import PersistenceLandscape
    >>> landscape = PersistenceLandscape(n_landscapes=2, resolution=3)
    >>> landscape.fit_transform([np.array([[0.0, 2.0], [0.5, 1.5]])]).round(3)
    array([[0.707, 1.414, 0.707, 0.   , 0.707, 0.   ]])
    """

    _parameter_constraints: dict = {
        **_GRID_CONSTRAINTS,
        "n_landscapes": [Interval(Integral, 1, MAX_LANDSCAPE_VALUES, closed="both")],
    }
    _feature = "landscape"

    def __init__(
        self,
        n_landscapes=5,
        resolution=100,
        sample_range=None,
        keep_endpoints=False,
        infinite="drop",
        n_jobs=None,
        dtype="float64",
        essential="deprecated",
    ):
        self.n_landscapes = n_landscapes
        super().__init__(
            resolution, sample_range, keep_endpoints, infinite, n_jobs, dtype, essential
        )

    def _check_params(self) -> None:
        super()._check_params()
        if int(self.n_landscapes) * int(self.resolution) > MAX_LANDSCAPE_VALUES:
            raise ValueError(
                f"PersistenceLandscape: n_landscapes * resolution = {self.n_landscapes} * "
                f"{self.resolution} values per diagram, more than MAX_LANDSCAPE_VALUES "
                f"({MAX_LANDSCAPE_VALUES})"
            )

    def _curves(self, points, starts, stops, grid):
        return landscapes(points, starts, stops, grid, self.n_landscapes)

    def _column_names(self):
        return [
            f"landscape{t + 1}_{g}"
            for t in range(self.n_landscapes)
            for g in range(self._grid_size())
        ]


class Silhouette(_GridFunction):
    __doc__ = f"""Persistence silhouettes: the weighted mean of the tent functions.

    ``sqrt 2 * sum_j w_j tent_j(x) / sum_j w_j`` with ``w_j = (d_j - b_j) ** power``
    (Chazal et al. 2014), sampled on a grid; a diagram without points (or of zero total
    weight) gives zeros.

    Parameters
    ----------
    power : float, default=1.0
        Exponent of the persistence in the weights: 0 weighs every point alike, larger
        values favour the persistent points.
    {_GRID_PARAMETERS}

    Notes
    -----
    Equals ``gudhi.representations.Silhouette(weight=lambda p: (p[1] - p[0]) ** power,
    resolution, sample_range)`` on one non-empty diagram per sample (tested to 1e-10);
    gudhi returns NaN for an empty diagram.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_meshph import Silhouette
    >>> Silhouette(resolution=3).fit_transform([np.array([[0.0, 2.0]])]).round(3)
    array([[0.707, 1.414, 0.707]])
    """

    _parameter_constraints: dict = {
        **_GRID_CONSTRAINTS,
        "power": [Interval(Real, 0, None, closed="left")],
    }
    _feature = "silhouette"

    def __init__(
        self,
        power=1.0,
        resolution=100,
        sample_range=None,
        keep_endpoints=False,
        infinite="drop",
        n_jobs=None,
        dtype="float64",
        essential="deprecated",
    ):
        self.power = power
        super().__init__(
            resolution, sample_range, keep_endpoints, infinite, n_jobs, dtype, essential
        )

    def _curves(self, points, starts, stops, grid):
        weights = (points[:, 1] - points[:, 0]) ** float(self.power)
        return silhouettes(points, weights, starts, stops, grid)


class BettiCurve(_GridFunction):
    __doc__ = f"""Betti curves: the number of points alive at each filtration value.

    ``beta(x) = #{{j : b_j <= x < d_j}}``, sampled on a grid; with the default
    ``infinite="drop"`` the essential classes do not count (``"clip"`` counts them up
    to the largest fitted death).

    Parameters
    ----------
    {_GRID_PARAMETERS}

    Notes
    -----
    Equals ``gudhi.representations.BettiCurve(resolution, sample_range,
    keep_endpoints=...)`` on one diagram per sample (tested).

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_meshph import BettiCurve
    >>> BettiCurve(resolution=3).fit_transform([np.array([[0.0, 2.0], [0.5, 1.5]])])
    array([[2., 2., 1.]])
    """

    _feature = "betti"

    def _curves(self, points, starts, stops, grid):
        return betti_curves(points, starts, stops, grid)


class EntropyCurve(_GridFunction):
    __doc__ = f"""The entropy summary function of each diagram, sampled on a grid.

    ``E(x) = -sum_j p_j log p_j`` over the points with ``b_j <= x < d_j``, where
    ``p_j = (d_j - b_j) / sum_i (d_i - b_i)`` (Atienza et al. 2020); optionally divided
    by its sum over the grid.

    Parameters
    ----------
    normalized : bool, default=True
        Divide each curve by the sum of its values (a curve of zeros stays zero).
    {_GRID_PARAMETERS}

    Notes
    -----
    gudhi's ``Entropy(mode="vector")`` evaluates the curve at ``x_min + i * step`` (one
    step before its reported ``grid_``); ours is evaluated at ``grids_`` itself.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_meshph import EntropyCurve
    >>> curve = EntropyCurve(resolution=3, normalized=False)
    >>> curve.fit_transform([np.array([[0.0, 2.0], [0.5, 1.5]])]).round(3)
    array([[0.637, 0.637, 0.27 ]])
    """

    _parameter_constraints: dict = {**_GRID_CONSTRAINTS, "normalized": ["boolean"]}
    _feature = "entropy"

    def __init__(
        self,
        normalized=True,
        resolution=100,
        sample_range=None,
        keep_endpoints=False,
        infinite="drop",
        n_jobs=None,
        dtype="float64",
        essential="deprecated",
    ):
        self.normalized = normalized
        super().__init__(
            resolution, sample_range, keep_endpoints, infinite, n_jobs, dtype, essential
        )

    def _curves(self, points, starts, stops, grid):
        curves = entropy_curves(points, starts, stops, grid)
        if self.normalized:
            sums = curves.sum(axis=1, keepdims=True)
            curves = np.divide(curves, sums, out=np.zeros_like(curves), where=sums > 0)
        return curves
