"""Exact nearest neighbours in a fitted collection under a fitted distance pipeline,
pruned by lower bounds, in bounded memory; and 1-NN classification on top."""

from __future__ import annotations

import os
from numbers import Integral

import numpy as np
from numpy.lib.format import open_memmap
from sklearn.base import BaseEstimator, clone
from sklearn.pipeline import Pipeline, make_pipeline
from sklearn.utils import check_random_state
from sklearn.utils.validation import check_is_fitted

from .._base import ClassifierScoreMixin, as_sample_list
from .._param_validation import HasMethods, Interval, Options, check_params
from ..combine import CombinedDistance
from ..pipelines import make_mesh_distance
from .parts import IndexedPart, is_indexable

__all__ = ["ShapeNeighbors", "ShapeNeighborsClassifier"]

# Relative margin under which a lower bound prunes nothing: the bounds and the exact
# distances are rounded differently (float32 matrices too), the answer stays exact.
SLACK = 1e-6


def _split(distance):
    """``(head, metric)``: the steps before the distance (or None) and the distance,
    through nested pipelines (the ``"features"`` preset ends in a pipeline of features
    then their distance)."""
    heads, metric = [], distance
    while isinstance(metric, Pipeline):
        if len(metric.steps) > 1:
            heads.append(metric[:-1])
        metric = metric.steps[-1][1]
    head = None if not heads else heads[0] if len(heads) == 1 else make_pipeline(*heads)
    if not (isinstance(metric, CombinedDistance) or is_indexable(metric)):
        raise TypeError(
            "distance must be a CombinedDistance, DiagramDistance or FeatureDistance, or a "
            f"Pipeline ending in one (as make_mesh_distance() returns), got {type(metric).__name__}"
        )
    if isinstance(metric, CombinedDistance):  # refused before a part is fitted
        weights = metric._fitted_weights()  # all 0 refused there
        for name, part in metric.transformer_list:
            if weights[name] > 0:  # a part of weight 0 is left out
                _final(name, part)
    return head, metric


def _final(name, part):
    """``(stateless steps or None, final step)`` of a part, which must end in an
    indexable distance."""
    stateless, final = None, part
    if isinstance(part, Pipeline):
        final = part.steps[-1][1]
        stateless = part[:-1] if len(part.steps) > 1 else None
    if not is_indexable(final):
        raise TypeError(
            f"part {name!r} ends in a {type(final).__name__}; an index needs "
            "DiagramDistance or FeatureDistance parts"
        )
    return stateless, final


def _fitted_parts(metric):
    """``(name, factor, stateless steps or None, final step)`` of each part of a fitted
    metric with a positive weight; ``factor`` is its weight over its scale (None: a
    metric of one part, taken as it is)."""
    if isinstance(metric, CombinedDistance):
        named = [
            (name, metric.weights_[name] / metric.scales_[name], part)
            for name, part in metric.parts_
            if metric.weights_[name] > 0
        ]
    else:
        named = [("distance", None, metric)]
    return [(name, factor, *_final(name, part)) for name, factor, part in named]


def _total(terms):
    """The sum of the parts' terms, in their order (the fitted metric's own order)."""
    total = None
    for term in terms:
        total = term if total is None else total + term
    return total


def _blocks(n, size):
    return [(start, min(start + size, n)) for start in range(0, n, size)]


def _in_block(function, start, stop):
    """``function(start, stop)``, its errors naming the block of samples they happened in
    (the stages name samples by their index in the block)."""
    try:
        return function(start, stop)
    except ValueError as error:
        raise ValueError(f"samples {start} to {stop - 1} of X: {error}") from error


