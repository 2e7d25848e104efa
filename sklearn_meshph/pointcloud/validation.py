"""Validation of point clouds: every cloud passes :func:`check_point_cloud`.

Which samples are clouds is decided in one place, :mod:`sklearn_meshph.inputs`.
"""

from __future__ import annotations

import numpy as np

from ..mesh.validation import where

__all__ = ["MIN_POINTS", "check_point_cloud"]

#: Fewest (distinct) points of a cloud: a tetrahedron's worth, and the four
#: eigenfunctions of the default ``eigen_index=(1, 2, 3)``.
MIN_POINTS = 4


def check_point_cloud(points, *, index: int | None = None) -> np.ndarray:
    """Validate one point cloud and return its points.

    Parameters
    ----------
    points : ndarray of shape (n, 3) or trimesh.PointCloud
        At least ``MIN_POINTS`` points with finite coordinates. Exact duplicates
        are accepted here; the eigen stage merges them (see
        :class:`LaplacianEigenTransformer`).
    index : int, optional
        Position of the cloud in a collection, used in error messages.

    Returns
    -------
    points : ndarray of shape (n, 3), float64, C-contiguous

    Raises
    ------
    ValueError
        If the array is not numeric of shape ``(n, 3)``, a coordinate is not finite,
        or there are fewer than ``MIN_POINTS`` points. The message names the sample.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_meshph import check_point_cloud
    >>> check_point_cloud(np.zeros((2, 3)), index=3)
    Traceback (most recent call last):
    ...
    ValueError: sample 3: a point cloud needs at least 4 points, got 2
    """
    place = where(index, "point cloud")
    if not isinstance(points, np.ndarray) and hasattr(points, "vertices"):
        points = points.vertices
    points = np.asarray(points)
    if points.dtype.kind not in "fiu" or points.ndim != 2 or points.shape[1] != 3:
        raise ValueError(
            f"{place}: a point cloud must be a numeric array of shape (n_points, 3), "
            f"got dtype {points.dtype} and shape {points.shape}"
        )
    points = np.ascontiguousarray(points, dtype=np.float64)
    finite = np.isfinite(points).all(axis=1)
    if not finite.all():
        bad = int(np.flatnonzero(~finite)[0])
        raise ValueError(f"{place}: point {bad} has a non-finite coordinate (NaN or inf)")
    if len(points) < MIN_POINTS:
        raise ValueError(
            f"{place}: a point cloud needs at least {MIN_POINTS} points, got {len(points)}"
        )
    return points
