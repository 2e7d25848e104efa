"""Point clouds as input: validation, and the dispatch between meshes and clouds.

A sample is a point cloud when it is a NumPy array (a mesh is never one array: it is a
``trimesh.Trimesh``, a ``(vertices, faces)`` pair or a path), a ``trimesh.PointCloud``
(or any object with ``vertices`` and no ``faces``), or a file holding points without
triangles (``.xyz``, ``.pts``, a PLY without faces). A nested list of points is not a
cloud: a list of two points would read as a ``(vertices, faces)`` pair; pass
``np.asarray(points)``. Meshes go through :func:`sklearn_meshph.check_mesh` unchanged.
"""

from __future__ import annotations

import os

import numpy as np

from ..mesh.validation import check_mesh, where
from .reading import read_sample_file

__all__ = ["MIN_POINTS", "check_input", "check_point_cloud", "is_point_cloud"]

#: Fewest (distinct) points of a cloud: a tetrahedron's worth, and the four
#: eigenfunctions of the default ``eigen_index=(1, 2, 3)``.
MIN_POINTS = 4


def is_point_cloud(sample) -> bool:
    """Whether ``sample`` (not a path) is a point cloud rather than a mesh."""
    return isinstance(sample, np.ndarray) or (
        hasattr(sample, "vertices") and not hasattr(sample, "faces")
    )


def check_point_cloud(points, *, index: int | None = None) -> np.ndarray:
    """Validate one point cloud and return its points.

    Parameters
    ----------
    points : ndarray of shape (n, 3) or trimesh.PointCloud
        At least ``MIN_POINTS`` (4) points with finite coordinates. Exact duplicates
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
        or there are fewer than 4 points. The message names the sample.

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


def check_input(sample, *, index: int | None = None) -> tuple[np.ndarray, np.ndarray | None]:
    """A mesh as ``(vertices, faces)``, or a point cloud as ``(points, None)``.

    Paths are read first (:func:`.reading.read_sample_file`): a file without triangles
    is a point cloud. Meshes are validated by :func:`sklearn_meshph.check_mesh`, with
    its messages; clouds by :func:`check_point_cloud`.
    """
    if isinstance(sample, str | os.PathLike):
        sample = read_sample_file(sample, where(index))
    if is_point_cloud(sample):
        return check_point_cloud(sample, index=index), None
    if not hasattr(sample, "vertices") and not (
        isinstance(sample, tuple | list) and len(sample) == 2
    ):
        raise TypeError(
            f"{where(index)}: expected a trimesh.Trimesh, a (vertices, faces) pair or a "
            "path, or a point cloud (an (n, 3) array or a trimesh.PointCloud), got "
            f"{type(sample).__name__}"
        )
    return check_mesh(sample, index=index)
