"""Mesh input: reading, validation and the cleaning policy.

Every mesh-taking function and estimator goes through :func:`check_mesh` (validation,
which raises) and :func:`clean_mesh` (the documented cleaning policy, which never raises
on a valid mesh unless asked to).
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ._assembly import (
    edge_matrix_csr,
    first_of_duplicate_faces,
    nondegenerate_faces,
    vertex_components,
)

__all__ = ["CleanMesh", "check_mesh", "clean_mesh", "mesh_edges"]

# A face is degenerate when twice its area is below this fraction of its longest edge
# squared: its vertices are (numerically) collinear or coincident, whatever the scale.
_DEGENERATE_SINE = 1e-12

COMPONENT_POLICIES = ("largest", "error")


def _where(index: int | None) -> str:
    return "mesh" if index is None else f"sample {index}"


def _load_path(path, index):
    import trimesh

    path = os.fspath(path)
    if not os.path.isfile(path):
        raise ValueError(f"{_where(index)}: mesh file {path!r} does not exist")
    try:
        loaded = trimesh.load(path, process=False, force="mesh")
    except Exception as exc:  # trimesh raises many types on malformed files
        raise ValueError(f"{_where(index)}: cannot read mesh file {path!r}: {exc}") from exc
    if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
        raise ValueError(f"{_where(index)}: mesh file {path!r} contains no triangles")
    return loaded.vertices, loaded.faces


def check_mesh(mesh, *, index: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Validate one mesh and return its ``(vertices, faces)`` arrays.

    Parameters
    ----------
    mesh : trimesh.Trimesh, (vertices, faces) pair, str or os.PathLike
        A triangle mesh: a trimesh object, a pair of arrays of shapes (n, 3) (float) and
        (m, 3) (integer), or the path of a mesh file trimesh reads (OBJ, PLY, OFF, STL,
        GLB...), loaded with ``process=False`` so that the vertex order is kept.
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
        If the file cannot be read, the arrays have the wrong shape or dtype, a vertex
        coordinate is not finite, a face index is out of range, or there are no faces.
    """
    where = _where(index)
    if isinstance(mesh, str | os.PathLike):
        vertices, faces = _load_path(mesh, index)
    elif hasattr(mesh, "vertices") and hasattr(mesh, "faces"):
        vertices, faces = mesh.vertices, mesh.faces
    elif isinstance(mesh, tuple | list) and len(mesh) == 2:
        vertices, faces = mesh
    else:
        raise TypeError(
            f"{where}: expected a trimesh.Trimesh, a (vertices, faces) pair or a path, "
            f"got {type(mesh).__name__}"
        )

    try:
        vertices = np.asarray(vertices)
        faces = np.asarray(faces)
    except (ValueError, TypeError) as exc:
        raise ValueError(f"{where}: vertices and faces must be arrays: {exc}") from exc
    if vertices.dtype.kind not in "fiu" or vertices.ndim != 2 or vertices.shape[1] != 3:
        raise ValueError(
            f"{where}: vertices must be a numeric array of shape (n_vertices, 3), "
            f"got dtype {vertices.dtype} and shape {vertices.shape}"
        )
    if faces.ndim != 2 or faces.shape[1] != 3:
        raise ValueError(
            f"{where}: faces must be an array of shape (n_faces, 3), got shape {faces.shape}"
        )
    if len(vertices) == 0:
        raise ValueError(f"{where}: the mesh has no vertices")
    if len(faces) == 0:
        raise ValueError(f"{where}: the mesh has no faces")
    vertices = vertices.astype(np.float64, copy=False)
    if not np.isfinite(vertices).all():
        bad = int(np.flatnonzero(~np.isfinite(vertices).all(axis=1))[0])
        raise ValueError(f"{where}: vertex {bad} has a non-finite coordinate (NaN or inf)")

    return vertices, check_faces(faces, len(vertices), where)


def check_faces(faces, n_vertices: int, where: str = "mesh") -> np.ndarray:
    """``faces`` as a C-contiguous int64 ``(m, 3)`` array of indices below ``n_vertices``.

    Integral floats are accepted. The compiled loops of the Laplacians do not check
    bounds, so every path to them comes through here: a bad index is a ``ValueError``,
    never a read out of bounds.
    """
    faces = np.asarray(faces)
    if faces.ndim != 2 or faces.shape[1] != 3:
        raise ValueError(
            f"{where}: faces must be an array of shape (n_faces, 3), got shape {faces.shape}"
        )
    if faces.dtype.kind == "f":
        if not np.isfinite(faces).all() or not (faces == np.round(faces)).all():
            raise ValueError(f"{where}: face indices must be integers")
    elif faces.dtype.kind not in "iu":
        raise ValueError(f"{where}: face indices must be integers, got dtype {faces.dtype}")
    if len(faces) and (faces.min() < 0 or faces.max() >= n_vertices):
        bad = int(np.flatnonzero(((faces < 0) | (faces >= n_vertices)).any(axis=1))[0])
        raise ValueError(
            f"{where}: face {bad} has index {faces[bad].tolist()} out of range for "
            f"{n_vertices} vertices"
        )
    return np.ascontiguousarray(faces, dtype=np.int64)


