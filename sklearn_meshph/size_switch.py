"""SizeSwitchClassifier: one classifier for small training sets, another for large
ones, chosen at each fit by the number of training samples (the graph classifier's
last step: a kernel SVM whose cost grows as the square of the training graphs, trees
above a size)."""

from __future__ import annotations

from copy import deepcopy
from numbers import Integral

import numpy as np
import scipy.sparse as sp
from sklearn.base import BaseEstimator, clone
from sklearn.utils import get_tags
from sklearn.utils.metaestimators import available_if
from sklearn.utils.validation import check_is_fitted

from ._base import ClassifierScoreMixin
from ._param_validation import HasMethods, Interval, check_params

__all__ = ["SizeSwitchClassifier"]


def _n_samples(X) -> int:
    """The number of samples of ``X``: its first axis, or its length."""
    shape = getattr(X, "shape", None)
    if shape is not None and len(shape) > 0:
        return int(shape[0])
    if shape is not None:
        raise TypeError("SizeSwitchClassifier takes samples along a first axis, got a 0-d array")
    if hasattr(X, "__len__"):
        return len(X)
    if hasattr(X, "__array__"):
        shape = np.asarray(X).shape
        return int(shape[0]) if shape else 0
    raise TypeError(
        f"SizeSwitchClassifier takes a sequence or an array-like of samples, got {type(X).__name__}"
    )


def _chosen_has(name: str):
    """``available_if`` test: the fitted estimator has ``name`` (before ``fit``, one of
    the candidates has it: which one a fit chooses is not known yet, and a wrapper such
    as ``CalibratedClassifierCV`` asks before fitting)."""

    def check(self) -> bool:
        if hasattr(self, "estimator_"):
            return hasattr(self.estimator_, name)
        return hasattr(self.small, name) or hasattr(self.large, name)

    return check


