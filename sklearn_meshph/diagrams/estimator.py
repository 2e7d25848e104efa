"""The base of the transformers whose samples are persistence diagrams: one documented
``fit``, ``transform`` and ``fit_transform`` for the distances, the kernels and the
vectorizers, each subclass saying what fitting learns and what a sample gives."""

from __future__ import annotations

from sklearn.utils.validation import check_is_fitted

from .._base import SampleTransformer

__all__ = ["DiagramTransformer"]


class DiagramTransformer(SampleTransformer):
    """Base of the transformers of samples of diagrams (one ``(n, 2)`` array or a tuple
    of them, as :class:`LowerStarPersistence` returns).

    Subclasses define ``_fit(X)`` (validate and learn; return what ``_fit_output``
    needs), ``_fit_output(fitted)`` (the output for the fitted samples themselves),
    ``_validate(X)`` (samples checked against the fitted ones) and ``_output(samples)``
    (the output for validated samples); ``fit_transform`` validates ``X`` once.
    """

    _sample_kind = "diagrams"
    _requires_fit = True

    def fit(self, X, y=None):
        """Validate the samples and learn from them what ``transform`` needs.

        Parameters
        ----------
        X : sequence of diagrams or of tuples of diagrams
            Each sample an ``(n, 2)`` array of (birth, death) rows or a tuple of them,
            all samples with the same number of diagrams.
        y : ignored

        Returns
        -------
        self
        """
        self._fit(X)
        return self

    def transform(self, X):
        """One row per sample of ``X``: its features, or its values with each fitted
        sample (distances, kernel values).

        Parameters
        ----------
        X : sequence of diagrams or of tuples of diagrams
            With as many diagrams per sample as the fitted samples.

        Returns
        -------
        ndarray of shape (len(X), n_features_out)
        """
        check_is_fitted(self)
        return self._output(self._validate(X))

    def fit_transform(self, X, y=None):
        """Fit, and return the output for ``X`` itself, validating ``X`` once (for
        distances and kernels: the symmetric matrix, each pair computed once).

        Parameters
        ----------
        X : sequence of diagrams or of tuples of diagrams
        y : ignored

        Returns
        -------
        ndarray of shape (len(X), n_features_out)
        """
        return self._fit_output(self._fit(X))
