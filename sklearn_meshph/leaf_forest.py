"""Extremely randomized trees whose leaf size is chosen inside the training data, by
out-of-bag accuracy: the graph classifier's last step (a choice made per fit, so a
cross-validation around it stays nested)."""

from __future__ import annotations

import warnings
from numbers import Integral, Real

import numpy as np
from sklearn.base import BaseEstimator
from sklearn.ensemble import ExtraTreesClassifier
from sklearn.utils import check_random_state
from sklearn.utils.validation import check_is_fitted, validate_data

from ._base import ClassifierScoreMixin
from ._param_validation import N_JOBS, Interval, Options, check_params

__all__ = ["LeafSizeForest"]


class _LeafSizes:
    """A non-empty tuple or list of distinct leaf sizes, each an int of at least 1."""

    def __call__(self, value) -> bool:
        if not isinstance(value, tuple | list) or not value:
            return False
        sizes = [v for v in value if isinstance(v, Integral) and not isinstance(v, bool)]
        return len(sizes) == len(value) and min(sizes) >= 1 and len(set(sizes)) == len(sizes)

    def __str__(self) -> str:
        return "a non-empty tuple of distinct ints of at least 1"


def _oob_accuracy(forest, y) -> float:
    """Accuracy of the out-of-bag votes over the samples some tree left out."""
    votes = forest.oob_decision_function_
    voted = votes.sum(axis=1) > 0
    if not voted.any():
        return 0.0
    predicted = forest.classes_[np.argmax(votes[voted], axis=1)]
    return float(np.mean(predicted == y[voted]))


class LeafSizeForest(ClassifierScoreMixin, BaseEstimator):
    """Extremely randomized trees, with the leaf size their out-of-bag votes prefer.

    ``fit`` grows one forest of ``n_estimators`` bootstrapped extremely randomized
    trees per candidate ``min_samples_leaf`` and picks the one whose out-of-bag
    accuracy (each training sample voted on by the trees that did not draw it) is
    highest; ties go to the earlier candidate. With ``bootstrap=False`` (the default)
    it then grows the forest it keeps at that leaf size on every training sample,
    without bootstrap; with ``bootstrap=True`` it keeps the bootstrapped one. The
    choice uses the training samples only, so a cross-validation around the forest is
    nested; it needs no held-out folds, and costs one forest per candidate (and one
    more without bootstrap). Small leaves suit data with near-duplicate samples of the
    same class; larger leaves average noisy labels.

    Parameters
    ----------
    n_estimators : int, default=300
        Trees of each candidate forest.
    min_samples_leaf : tuple of int, default=(1, 5)
        Candidate leaf sizes (distinct, each at least 1).
    max_features : {"sqrt", "log2"}, int, float or None, default="sqrt"
        Features drawn at each split (as ``ExtraTreesClassifier``'s).
    bootstrap : bool, default=False
        Whether the kept forest is the bootstrapped one that won the choice, rather
        than one grown again on every training sample.
    n_jobs : int, default=None
        Parallel jobs of each forest (joblib); the result does not depend on it (the
        probabilities up to rounding).
    random_state : int, RandomState or None, default=None
        Seed of every candidate forest (the same bootstrap draws for each).

    Attributes
    ----------
    forest_ : ExtraTreesClassifier
        The forest kept, at the chosen leaf size.
    min_samples_leaf_ : int
        Its leaf size.
    oob_scores_ : ndarray of shape (n_candidates,)
        The out-of-bag accuracy of each candidate, in ``min_samples_leaf`` order.
    classes_ : ndarray
    n_features_in_ : int

    See Also
    --------
    sklearn_meshph.make_graph_classifier : The graph pipeline it ends.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_meshph.leaf_forest import LeafSizeForest
    >>> rng = np.random.default_rng(0)
    >>> X = rng.normal(size=(60, 3))
    >>> y = (X[:, 0] > 0).astype(int)
    >>> forest = LeafSizeForest(n_estimators=50, random_state=0).fit(X, y)
    >>> forest.min_samples_leaf_ in (1, 5)
    True
    """

    _parameter_constraints: dict = {
        "n_estimators": [Interval(Integral, 1, None, closed="left")],
        "min_samples_leaf": [_LeafSizes()],
        "bootstrap": ["boolean"],
        "max_features": [
            Interval(Integral, 1, None, closed="left"),
            Interval(Real, 0.0, 1.0, closed="right"),
            Options(("sqrt", "log2")),
            None,
        ],
        "n_jobs": N_JOBS,
        "random_state": ["random_state"],
    }

    def __init__(
        self,
        n_estimators=300,
        min_samples_leaf=(1, 5),
        max_features="sqrt",
        bootstrap=False,
        n_jobs=None,
        random_state=None,
    ):
        self.n_estimators = n_estimators
        self.min_samples_leaf = min_samples_leaf
        self.max_features = max_features
        self.bootstrap = bootstrap
        self.n_jobs = n_jobs
        self.random_state = random_state

    def fit(self, X, y):
        """Grow a forest per candidate leaf size; keep the best out of bag.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
        y : array-like of shape (n_samples,)

        Returns
        -------
        self
        """
        check_params(self._parameter_constraints, self.get_params(), type(self).__name__)
        X, y = validate_data(self, X, y)
        seed = self.random_state
        if not isinstance(seed, Integral):  # None or a RandomState: one seed drawn, so
            seed = check_random_state(seed).randint(2**31)  # every candidate draws alike
        forests, scores = [], []
        for leaf in self.min_samples_leaf:
            forest = self._forest(leaf, seed, bootstrap=True)
            with warnings.catch_warnings():
                # Too few trees leave some samples without an out-of-bag vote: they are
                # left out of the accuracy (_oob_accuracy), not counted as wrong.
                warnings.filterwarnings("ignore", "Some inputs do not have OOB scores")
                forests.append(forest.fit(X, y))
            scores.append(_oob_accuracy(forest, y))
        best = int(np.argmax(scores))
        self.min_samples_leaf_ = int(self.min_samples_leaf[best])
        if self.bootstrap:
            self.forest_ = forests[best]
        else:
            self.forest_ = self._forest(self.min_samples_leaf_, seed, bootstrap=False).fit(X, y)
        self.oob_scores_ = np.array(scores)
        self.classes_ = self.forest_.classes_
        return self

    def _forest(self, leaf, seed, *, bootstrap):
        share = self.max_features
        if isinstance(share, Real) and not isinstance(share, Integral):
            share = float(share)  # scikit-learn's forests refuse a NumPy float
        return ExtraTreesClassifier(
            self.n_estimators,
            min_samples_leaf=leaf,
            max_features=share,
            bootstrap=bootstrap,
            oob_score=bootstrap,
            n_jobs=self.n_jobs,
            random_state=seed,
        )

    def predict_proba(self, X):
        """Class probabilities of the chosen forest.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)

        Returns
        -------
        ndarray of shape (n_samples, n_classes)
        """
        check_is_fitted(self, "forest_")
        X = validate_data(self, X, reset=False)
        return self.forest_.predict_proba(X)

    def predict(self, X):
        """Classes of the chosen forest.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)

        Returns
        -------
        ndarray of shape (n_samples,)
        """
        proba = self.predict_proba(X)  # checks that the forest is fitted first
        return self.classes_[np.argmax(proba, axis=1)]

    @property
    def feature_importances_(self):
        """Impurity-based importances of the chosen forest's features."""
        check_is_fitted(self, "forest_")
        return self.forest_.feature_importances_
