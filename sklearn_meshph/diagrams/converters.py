"""Converters between our diagrams and the formats of gudhi, persim and giotto-tda.

Our format: a float64 array of shape (n, 2), rows (birth, death), death ``inf`` for
essential classes; a sample with several diagrams is a tuple of such arrays.
"""

from __future__ import annotations

from numbers import Integral

import numpy as np

from .._param_validation import Interval, validate_params
from .validation import check_diagram, check_sample, check_samples

__all__ = ["from_giotto", "from_gudhi", "from_persim", "to_giotto", "to_gudhi", "to_persim"]


_DIMENSION = {"dimension": [Interval(Integral, 0, None, closed="left")]}


@validate_params(_DIMENSION)
def to_gudhi(diagram, dimension: int = 0) -> list[tuple[int, tuple[float, float]]]:
    """A diagram as gudhi's ``persistence()`` list of ``(dimension, (birth, death))``.

    Parameters
    ----------
    diagram : array-like of shape (n, 2)
    dimension : int, default=0
        Homology dimension written in every entry.

    Returns
    -------
    list of (int, (float, float))

    Examples
    --------
    >>> to_gudhi([[0.0, 1.0], [0.5, float("inf")]])
    [(0, (0.0, 1.0)), (0, (0.5, inf))]
    """
    return [(dimension, (float(b), float(d))) for b, d in check_diagram(diagram)]


@validate_params(_DIMENSION)
def from_gudhi(persistence, dimension: int = 0) -> np.ndarray:
    """The pairs of one homology dimension of a gudhi ``persistence()`` list.

    Parameters
    ----------
    persistence : list of (int, (float, float)) or array-like of shape (n, 2)
        gudhi's ``SimplexTree.persistence()`` output, or an array such as
        ``persistence_intervals_in_dimension(k)`` (returned as it is, validated).
    dimension : int, default=0
        Which homology dimension to keep from a list.

    Returns
    -------
    diagram : ndarray of shape (n, 2)

    Examples
    --------
    >>> from_gudhi([(1, (0.5, 2.0)), (0, (0.0, float("inf")))], dimension=1)
    array([[0.5, 2. ]])
    """
    if isinstance(persistence, np.ndarray):
        return check_diagram(persistence)
    rows = [pair for dim, pair in persistence if dim == dimension]
    return check_diagram(np.array(rows, dtype=float).reshape(-1, 2))


def to_persim(diagrams) -> list[np.ndarray]:
    """persim's format: a list with one (n, 2) array per homology dimension.

    Parameters
    ----------
    diagrams : array-like of shape (n, 2), or tuple of them
        One diagram, or a sample's diagrams (the k-th in position k).

    Returns
    -------
    list of ndarray of shape (n, 2)
    """
    return list(check_sample(diagrams))


@validate_params(_DIMENSION)
def from_persim(diagrams, dimension: int = 0) -> np.ndarray:
    """The diagram of one homology dimension from a persim list (ripser's ``"dgms"``).

    Parameters
    ----------
    diagrams : list of array-like of shape (n, 2)
    dimension : int, default=0

    Returns
    -------
    diagram : ndarray of shape (n, 2)
    """
    return check_diagram(diagrams[dimension])


def to_giotto(samples, dimensions=None) -> np.ndarray:
    """giotto-tda's padded 3-D array ``(n_samples, n_points, 3)`` of (birth, death, dim).

    Parameters
    ----------
    samples : sequence of diagrams or of tuples of diagrams
        The k-th diagram of each sample is written with homology dimension
        ``dimensions[k]``.
    dimensions : tuple of int, default=None
        Dimension of each diagram of a sample; ``None`` means ``0, 1, 2, ...``. Must be
        distinct: giotto-tda finds a dimension's points by their third column.

    Returns
    -------
    array : ndarray of shape (n_samples, n_points, 3)
        Points sorted by dimension. Every sample has, in each dimension, as many points
        as the largest diagram of that dimension, as giotto-tda requires; the missing
        ones are padded with diagonal points ``(0, 0)``, which diagram distances ignore.
        Infinite deaths are kept (giotto-tda itself drops essential classes: remove them
        first, e.g. with ``LowerStarPersistence(essential="drop")``, to match it).

    Examples
    --------
    >>> import numpy as np
    >>> to_giotto([np.array([[0.0, 1.0]]), np.empty((0, 2))])[:, :, :2].tolist()
    [[[0.0, 1.0]], [[0.0, 0.0]]]
    """
    parts = check_samples(samples)
    n_parts = len(parts[0])
    dims = tuple(range(n_parts)) if dimensions is None else tuple(dimensions)
    if len(dims) != n_parts or len(set(dims)) != len(dims):
        raise ValueError(f"dimensions must be {n_parts} distinct integers, got {dims}")
    slots = [max((len(p[k]) for p in parts), default=0) for k in range(n_parts)]
    out = np.zeros((len(parts), sum(slots), 3))
    start = 0
    for k in np.argsort(dims, kind="stable"):
        out[:, start : start + slots[k], 2] = dims[k]
        for i, p in enumerate(parts):
            out[i, start : start + len(p[k]), :2] = p[k]
        start += slots[k]
    return out


def from_giotto(array, dimensions=(0,)) -> list:
    """Samples from a giotto-tda 3-D array, dropping diagonal (padding) points.

    Parameters
    ----------
    array : array-like of shape (n_samples, n_points, 3)
    dimensions : tuple of int, default=(0,)
        Homology dimensions to extract, in the order of the output.

    Returns
    -------
    samples : list
        One ``(n, 2)`` array per sample for a single dimension, else a tuple of them.
    """
    array = np.asarray(array, dtype=float)
    if array.ndim != 3 or array.shape[2] != 3:
        raise ValueError(
            f"a giotto-tda array has shape (n_samples, n_points, 3), got {array.shape}"
        )
    samples = []
    for i, points in enumerate(array):
        real = points[points[:, 1] > points[:, 0]]
        parts = tuple(
            check_diagram(real[real[:, 2] == k, :2], index=i, part=j)
            for j, k in enumerate(dimensions)
        )
        samples.append(parts[0] if len(parts) == 1 else parts)
    return samples
