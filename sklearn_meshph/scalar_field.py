"""ScalarField: vertex functions on a mesh, the data passed between pipeline stages."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["ScalarField"]


@dataclass(frozen=True, eq=False)
class ScalarField:
    """One or several functions on the vertices of a triangle mesh.

    This is what :class:`LaplacianEigenTransformer` returns per mesh and what
    :class:`LowerStarPersistence` takes. Everything is plain NumPy, so it pickles and
    crosses process boundaries cheaply.

    Parameters
    ----------
    vertices : ndarray of shape (n_vertices, 3)
        Vertex positions of the (cleaned) mesh the values live on.
    faces : ndarray of shape (n_faces, 3)
        Triangles, as indices into ``vertices``.
    values : ndarray of shape (n_vertices,) or (n_vertices, n_functions)
        The function values, one row per vertex.
    eigenvalues : ndarray of shape (n_functions,), optional
        The eigenvalue of each column when the values are Laplacian eigenfunctions.
    vertex_indices : ndarray of shape (n_vertices,), optional
        Index of each vertex in the input mesh it came from, when the mesh was cleaned
        (see :func:`sklearn_meshph.clean_mesh`). ``None`` means the identity.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_meshph import ScalarField
    >>> tetra_v = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    >>> tetra_f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    >>> field = ScalarField(tetra_v, tetra_f, tetra_v[:, 2])
    >>> field.n_vertices, field.n_functions
    (4, 1)
    """

    vertices: np.ndarray
    faces: np.ndarray
    values: np.ndarray
    eigenvalues: np.ndarray | None = None
    vertex_indices: np.ndarray | None = field(default=None, repr=False)

    def __post_init__(self):
        vertices = np.asarray(self.vertices, dtype=np.float64)
        faces = np.asarray(self.faces)
        values = np.asarray(self.values, dtype=np.float64)
        if vertices.ndim != 2 or vertices.shape[1] != 3:
            raise ValueError(f"vertices must have shape (n, 3), got {vertices.shape}")
        if faces.ndim != 2 or faces.shape[1] != 3 or faces.dtype.kind not in "iu":
            raise ValueError(
                f"faces must be an integer array of shape (m, 3), got {faces.dtype} {faces.shape}"
            )
        if values.ndim not in (1, 2) or values.shape[0] != len(vertices):
            raise ValueError(
                f"values must have shape ({len(vertices)},) or ({len(vertices)}, k), "
                f"got {values.shape}"
            )
        if not np.isfinite(values).all():
            raise ValueError("values must be finite (no NaN or inf)")
        object.__setattr__(self, "vertices", vertices)
        object.__setattr__(self, "faces", faces.astype(np.int64, copy=False))
        object.__setattr__(self, "values", values)
        if self.eigenvalues is not None:
            object.__setattr__(
                self, "eigenvalues", np.atleast_1d(np.asarray(self.eigenvalues, np.float64))
            )
        if self.vertex_indices is not None:
            object.__setattr__(self, "vertex_indices", np.asarray(self.vertex_indices))

    @property
    def n_vertices(self) -> int:
        """Number of vertices."""
        return len(self.vertices)

    @property
    def n_functions(self) -> int:
        """Number of functions (columns of ``values``)."""
        return 1 if self.values.ndim == 1 else self.values.shape[1]

    def columns(self) -> list[np.ndarray]:
        """The functions as a list of 1-D arrays."""
        if self.values.ndim == 1:
            return [self.values]
        return [self.values[:, j] for j in range(self.values.shape[1])]
