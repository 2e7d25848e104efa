"""Blocks of features scaled to a common Euclidean size: the feature counterpart of the
distances' median normalization, so that vectorized diagrams of different units can be
concatenated and compared by one Euclidean distance (linear models, nearest-neighbour
indexes)."""

from __future__ import annotations

from numbers import Integral

import numpy as np
from sklearn.base import BaseEstimator, OneToOneFeatureMixin, TransformerMixin
from sklearn.utils.validation import check_is_fitted, validate_data

from .._param_validation import Interval, check_params

__all__ = ["DistanceScaler"]


def _finite_rows(X: np.ndarray) -> np.ndarray:
    finite = np.isfinite(X).all(axis=1)
    if not finite.all():
        row = int(np.flatnonzero(~finite)[0])
        raise ValueError(f"sample {row}: its features hold NaN or infinite values")
    return X


#: Scales below this are computed again on the rescaled block (the variance, their
#: square, is then near or in float64's subnormals).
_SMALL_SCALE = float(np.sqrt(np.finfo(np.float64).tiny)) * 2**26


def _block_scales(X: np.ndarray, n_blocks: int) -> np.ndarray:
    """``sqrt(2 * total variance)`` of each block of columns (1 for a block without
    variance). Where the variance overflows or underflows (features near 1e308 or
    1e-200), it is computed on the block divided by its largest magnitude."""
    with np.errstate(over="ignore", under="ignore", invalid="ignore"):
        scales = np.sqrt(2.0 * X.var(axis=0).reshape(n_blocks, -1).sum(axis=1))
    blocks = X.reshape(len(X), n_blocks, -1)
    for b in np.flatnonzero(~np.isfinite(scales) | (scales < _SMALL_SCALE)):
        top = float(np.abs(blocks[:, b]).max())
        if top == 0:
            continue
        with np.errstate(over="ignore"):
            scales[b] = np.sqrt(2.0 * (blocks[:, b] / top).var(axis=0).sum()) * top
        if not np.isfinite(scales[b]):
            raise ValueError(
                f"block {b}: the root-mean-square distance between the fitted samples "
                "exceeds float64; rescale the features"
            )
    # A block whose rows are all equal has no variance, whatever the rounding of its
    # mean makes of it (constant 0.1 gave 2.8e-17, and rows 3.6e15 after the scaling).
    constant = (blocks == blocks[:1]).all(axis=(0, 2))
    return np.where((scales > 0) & ~constant, scales, 1.0)


class DistanceScaler(OneToOneFeatureMixin, TransformerMixin, BaseEstimator):
    """Divide each block of columns by its root-mean-square distance between fitted rows.

    The columns are split into ``n_blocks`` equal consecutive blocks (a vectorizer's
    diagram positions, such as the times of a heat kernel signature). ``fit`` learns,
    per block, the root mean square of the Euclidean distance between two fitted rows
    drawn independently, ``sqrt(2 * total variance)`` (one pass over the rows: no pairs
    are formed);
    ``transform`` divides each block by it, and the whole by ``sqrt(n_blocks)``. After
    it, every block weighs the same in the squared Euclidean distance, and the whole
    has a root-mean-square distance of 1 between fitted rows, whatever the units of
    its features. A block whose fitted rows are all equal is divided by 1 (it
    separates no fitted pair). Rows are not centred: the transform is a scaling, so
    zero stays zero.

    Parameters
    ----------
    n_blocks : int, default=1
        Number of equal blocks of columns, scaled separately; it must divide the
        number of features.

    Attributes
    ----------
    scales_ : ndarray of shape (n_blocks,)
        The root-mean-square distance of each block among the fitted rows (1 for a
        block without variance).
    n_features_in_ : int
    feature_names_in_ : ndarray of str
        The columns of a fitted DataFrame (only when fitted on one).

    See Also
    --------
    sklearn_meshph.make_mesh_features : the default's diagrams and spectrum as features,
        each part scaled by it.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_meshph import DistanceScaler
    >>> X = np.array([[0.0, 0.0], [2.0, 0.0], [0.0, 200.0]])
    >>> scaler = DistanceScaler(n_blocks=2).fit(X)
    >>> (3 * scaler.scales_).round(6).tolist()  # sqrt(2 * variance) of each column
    [4.0, 400.0]
    >>> (np.sqrt(2) * scaler.transform(X)).round(6).tolist()  # each block / sqrt(2)
    [[0.0, 0.0], [1.5, 0.0], [0.0, 1.5]]
    """

    _parameter_constraints: dict = {"n_blocks": [Interval(Integral, 1, None, closed="left")]}

    def __init__(self, n_blocks=1):
        self.n_blocks = n_blocks

    def fit(self, X, y=None):
        """Learn each block's root-mean-square distance between the rows of ``X``.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
            Finite rows, the fitted samples (a sample with NaN or infinite values is
            refused by its index).
        y : None
            Ignored.

        Returns
        -------
        self
        """
        check_params(self._parameter_constraints, self.get_params(deep=False), "DistanceScaler")
        X = _finite_rows(
            validate_data(self, X, dtype=np.float64, ensure_all_finite=False, reset=True)
        )
        n_features = X.shape[1]
        if n_features % self.n_blocks:
            raise ValueError(
                f"n_blocks={self.n_blocks} does not divide the {n_features} features into "
                "equal blocks"
            )
        self.scales_ = _block_scales(X, self.n_blocks)
        return self

    def transform(self, X):
        """Divide each block by its learned scale, and the whole by ``sqrt(n_blocks)``.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)

        Returns
        -------
        ndarray of shape (n_samples, n_features)
        """
        check_is_fitted(self, "scales_")
        X = _finite_rows(
            validate_data(self, X, dtype=np.float64, ensure_all_finite=False, reset=False)
        )
        divisors = np.repeat(self.scales_, X.shape[1] // len(self.scales_))
        with np.errstate(over="ignore"):
            scaled = X / (divisors * np.sqrt(len(self.scales_)))
        bad = ~np.isfinite(scaled).all(axis=1)
        if bad.any():
            raise ValueError(
                f"sample {int(np.flatnonzero(bad)[0])}: its features divided by the fitted "
                "scales overflow float64 (they are far larger than the fitted samples')"
            )
        return scaled
