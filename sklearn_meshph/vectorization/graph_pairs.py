"""GraphPairDistances: the distances between graphs that a sum of kernels is made of
(the sliced Wasserstein distance of each extended diagram, the Weisfeiler-Lehman
patterns' distance, the maximum mean discrepancy of the nodes' signatures, the distance
between the features), stacked per pair."""

from __future__ import annotations

from numbers import Integral, Real

import numpy as np
import scipy.sparse as sp
from scipy.spatial.distance import cdist
from sklearn.utils import check_random_state
from sklearn.utils.validation import check_is_fitted

from .._base import SampleTransformer
from .._param_validation import N_JOBS, Interval, Options
from ..diagrams.distances import MAX_DIRECTIONS
from ..diagrams.per_diagram import PerDiagramDistance
from ..persistence import LowerStarPersistence
from .graph_features import GraphFeatures, wl_labels
from .summaries import DiagramStatistics

# Diagram points of graph signatures at most this long are the rounding of symmetric
# nodes' signatures (up to 1e-14 on the shared TU datasets), not structure: dropped, so
# that a graph's diagrams do not depend on the order of its nodes.
GRAPH_MIN_PERSISTENCE = 1e-11

__all__ = ["GraphPairDistances"]


def _pattern_counts(field, iterations: int):
    """The distinct Weisfeiler-Lehman labels of a graph (iteration-salted) and counts."""
    # The salt of a level wraps modulo 2^64 from level 9 on, as meant: taken in Python
    # ints, so that no overflow warning is raised (an error under -W error).
    labels = [
        np.uint64(level * (2**61 - 1) % 2**64) + values
        for level, values in enumerate(wl_labels(field.edges, field.n_vertices, iterations))
    ]
    return np.unique(np.concatenate(labels), return_counts=True)


def _log_scaled(features: np.ndarray) -> np.ndarray:
    """``sign(x) log(1 + |x|)``: counts, totals and ranges of many orders of magnitude
    brought to comparable spreads, zero and the signs kept."""
    return np.sign(features) * np.log1p(np.abs(features))


def _check_finite(features: np.ndarray) -> np.ndarray:
    """``features``, refused naming the graph if one is not finite (a NaN would make
    every distance of its graph NaN, or every graph's through the statistics)."""
    bad = ~np.isfinite(features)
    if bad.any():
        i, j = np.argwhere(bad)[0]
        raise ValueError(f"graph {i}: feature {j} is {features[i, j]}, not finite")
    return features