class _ShapeIndex(BaseEstimator):
    """What :class:`ShapeNeighbors` and :class:`ShapeNeighborsClassifier` share: the
    fitted rows, their bounds, the exact distances and the best-first search."""

    _parameter_constraints: dict = {
        "distance": [HasMethods(["fit", "transform"]), None],
        "n_neighbors": [Interval(Integral, 1, None, closed="left")],
        "scale_samples": [Interval(Integral, 2, None, closed="left"), None],
        "block_size": [Interval(Integral, 1, None, closed="left")],
        "random_state": ["random_state"],
    }

    def __init__(
        self, distance=None, n_neighbors=5, scale_samples=1000, block_size=64, random_state=0
    ):
        self.distance = distance
        self.n_neighbors = n_neighbors
        self.scale_samples = scale_samples
        self.block_size = block_size
        self.random_state = random_state

    def _fit_index(self, X, **state):
        """Index ``X``, with ``state`` (attributes set with the index): all of it, or, if
        any step fails, nothing (a failed refit leaves the last fit whole)."""
        before = dict(self.__dict__)
        try:
            self.__dict__.update(state)
            return self._index(X)
        except BaseException:
            self.__dict__.clear()
            self.__dict__.update(before)
            raise

    def _index(self, X):
        check_params(self._parameter_constraints, self.get_params(deep=False), type(self).__name__)
        distance = make_mesh_distance() if self.distance is None else clone(self.distance)
        head, metric = _split(distance)
        samples = as_sample_list(X, "samples")
        n = len(samples)
        chosen = np.arange(n)
        if self.scale_samples is not None and n > self.scale_samples:
            rng = check_random_state(self.random_state)
            chosen = np.sort(rng.choice(n, self.scale_samples, replace=False))
        inputs = [samples[i] for i in chosen]
        fields = inputs if head is None else head.fit_transform(inputs)
        metric.fit(fields)
        known = dict(zip(chosen.tolist(), fields, strict=True))
        self.distance_, self.scale_indices_, self.n_samples_fit_ = distance, chosen, n
        self._parts_ = [
            (name, factor, stateless, IndexedPart(final, 1.0 if factor is None else factor))
            for name, factor, stateless, final in _fitted_parts(metric)
        ]

        def fields_of(start, stop):  # the chosen samples went through the head already
            missing = [i for i in range(start, stop) if i not in known]
            computed = [samples[i] for i in missing]
            if missing and head is not None:
                computed = head.transform(computed)
            fresh = dict(zip(missing, computed, strict=True))
            return [known[i] if i in known else fresh[i] for i in range(start, stop)]

        self.rows_ = self._part_rows(fields_of, n)
        self._vectors_ = [
            part.fit(self.rows_[name]).embed(self.rows_[name]) for name, _, _, part in self._parts_
        ]
        return self

    def _part_rows(self, fields_of, n):
        """Each part's validated rows of ``n`` samples, by part name, block by block
        (``fields_of(start, stop)``: the head's output for the samples of a block)."""
        rows = {name: [] for name, *_ in self._parts_}

        def through(start, stop):
            block = fields_of(start, stop)
            for name, _, stateless, part in self._parts_:
                out = block if stateless is None else stateless.transform(block)
                rows[name].extend(part.validate(out))

        for start, stop in _blocks(n, self.block_size):
            _in_block(through, start, stop)
        return {
            name: rows[name] if part.diagrams else np.asarray(rows[name], float).reshape(n, -1)
            for name, _, _, part in self._parts_
        }

    def _represent(self, X):
        """Each part's validated rows of the samples ``X``, through the fitted stages."""
        head, _ = _split(self.distance_)
        samples = as_sample_list(X, "samples")

        def fields_of(start, stop):
            return samples[start:stop] if head is None else head.transform(samples[start:stop])

        return self._part_rows(fields_of, len(samples))

    def _term(self, part, query, cols):
        """One part's term of the combined distance of query rows to the fitted samples
        ``cols``: its exact distances times its factor."""
        name, factor, _, indexed = part
        matrix = np.asarray(indexed.exact(query[name], cols), dtype=float)
        return matrix if factor is None else factor * matrix

    def _exact(self, query, cols):
        """The exact ``(n_queries, len(cols))`` distances of query rows to the fitted
        samples ``cols``, the parts combined as the fitted metric combines them."""
        return _total(self._term(part, query, cols) for part in self._parts_)

    def _lower(self, query):
        """Lower bounds of each part's term of the combined distance of query rows to
        every fitted sample: one ``(n_queries, n_fitted)`` array per part."""
        return [
            part.lower(part.embed(query[name]), fitted)
            for (name, _, _, part), fitted in zip(self._parts_, self._vectors_, strict=True)
        ]

    def _stages(self, query):
        """The parts in the order a query computes their exact terms: by the number of
        diagram points of the query (feature parts first), the costliest last."""

        def points(part):
            name, _, _, indexed = part
            return sum(len(d) for d in query[name][0]) if indexed.diagrams else 0

        return sorted(range(len(self._parts_)), key=lambda j: points(self._parts_[j]))

    def _batch(self, query, terms, cols, kth):
        """The exact distances of a query to the candidates ``cols`` that can still be
        among its nearest, and which those are. ``terms`` holds each part's lower bounds
        of the candidates; part by part, cheapest first, the exact terms replace the
        bounds, and a candidate whose bound so tightened exceeds the ``k``-th exact
        distance ``kth`` found so far is dropped before its costlier terms."""
        alive = np.ones(len(cols), dtype=bool)
        for j in self._stages(query):
            if np.isfinite(kth):
                alive &= _total(terms) * (1.0 - SLACK) <= kth
            if not alive.any():
                return np.empty(0), cols[alive]
            terms[j][alive] = self._term(self._parts_[j], query, cols[alive])[0]
        return _total(term[alive] for term in terms), cols[alive]

    def _select(self, query, lower, k, exclude):
        """The ``k`` nearest fitted samples of one query (ties: lowest index) and the
        number of them whose exact distance was computed, best first by lower bound
        (``lower``: each part's lower bounds of the query's terms)."""
        total = _total(lower)
        order = np.argsort(total, kind="stable")
        if exclude is not None:
            order = order[order != exclude]
        n_finite = int(np.sum(np.isfinite(total[order])))
        safe = total[order[:n_finite]] * (1.0 - SLACK)
        distances, indices = [np.empty(0)], [np.empty(0, dtype=np.int64)]
        done, batch, kth = 0, max(8, 2 * k), np.inf  # batches of one size
        while done < n_finite:
            cols = order[done : done + batch]
            found, kept = self._batch(query, [term[cols] for term in lower], cols, kth)
            distances.append(found)
            indices.append(kept)
            done += len(cols)
            if sum(len(d) for d in distances) >= k:
                kth = np.partition(np.concatenate(distances), k - 1)[k - 1]
                if done < n_finite and safe[done] > kth:
                    break
        distances, indices = np.concatenate(distances), np.concatenate(indices)
        if len(distances) < k:  # the samples whose essential points differ in number: at inf
            extra = order[n_finite : n_finite + k - len(distances)]
            distances = np.concatenate([distances, np.full(len(extra), np.inf)])
            indices = np.concatenate([indices, extra])
        best = np.lexsort((indices, distances))[:k]
        return distances[best], indices[best], len(distances)

    def _query(self, X, n_neighbors):
        """``(distances, indices, n_exact)`` of the ``n_neighbors`` nearest fitted samples
        of each sample of ``X`` (``None``: each fitted sample, itself excluded)."""
        check_is_fitted(self, "rows_")
        k = self.n_neighbors if n_neighbors is None else n_neighbors
        available = self.n_samples_fit_ - (X is None)
        if isinstance(k, bool) or not isinstance(k, Integral) or not 1 <= k <= available:
            raise ValueError(
                f"n_neighbors must be an int in [1, {available}] (the fitted samples"
                f"{', less the query' if X is None else ''}), got {k!r}"
            )
        query = self.rows_ if X is None else self._represent(X)
        n_queries = len(next(iter(query.values())))
        distances = np.empty((n_queries, k))
        indices = np.empty((n_queries, k), dtype=np.int64)
        n_exact = np.empty(n_queries, dtype=np.int64)
        for start, stop in _blocks(n_queries, self.block_size):
            block = {name: rows[start:stop] for name, rows in query.items()}
            lower = self._lower(block)
            for i in range(stop - start):
                one = {name: rows[i : i + 1] for name, rows in block.items()}
                exclude = start + i if X is None else None
                found = self._select(one, [term[i] for term in lower], k, exclude)
                distances[start + i], indices[start + i], n_exact[start + i] = found
        return distances, indices, n_exact

    def kneighbors(self, X=None, n_neighbors=None, return_distance=True):
        """The nearest fitted samples of each sample, exact under the fitted distance.

        Parameters
        ----------
        X : sequence of samples or None, default=None
            What ``distance`` takes (meshes for :func:`make_mesh_distance`). ``None``:
            the fitted samples, each one's own index excluded from its neighbours.
        n_neighbors : int or None, default=None
            ``None``: the ``n_neighbors`` of the estimator.
        return_distance : bool, default=True

        Returns
        -------
        distances : ndarray of shape (n_queries, n_neighbors)
            Only when ``return_distance``; ``inf`` for samples whose essential points
            differ in number from the query's.
        indices : ndarray of shape (n_queries, n_neighbors)
            Into the fitted samples, nearest first; equal distances by lowest index.
        """
        distances, indices, _ = self._query(X, n_neighbors)
        return (distances, indices) if return_distance else indices

    def exact_fraction(self, X=None, n_neighbors=None):
        """The fraction of the fitted samples whose exact distance a query computes, every
        part of it (the rest are pruned by their lower bounds, some after the exact terms
        of their cheaper parts): what :meth:`kneighbors` costs.

        Parameters
        ----------
        X, n_neighbors : as for :meth:`kneighbors`

        Returns
        -------
        ndarray of shape (n_queries,)
        """
        return self._query(X, n_neighbors)[2] / self.n_samples_fit_

    def distance_matrix(self, X=None, *, path=None, dtype="float32"):
        """Every exact distance, to a file row block by row block when ``path`` is given.

        For t-SNE and leave-one-out on collections whose matrix does not fit in memory:
        with ``path``, the matrix is a :func:`numpy.lib.format.open_memmap` ``.npy``
        file, and the memory used is one block of ``block_size`` rows of float64 per
        part on top of the fitted rows (docs/scale.md).

        Parameters
        ----------
        X : sequence of samples or None, default=None
            ``None``: the symmetric matrix of the fitted samples, each unordered pair
            computed once (as ``distance.fit_transform`` of the fitted samples returns
            it, when the scales were learned on all of them).
        path : str, path or None, default=None
            Where to write the matrix (an ``.npy`` file, overwritten; anything else at
            that path, such as a FIFO or a device, is refused); ``None``: in memory.
        dtype : {"float32", "float64"}, default="float32"

        Returns
        -------
        ndarray or numpy.memmap of shape (n_queries, n_samples_fit_)
        """
        check_is_fitted(self, "rows_")
        if not Options(("float32", "float64"))(dtype):
            raise ValueError(f"dtype must be 'float32' or 'float64', got {dtype!r}")
        if path is not None and os.path.lexists(path) and not os.path.isfile(path):
            # A FIFO would block or fail as "not seekable", a device be written to.
            raise ValueError(f"path {os.fspath(path)!r} exists and is not a regular file")
        query = self.rows_ if X is None else self._represent(X)
        n_rows, n = len(next(iter(query.values()))), self.n_samples_fit_
        shape = (n_rows, n)
        if path is None:
            out = np.empty(shape, dtype=dtype)
        else:
            out = open_memmap(path, mode="w+", dtype=dtype, shape=shape)
        for start, stop in _blocks(n_rows, self.block_size):
            block = {name: rows[start:stop] for name, rows in query.items()}
            first = start if X is None else 0  # symmetric: the columns from the block on
            values = self._exact(block, np.arange(first, n))
            out[start:stop, first:] = values
            if X is None:
                out[first:, start:stop] = values.T
        if path is not None:
            out.flush()
        return out

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.input_tags.two_d_array = False
        return tags


