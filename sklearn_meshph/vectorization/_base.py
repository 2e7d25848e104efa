"""What the vectorizers and kernels share: validated samples of diagrams, the policy for
essential points, and what ``fit`` learns per diagram position."""

from __future__ import annotations

from numbers import Integral

import numpy as np
from joblib import delayed, effective_n_jobs
from sklearn.utils.validation import check_is_fitted

from .._base import SampleTransformer, as_sample_list
from .._param_validation import Options
from .._progress import parallel

__all__ = [
    "COMMON_CONSTRAINTS",
    "ESSENTIAL_POLICIES",
    "DiagramTransformer",
    "chunks",
]

ESSENTIAL_POLICIES = ("drop", "clip", "error")

#: The parameters every vectorizer and kernel has, and their constraints.
COMMON_CONSTRAINTS: dict = {
    "essential": [Options(ESSENTIAL_POLICIES)],
    "n_jobs": [Integral, None],
    "dtype": [Options(("float64", "float32"))],
}

# Samples per parallel task at most: bounds the memory of the rows in flight.
_CHUNK = 2048


def chunks(n: int, n_jobs) -> list[tuple[int, int]]:
    """Consecutive ``(start, stop)`` blocks of samples: a few per worker, each at most
    ``_CHUNK`` samples."""
    n_blocks = max(-(-n // _CHUNK), min(n, 4 * effective_n_jobs(n_jobs)))
    bounds = np.linspace(0, n, n_blocks + 1).astype(int)
    return [(a, b) for a, b in zip(bounds[:-1], bounds[1:], strict=True) if b > a]


class DiagramTransformer(SampleTransformer):
    """Base of the transformers whose samples are persistence diagrams (one ``(n, 2)``
    array or a tuple of them, as :class:`LowerStarPersistence` returns).

    ``_fit_packed(X)`` validates the samples and applies the ``essential`` policy
    (learning, for ``"clip"``, the largest finite death of each position);
    ``_checked_packed(X)`` does the same at transform time with the fitted values. Both
    return a :class:`Packed` collection (``.samples()`` gives tuples of diagrams).
    """

    _sample_kind = "diagrams"
    _requires_fit = True

    def _fit_packed(self, X) -> Packed:
        """Validate ``X``, learn the clipping value of each position (its largest
        finite death) and apply the ``essential`` policy."""
        X = as_sample_list(X, "diagrams")  # read once: X may be a generator
        SampleTransformer.fit(self, X)
        packed = pack_samples(X)
        self.n_diagrams_ = packed.n_diagrams
        finite = np.isfinite(packed.points[:, 1])
        position = packed.diagram_of_rows() % packed.n_diagrams
        self.clip_values_ = np.array(
            [
                packed.points[finite & (position == k), 1].max()
                if (finite & (position == k)).any()
                else 0.0
                for k in range(packed.n_diagrams)
            ]
        )
        return apply_essential(packed, self.essential, self.clip_values_)

    def _checked_packed(self, X) -> Packed:
        """Validate ``X`` against the fitted data and apply the ``essential`` policy."""
        check_is_fitted(self, "n_diagrams_")
        packed = pack_samples(X, n_diagrams=self.n_diagrams_)
        return apply_essential(packed, self.essential, self.clip_values_)


# The packed path of the vectorizers -------------------------------------------------
#
# Every row of every diagram of every sample in one (N, 2) array; diagram k of sample i
# is rows offsets[i * K + k] : offsets[i * K + k + 1] (K diagrams per sample). Checks and
# the essential policy then cost a few array operations for the whole collection.


class Packed:
    """Validated samples of ``n_diagrams`` diagrams each, packed (see above)."""

    __slots__ = ("n_diagrams", "offsets", "points")

    def __init__(self, points, offsets, n_diagrams):
        self.points, self.offsets, self.n_diagrams = points, offsets, n_diagrams

    @property
    def n_samples(self) -> int:
        return (len(self.offsets) - 1) // self.n_diagrams

    def diagram_of_rows(self) -> np.ndarray:
        """The (flat) diagram index of each row."""
        sizes = np.diff(self.offsets)
        return np.repeat(np.arange(len(sizes)), sizes)

    def block(self, a: int, b: int) -> Packed:
        """Samples ``a:b``, rows copied out (what a parallel task receives)."""
        k = self.n_diagrams
        lo, hi = self.offsets[a * k], self.offsets[b * k]
        return Packed(self.points[lo:hi].copy(), self.offsets[a * k : b * k + 1] - lo, k)

    def position(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        """``(starts, stops)`` of diagram ``k`` of every sample."""
        starts = self.offsets[k : len(self.offsets) - 1 : self.n_diagrams]
        stops = self.offsets[k + 1 :: self.n_diagrams]
        return np.ascontiguousarray(starts), np.ascontiguousarray(stops)

    def samples(self) -> list[tuple[np.ndarray, ...]]:
        """Each sample as a tuple of its diagrams (views of ``points``)."""
        k, o, p = self.n_diagrams, self.offsets, self.points
        return [
            tuple(p[o[i * k + j] : o[i * k + j + 1]] for j in range(k))
            for i in range(self.n_samples)
        ]

    def rows_of_position(self, k: int) -> np.ndarray:
        starts, stops = self.position(k)
        if not len(starts):
            return np.empty((0, 2))
        return np.concatenate([self.points[a:b] for a, b in zip(starts, stops, strict=True)])


_EMPTY = np.empty((0, 2))


def pack_samples(X, n_diagrams: int | None = None) -> Packed:
    """Validate samples of diagrams (the rules of :func:`check_samples`, the same
    messages) and pack them."""
    from ..diagrams.validation import check_diagram

    samples = as_sample_list(X, "diagrams")
    arrays, tuples, count = [], [], None
    for i, sample in enumerate(samples):
        parts = sample if isinstance(sample, tuple) else (sample,)
        if count is None:
            count = len(parts)
        elif len(parts) != count:
            raise ValueError(f"samples have different numbers of diagrams: {count}, {len(parts)}")
        tuples.append(isinstance(sample, tuple))
        for k, diagram in enumerate(parts):
            if (
                type(diagram) is np.ndarray
                and diagram.dtype == np.float64
                and diagram.ndim == 2
                and diagram.shape[1] == 2
            ):
                arrays.append(diagram)
                continue
            try:
                array = np.asarray(diagram, dtype=np.float64)
            except (TypeError, ValueError):
                array = None
            if array is None or (array.size and (array.ndim != 2 or array.shape[1] != 2)):
                check_diagram(diagram, index=i, part=k if tuples[-1] else None)  # raises
            arrays.append(array if array.size else _EMPTY)
    if n_diagrams is not None and count != n_diagrams:
        raise ValueError(f"X has {count} diagrams per sample, the fitted data {n_diagrams}")
    sizes = np.fromiter((len(a) for a in arrays), dtype=np.int64, count=len(arrays))
    offsets = np.zeros(len(arrays) + 1, dtype=np.int64)
    np.cumsum(sizes, out=offsets[1:])
    points = np.concatenate(arrays) if arrays else _EMPTY.copy()
    with np.errstate(invalid="ignore"):
        bad = np.isnan(points).any(axis=1) | ~np.isfinite(points[:, 0])
        bad |= points[:, 1] < points[:, 0]
    if bad.any():
        flat = int(np.searchsorted(offsets, np.flatnonzero(bad)[0], side="right") - 1)
        i, k = divmod(flat, count)
        check_diagram(arrays[flat], index=i, part=k if tuples[i] else None)  # raises
    return Packed(np.ascontiguousarray(points), offsets, count)


def apply_essential(packed: Packed, policy: str, clip_values=None) -> Packed:
    """``packed`` with its essential points dropped, clipped at ``clip_values`` (per
    position) or refused."""
    infinite = np.isinf(packed.points[:, 1])
    if not infinite.any():
        return packed
    diagram = packed.diagram_of_rows()
    if policy == "error":
        first = int(np.flatnonzero(infinite)[0])
        flat = int(diagram[first])
        i, k = divmod(flat, packed.n_diagrams)
        raise ValueError(
            f"sample {i}, diagram {k}: row {first - packed.offsets[flat]} is an essential "
            "point (death inf); set essential='drop' or 'clip', or drop them upstream "
            "(LowerStarPersistence(essential='drop' or 'max'))"
        )
    if policy == "clip":
        points = packed.points.copy()
        position = diagram[infinite] % packed.n_diagrams
        points[infinite, 1] = np.maximum(np.asarray(clip_values)[position], points[infinite, 0])
        return Packed(points, packed.offsets, packed.n_diagrams)
    keep = ~infinite
    offsets = np.zeros_like(packed.offsets)
    np.cumsum(np.bincount(diagram[keep], minlength=len(offsets) - 1), out=offsets[1:])
    return Packed(np.ascontiguousarray(packed.points[keep]), offsets, packed.n_diagrams)


class PackedVectorizer(DiagramTransformer):
    """Base of the vectorizers: samples packed once, ``_fit_positions(packed)`` learns
    per position, ``_compute(k, points, starts, stops)`` gives the block of columns of
    position ``k`` for the diagrams ``starts:stops`` of ``points``."""

    def fit(self, X, y=None):
        """Learn what the vectorization needs from the diagrams of each position.

        Parameters
        ----------
        X : sequence of diagrams or of tuples of diagrams
        y : ignored

        Returns
        -------
        self
        """
        self._fit_positions(self._fit_packed(X))
        return self

    def transform(self, X):
        """The feature vector of each sample: the columns of each of its diagrams,
        position after position.

        Parameters
        ----------
        X : sequence of diagrams or of tuples of diagrams

        Returns
        -------
        ndarray of shape (n_samples, n_features)
        """
        return self._rows(self._checked_packed(X))

    def fit_transform(self, X, y=None):
        """Fit and transform ``X``, validating it once.

        Parameters
        ----------
        X : sequence of diagrams or of tuples of diagrams
        y : ignored

        Returns
        -------
        ndarray of shape (n_samples, n_features)
        """
        packed = self._fit_packed(X)
        self._fit_positions(packed)
        return self._rows(packed)

    def _rows(self, packed: Packed) -> np.ndarray:
        n_jobs = getattr(self, "n_jobs", None)
        blocks = chunks(packed.n_samples, n_jobs)
        if len(blocks) == 1 or effective_n_jobs(n_jobs) == 1:
            return self._block_rows(packed)
        # The compiled loops release the GIL: threads, unless a parallel_backend says
        # otherwise (then each task carries only its block of samples).
        tasks = parallel(n_jobs, prefer="threads")(
            delayed(self._block_rows)(packed.block(a, b)) for a, b in blocks
        )
        return np.vstack(list(tasks))

    def _block_rows(self, packed: Packed) -> np.ndarray:
        columns = [
            self._compute(k, packed.points, *packed.position(k)) for k in range(packed.n_diagrams)
        ]
        return np.hstack(columns).astype(self.dtype, copy=False)