def _log_statistics(fitted: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean and standard deviation of the log-scaled ``fitted`` features, the deviation
    ``inf`` where a feature is constant on them (it separates none of them: left out)."""
    logs = _log_scaled(_check_finite(fitted))
    mean, scale = logs.mean(axis=0), logs.std(axis=0)
    return mean, np.where(scale > 1e-12 * (1 + np.abs(mean)), scale, np.inf)


def _standardized_distances(features, fitted, mean, scale) -> np.ndarray:
    """Squared Euclidean distances of the log-scaled features standardized by
    ``mean`` and ``scale``, ``features`` against ``fitted``."""
    _check_finite(features)
    left, right = ((_log_scaled(part) - mean) / scale for part in (features, fitted))
    return cdist(left, right, "sqeuclidean")


def _node_values(field) -> np.ndarray:
    """A graph field's signatures as ``(n_nodes, n_signatures)``."""
    return np.asarray(field.values, dtype=np.float64).reshape(field.n_vertices, -1)


def _mean_embedding(values: np.ndarray, projection: np.ndarray, phases: np.ndarray):
    """The mean over a graph's nodes of their random Fourier features
    ``sqrt(2 / D) cos(x W + b)`` (Rahimi and Recht, NeurIPS 2007): the inner product of
    two graphs' means estimates the mean of the Gaussian kernel over their pairs of
    nodes, so their squared distance estimates the squared maximum mean discrepancy."""
    out = np.zeros(projection.shape[1])
    # A block of nodes at a time: at most about 8 MB of features.
    rows = max(1, (1 << 20) // projection.shape[1])
    for start in range(0, len(values), rows):
        out += np.cos(values[start : start + rows] @ projection + phases).sum(axis=0)
    return out * np.sqrt(2.0 / projection.shape[1]) / len(values)


def _pattern_distances(left, right) -> np.ndarray:
    """``2 - 2 k`` for the normalized Weisfeiler-Lehman kernel ``k`` of each pair: the
    squared distance between the graphs' count vectors scaled to unit length."""
    vocabulary = np.unique(np.concatenate([labels for labels, _ in left + right]))

    def matrix(side):
        rows = np.repeat(np.arange(len(side)), [len(labels) for labels, _ in side])
        cols = np.searchsorted(vocabulary, np.concatenate([labels for labels, _ in side]))
        counts = np.concatenate([counts for _, counts in side]).astype(np.float64)
        m = sp.csr_matrix((counts, (rows, cols)), shape=(len(side), len(vocabulary)))
        return sp.diags(1.0 / np.sqrt(m.multiply(m).sum(axis=1).A1)) @ m

    kernel = (matrix(left) @ matrix(right).T).toarray()
    return np.maximum(2.0 - 2.0 * kernel, 0.0)


class GraphPairDistances(SampleTransformer):
    """Distances between graphs, one matrix per kind, stacked: what
    :class:`KernelSumSVC` turns into a sum of kernels.

    ``fit`` stores the graphs' extended diagrams, features and Weisfeiler-Lehman
    patterns; ``transform(X)`` returns the ``(len(X), n_fitted, n_positions)`` array of
    the distances of each graph of ``X`` to each fitted graph, and ``fit_transform(X)``
    the symmetric stack of ``X`` (each pair computed once). The positions are

    - one per extended diagram (the four kinds of :class:`LowerStarPersistence` with
      ``filtration="extended"`` for each signature): the sliced Wasserstein distance,
      whose ``exp(-d / (2 sigma^2))`` is the sliced Wasserstein kernel;
    - the Weisfeiler-Lehman subtree patterns of the degrees (Shervashidze et al., JMLR
      2011): ``2 - 2 k`` with ``k`` the normalized count kernel (exact patterns,
      ``wl_iterations`` iterations after the degrees);
    - the maximum mean discrepancy of the graphs' nodes, each node the vector of its
      signatures, under the Gaussian kernel ``exp(-|x - x'|^2 / (2 node_bandwidth^2))``:
      the squared distance between the graphs' kernel mean embeddings (the distribution
      of the signatures over the nodes, where the diagrams keep the critical values
      along the edges), estimated with ``n_random_features`` random Fourier features
      drawn from ``random_state`` (the same for every graph);
    - the distance between the features (:class:`DiagramStatistics` of the diagrams
      and :class:`GraphFeatures`): with ``features="standardized"``, the squared
      Euclidean distance of the features log-scaled (``sign(x) log(1 + |x|)``) and
      standardized by the fitted graphs' means and standard deviations (features
      constant on the fitted graphs left out), whose ``exp(-d / (2 sigma^2))`` is a
      Gaussian kernel; with ``features="canberra"``, their Canberra distance, which no
      feature's scale dominates and which learns nothing from the fitted graphs.

    The diagrams', patterns' and nodes' distances of a pair depend on that pair alone; the
    standardized features' depend on the fitted graphs' statistics too. So the stack
    of all the samples gives every fold's by :meth:`fold_stack` (a slice, the features'
    position computed again with the fold's statistics), without recomputing the
    diagrams' distances; with ``features="canberra"`` the slice alone does (a
    cross-validation of a pairwise estimator does that slicing).

    Parameters
    ----------
    n_directions : int, default=10
        Lines of the sliced Wasserstein distance (at most 10,000).
    min_persistence : float, default=1e-11
        Diagram points at most this long are dropped (:class:`LowerStarPersistence`'s
        ``min_persistence``). The signatures of symmetric nodes are equal up to
        rounding (differences up to 1e-14 measured on the shared TU datasets), so
        their points of length near zero would come and go with the nodes' order.
        Above 1e-14 the lengths there are few up to 1e-9 (25 points between 1e-13
        and 1e-11 on MUTAG and PROTEINS, dropped too). :func:`make_graph_classifier`'s
        trees drop the same.
    wl_iterations : int, default=3
        Weisfeiler-Lehman iterations after the degrees.
    node_bandwidth : float, default=0.03
        ``sigma`` of the nodes' Gaussian kernel, in the signatures' units (heat kernel
        signatures of the normalized Laplacian lie in [0, 1]; the median distance
        between two nodes' signatures at t = 0.1, 1 and 10 is 0.027 to 0.049 on the
        shared TU datasets). Fixed, not learned from the fitted graphs, so a pair's
        distance depends on that pair alone.
    n_random_features : int, default=1024
        Random Fourier features of the discrepancy (the estimate's correlation with
        the exact discrepancy was 0.9995 on MUTAG and COX2 with 1,024). Each fitted
        graph keeps this many floats (``embeddings_``: 8 MB per 1,000 graphs at 1,024).
    features : {"standardized", "canberra"}, default="standardized"
        The features' distance (above). Under PersLay's protocol the standardized
        features' kernel gave PROTEINS 75.7 against 74.6 with the Canberra distance and
        IMDB-BINARY 74.0 against 73.4, the other four within 0.2 (``docs/graphs.md``).
    n_jobs : int, default=None
        Parallel jobs of the persistence and the distances (joblib).
    random_state : int, RandomState or None, default=0
        Seed of the random Fourier features.

    Attributes
    ----------
    n_positions_ : int
        The last axis of the output: the diagrams, then the patterns, the nodes'
        discrepancy and the features.
    n_features_in_ : int
        Number of fitted graphs.
    features_ : ndarray of shape (n_fitted, n_features)
        The fitted graphs' features.
    embeddings_ : ndarray of shape (n_fitted, n_random_features)
        The fitted graphs' mean random Fourier features.
    projection_, phases_ : ndarray
        The random Fourier features' frequencies ``(n_signatures, n_random_features)``
        and phases.
    features_mean_, features_scale_ : ndarray of shape (n_features,)
        With ``features="standardized"``: the mean and standard deviation of the
        log-scaled features over the fitted graphs (``inf`` where a feature is constant
        on them: it is left out).

    See Also
    --------
    KernelSumSVC : The classifier of these stacks.
    make_graph_classifier : ``make_graph_classifier(classifier="kernels")`` chains the
        eigen stage, this and :class:`KernelSumSVC`.
    """

    _sample_kind = "graph fields"
    _requires_fit = True  # transform needs the fitted graphs and scales
    _parameter_constraints = {
        "n_directions": [Interval(Integral, 1, MAX_DIRECTIONS, closed="both")],
        "min_persistence": [Interval(Real, 0, None, closed="left")],
        "wl_iterations": [Interval(Integral, 0, 100, closed="both")],
        # Far from the float limits: the frequencies are 1 / node_bandwidth.
        "node_bandwidth": [Interval(Real, 1e-12, 1e12, closed="both")],
        "n_random_features": [Interval(Integral, 1, 100_000, closed="both")],
        "features": [Options(("standardized", "canberra"))],
        "n_jobs": N_JOBS,
        "random_state": ["random_state"],
    }

    def __init__(
        self,
        n_directions=10,
        min_persistence=GRAPH_MIN_PERSISTENCE,
        wl_iterations=3,
        node_bandwidth=0.03,
        n_random_features=1024,
        features="standardized",
        n_jobs=None,
        random_state=0,
    ):
        self.n_directions = n_directions
        self.min_persistence = min_persistence
        self.wl_iterations = wl_iterations
        self.node_bandwidth = node_bandwidth
        self.n_random_features = n_random_features
        self.features = features
        self.n_jobs = n_jobs
        self.random_state = random_state

    def _describe(self, X, fitting: bool):
        """Diagrams, features, and the pattern counts and nodes' mean random features,
        of the graph fields ``X``."""
        if fitting:
            self.graph_ = GraphFeatures().fit(X)
            self.persistence_ = LowerStarPersistence(
                filtration="extended", min_persistence=self.min_persistence, n_jobs=self.n_jobs
            )
            diagrams = self.persistence_.fit_transform(X)
            self.statistics_ = DiagramStatistics(n_jobs=self.n_jobs).fit(diagrams)
        else:
            diagrams = self.persistence_.transform(X)
        features = np.hstack([self.statistics_.transform(diagrams), self.graph_.transform(X)])
        patterns = [_pattern_counts(field, self.wl_iterations) for field in X]
        if fitting:
            rng = check_random_state(self.random_state)
            shape = (_node_values(X[0]).shape[1], self.n_random_features)
            self.projection_ = rng.standard_normal(shape) / self.node_bandwidth
            self.phases_ = rng.uniform(0.0, 2.0 * np.pi, self.n_random_features)
        embeddings = np.array(
            [_mean_embedding(_node_values(f), self.projection_, self.phases_) for f in X]
        )
        return diagrams, features, patterns, embeddings

    def _standardize(self, fitted: np.ndarray) -> None:
        """Learn the log-scaled features' means and scales on the ``fitted`` rows."""
        self.features_mean_, self.features_scale_ = _log_statistics(fitted)

    def _feature_distances(self, features: np.ndarray, fitted: np.ndarray) -> np.ndarray:
        if self.features == "canberra":
            return np.nan_to_num(cdist(features, fitted, "canberra"))
        return _standardized_distances(features, fitted, self.features_mean_, self.features_scale_)

    def _stack(self, sliced, features, patterns, embeddings):
        parts = [
            sliced,
            _pattern_distances(patterns, self.patterns_),
            cdist(embeddings, self.embeddings_, "sqeuclidean"),
            self._feature_distances(features, self.features_),
        ]
        return np.dstack(parts)

    def _indices(self, part, name: str) -> np.ndarray:
        """``part`` as indices of fitted samples (negative ones would wrap silently)."""
        part = np.asarray(part)
        if part.ndim != 1 or not (np.issubdtype(part.dtype, np.integer) or part.size == 0):
            raise ValueError(f"{name} must be a 1-d array of sample indices")
        outside = (part < 0) | (part >= self.n_features_in_)
        if outside.any():
            raise ValueError(
                f"{name}: index {part[outside][0]} is not one of the "
                f"{self.n_features_in_} fitted samples"
            )
        return part.astype(np.intp)

    def fold_stack(self, stack, rows, train) -> np.ndarray:
        """The distances of samples ``rows`` to samples ``train`` that this transformer
        fitted on the samples ``train`` alone would give, from ``stack``, its
        ``fit_transform`` of all its samples (in the same order).

        The diagrams', patterns' and nodes' positions are the slice
        ``stack[rows][:, train]``;
        the features' (standardized by the ``train`` samples' statistics) is computed
        again from ``features_``. This is how a cross-validation of the kernel SVM
        computes the expensive distances once, not once per fold.

        Parameters
        ----------
        stack : ndarray of shape (n_fitted, n_fitted, n_positions_)
        rows, train : array-like of int
            Indices of fitted samples.

        Returns
        -------
        ndarray of shape (len(rows), len(train), n_positions_)
        """
        check_is_fitted(self, "n_positions_")
        stack = np.asarray(stack)
        if stack.shape != (self.n_features_in_, self.n_features_in_, self.n_positions_):
            raise ValueError(
                f"stack has shape {stack.shape}, expected the fitted samples' "
                f"{(self.n_features_in_, self.n_features_in_, self.n_positions_)}"
            )
        rows, train = (
            self._indices(part, name) for part, name in ((rows, "rows"), (train, "train"))
        )
        # The fancy index copies already: no second copy of a 1.5 GB block (NCI1).
        out = np.asarray(stack[np.ix_(rows, train)], dtype=np.float64)
        if self.features == "standardized":
            fitted = self.features_[train]
            statistics = _log_statistics(fitted)
            out[:, :, -1] = _standardized_distances(self.features_[rows], fitted, *statistics)
        return out

    def fit(self, X, y=None):
        """Store the diagrams, features and patterns of the graph fields ``X`` (from
        :class:`LaplacianEigenTransformer`); ``y`` is ignored. Returns ``self``."""
        diagrams = self._fit(X)
        self._fitted(self.sliced_.fit(diagrams))
        return self

    def _fit(self, X):
        self._check_params()
        X = GraphFeatures()._fields(X)
        diagrams, self.features_, self.patterns_, self.embeddings_ = self._describe(X, fitting=True)
        if self.features == "standardized":
            self._standardize(self.features_)
        self.sliced_ = PerDiagramDistance(n_directions=self.n_directions, n_jobs=self.n_jobs)
        self.n_features_in_ = len(X)
        return diagrams

    def _fitted(self, sliced):
        self.n_positions_ = self.sliced_.n_diagrams_ + 3
        return sliced

    def fit_transform(self, X, y=None):
        """Fit, and return the symmetric stack of the fitted graphs.

        Returns
        -------
        ndarray of shape (n_samples, n_samples, n_positions_)
        """
        diagrams = self._fit(X)
        sliced = self._fitted(self.sliced_.fit_transform(diagrams))
        return self._stack(sliced, self.features_, self.patterns_, self.embeddings_)

    def transform(self, X):
        """The distances of each graph of ``X`` to each fitted graph.

        Parameters
        ----------
        X : sequence of ScalarField
            Graph fields with as many signatures as the fitted ones.

        Returns
        -------
        ndarray of shape (n_samples, n_fitted, n_positions_)
        """
        check_is_fitted(self, "n_positions_")
        X = self.graph_._fields(X, self.graph_.n_functions_)
        diagrams, features, patterns, embeddings = self._describe(X, fitting=False)
        return self._stack(self.sliced_.transform(diagrams), features, patterns, embeddings)
