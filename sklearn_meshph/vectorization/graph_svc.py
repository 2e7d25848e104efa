"""KernelSumSVC: a support vector classifier on a sum of kernels of precomputed
distances, which kernels to sum and its ``C`` chosen by cross-validation inside each
fit (on the training samples only)."""

from __future__ import annotations

import itertools
from numbers import Integral, Real

import numpy as np
from sklearn.base import BaseEstimator
from sklearn.model_selection import KFold
from sklearn.svm import SVC
from sklearn.utils.multiclass import check_classification_targets
from sklearn.utils.validation import check_is_fitted, check_random_state

from .._base import ClassifierScoreMixin, median_scale
from .._param_validation import Interval, Numbers, Options, check_params
from ._base import BANDWIDTH

__all__ = ["KernelSumSVC"]

#: Elements of the stack whose exponentials are taken at once (64 MB of float64).
_KERNEL_BLOCK = 1 << 23
# Groups of positions at most: every non-empty sum of them is a candidate (2**8 - 1 =
# 255 sums, each cross-validated for every C).
MAX_GROUPS = 8


class KernelSumSVC(ClassifierScoreMixin, BaseEstimator):
    """SVM on a sum of kernels of distances, the kernels summed and ``C`` chosen by
    cross-validation on the training samples.

    The input is a stack of distances, ``(n_samples, n_fitted, n_positions)`` (as
    :class:`GraphPairDistances` or :class:`PerDiagramDistance` return; a matrix is one
    position). Each position ``k`` gives the kernel ``exp(-d_k / (2 bandwidth^2 m_k))``
    with ``m_k`` the median of its distances among the training samples; the positions
    of a group are averaged into the group's kernel. ``fit`` tries every non-empty set
    of groups (their kernels summed) with every ``C``, by ``cv``-fold shuffled
    cross-validation on the training samples (on a random subset of at most
    ``max_selection_samples`` of them), keeps the best (the first on ties), and fits an
    ``SVC(kernel="precomputed")`` with it on all the training samples. So nothing is
    chosen by looking at the samples a cross-validation of this estimator tests.

    Parameters
    ----------
    groups : sequence of int, "graph" or None, default=None
        The group of each position (``None``: each position is its own group). Every
        non-empty sum of groups is a candidate, so at most ``MAX_GROUPS`` (8: 255
        sums) groups are allowed; a stack with more positions needs ``groups``.
        ``"graph"``: the layout of :class:`GraphPairDistances`, every position but the
        last three (the diagrams, however many signatures) in one group, the patterns
        in a second, the nodes' discrepancy and the features in a third (their two
        kernels averaged); it follows a change of the signatures' times.
    bandwidth : float, default=1.0
        ``sigma`` of the positions' kernels, in units of their median distance.
    C : sequence of float, default=(1.0, 10.0, 100.0)
        Candidate regularizations of the SVM.
    cv : int, default=5
        Folds of the internal cross-validation (one per sample, leave-one-out, when
        there are fewer samples than that).
    max_selection_samples : int, default=1000
        At most this many training samples (drawn at random) choose the kernels and
        ``C``; the SVM kept is fitted on all of them.
    random_state : int, RandomState or None, default=0
        Seed of the internal folds and of the subset.

    Attributes
    ----------
    classes_ : ndarray
        The classes.
    scales_ : ndarray of shape (n_positions,)
        The median distance of each position among the training samples.
    weights_ : ndarray of shape (n_groups,)
        1 for the groups summed, 0 for the others.
    C_ : float
        The ``C`` chosen.
    cv_scores_ : dict
        Mean internal accuracy of each candidate, keyed by ``(weights, C)``.
    svc_ : sklearn.svm.SVC
        The fitted SVM.
    n_features_in_ : int
        Number of training samples (the columns ``predict`` expects).

    See Also
    --------
    GraphPairDistances : The distances between graphs this is made for.
    DistanceKernel : One kernel of such stacks, for a grid search by hand.
    """

    _parameter_constraints = {
        "groups": [tuple, list, np.ndarray, Options(("graph",)), None],
        "bandwidth": BANDWIDTH,
        "C": [Numbers()],
        "cv": [Interval(Integral, 2, None, closed="left")],
        "max_selection_samples": [Interval(Integral, 2, None, closed="left")],
        "random_state": ["random_state"],
    }

    def __init__(
        self,
        groups=None,
        bandwidth=1.0,
        C=(1.0, 10.0, 100.0),
        cv=5,
        max_selection_samples=1000,
        random_state=0,
    ):
        self.groups = groups
        self.bandwidth = bandwidth
        self.C = C
        self.cv = cv
        self.max_selection_samples = max_selection_samples
        self.random_state = random_state

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.input_tags.pairwise = True
        # A stack of distances (as DistanceKernel's input), not rows of features.
        tags.input_tags.two_d_array = False
        tags.input_tags.three_d_array = True
        return tags

    def _stack(self, X, n_fitted=None) -> np.ndarray:
        """``X`` as a 3-d stack of valid distances, rows named in the errors."""
        X = np.asarray(X, dtype=np.float64)
        if X.ndim == 2:
            X = X[:, :, None]
        if X.ndim != 3:
            raise ValueError(f"X must be a 2-d or 3-d stack of distances, got {X.ndim} dims")
        columns = X.shape[0] if n_fitted is None else n_fitted
        if X.shape[1] != columns:
            raise ValueError(
                f"X has {X.shape[1]} columns, expected {columns} "
                + ("(a square stack)" if n_fitted is None else "(the training samples)")
            )
        if n_fitted is not None and X.shape[2] != len(self.scales_):
            raise ValueError(f"X has {X.shape[2]} positions, fitted {len(self.scales_)}")
        bad = np.isnan(X) | (X < 0)
        if bad.any():
            i, j, k = np.argwhere(bad)[0]
            raise ValueError(
                f"sample {i}: distance {X[i, j, k]} to training sample {j} (position {k}); "
                "distances must be non-negative or inf"
            )
        return X

    def _groups(self, n_positions) -> np.ndarray:
        if self.groups is None:
            return np.arange(n_positions)
        if isinstance(self.groups, str):
            if n_positions < 4:
                raise ValueError(
                    f'groups="graph" needs at least 4 positions (diagrams, patterns, '
                    f"nodes, features), the stack has {n_positions}"
                )
            return np.r_[np.zeros(n_positions - 3, dtype=np.intp), 1, 2, 2]
        groups = np.asarray(self.groups)
        if groups.shape != (n_positions,) or not np.issubdtype(groups.dtype, np.integer):
            raise ValueError(f"groups must give an int to each of the {n_positions} positions")
        return np.unique(groups, return_inverse=True)[1]

    def _kernels(self, X) -> np.ndarray:
        """The ``(n, m, n_groups)`` kernels of the groups (one pass over the stack, a
        block of rows at a time: the exponentials of all the positions at once would be
        another copy of the stack, 1.6 GB for 3,700 graphs and 15 positions)."""
        average = np.zeros((len(self.group_of_), self.n_groups_))
        average[np.arange(len(self.group_of_)), self.group_of_] = 1.0
        average /= np.bincount(self.group_of_)
        out = np.empty((X.shape[0], X.shape[1], self.n_groups_))
        rows = max(1, _KERNEL_BLOCK // max(1, X.shape[1] * X.shape[2]))
        for start in range(0, X.shape[0], rows):
            # d / m first, then / (2 bandwidth^2): the product 2 bandwidth^2 m underflows
            # to 0 for a small bandwidth and small distances (0 / -0.0 is NaN). With the
            # default bandwidth of 1 the two orders give the same bits (powers of two).
            with np.errstate(over="ignore"):  # far pairs at a tiny bandwidth: -inf, kernel 0
                scaled = X[start : start + rows] / self.scales_
                scaled /= -2.0 * self.bandwidth**2
            out[start : start + rows] = np.exp(scaled, out=scaled) @ average
        return out

    def fit(self, X, y):
        """Choose the kernels and ``C`` by internal cross-validation, fit the SVM.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_samples, n_positions) or (n, n)
            Distances between the training samples.
        y : array-like of shape (n_samples,)

        Returns
        -------
        self
        """
        check_params(self._parameter_constraints, self.get_params(deep=False), "KernelSumSVC")
        # not (c > 0) also refuses NaN, which SVC would report as its own C's fault
        if len(self.C) == 0 or any(
            isinstance(c, bool) or not isinstance(c, Real) or not (0 < c < np.inf) for c in self.C
        ):
            raise ValueError(
                f"C must be a non-empty sequence of positive finite numbers, got {self.C}"
            )
        X = self._stack(X)
        y = np.asarray(y)
        check_classification_targets(y)
        if len(y) != len(X):
            raise ValueError(f"X has {len(X)} samples, y has {len(y)}")
        if len(y) < 2:
            raise ValueError(
                f"{len(y)} training sample: the internal cross-validation needs at least 2"
            )
        self.group_of_ = self._groups(X.shape[2])
        self.n_groups_ = self.group_of_.max() + 1
        if self.n_groups_ > MAX_GROUPS:
            raise ValueError(
                f"{self.n_groups_} groups of positions: their {2**self.n_groups_ - 1} "
                f"sums would each be cross-validated; at most {MAX_GROUPS} groups are "
                'allowed. Pass groups (groups="graph" for a GraphPairDistances stack)'
            )
        self.scales_ = np.array([median_scale(X[:, :, k]) for k in range(X.shape[2])])
        kernels = self._kernels(X)
        rng = check_random_state(self.random_state)
        chosen = np.arange(len(y))
        if len(y) > self.max_selection_samples:
            chosen = np.sort(rng.choice(len(y), self.max_selection_samples, replace=False))
        # Fewer samples than folds: leave-one-out (a fit on a handful of samples works).
        n_folds = min(self.cv, len(chosen))
        folds = list(KFold(n_folds, shuffle=True, random_state=rng).split(chosen))
        self.cv_scores_ = {}
        for weights in itertools.product((0, 1), repeat=self.n_groups_):
            if not any(weights):
                continue
            kernel = kernels[np.ix_(chosen, chosen)] @ np.array(weights, dtype=np.float64)
            for c in self.C:
                self.cv_scores_[weights, c] = np.mean(
                    [self._score(kernel, y[chosen], train, test, c) for train, test in folds]
                )
        (weights, self.C_), _ = max(self.cv_scores_.items(), key=lambda item: item[1])
        self.weights_ = np.array(weights, dtype=np.float64)
        self.svc_ = SVC(C=self.C_, kernel="precomputed").fit(kernels @ self.weights_, y)
        self.classes_ = self.svc_.classes_
        self.n_features_in_ = len(y)
        return self

    @staticmethod
    def _score(kernel, y, train, test, c) -> float:
        if len(np.unique(y[train])) < 2:
            return float(np.mean(y[test] == y[train][0]))
        svc = SVC(C=c, kernel="precomputed").fit(kernel[np.ix_(train, train)], y[train])
        return float(np.mean(svc.predict(kernel[np.ix_(test, train)]) == y[test]))

    def _kernel(self, X) -> np.ndarray:
        check_is_fitted(self, "svc_")
        return self._kernels(self._stack(X, self.n_features_in_)) @ self.weights_

    def decision_function(self, X):
        """The SVM's decision function of the samples whose distances to the training
        samples are ``X``, of shape ``(n_samples, n_fitted, n_positions)`` (or a
        matrix)."""
        kernel = self._kernel(X)  # checks that the classifier is fitted first
        return self.svc_.decision_function(kernel)

    def predict(self, X):
        """The classes of the samples whose distances to the training samples are ``X``.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_fitted, n_positions) or (n, n_fitted)

        Returns
        -------
        ndarray of shape (n_samples,)
        """
        kernel = self._kernel(X)  # checks that the classifier is fitted first
        return self.svc_.predict(kernel)
