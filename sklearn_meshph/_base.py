"""What the estimators share: samples that are meshes, fields or diagrams, not rows."""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence

import numpy as np
from sklearn.base import BaseEstimator, ClassifierMixin, TransformerMixin
from sklearn.utils.validation import validate_data

from ._param_validation import check_params

__all__ = [
    "ObjectOutput",
    "SampleTransformer",
    "as_sample_list",
    "cast_output",
    "median_scale",
]

OUTPUTS = ("default", "pandas", "polars")


def median_scale(matrix) -> float:
    """The median normalization of a distance matrix among the fitted samples.

    The median of its positive finite off-diagonal entries (a median ignores the
    outliers that a maximum or a mean would follow), or 1 when there is none: a
    matrix that separates no fitted pair adds nothing whatever it is divided by.
    """
    matrix = np.asarray(matrix, dtype=np.float64)
    off = matrix[~np.eye(*matrix.shape, dtype=bool)]
    off = off[np.isfinite(off) & (off > 0)]
    if not off.size:
        return 1.0
    half = off.size // 2
    if off.size % 2:
        return float(np.partition(off, half)[half])
    low, high = np.partition(off, [half - 1, half])[half - 1 : half + 1]
    with np.errstate(over="ignore"):
        middle = (low + high) / 2  # np.median's, to the bit
    # Two middle values near the largest float: their sum overflowed (a scale of inf
    # made that part's distances all 0).
    return float(middle if np.isfinite(middle) else low + (high - low) / 2)


def cast_output(values, dtype, what: str) -> np.ndarray:
    """``values`` (float64, one row per sample) in ``dtype``, refused (naming the first
    sample) where a finite entry does not fit it: float32 holds up to about 3.4e38."""
    values = np.asarray(values)
    with np.errstate(over="ignore"):
        cast = values.astype(dtype, copy=False)
    if cast is not values:
        lost = np.isinf(cast) & np.isfinite(values)
        if lost.any():
            i = int(np.flatnonzero(lost.reshape(len(lost), -1).any(axis=1))[0])
            raise ValueError(
                f"sample {i}: its {what} overflow {np.dtype(dtype).name}; rescale the "
                "diagrams, or use dtype='float64'"
            )
    return cast


def as_sample_list(X, what: str = "meshes") -> list:
    """``X`` as a list of samples, refusing a single sample passed by mistake."""
    if isinstance(X, np.ndarray) and X.dtype == object and X.ndim == 1:
        X = list(X)
    if isinstance(X, str | bytes | os.PathLike | np.ndarray) or hasattr(X, "vertices"):
        raise TypeError(
            f"X must be a sequence of {what} (one per sample), got a single "
            f"{type(X).__name__}; wrap it in a list"
        )
    if isinstance(X, Mapping):
        raise TypeError(
            f"X must be a sequence of {what}, got a {type(X).__name__} (iterating it would "
            "give its keys); pass list(X.values()) or list(X.keys())"
        )
    if not isinstance(X, Sequence) and not hasattr(X, "__iter__"):
        raise TypeError(f"X must be a sequence of {what}, got {type(X).__name__}")
    samples = list(X)
    if not samples:
        raise ValueError(f"X is empty: expected at least one of {what}")
    return samples


class ObjectOutput:
    """Mixin of the stages whose output is one object per sample (a scalar field, a set
    of diagrams), not a row of columns.

    Subclasses are declared with ``auto_wrap_output_keys=None``: no output container
    (``set_output``, ``sklearn.set_config(transform_output=...)``) ever wraps their
    output.
    """

    def get_feature_names_out(self, input_features=None):
        """Names of the output columns: none, the output is one object per sample.

        It lets :meth:`sklearn.pipeline.Pipeline.get_feature_names_out` and
        :class:`sklearn.pipeline.FeatureUnion` pass through this stage to the
        vectorizers after it, which name their own columns.

        Parameters
        ----------
        input_features : ignored

        Returns
        -------
        ndarray of str of shape (0,)
        """
        return np.array([], dtype=object)


class SampleTransformer(TransformerMixin, BaseEstimator):
    """Base of the transformers whose samples are meshes, scalar fields or diagrams.

    Subclasses declare ``_parameter_constraints`` and ``_sample_kind`` (the word used in
    error messages); ``fit`` checks the parameters and the samples, and
    ``_check_params`` lets ``transform`` do the same for estimators that learn nothing.
    """

    _sample_kind = "samples"
    _requires_fit = False

    def _check_params(self) -> None:
        check_params(self._parameter_constraints, self.get_params(deep=False), type(self).__name__)

    def set_output(self, *, transform=None):
        """Set the output container of ``transform`` and ``fit_transform``.

        A transformer whose output is a table returns a DataFrame after
        ``set_output(transform="pandas")``. The others (:class:`ObjectOutput`) return
        samples that are not rows (scalar fields, diagrams) and keep them as they are:
        they accept the call so that :meth:`sklearn.pipeline.Pipeline.set_output`, which
        configures every step, works on a pipeline that passes through them.

        Parameters
        ----------
        transform : {"default", "pandas", "polars"}, default=None
            The container of tabular output; ``None`` leaves it unchanged.

        Returns
        -------
        self
        """
        if transform is None:
            return self
        if transform not in OUTPUTS:
            raise ValueError(f"transform must be one of {OUTPUTS} or None, got {transform!r}")
        if not hasattr(self, "_sklearn_output_config"):
            self._sklearn_output_config = {}
        self._sklearn_output_config["transform"] = transform
        return self

    def _check_samples(self, X) -> list:
        return as_sample_list(X, self._sample_kind)

    def fit_transform(self, X, y=None, **fit_params):
        """``fit(X)`` then ``transform(X)``, ``X`` read once (a generator works).

        Parameters
        ----------
        X : iterable of samples
        y : ignored
        **fit_params : passed to ``fit``

        Returns
        -------
        The output of ``transform``.
        """
        samples = as_sample_list(X, self._sample_kind)
        return self.fit(samples, y, **fit_params).transform(samples)

    def fit(self, X, y=None):
        """Check the parameters and the samples; learns nothing unless overridden.

        Parameters
        ----------
        X : sequence of samples
        y : ignored

        Returns
        -------
        self
        """
        self._check_params()
        samples = self._check_samples(X)
        validate_data(self, X=samples, skip_check_array=True, ensure_2d=False)
        return self

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.requires_fit = self._requires_fit
        tags.input_tags.two_d_array = False
        tags.transformer_tags.preserves_dtype = []
        return tags


class ClassifierScoreMixin(ClassifierMixin):
    """scikit-learn's ``ClassifierMixin`` with a ``score`` documented for any samples
    (sequences of meshes or graphs, stacks of distances, rows), whose docstring the
    documentation can render (the inherited one cross-references a page it has not)."""

    def score(self, X, y, sample_weight=None):
        """The accuracy of :meth:`predict` on ``X`` against ``y`` (weighted by
        ``sample_weight``; scikit-learn's ``accuracy_score``).

        Parameters
        ----------
        X : the samples :meth:`predict` takes
        y : array-like of shape (n_samples,)
        sample_weight : array-like of shape (n_samples,), default=None

        Returns
        -------
        float
        """
        return super().score(X, y, sample_weight=sample_weight)
