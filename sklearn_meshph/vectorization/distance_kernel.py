"""DistanceKernel: the kernel of precomputed distances, ``exp(-d / (2 sigma^2))`` per
diagram position, combined; the cheap stage whose bandwidths a grid search varies
while the distances stay computed once."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from sklearn.base import ClassNamePrefixFeaturesOutMixin
from sklearn.utils.validation import check_is_fitted

from .._base import SampleTransformer, median_scale
from .._param_validation import Options
from ._base import (
    BANDWIDTH,
    COMBINATIONS,
    COMBINE_PARAMETERS,
    PER_POSITION,
    combine_positions,
    position_bandwidths,
    position_weights,
)

__all__ = ["DistanceKernel"]


class DistanceKernel(ClassNamePrefixFeaturesOutMixin, SampleTransformer):
    __doc__ = f"""Kernel of precomputed distances between samples: ``exp(-d_k / (2 sigma_k^2))``
    for each diagram position ``k``, combined into one kernel matrix.

    Made for the per-position distances of :class:`PerDiagramDistance` (or
    :func:`pairwise_diagram_distances` with ``per_diagram=True``): with the sliced
    Wasserstein distance, each position's kernel is the sliced Wasserstein kernel of
    Carrière, Cuturi & Oudot (2017). The distances are computed once; this stage only
    takes exponentials, so a grid search over its bandwidths (and the classifier's
    parameters) costs almost nothing more per candidate. ``fit`` takes the square
    distances of the fitted samples (and learns the positions' scales with
    ``normalization="median"``); ``transform`` the ``(n_samples, n_fitted)`` distances to
    them, and returns the ``(n_samples, n_fitted)`` kernel, ready for
    ``SVC(kernel="precomputed")``.

    Parameters
    ----------
    bandwidth : float or array-like of shape (n_diagrams,), default=1.0
        The scale ``sigma`` of ``exp(-d / (2 sigma^2))``, in the distances' units (or in
        their medians' with ``normalization="median"``); a sequence gives each diagram
        position its own. Neither so small that its square underflows nor so large
        that the Gaussian's peak does.
    normalization : {{"none", "median"}}, default="none"
        ``"median"``: each position's distances are first divided by their median over
        the fitted pairs (its positive finite off-diagonal distances; 1 if there is
        none), learned by ``fit`` (``scales_``), so that one bandwidth suits positions
        on different scales and a grid of bandwidths is a grid of ratios to the data's
        typical distance.
    {COMBINE_PARAMETERS.format(default="product")}

    Attributes
    ----------
    n_diagrams_ : int
        Diagram positions (the last axis of a 3-d input; 1 for a matrix).
    n_features_in_ : int
        Number of fitted samples: the columns ``transform`` expects and returns (as
        for scikit-learn's pairwise estimators).
    scales_ : ndarray of shape (n_diagrams,)
        The divisor of each position's distances (all 1 with ``normalization="none"``).

    See Also
    --------
    PerDiagramDistance : The distances this kernel is made of.
    SlicedWassersteinKernel : The same kernel from the diagrams, in one stage.

    Notes
    -----
    The input is ``(n_samples, n_fitted)`` (one position: e.g. :class:`DiagramDistance`'s
    output) or ``(n_samples, n_fitted, n_diagrams)``; distances must be non-negative or
    ``inf`` (kernel value 0: the sliced Wasserstein distance between diagrams of
    different numbers of essential points). The estimator is pairwise in scikit-learn's
    sense: as the first step of a pipeline, a cross-validation slices a precomputed
    stack of all the samples into the folds' blocks (rows and columns), so the
    distances are computed once for every fold and candidate.

    With the sliced Wasserstein distance the kernel is positive semi-definite for any
    bandwidths, weights and combination: each ``exp(-SW_k / (2 sigma_k^2))`` is (SW is
    conditionally negative definite), and so are their non-negative sums and their
    products. Its ``"product"`` with one bandwidth is :class:`SlicedWassersteinKernel`
    (to rounding: it multiplies the positions' exponentials, the kernel takes one
    exponential of their summed exponents).

    Examples
    --------
    Two samples of two diagrams each, at sliced Wasserstein distances 1 (first
    diagrams) and 2 (second diagrams), each position with its own bandwidth:

    >>> import numpy as np
    >>> from sklearn_meshph import DistanceKernel
    >>> stack = np.array([[[0.0, 0.0], [1.0, 2.0]], [[1.0, 2.0], [0.0, 0.0]]])
    >>> kernel = DistanceKernel(bandwidth=[1.0, 2.0], combine="mean")
    >>> kernel.fit_transform(stack).round(3)
    array([[1.   , 0.693],
           [0.693, 1.   ]])

    The search over the bandwidths of a pipeline starting with this kernel slices a
    precomputed stack of all the samples (:func:`pairwise_diagram_distances` with
    ``per_diagram=True``) into the folds' blocks; see :class:`PerDiagramDistance` for a
    pipeline from the diagrams.
    """

    _requires_fit = True
    _parameter_constraints: dict = {
        "bandwidth": [*BANDWIDTH, PER_POSITION],
        "normalization": [Options(("none", "median"))],
        "combine": [Options(COMBINATIONS)],
        "diagram_weights": [PER_POSITION, None],
    }

    def __init__(
        self, bandwidth=1.0, normalization="none", combine="product", diagram_weights=None
    ):
        self.bandwidth = bandwidth
        self.normalization = normalization
        self.combine = combine
        self.diagram_weights = diagram_weights

    def fit(self, X, y=None):
        """Learn the number of fitted samples, of diagram positions and their scales.

        Parameters
        ----------
        X : array-like of shape (n, n) or (n, n, n_diagrams)
            The distances between the fitted samples (per diagram position).
        y : ignored

        Returns
        -------
        self
        """
        self._check_params()
        distances = _distances(X)
        n, m, n_diagrams = distances.shape
        if n != m:
            raise ValueError(
                f"fit takes the square distances between the fitted samples, got shape "
                f"{np.shape(X)}"
            )
        position_bandwidths(self.bandwidth, n_diagrams)  # refused at fit, not later
        position_weights(self.diagram_weights, self.combine, n_diagrams)
        self.n_diagrams_, self.n_features_in_ = n_diagrams, n
        self.scales_ = np.ones(n_diagrams)
        if self.normalization == "median":
            self.scales_ = np.array([median_scale(distances[:, :, k]) for k in range(n_diagrams)])
        return self

    def transform(self, X):
        """The kernel of the samples of ``X`` with the fitted samples.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_fitted) or (n_samples, n_fitted, n_diagrams)
            The samples' distances to the fitted samples (per diagram position).

        Returns
        -------
        ndarray of shape (n_samples, n_fitted)
        """
        check_is_fitted(self, "n_features_in_")
        self._check_params()
        distances = _distances(X)
        expected = (self.n_features_in_, self.n_diagrams_)
        if distances.shape[1:] != expected:
            raise ValueError(
                f"X has shape {np.shape(X)}: expected {self.n_features_in_} columns (the fitted "
                f"samples) and {self.n_diagrams_} diagram positions"
            )
        bandwidths = position_bandwidths(self.bandwidth, self.n_diagrams_)
        weights = position_weights(self.diagram_weights, self.combine, self.n_diagrams_)
        kernels = (
            np.exp(-(distances[:, :, k].astype(np.float64) / scale) / (2.0 * b * b))
            for k, (b, scale) in enumerate(zip(bandwidths, self.scales_, strict=True))
        )
        return combine_positions(kernels, self.combine, weights)

    def fit_transform(self, X, y=None):
        """Fit on the fitted samples' square distances and return their kernel.

        Parameters
        ----------
        X : array-like of shape (n, n) or (n, n, n_diagrams)
        y : ignored

        Returns
        -------
        ndarray of shape (n, n)
        """
        return self.fit(X).transform(X)

    @property
    def _n_features_out(self) -> int:
        return self.n_features_in_

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.input_tags.pairwise = True
        return tags


def _distances(X) -> np.ndarray:
    """``X`` as an ``(n, m, n_diagrams)`` array of distances (float32 kept: a large stack
    is not copied), refused (naming the sample) when not 2-d or 3-d, sparse, negative or
    NaN."""
    if sp.issparse(X):
        raise TypeError("X must be a dense array of distances, got a sparse matrix")
    try:
        distances = np.asarray(X)
    except ValueError as error:  # rows of different lengths
        raise ValueError(f"X must be a rectangular array of distances: {error}") from error
    if distances.dtype.kind not in "iuf":
        raise TypeError(f"X must hold real distances, got an array of dtype {distances.dtype}")
    if distances.dtype not in (np.float32, np.float64):
        distances = distances.astype(np.float64)
    if distances.ndim not in (2, 3) or 0 in distances.shape:
        raise ValueError(
            "X must be distances of shape (n_samples, n_fitted) or (n_samples, n_fitted, "
            f"n_diagrams), none empty, got shape {distances.shape}"
        )
    distances = distances.reshape(*distances.shape[:2], -1)
    bad = np.isnan(distances) | (distances < 0)
    if bad.any():
        i, j, k = (int(v) for v in np.argwhere(bad)[0])
        raise ValueError(
            f"sample {i}: its distance to fitted sample {j} (diagram position {k}) is "
            f"{float(distances[i, j, k])!r}; distances must be non-negative (or inf)"
        )
    return distances
