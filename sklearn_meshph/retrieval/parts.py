"""The parts of a fitted metric as an index reads them: exact distances from a query
to chosen fitted samples, and lower bounds of them for every fitted sample at once.

Exact distances are the part's own compiled kernels (:func:`pair_distances`) on the
pairs asked for, combined as its last step combines them: the same operations on the
same numbers as its ``transform``, so the same bits.

Each part of a fitted metric (a :class:`DiagramDistance` or a :class:`FeatureDistance`)
turns its samples into fixed-length rows whose distance, taken for all fitted rows in
one vectorized call, never exceeds the part's exact distance:

- A diagram becomes the distances of its finite points to the diagonal in the ground
  norm (``(d - b) / 2`` times ``2^(1/p)``, the cost of sending the point to the
  diagonal), sorted in decreasing order and padded with zeros; the distance to the
  diagonal is 1-Lipschitz, so any matching of two diagrams costs at least the matching
  of these numbers on a half-line, and in one dimension the sorted matching is optimal:
  the l_q distance of the sorted vectors is at most the q-Wasserstein distance (its l_inf
  distance at most the bottleneck distance). The first ``N_TOP`` values are kept and the
  l_q norm of the others (their maximum for the bottleneck distance), whose difference
  is at most the l_q distance of the dropped values (Minkowski's inequality).
- The essential points (death ``inf``) are matched by sorted birth, exactly: their
  sorted births are kept, and a different number of them makes the distance infinite,
  exactly as the metric does.
- The positions of a tuple are divided by the fitted scales and combined as the metric
  combines them (l_q norm, maximum), so a part is one l_q distance between rows. The
  sliced Wasserstein distance has no bound here (0).
- A feature part's bound is its own distance, cheap for all rows at once.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.distance import cdist

from .._feature_distances import feature_distances
from ..combine import FeatureDistance
from ..diagrams import DiagramDistance
from ..diagrams.distances import kernel_metric
from ..diagrams.pairwise import as_packed, pack_for_metric, pair_distances
from ..diagrams.validation import check_samples

__all__ = ["N_TOP", "IndexedPart", "is_indexable"]

# Distances to the diagonal kept per diagram (the rest as one norm).
N_TOP = 16


def _norm(values, q):
    """The l_q norm of non-negative ``values`` (their maximum at ``q = inf``), scaled
    so that no power overflows."""
    if not len(values):
        return 0.0
    top = float(values.max())
    if np.isinf(q) or top == 0.0:
        return top
    return top * float(np.sum((values / top) ** q)) ** (1.0 / q)


class IndexedPart:
    """One fitted part of a metric: its exact distances and their lower bounds.

    ``final`` is the fitted last step of the part, ``factor`` the part's weight over
    its scale in the combination. :meth:`fit` packs the fitted rows for the kernels and
    sets the number of essential births kept per diagram position.
    """

    def __init__(self, final, factor):
        self.final, self.factor = final, factor
        self.diagrams = isinstance(final, DiagramDistance)
        if not self.diagrams:
            return
        params = final.distance_params_
        metric, order, p = params["metric"], float(params["order"]), float(params["internal_p"])
        self.sliced = metric == "sliced-wasserstein"
        self.q = np.inf if metric == "bottleneck" or np.isinf(order) else order
        self.factor_p = 1.0 if np.isinf(self.q) or np.isinf(p) else 2.0 ** (1.0 / p)
        self.scales = np.asarray(final.scales_, dtype=float)
        self.code, self.order = kernel_metric(metric, order, p)
        self.whole = params["normalization"] == "none"  # a tuple at once, else by position

    def _pack(self, rows):
        """Validated rows packed for the kernel: whole tuples, or one pack per position."""
        packed = as_packed(rows)
        n_directions = self.final.distance_params_["n_directions"]
        if self.whole:
            return [pack_for_metric(packed, self.code, n_directions)]
        positions = range(self.final.n_diagrams_)
        return [pack_for_metric(packed.only(k), self.code, n_directions) for k in positions]

    def fit(self, rows):
        """Pack the validated fitted ``rows`` and keep as many essential births per
        position as they hold at most; returns ``self``."""
        if self.diagrams:
            self.packed = self._pack(rows)
            self.n_essential = np.zeros(self.final.n_diagrams_, dtype=np.int64)
            for sample in rows:
                for k, diagram in enumerate(sample):
                    count = int(np.sum(~np.isfinite(diagram[:, 1])))
                    self.n_essential[k] = max(self.n_essential[k], count)
        else:
            self.features = rows
        return self

    def exact(self, query, cols):
        """The part's ``(len(query), len(cols))`` distances from validated query rows to
        the fitted samples ``cols``, as its last step's ``transform`` computes them."""
        final = self.final
        if not self.diagrams:
            return feature_distances(query, self.features[cols], final.metric, final.n_jobs)
        rows = np.repeat(np.arange(len(query)), len(cols))
        cols = np.tile(np.asarray(cols, dtype=np.int64), len(query))
        p = float(final.distance_params_["internal_p"])
        n_parts = final.n_diagrams_ if self.whole else 1
        matrices = [
            pair_distances(left, right, rows, cols, n_parts, self.code, self.order, p).reshape(
                len(query), -1
            )
            for left, right in zip(self._pack(query), self.packed, strict=True)
        ]
        if self.whole:
            return matrices[0].astype(final.dtype, copy=False)
        # DiagramDistance's combination of the positions divided by their scales.
        scaled = [part / scale for part, scale in zip(matrices, self.scales, strict=True)]
        metric = final.distance_params_["metric"]
        if metric == "sliced-wasserstein":
            total = sum(scaled)
        elif np.isinf(self.q):
            total = np.maximum.reduce(scaled)
        else:
            total = sum(part**self.order for part in scaled) ** (1.0 / self.order)
        return total.astype(final.dtype, copy=False)

    def validate(self, rows):
        """Rows as the final step checks them (tuples of diagrams, or a float array)."""
        if self.diagrams:
            return check_samples(rows, n_diagrams=self.final.n_diagrams_)
        rows = np.asarray(rows, dtype=np.float64)
        if rows.ndim != 2 or rows.shape[1] != self.final.n_features_in_:
            raise ValueError(
                f"the feature part expects rows of {self.final.n_features_in_} features, "
                f"got an array of shape {rows.shape}"
            )
        return rows

    def embed(self, rows):
        """``(vectors, essential counts)`` of validated rows: what :meth:`lower` reads."""
        if not self.diagrams:
            return rows, np.zeros((len(rows), 0), dtype=np.int64)
        n, n_diagrams = len(rows), self.final.n_diagrams_
        if self.sliced:
            return np.zeros((n, 0)), np.zeros((n, 0), dtype=np.int64)
        widths = N_TOP + 1 + self.n_essential
        starts = np.concatenate([[0], np.cumsum(widths)])
        vectors = np.zeros((n, starts[-1]))
        counts = np.zeros((n, n_diagrams), dtype=np.int64)
        for i, sample in enumerate(rows):
            for k, diagram in enumerate(sample):
                finite = np.isfinite(diagram[:, 1])
                gaps = diagram[finite, 1] - diagram[finite, 0]
                to_diagonal = np.sort(gaps)[::-1] / 2.0 * self.factor_p
                births = np.sort(diagram[~finite, 0])[: self.n_essential[k]]
                counts[i, k] = int(np.sum(~finite))
                row = vectors[i, starts[k] : starts[k + 1]]
                row[: min(N_TOP, len(to_diagonal))] = to_diagonal[:N_TOP]
                row[N_TOP] = _norm(to_diagonal[N_TOP:], self.q)
                row[N_TOP + 1 : N_TOP + 1 + len(births)] = births
                row /= self.scales[k]
        return vectors, counts

    def lower(self, query, fitted):
        """The ``(len(query), len(fitted))`` lower bounds of the part's distance, times the
        part's factor; ``inf`` where the essential points differ in number (the exact
        distance is then ``inf`` too)."""
        (left, left_counts), (right, right_counts) = query, fitted
        if not self.diagrams:
            final = self.final
            bound = feature_distances(left, right, final.metric, final.n_jobs)
            return self.factor * bound
        if self.sliced:
            return np.zeros((len(left), len(right)))
        if np.isinf(self.q):
            bound = cdist(left, right, "chebyshev")
        elif self.q == 1.0:
            bound = cdist(left, right, "cityblock")
        else:
            bound = cdist(left, right, "minkowski", p=self.q)
        bound *= self.factor
        for k in range(left_counts.shape[1]):
            bound[left_counts[:, k, None] != right_counts[None, :, k]] = np.inf
        return bound


def is_indexable(final) -> bool:
    """Whether a part's last step is one whose distance :class:`PartBound` bounds."""
    return isinstance(final, DiagramDistance | FeatureDistance)