class SizeSwitchClassifier(ClassifierScoreMixin, BaseEstimator):
    """A clone of ``small`` fitted when there are at most ``max_small_samples`` training
    samples, of ``large`` otherwise.

    For a classifier whose fit costs the square of the training samples or more (a
    kernel method on precomputed distances) with a cheaper one to take over on large
    training sets. The choice depends on the number of training samples only, so a
    cross-validation around it stays nested (each fit chooses on its own training
    samples). Predictions go through the chosen estimator ``batch_size`` samples at a
    time, which bounds the memory of a pairwise estimator (a block of distances to the
    training samples per batch) and changes no prediction (each sample's is its own).

    Parameters
    ----------
    small : classifier, default=None
        Fitted (a clone) on at most ``max_small_samples`` training samples. Required.
    large : classifier, default=None
        Fitted (a clone) on more. Required.
    max_small_samples : int, default=2000
        The largest training set ``small`` is fitted on.
    batch_size : int, default=1000
        Samples predicted at a time.

    Attributes
    ----------
    estimator_ : estimator
        The fitted clone of ``small`` or ``large``.
    chosen_ : {"small", "large"}
        Which one.
    classes_ : ndarray
        The classes (the fitted estimator's).
    n_features_in_, feature_names_in_
        The fitted estimator's, when it has them.

    See Also
    --------
    sklearn_meshph.make_graph_classifier : The graph pipeline it ends
        (``classifier="auto"``).

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn.neighbors import KNeighborsClassifier
    >>> from sklearn.tree import DecisionTreeClassifier
    >>> from sklearn_meshph.size_switch import SizeSwitchClassifier
    >>> X = np.arange(20.0).reshape(-1, 1)
    >>> y = (X[:, 0] > 9).astype(int)
    >>> model = SizeSwitchClassifier(KNeighborsClassifier(3), DecisionTreeClassifier(),
    ...                              max_small_samples=10)
    >>> model.fit(X, y).chosen_
    'large'
    >>> model.fit(X[5:15], y[5:15]).chosen_
    'small'
    """

    _parameter_constraints: dict = {
        "small": [HasMethods(["fit", "predict"])],
        "large": [HasMethods(["fit", "predict"])],
        "max_small_samples": [Interval(Integral, 0, None, closed="left")],
        "batch_size": [Interval(Integral, 1, None, closed="left")],
    }

    def __init__(self, small=None, large=None, max_small_samples=2000, batch_size=1000):
        self.small = small
        self.large = large
        self.max_small_samples = max_small_samples
        self.batch_size = batch_size

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        if hasattr(self.small, "__sklearn_tags__"):
            # What the candidates read (graphs, stacks, arrays): the small one's word.
            tags.input_tags = deepcopy(get_tags(self.small).input_tags)
            if hasattr(self.large, "__sklearn_tags__"):
                # Missing values only where both candidates take them.
                tags.input_tags.allow_nan &= get_tags(self.large).input_tags.allow_nan
        return tags

    def fit(self, X, y, **fit_params):
        """Fit a clone of ``small`` or ``large``, by the number of samples of ``X``.

        Parameters
        ----------
        X : sequence or array-like of n_samples samples
            What the candidates read.
        y : array-like of shape (n_samples,)
        **fit_params
            Passed to the chosen estimator's ``fit``.

        Returns
        -------
        self
        """
        check_params(self._parameter_constraints, self.get_params(deep=False), type(self).__name__)
        chosen = "small" if _n_samples(X) <= self.max_small_samples else "large"
        template = self.small if chosen == "small" else self.large
        fitted = clone(template).fit(X, y, **fit_params)
        if not hasattr(fitted, "classes_"):
            raise TypeError(
                f"SizeSwitchClassifier's {chosen!r} estimator ({type(template).__name__}) "
                "is not a classifier: it has no classes_ once fitted"
            )
        # Set together once the fit succeeded: a failed refit leaves the last fit whole.
        self.estimator_, self.chosen_, self.classes_ = fitted, chosen, fitted.classes_
        return self

    @property
    def n_features_in_(self):
        """The fitted estimator's (an ``AttributeError`` when it has none)."""
        return self.estimator_.n_features_in_

    @property
    def feature_names_in_(self):
        """The fitted estimator's (an ``AttributeError`` when it has none)."""
        return self.estimator_.feature_names_in_

    def _batched(self, method: str, X):
        check_is_fitted(self, "estimator_")
        call = getattr(self.estimator_, method)
        n_samples = _n_samples(X)
        if n_samples <= self.batch_size:
            return call(X)
        if sp.issparse(X):
            X = X.tocsr()  # rows sliced (a COO matrix has no slices)
        elif hasattr(X, "iloc"):
            X = X.iloc  # a DataFrame's rows by position
        elif not hasattr(X, "__getitem__"):
            X = np.asarray(X)  # an array-like with no slices of its own
        return np.concatenate(
            [
                call(X[start : start + self.batch_size])
                for start in range(0, n_samples, self.batch_size)
            ]
        )

    def predict(self, X):
        """Classes of the fitted estimator, ``batch_size`` samples at a time.

        Parameters
        ----------
        X : sequence or array-like of n_samples samples

        Returns
        -------
        ndarray of shape (n_samples,)
        """
        return self._batched("predict", X)

    @available_if(_chosen_has("predict_proba"))
    def predict_proba(self, X):
        """Class probabilities of the fitted estimator (when it gives them).

        Parameters
        ----------
        X : sequence or array-like of n_samples samples

        Returns
        -------
        ndarray of shape (n_samples, n_classes)
        """
        return self._batched("predict_proba", X)

    @available_if(_chosen_has("decision_function"))
    def decision_function(self, X):
        """Decision values of the fitted estimator (when it gives them).

        Parameters
        ----------
        X : sequence or array-like of n_samples samples

        Returns
        -------
        ndarray of shape (n_samples,) or (n_samples, n_classes)
        """
        return self._batched("decision_function", X)
