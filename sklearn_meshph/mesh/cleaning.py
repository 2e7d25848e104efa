"""The cleaning policy: what the spectral stage does with imperfect meshes."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._param_validation import Options, validate_params
from ._geometry import (
    DEGENERATE_SINE,
    face_double_areas,
    first_of_duplicate_faces,
    nondegenerate_faces,
)
from ._graph import connected_components
from .validation import check_mesh, where

__all__ = ["COMPONENT_POLICIES", "CleanMesh", "clean_mesh"]

COMPONENT_POLICIES = ("largest", "error")


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


@validate_params(
    {"components": [Options(COMPONENT_POLICIES)], "index": [int, None]},
)
def clean_mesh(
    vertices: np.ndarray,
    faces: np.ndarray,
    *,
    components: str = "largest",
    index: int | None = None,
) -> CleanMesh:
    """Apply the cleaning policy to a mesh.

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
    vertices : array-like of shape (n, 3)
    faces : array-like of shape (m, 3)
        Validated as by :func:`check_mesh`.
    components : {"largest", "error"}, default="largest"
        What to do with a mesh of several connected components.
    index : int, optional
        Position of the mesh in a collection, used in error messages.

    Returns
    -------
    CleanMesh
        The kept vertices and faces, and ``vertex_indices`` mapping each kept vertex to
        its index in the input.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_meshph import clean_mesh
    >>> vertices = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [5, 5, 5]], dtype=float)
    >>> clean_mesh(vertices, [[0, 1, 2], [0, 1, 2]]).vertex_indices
    array([0, 1, 2])
    """
    vertices, faces = check_mesh((vertices, faces), index=index)
    return clean_checked(vertices, faces, components=components, index=index)


def clean_checked(vertices, faces, *, components: str, index: int | None) -> CleanMesh:
    """:func:`clean_mesh` on arrays that :func:`check_mesh` has already validated."""
    place = where(index)
    keep = nondegenerate_faces(vertices, faces, DEGENERATE_SINE)
    faces = faces[keep]
    if len(faces) == 0:
        raise ValueError(f"{place}: every face is degenerate (zero area); nothing is left")
    faces = faces[first_of_duplicate_faces(faces)]

    used = np.zeros(len(vertices), dtype=bool)
    used[faces.ravel()] = True
    n_comp, labels = connected_components(len(vertices), faces)
    if n_comp - np.count_nonzero(~used) > 1:
        face_labels = labels[faces[:, 0]]
        n_real = len(np.unique(face_labels))
        if components == "error":
            raise ValueError(
                f"{place}: the mesh has {n_real} connected components; pass "
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