class ShapeNeighbors(_ShapeIndex):
    """Exact nearest neighbours of shapes in a fitted collection, pruned by lower bounds.

    Like :class:`sklearn.neighbors.NearestNeighbors`, for the precomputed-metric
    pipelines of this package: ``fit`` learns the pipeline's scales (the medians of
    :class:`CombinedDistance` and :class:`DiagramDistance`) and stores each part's
    diagrams or features of the fitted samples, never a matrix of them; ``kneighbors``
    returns the same neighbours as sorting the rows of the fitted pipeline's
    ``transform`` (equal distances by lowest index), computing exact distances only for
    the candidates that cheap lower bounds cannot rule out (best first, until the
    ``k``-th exact distance is at most the next lower bound; within a batch of
    candidates, the exact terms of the cheaper parts first, each tightening the bound
    that may rule a candidate out before its costlier parts).

    Parameters
    ----------
    distance : Pipeline, CombinedDistance, DiagramDistance, FeatureDistance or None, \
            default=None
        The metric: a pipeline ending in a distance stage, as :func:`make_mesh_distance`
        returns (``None``: ``make_mesh_distance()``, the default), whose steps before
        it and before each part's last step transform samples one by one. Each part
        must end in a :class:`DiagramDistance` or a :class:`FeatureDistance`.
    n_neighbors : int, default=5
        Neighbours returned by default.
    scale_samples : int or None, default=1000
        The scales are learned as ``distance.fit`` learns them, on all fitted samples up
        to this many, above it on this many drawn at random (``random_state``): fitting
        the medians costs the distances of all their pairs. ``None``: always all.
    block_size : int, default=64
        Samples transformed together, and queries whose lower bounds are held at once
        (a ``block_size`` by ``n_samples_fit_`` float64 array per part).
    random_state : int, RandomState or None, default=0
        Draws the samples of the scales.

    Attributes
    ----------
    distance_ : Pipeline or estimator
        The fitted clone of ``distance`` (on the samples ``scale_indices_``).
    scale_indices_ : ndarray of int
        The fitted samples the scales were learned on.
    rows_ : dict of str to list or ndarray
        Each part's fitted rows (tuples of diagrams, or features), by part name
        (``"distance"`` for a metric of one part).
    n_samples_fit_ : int

    See Also
    --------
    ShapeNeighborsClassifier : Nearest-neighbour classification on the same index.
    retrieval_scores : The retrieval measures of SHREC from a distance matrix.

    Notes
    -----
    A part of weight 0 is left out. Lower bounds are described in
    :mod:`sklearn_meshph.retrieval.parts`; the fraction of exact distances a query
    computes is :meth:`exact_fraction`; measured costs are in ``docs/scale.md``.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_meshph import DiagramDistance, ShapeNeighbors
    >>> diagrams = [np.array([[0.0, t]]) for t in (1.0, 2.0, 4.0)]
    >>> index = ShapeNeighbors(DiagramDistance("wasserstein", order=1.0), n_neighbors=1)
    >>> index.fit(diagrams).kneighbors([np.array([[0.0, 1.5]])])
    (array([[0.5]]), array([[0]]))
    """

    def fit(self, X, y=None):
        """Learn the scales of ``distance`` and store the rows of every part.

        Parameters
        ----------
        X : sequence of samples
            What ``distance`` takes (meshes for :func:`make_mesh_distance`).
        y : ignored

        Returns
        -------
        self
        """
        return self._fit_index(X)


