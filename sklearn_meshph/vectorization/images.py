"""Persistence images: diagrams as Gaussian-smoothed, weighted pictures on a grid."""

from __future__ import annotations

from numbers import Integral

import numpy as np

from .._param_validation import Numbers, Options
from ._base import (
    BANDWIDTH,
    COMMON_CONSTRAINTS,
    WEIGHT_CONSTRAINTS,
    WEIGHT_PARAMETER,
    PackedVectorizer,
    common_sections,
    point_weights,
    resolve_range,
)
from ._compiled import images

#: Most pixels along each side of a persistence image (4096 x 4096 values per diagram at
#: most: 128 MiB per sample and diagram as float64).
MAX_PIXELS = 4096

__all__ = ["PersistenceImage"]

_SECTIONS = common_sections(
    """im_ranges_ : ndarray of shape (n_diagrams, 4)
        The grid's range of each diagram position."""
)


class PersistenceImage(PackedVectorizer):
    __doc__ = f"""Persistence images: each diagram as a weighted sum of Gaussians on a grid.

    Each point ``(b, d)`` becomes ``(b, d - b)`` (birth, persistence), weighted, and
    smoothed by an isotropic Gaussian of standard deviation ``bandwidth``; the image is
    that sum evaluated at the ``resolution[1] x resolution[0]`` grid points of
    ``im_range`` (Adams et al. 2017) and flattened row by row (rows: persistence from
    low to high, columns: birth). A sample of several diagrams gives one image per
    diagram, side by side.

    Parameters
    ----------
    bandwidth : float, default=1.0
        Standard deviation of the Gaussian, in the diagrams' units: neither so small
        that its square underflows nor so large that the Gaussian's peak does.
    resolution : tuple of 2 int, default=(20, 20)
        Grid points along birth and along persistence.
    im_range : tuple of 4 float, default=None
        ``(birth_min, birth_max, persistence_min, persistence_max)`` of the grid, each
        pair increasing and finite; ``None`` or NaN entries are learned by ``fit``, per
        diagram position, as the extremes of the fitted points. A learned axis of zero
        width (all births equal, as in Rips H0 diagrams) is widened by ``bandwidth`` on
        each side (pixels: by the axis's pixels times float64's step there, if that is
        more).
    sampling : {{"point", "pixel"}}, default="point"
        ``"point"``: the density at the grid points (gudhi's convention);
        ``"pixel"``: the mass of the Gaussians inside each pixel, the range split into
        ``resolution`` pixels per axis (persim's convention; an image then sums to the
        total weight that falls inside the range).
    {WEIGHT_PARAMETER}
    {_SECTIONS}

    See Also
    --------
    PersistenceLandscape, BettiCurve : Other vectorizations.

    Notes
    -----
    With one diagram per sample and the same ``im_range``, the output equals
    ``gudhi.representations.PersistenceImage(bandwidth, weight=w,
    resolution=list(resolution), im_range=...)`` (tested), gudhi's weight ``w`` being a
    function of one (birth, persistence) point: ``lambda x: 1`` for ``"constant"``; a
    callable here receives (birth, death) rows, as the kernels' weights do. gudhi learns
    one range over all diagrams it is fitted on, as we do per position. With
    ``sampling="pixel"`` and ``weight="persistence"`` it equals persim's
    ``PersistenceImager(birth_range, pers_range, pixel_size,
    kernel_params={{"sigma": bandwidth ** 2}})`` (its default weight, persistence to the
    power 1) transposed, when ``pixel_size`` divides both ranges (tested).

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_meshph import PersistenceImage
    >>> image = PersistenceImage(resolution=(3, 2), im_range=(0, 1, 0, 1), bandwidth=0.5)
    >>> image.fit_transform([np.array([[0.0, 1.0]])]).shape
    (1, 6)
    """

    _output_name = "images"

    _parameter_constraints: dict = {
        "bandwidth": BANDWIDTH,
        "resolution": [Numbers(2)],
        "im_range": [Numbers(4, none=True), None],
        "sampling": [Options(("point", "pixel"))],
        **WEIGHT_CONSTRAINTS,
        **COMMON_CONSTRAINTS,
    }

    def __init__(
        self,
        bandwidth=1.0,
        resolution=(20, 20),
        im_range=None,
        sampling="point",
        weight="constant",
        power=1.0,
        infinite="drop",
        n_jobs=None,
        dtype="float64",
        essential="deprecated",
    ):
        self.bandwidth = bandwidth
        self.resolution = resolution
        self.im_range = im_range
        self.sampling = sampling
        self.weight = weight
        self.power = power
        self.infinite, self.n_jobs, self.dtype = infinite, n_jobs, dtype
        self.essential = essential

    def _check_params(self) -> None:
        super()._check_params()
        if len(self.resolution) != 2 or not all(
            isinstance(r, Integral) and not isinstance(r, bool) and 1 <= r <= MAX_PIXELS
            for r in self.resolution
        ):
            raise ValueError(
                f"resolution must be 2 ints from 1 to {MAX_PIXELS} (MAX_PIXELS), got "
                f"{self.resolution!r}"
            )
        if self.im_range is not None and len(self.im_range) != 4:
            raise ValueError(f"im_range must have 4 entries, got {self.im_range!r}")

    def _fit_positions(self, packed):
        given = [None] * 4 if self.im_range is None else list(self.im_range)
        ranges = []
        for k in range(packed.n_diagrams):
            points = packed.only(k).points
            if len(points):
                births, persistence = points[:, 0], points[:, 1] - points[:, 0]
                learned = [births.min(), births.max(), persistence.min(), persistence.max()]
            else:  # nothing to learn from: a unit square at the origin
                learned = [0.0, 1.0, 0.0, 1.0]
            axes = []
            for axis, name in ((0, "im_range (births)"), (2, "im_range (persistence)")):
                lo, hi = resolve_range(given[axis : axis + 2], learned[axis : axis + 2], name)
                if lo == hi:  # a learned axis of zero width: its pixels would hold nothing
                    # Widened by the bandwidth; pixels, by as many steps of float64 as
                    # pixels where the bandwidth is below them (1e20 +- 1 is 1e20: pixels
                    # of no width hold nothing). Grid points keep a width of 0 there:
                    # all at the points, they see them (a wider grid would step over).
                    width = float(self.bandwidth)
                    if self.sampling == "pixel":
                        steps = self.resolution[axis // 2] * float(np.spacing(abs(lo)))
                        width = max(width, steps)
                    lo, hi = lo - width, hi + width
                axes += [lo, hi]
            ranges.append(axes)
        self.im_ranges_ = np.array(ranges)

    def _compute(self, k, packed, starts, stops):
        points = packed.points
        weights = point_weights(packed, starts, stops, self.weight, self.power)
        bp = np.column_stack([points[:, 0], points[:, 1] - points[:, 0]])
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
