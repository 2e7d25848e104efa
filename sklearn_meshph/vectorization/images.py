"""Persistence images: diagrams as Gaussian-smoothed, weighted pictures on a grid."""

from __future__ import annotations

from numbers import Integral, Real

import numpy as np

from .._param_validation import Interval, Options
from ._base import COMMON_CONSTRAINTS, PackedVectorizer
from ._compiled import images

__all__ = ["PersistenceImage"]


def point_weights(points_bp: np.ndarray, weight, sample: str = "") -> np.ndarray:
    """The weight of each point from its (birth, persistence) coordinates."""
    if weight == "constant":
        return np.ones(len(points_bp))
    if weight == "persistence":
        return points_bp[:, 1].copy()
    values = np.asarray(weight(points_bp), dtype=np.float64).reshape(-1)
    if values.shape != (len(points_bp),) or not np.isfinite(values).all():
        raise ValueError(
            f"weight{sample} must map an (n, 2) array of (birth, persistence) rows to n "
            f"finite weights, got shape {values.shape}"
        )
    return values


class PersistenceImage(PackedVectorizer):
    """Persistence images: each diagram as a weighted sum of Gaussians on a grid.

    Each point ``(b, d)`` becomes ``(b, d - b)`` (birth, persistence), weighted, and
    smoothed by an isotropic Gaussian of standard deviation ``bandwidth``; the image is
    that sum evaluated at the ``resolution[1] x resolution[0]`` grid points of
    ``im_range`` (Adams et al. 2017) and flattened row by row (rows: persistence from
    low to high, columns: birth). A sample of several diagrams gives one image per
    diagram, side by side.

    Parameters
    ----------
    bandwidth : float, default=1.0
        Standard deviation of the Gaussian, in the diagrams' units.
    resolution : tuple of 2 int, default=(20, 20)
        Grid points along birth and along persistence.
    im_range : tuple of 4 float, default=None
        ``(birth_min, birth_max, persistence_min, persistence_max)`` of the grid;
        ``None`` or NaN entries are learned by ``fit``, per diagram position, as the
        extremes of the fitted points.
    sampling : {"point", "pixel"}, default="point"
        ``"point"``: the density at the grid points (gudhi's convention);
        ``"pixel"``: the mass of the Gaussians inside each pixel, the range split into
        ``resolution`` pixels per axis (persim's convention; an image then sums to the
        total weight that falls inside the range).
    weight : {"constant", "persistence"} or callable, default="constant"
        Weight of each point: 1, its persistence ``d - b``, or a function of an
        ``(n, 2)`` array of (birth, persistence) rows returning ``n`` weights. Weighting
        by persistence makes the image stable (a small change of the diagram moves it
        little) and makes the diagonal's noise vanish.
    essential : {"drop", "clip", "error"}, default="drop"
        Points with infinite death: dropped, clipped at the largest finite death of
        their position among the fitted diagrams, or refused.
    n_jobs : int, default=None
        Blocks of samples computed in parallel (joblib).
    dtype : {"float64", "float32"}, default="float64"
        Of the output (computed in float64).

    Attributes
    ----------
    im_ranges_ : ndarray of shape (n_diagrams, 4)
        The grid's range of each diagram position.
    n_diagrams_ : int
        Diagrams per sample.
    clip_values_ : ndarray of shape (n_diagrams,)
        The largest finite death of each position (used by ``essential="clip"``).

    See Also
    --------
    PersistenceLandscape, BettiCurve : Other vectorizations.

    Notes
    -----
    With one diagram per sample, ``weight="constant"`` and the same ``im_range``, the
    output equals ``gudhi.representations.PersistenceImage(bandwidth, weight=lambda x:
    1, resolution=list(resolution), im_range=...)`` (tested to 1e-10); gudhi learns one
    range over all diagrams it is fitted on, as we do per position. With
    ``sampling="pixel"`` and ``weight="persistence"`` it equals persim's
    ``PersistenceImager(birth_range, pers_range, pixel_size,
    kernel_params={"sigma": bandwidth ** 2})`` (its default weight, persistence to the
    power 1) transposed, when ``pixel_size`` divides both ranges (tested).

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_meshph import PersistenceImage
    >>> image = PersistenceImage(resolution=(3, 2), im_range=(0, 1, 0, 1), bandwidth=0.5)
    >>> image.fit_transform([np.array([[0.0, 1.0]])]).shape
    (1, 6)
    """

    _parameter_constraints: dict = {
        "bandwidth": [Interval(Real, 0, None, closed="neither")],
        "resolution": [tuple, list],
        "im_range": [tuple, list, None],
        "sampling": [Options(("point", "pixel"))],
        "weight": [Options(("constant", "persistence")), callable],
        **COMMON_CONSTRAINTS,
    }

    def __init__(
        self,
        bandwidth=1.0,
        resolution=(20, 20),
        im_range=None,
        sampling="point",
        weight="constant",
        essential="drop",
        n_jobs=None,
        dtype="float64",
    ):
        self.bandwidth = bandwidth
        self.resolution = resolution
        self.im_range = im_range
        self.sampling = sampling
        self.weight = weight
        self.essential = essential
        self.n_jobs = n_jobs
        self.dtype = dtype

    def _check_params(self) -> None:
        super()._check_params()
        if len(self.resolution) != 2 or not all(
            isinstance(r, Integral) and r >= 1 for r in self.resolution
        ):
            raise ValueError(f"resolution must be 2 positive ints, got {self.resolution!r}")
        if self.im_range is not None and len(self.im_range) != 4:
            raise ValueError(f"im_range must have 4 entries, got {self.im_range!r}")

    def _fit_positions(self, packed):
        given = np.full(4, np.nan) if self.im_range is None else np.array(self.im_range, float)
        ranges = []
        for k in range(packed.n_diagrams):
            points = packed.rows_of_position(k)
            if len(points):
                births, persistence = points[:, 0], points[:, 1] - points[:, 0]
                learned = [births.min(), births.max(), persistence.min(), persistence.max()]
            else:  # nothing to learn from: a unit square at the origin
                learned = [0.0, 1.0, 0.0, 1.0]
            ranges.append(np.where(np.isnan(given), learned, given))
        self.im_ranges_ = np.array(ranges)

    def _compute(self, k, points, starts, stops):
        bp = np.column_stack([points[:, 0], points[:, 1] - points[:, 0]])
        weights = point_weights(bp, self.weight)
        lo_x, hi_x, lo_y, hi_y = self.im_ranges_[k]
        pixel = self.sampling == "pixel"
        xs = np.linspace(lo_x, hi_x, self.resolution[0] + pixel)
        ys = np.linspace(lo_y, hi_y, self.resolution[1] + pixel)
        return images(bp, weights, starts, stops, xs, ys, float(self.bandwidth), pixel)

    def get_feature_names_out(self, input_features=None):
        """``d<k>_pixel_<row>_<column>``: diagram ``k``, persistence row, birth column.

        Returns
        -------
        ndarray of str
        """
        rx, ry = self.resolution
        return np.array(
            [
                f"d{k}_pixel_{i}_{j}"
                for k in range(self.n_diagrams_)
                for i in range(ry)
                for j in range(rx)
            ],
            dtype=object,
        )
