"""Converters between our diagrams and the formats of gudhi, persim and giotto-tda.

Our format: a float64 array of shape (n, 2), rows (birth, death), death ``inf`` for
essential classes, one array per homology dimension or diagram type.
"""

from __future__ import annotations

import numpy as np

from .diagrams import check_diagram

__all__ = ["from_giotto", "from_gudhi", "from_persim", "to_giotto", "to_gudhi", "to_persim"]


def to_gudhi(diagram, dimension: int = 0) -> list[tuple[int, tuple[float, float]]]:
    """A diagram as gudhi's ``SimplexTree.persistence()`` list of ``(dim, (birth, death))``."""
    return [(dimension, (float(b), float(d))) for b, d in check_diagram(diagram)]


def from_gudhi(persistence, dimension: int = 0) -> np.ndarray:
    """The pairs of one dimension of a gudhi ``persistence()`` list (or an array)."""
    if isinstance(persistence, np.ndarray):
        return check_diagram(persistence)
    rows = [pair for dim, pair in persistence if dim == dimension]
    return check_diagram(np.array(rows, dtype=float).reshape(-1, 2))


def to_persim(diagrams) -> list[np.ndarray]:
    """persim's format: a list with one (n, 2) array per homology dimension."""
    if isinstance(diagrams, tuple | list):
        return [check_diagram(d) for d in diagrams]
    return [check_diagram(diagrams)]


def from_persim(diagrams, dimension: int = 0) -> np.ndarray:
    """One dimension of a persim list of diagrams."""
    return check_diagram(diagrams[dimension])


def to_giotto(samples, dimensions=None) -> np.ndarray:
    """giotto-tda's padded 3-D array ``(n_samples, n_points, 3)``: birth, death, dim.

    Each sample is a diagram or a tuple of diagrams (the k-th taken as homology
    dimension ``dimensions[k]``, default ``k``). Samples are padded with points on the
    diagonal at (0, 0), which every diagram distance ignores. Infinite deaths are kept
    (giotto-tda itself drops essential classes: remove them first to match it).
    """
    triples = []
    for sample in samples:
        parts = sample if isinstance(sample, tuple) else (sample,)
        dims = range(len(parts)) if dimensions is None else dimensions
        rows = [
            np.column_stack([check_diagram(d), np.full(len(check_diagram(d)), k, float)])
            for d, k in zip(parts, dims, strict=True)
        ]
        triples.append(np.vstack(rows) if rows else np.empty((0, 3)))
    width = max((len(t) for t in triples), default=0)
    out = np.zeros((len(triples), width, 3))
    for i, t in enumerate(triples):
        out[i, : len(t)] = t
        if len(t) < width:
            out[i, len(t) :, 2] = t[-1, 2] if len(t) else 0
    return out


def from_giotto(array, dimensions=(0,)) -> list:
    """Samples from a giotto-tda 3-D array, dropping diagonal (padding) points.

    Returns one array per sample for a single dimension, else a tuple per sample.
    """
    array = np.asarray(array, dtype=float)
    if array.ndim != 3 or array.shape[2] != 3:
        raise ValueError(
            f"a giotto-tda array has shape (n_samples, n_points, 3), got {array.shape}"
        )
    samples = []
    for points in array:
        real = points[points[:, 1] > points[:, 0]]
        parts = tuple(check_diagram(real[real[:, 2] == k, :2]) for k in dimensions)
        samples.append(parts[0] if len(parts) == 1 else parts)
    return samples
