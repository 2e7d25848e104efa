"""Validation of persistence diagrams, and the packed format that distances, kernels
and vectorizers share: every row of every diagram of every sample in one ``(N, 2)``
array, diagram ``k`` of sample ``i`` being rows ``offsets[i * K + k] : offsets[i * K + k
+ 1]`` (``K`` diagrams per sample). :func:`pack_samples` is the one validator of samples
of diagrams; checks then cost a few array operations for the whole collection."""

from __future__ import annotations

import numpy as np

from .._base import as_sample_list

__all__ = ["Packed", "check_diagram", "check_sample", "check_samples", "pack_samples"]


#: Largest magnitude of a finite birth or death (2**1022, about 4.5e307): the sum or
#: difference of any two is then finite, as every distance's costs and every
#: vectorization's persistence and midpoints need (beyond it a persistence of
#: ``1e308 - (-1e308)`` was infinite, and the Wasserstein solver crashed on it).
MAX_DIAGRAM_VALUE = 2.0**1022


def check_diagram(diagram, *, index: int | None = None, part: int | None = None) -> np.ndarray:
    """Validate one diagram and return it as a float64 array of shape (n, 2).

    Rows are (birth, death) with a finite birth and ``death >= birth``; death may be
    ``+inf`` (an essential class). Finite values are at most :data:`MAX_DIAGRAM_VALUE`
    in magnitude. An empty diagram (no rows) is valid.

    Raises
    ------
    ValueError
        Naming the sample (and the diagram within it) and the problem: wrong shape,
        non-numeric, complex, NaN, infinite birth, death below birth, a value beyond
        :data:`MAX_DIAGRAM_VALUE`.
    """
    where = "diagram" if index is None else f"sample {index}"
    if part is not None:
        where += f", diagram {part}"
    if isinstance(diagram, np.ndarray) and np.iscomplexobj(diagram):
        raise ValueError(f"{where}: a diagram must be real, got complex values")
    try:
        array = np.asarray(diagram, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{where}: not a numeric (n, 2) array: {exc}") from exc
    if array.size == 0:
        return np.empty((0, 2))
    if array.ndim != 2 or array.shape[1] != 2:
        raise ValueError(f"{where}: a diagram must have shape (n, 2), got {array.shape}")
    if np.isnan(array).any():
        row = int(np.flatnonzero(np.isnan(array).any(axis=1))[0])
        raise ValueError(f"{where}: row {row} contains NaN")
    if not np.isfinite(array[:, 0]).all():
        row = int(np.flatnonzero(~np.isfinite(array[:, 0]))[0])
        raise ValueError(f"{where}: row {row} has an infinite birth")
    if (array[:, 1] < array[:, 0]).any():
        row = int(np.flatnonzero(array[:, 1] < array[:, 0])[0])
        raise ValueError(
            f"{where}: row {row} has death {array[row, 1]} below birth {array[row, 0]}"
        )
    huge = (np.abs(array) > MAX_DIAGRAM_VALUE) & np.isfinite(array)
    if huge.any():
        row = int(np.flatnonzero(huge.any(axis=1))[0])
        raise ValueError(
            f"{where}: row {row} holds {float(array[row][huge[row]][0])!r}, beyond the largest "
            f"finite value a diagram may hold, {MAX_DIAGRAM_VALUE:.3g} (MAX_DIAGRAM_VALUE: "
            "differences of larger values overflow); rescale the diagrams"
        )
    return array


def check_sample(sample, index: int | None = None) -> tuple[np.ndarray, ...]:
    """A sample as a tuple of validated diagrams.

    A tuple is several diagrams; anything else (an array, a list of rows) is one.
    """
    if isinstance(sample, tuple):
        return tuple(check_diagram(d, index=index, part=k) for k, d in enumerate(sample))
    return (check_diagram(sample, index=index),)


def check_samples(samples, n_diagrams: int | None = None) -> list[tuple[np.ndarray, ...]]:
    """Validated samples, all with the same number of diagrams (``n_diagrams`` if given):
    :func:`pack_samples`, each sample returned as a tuple of diagrams.

    Raises
    ------
    ValueError
        If a diagram is malformed (naming the sample), if the samples hold different
        numbers of diagrams, or if they do not hold ``n_diagrams``.
    """
    return pack_samples(samples, n_diagrams).samples()


class Packed:
    """Validated samples of ``n_diagrams`` diagrams each, packed (see the module)."""

    __slots__ = ("first", "n_diagrams", "offsets", "points")

    def __init__(self, points, offsets, n_diagrams, first=0):
        self.points, self.offsets, self.n_diagrams = points, offsets, n_diagrams
        self.first = first  # the index of the first sample, in messages

    @classmethod
    def from_checked(cls, samples) -> Packed:
        """Samples already validated (tuples of ``(n, 2)`` float64 arrays), packed."""
        arrays = [diagram for sample in samples for diagram in sample]
        return cls._of(arrays, len(samples[0]) if len(samples) else 1)

    @classmethod
    def _of(cls, arrays, n_diagrams) -> Packed:
        offsets = np.zeros(len(arrays) + 1, dtype=np.int64)
        np.cumsum([len(a) for a in arrays], out=offsets[1:])
        points = np.concatenate(arrays) if arrays else _EMPTY.copy()
        return cls(np.ascontiguousarray(points, dtype=np.float64), offsets, n_diagrams)

    def __len__(self) -> int:
        return self.n_samples

    @property
    def n_samples(self) -> int:
        return (len(self.offsets) - 1) // self.n_diagrams

    def diagram_of_rows(self) -> np.ndarray:
        """The (flat) diagram index of each row."""
        sizes = np.diff(self.offsets)
        return np.repeat(np.arange(len(sizes)), sizes)

    def where(self, row: int) -> str:
        """``"sample i, diagram k: row r"`` for a row of ``points``."""
        flat = int(np.searchsorted(self.offsets, row, side="right") - 1)
        i, k = divmod(flat, self.n_diagrams)
        return f"sample {self.first + i}, diagram {k}: row {row - self.offsets[flat]}"

    def block(self, a: int, b: int) -> Packed:
        """Samples ``a:b``, rows copied out (what a parallel task receives)."""
        k = self.n_diagrams
        lo, hi = self.offsets[a * k], self.offsets[b * k]
        offsets = self.offsets[a * k : b * k + 1] - lo
        return Packed(self.points[lo:hi].copy(), offsets, k, self.first + a)

    def position(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        """``(starts, stops)`` of diagram ``k`` of every sample."""
        starts = self.offsets[k : len(self.offsets) - 1 : self.n_diagrams]
        stops = self.offsets[k + 1 :: self.n_diagrams]
        return np.ascontiguousarray(starts), np.ascontiguousarray(stops)

    def only(self, k: int) -> Packed:
        """Diagram ``k`` of every sample, as samples of one diagram."""
        starts, stops = self.position(k)
        return Packed._of([self.points[a:b] for a, b in zip(starts, stops, strict=True)], 1)

    def samples(self) -> list[tuple[np.ndarray, ...]]:
        """Each sample as a tuple of its diagrams (views of ``points``)."""
        k, o, p = self.n_diagrams, self.offsets, self.points
        return [
            tuple(p[o[i * k + j] : o[i * k + j + 1]] for j in range(k))
            for i in range(self.n_samples)
        ]


_EMPTY = np.empty((0, 2))


def _is_diagram_array(diagram) -> bool:
    return (
        type(diagram) is np.ndarray
        and diagram.dtype == np.float64
        and diagram.ndim == 2
        and diagram.shape[1] == 2
    )


def pack_samples(X, n_diagrams: int | None = None) -> Packed:
    """Validate samples of diagrams and pack them: the validator of every distance,
    kernel and vectorizer.

    A sample is one diagram (an ``(n, 2)`` array or a list of rows) or a tuple of them;
    all samples hold the same number of diagrams (``n_diagrams`` if given). Rows are
    checked as :func:`check_diagram` checks them, with its messages.
    """
    samples = as_sample_list(X, "diagrams")
    arrays, tuples, count = [], [], None
    for i, sample in enumerate(samples):
        parts = sample if isinstance(sample, tuple) else (sample,)
        if count is None:
            count = len(parts)
        elif len(parts) != count:
            raise ValueError(
                f"samples have different numbers of diagrams: sample 0 has {count}, "
                f"sample {i} has {len(parts)}"
            )
        tuples.append(isinstance(sample, tuple))
        for k, diagram in enumerate(parts):
            if _is_diagram_array(diagram):
                arrays.append(diagram)
                continue
            if isinstance(diagram, np.ndarray) and np.iscomplexobj(diagram):
                check_diagram(diagram, index=i, part=k if tuples[-1] else None)  # raises
            try:
                array = np.asarray(diagram, dtype=np.float64)
            except (TypeError, ValueError):
                array = None
            if array is None or (array.size and (array.ndim != 2 or array.shape[1] != 2)):
                check_diagram(diagram, index=i, part=k if tuples[-1] else None)  # raises
            arrays.append(array if array.size else _EMPTY)
    if count == 0:
        raise ValueError("sample 0: an empty tuple holds no diagram")
    if n_diagrams is not None and count != n_diagrams:
        raise ValueError(f"X has {count} diagrams per sample, the fitted data {n_diagrams}")
    packed = Packed._of(arrays, count)
    points = packed.points
    with np.errstate(invalid="ignore"):
        bad = np.isnan(points).any(axis=1) | ~np.isfinite(points[:, 0])
        bad |= points[:, 1] < points[:, 0]
        bad |= ((np.abs(points) > MAX_DIAGRAM_VALUE) & np.isfinite(points)).any(axis=1)
    if bad.any():
        flat = int(np.searchsorted(packed.offsets, np.flatnonzero(bad)[0], side="right") - 1)
        i, k = divmod(flat, count)
        check_diagram(arrays[flat], index=i, part=k if tuples[i] else None)  # raises
    return packed
