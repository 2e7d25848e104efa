"""Validation of mesh input: every mesh, face array and vertex function passes here.

The compiled loops downstream do not check bounds, so these checks are what stands
between a malformed input and a read out of bounds: a bad value is a ``ValueError``
naming the sample and the problem, never a crash.
"""

from __future__ import annotations

import os

import numpy as np

from .reading import read_mesh_file

__all__ = ["check_edges", "check_faces", "check_mesh", "check_values", "where"]


def where(index: int | None, what: str = "mesh") -> str:
    """How error messages name a sample: its position in a collection, if known."""
    return what if index is None else f"sample {index}"


def check_mesh(mesh, *, index: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Validate one mesh and return its ``(vertices, faces)`` arrays.

    Parameters
    ----------
    mesh : trimesh.Trimesh, (vertices, faces) pair, str or os.PathLike
        A triangle mesh: a trimesh object, a pair of arrays of shapes (n, 3) (float) and
        (m, 3) (integer), or the path of a mesh file trimesh reads (OBJ, PLY, OFF, STL,
        GLB...), loaded with ``process=False`` so that the vertex order is kept. A path
        may be compressed (``.gz``, ``.bz2``, ``.xz``: ``bunny.off.gz``); it is then
        decompressed in memory, and refused beyond
        ``sklearn_meshph.mesh.reading.MAX_DECOMPRESSED_SIZE`` bytes (2 GiB).
    index : int, optional
        Position of the mesh in a collection, used in error messages.

    Returns
    -------
    vertices : ndarray of shape (n, 3), float64
    faces : ndarray of shape (m, 3), int64

    Raises
    ------
    TypeError
        If ``mesh`` is none of the accepted types.
    ValueError
        If the file does not exist, is empty, cannot be decompressed or read (the
        message names the file), the arrays have the wrong shape or dtype, a vertex
        coordinate is not finite, a face index is out of range, or there are no faces.

    Examples
    --------
    >>> from sklearn_meshph import check_mesh
    >>> check_mesh(([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 3]]))
    Traceback (most recent call last):
    ...
    ValueError: mesh: face 0 has index [0, 1, 3] out of range for 3 vertices
    """
    place = where(index)
    if isinstance(mesh, str | os.PathLike):
        mesh = read_mesh_file(mesh, place)
    if hasattr(mesh, "vertices") and hasattr(mesh, "faces"):
        vertices, faces = mesh.vertices, mesh.faces
    elif isinstance(mesh, tuple | list) and len(mesh) == 2:
        vertices, faces = mesh
    else:
        raise TypeError(
            f"{place}: expected a trimesh.Trimesh, a (vertices, faces) pair or a path, "
            f"got {type(mesh).__name__}"
        )
    vertices = check_vertices(vertices, place)
    faces = check_faces(faces, len(vertices), place)
    if len(faces) == 0:
        raise ValueError(f"{place}: the mesh has no faces")
    return vertices, faces


def check_vertices(vertices, place: str = "mesh") -> np.ndarray:
    """``vertices`` as a C-contiguous float64 ``(n, 3)`` array of finite coordinates."""
    vertices = _as_array(vertices, "vertices", place)
    if vertices.dtype.kind not in "fiu" or vertices.ndim != 2 or vertices.shape[1] != 3:
        raise ValueError(
            f"{place}: vertices must be a numeric array of shape (n_vertices, 3), "
            f"got dtype {vertices.dtype} and shape {vertices.shape}"
        )
    if len(vertices) == 0:
        raise ValueError(f"{place}: the mesh has no vertices")
    vertices = np.ascontiguousarray(vertices, dtype=np.float64)
    if not np.isfinite(vertices).all():
        bad = int(np.flatnonzero(~np.isfinite(vertices).all(axis=1))[0])
        raise ValueError(f"{place}: vertex {bad} has a non-finite coordinate (NaN or inf)")
    return vertices


def check_faces(faces, n_vertices: int, place: str = "mesh") -> np.ndarray:
    """``faces`` as a C-contiguous int64 ``(m, 3)`` array of indices below ``n_vertices``.

    Integral floats are accepted.
    """
    faces = _as_array(faces, "faces", place)
    if faces.ndim != 2 or faces.shape[1] != 3:
        raise ValueError(
            f"{place}: faces must be an array of shape (n_faces, 3), got shape {faces.shape}"
        )
    if faces.dtype.kind == "f":
        if not np.isfinite(faces).all() or not (faces == np.round(faces)).all():
            raise ValueError(f"{place}: face indices must be integers")
    elif faces.dtype.kind not in "iu":
        raise ValueError(f"{place}: face indices must be integers, got dtype {faces.dtype}")
    return _in_range(faces, n_vertices, "face", place)


def check_edges(edges, n_vertices: int, place: str = "mesh") -> np.ndarray:
    """``edges`` as a C-contiguous int64 ``(m, 2)`` array of indices below ``n_vertices``."""
    edges = _as_array(edges, "edges", place)
    if edges.ndim != 2 or edges.shape[1] != 2 or edges.dtype.kind not in "iu":
        raise ValueError(
            f"{place}: edges must be an integer array of shape (n_edges, 2), got dtype "
            f"{edges.dtype} and shape {edges.shape}"
        )
    return _in_range(edges, n_vertices, "edge", place)


def _as_array(array, what: str, place: str) -> np.ndarray:
    try:
        return np.asarray(array)
    except (ValueError, TypeError) as exc:
        raise ValueError(f"{place}: {what} must be an array: {exc}") from exc


def _in_range(indices: np.ndarray, n_vertices: int, what: str, place: str) -> np.ndarray:
    """Integer ``indices`` (one row per face or edge) as C-contiguous int64, or a
    ``ValueError`` naming the first row with an index out of ``range(n_vertices)``."""
    if len(indices) and (indices.min() < 0 or indices.max() >= n_vertices):
        bad = int(np.flatnonzero(((indices < 0) | (indices >= n_vertices)).any(axis=1))[0])
        raise ValueError(
            f"{place}: {what} {bad} has index {indices[bad].tolist()} out of range for "
            f"{n_vertices} vertices"
        )
    return np.ascontiguousarray(indices, dtype=np.int64)


def check_values(values, n_vertices: int, place: str = "values") -> np.ndarray:
    """Vertex values as float64, shape ``(n_vertices,)`` or ``(n_vertices, k)``, finite
    and real (complex ones are refused: NumPy would drop the imaginary parts with only a
    warning)."""
    try:
        is_complex = np.iscomplexobj(values)  # converts a sequence: a ragged one raises
        if not is_complex:
            values = np.asarray(values, dtype=np.float64)
    except OverflowError:  # a Python int beyond float64
        raise ValueError(f"{place}: values must be finite, got one beyond float64") from None
    except (ValueError, TypeError) as exc:
        raise ValueError(f"{place}: values must be a numeric array: {exc}") from exc
    if is_complex:
        raise ValueError(f"{place}: values must be real numbers, got complex ones")
    if values.ndim not in (1, 2) or values.shape[0] != n_vertices:
        raise ValueError(
            f"{place}: values must have shape ({n_vertices},) or ({n_vertices}, k) to match "
            f"the mesh's vertices, got {values.shape}"
        )
    if not np.isfinite(values).all():
        raise ValueError(f"{place}: values contain NaN or inf")
    return values