@dataclass(frozen=True, eq=False)
class CleanMesh:
    """A mesh after the cleaning policy of :func:`clean_mesh`.

    Attributes
    ----------
    vertices : ndarray of shape (n, 3)
    faces : ndarray of shape (m, 3)
        Indices into ``vertices``.
    vertex_indices : ndarray of shape (n,)
        For each kept vertex, its index in the input mesh.
    """

    vertices: np.ndarray
    faces: np.ndarray
    vertex_indices: np.ndarray


def face_double_areas(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Twice the area of each face."""
    p0, p1, p2 = (vertices[faces[:, i]] for i in range(3))
    return np.linalg.norm(np.cross(p1 - p0, p2 - p0), axis=1)


def _nondegenerate(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    return nondegenerate_faces(
        np.ascontiguousarray(vertices), np.ascontiguousarray(faces), _DEGENERATE_SINE
    )


def mesh_edges(faces: np.ndarray, n_vertices: int) -> sp.csr_matrix:
    """Symmetric vertex adjacency (CSR, data 1) of the edges of ``faces``.

    Built by a counting sort on rows with duplicates merged per row (compiled), an order
    of magnitude faster than ``np.unique`` over edge rows on large meshes.
    """
    faces = np.ascontiguousarray(faces, dtype=np.int64)
    ones = np.ones(faces.shape)
    arrays = edge_matrix_csr(n_vertices, faces, ones, False)
    return sp.csr_matrix(arrays, shape=(n_vertices, n_vertices))


def clean_mesh(
    vertices: np.ndarray,
    faces: np.ndarray,
    *,
    components: str = "largest",
    index: int | None = None,
) -> CleanMesh:
    """Apply the cleaning policy to a validated mesh.

    The policy, in order:

    1. faces with a repeated vertex index, and degenerate faces (collinear or coincident
       vertices: twice the area at most ``1e-12`` times the longest edge squared) are
       dropped: they have no area and would make the cotangent weights infinite;
    2. faces listing the same three vertices as an earlier face are dropped;
    3. vertices referenced by no remaining face are dropped;
    4. connected components (through shared vertices): with ``components="largest"``
       only the component of largest surface area is kept (ties: the one holding the
       lowest vertex index); with ``components="error"`` several components raise.

    Non-manifold edges and inconsistent face orientation are kept as they are: the
    Laplacians used here depend on neither.

    Parameters
    ----------
    vertices : ndarray of shape (n, 3)
    faces : ndarray of shape (m, 3)
        As returned by :func:`check_mesh`.
    components : {"largest", "error"}, default="largest"
        What to do with a mesh of several connected components.
    index : int, optional
        Position of the mesh in a collection, used in error messages.

    Returns
    -------
    CleanMesh
        The kept vertices and faces, and ``vertex_indices`` mapping each kept vertex to
        its index in the input.
    """
    where = _where(index)
    if components not in COMPONENT_POLICIES:
        raise ValueError(f"components must be one of {COMPONENT_POLICIES}, got {components!r}")
    keep = _nondegenerate(vertices, faces)
    faces = faces[keep]
    if len(faces) == 0:
        raise ValueError(f"{where}: every face is degenerate (zero area); nothing is left")
    faces = faces[first_of_duplicate_faces(faces)]

    used = np.zeros(len(vertices), dtype=bool)
    used[faces.ravel()] = True
    n_comp, labels = vertex_components(len(vertices), faces)
    if n_comp - np.count_nonzero(~used) > 1:
        face_labels = labels[faces[:, 0]]
        n_real = len(np.unique(face_labels))
        if components == "error":
            raise ValueError(
                f"{where}: the mesh has {n_real} connected components; pass "
                "components='largest' to keep the one of largest area"
            )
        area = np.bincount(face_labels, weights=face_double_areas(vertices, faces))
        largest = int(np.argmax(area))  # argmax takes the first maximum: lowest label
        faces = faces[face_labels == largest]
        used[:] = False
        used[faces.ravel()] = True

    vertex_indices = np.flatnonzero(used)
    new_index = np.full(len(vertices), -1, dtype=np.int64)
    new_index[vertex_indices] = np.arange(len(vertex_indices))
    return CleanMesh(
        vertices=np.ascontiguousarray(vertices[vertex_indices]),
        faces=np.ascontiguousarray(new_index[faces]),
        vertex_indices=vertex_indices,
    )