class ShapeNeighborsClassifier(ClassifierScoreMixin, _ShapeIndex):
    """Nearest-neighbour classification of shapes, exact and pruned
    (:class:`ShapeNeighbors`' index), like :class:`sklearn.neighbors.KNeighborsClassifier`.

    Parameters
    ----------
    distance, scale_samples, block_size, random_state
        As for :class:`ShapeNeighbors`.
    n_neighbors : int, default=1
        Neighbours that vote (uniform weights; a tied vote goes to the first class of
        ``classes_``).

    Attributes
    ----------
    classes_ : ndarray
    distance_, scale_indices_, rows_, n_samples_fit_
        As for :class:`ShapeNeighbors`.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_meshph import DiagramDistance, ShapeNeighborsClassifier
    >>> diagrams = [np.array([[0.0, t]]) for t in (1.0, 1.2, 4.0, 4.5)]
    >>> model = ShapeNeighborsClassifier(DiagramDistance()).fit(diagrams, ["a", "a", "b", "b"])
    >>> model.predict([np.array([[0.0, 4.2]])])
    array(['b'], dtype='<U1')
    """

    def __init__(
        self, distance=None, n_neighbors=1, scale_samples=1000, block_size=64, random_state=0
    ):
        super().__init__(
            distance=distance,
            n_neighbors=n_neighbors,
            scale_samples=scale_samples,
            block_size=block_size,
            random_state=random_state,
        )

    def fit(self, X, y):
        """Index ``X`` and keep its labels.

        Parameters
        ----------
        X : sequence of samples
        y : array-like of shape (n_samples,)

        Returns
        -------
        self
        """
        samples = as_sample_list(X, "samples")  # read once: X may be a generator
        y = np.asarray(y)
        if y.ndim != 1 or len(y) != len(samples):
            raise ValueError(
                f"y must hold one label per sample of X ({len(samples)}), got shape {y.shape}"
            )
        classes, codes = np.unique(y, return_inverse=True)
        return self._fit_index(samples, classes_=classes, _codes_=codes)

    def predict_proba(self, X):
        """The share of each class among the neighbours of each sample.

        Parameters
        ----------
        X : sequence of samples

        Returns
        -------
        ndarray of shape (n_samples, n_classes)
        """
        indices = self.kneighbors(X, return_distance=False)
        votes = self._codes_[indices]
        counts = np.stack([np.sum(votes == c, axis=1) for c in range(len(self.classes_))], 1)
        return counts / indices.shape[1]

    def predict(self, X):
        """The class most neighbours of each sample belong to.

        Parameters
        ----------
        X : sequence of samples
            As for :meth:`kneighbors`.

        Returns
        -------
        ndarray of shape (n_samples,)
            Labels of ``classes_``; a tied vote gives the first of them.
        """
        proba = self.predict_proba(X)  # checks that the classifier is fitted first
        return self.classes_[np.argmax(proba, axis=1)]
