"""ScalarField: vertex functions on a mesh or a point cloud, the data passed between
pipeline stages."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .cleaning import CleaningReport
from .validation import check_edges, check_faces, check_values, check_vertices

__all__ = ["ScalarField"]


def _frozen(array: np.ndarray) -> np.ndarray:
    array = array.copy()
    array.flags.writeable = False
    return array


@dataclass(frozen=True, eq=False)
class ScalarField:
    """One or several functions on the vertices of a triangle mesh or a point cloud.

    This is what :class:`LaplacianEigenTransformer` returns per mesh and what
    :class:`LowerStarPersistence` takes. Everything is plain NumPy, so it pickles and
    crosses process boundaries cheaply.

    Every field is validated when it is made (shapes, finite values, face and edge
    indices in range), so the compiled stages downstream can trust it.

    The complex that :class:`LowerStarPersistence` filters is the vertices, the edges of
    ``faces`` and ``edges``. A point cloud has no faces (an empty ``(0, 3)`` array) and
    its neighbourhood graph as ``edges``.

    Parameters
    ----------
    vertices : ndarray of shape (n_vertices, 3)
        Vertex positions of the (cleaned) mesh the values live on; ``(n_nodes, 0)`` for
        a graph (nodes have no coordinates; its edges are ``edges``).
    faces : ndarray of shape (n_faces, 3)
        Triangles, as indices into ``vertices``; ``(0, 3)`` for a point cloud.
    values : ndarray of shape (n_vertices,) or (n_vertices, n_functions)
        The function values, one row per vertex.
    eigenvalues : ndarray of shape (n_functions,), optional
        The eigenvalue of each column when the values are Laplacian eigenfunctions.
    vertex_indices : ndarray of shape (n_vertices,), optional
        Index of each vertex in the input mesh it came from, when the mesh was cleaned
        (see :func:`sklearn_meshph.clean_mesh`). ``None`` means the identity.
    input_to_kept : ndarray of shape (n_input_vertices,), optional
        For each vertex of the input mesh, the index of the vertex it became here
        (vertices welded together share one), or -1 if cleaning dropped it:
        ``values[input_to_kept]`` gives a value per input vertex (meaningless where the
        map is -1). ``None`` means the identity.
    cleaning : CleaningReport, optional
        What cleaning dropped from the input mesh, and why; ``None`` when nothing was
        dropped (welding alone is not dropping).
    spectrum : ndarray of shape (n_eigenpairs,), optional
        Every eigenvalue the eigen stage solved for this mesh, ascending, the constant
        eigenfunction's first (at unit area by default): what :class:`ShapeDNA` reads.
    edges : ndarray of shape (n_edges, 2), optional
        Edges of the complex beyond those of the faces, as indices into ``vertices``:
        for a point cloud, the edges of its local triangles (see
        :class:`LaplacianEigenTransformer`). ``None`` means none.
    column_names : tuple of str, optional
        What each column of ``values`` is, for labels and legends:
        :class:`LaplacianEigenTransformer` sets ``"eigenfunction 3"``, ``"heat kernel
        signature t=0.0312"``, ``"log heat kernel signature t=..."`` or ``"wave kernel
        signature e=..."``. ``None`` (the default) names them ``"function 0"``,
        ``"function 1"``...

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_meshph import ScalarField
    >>> tetra_v = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    >>> tetra_f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    >>> field = ScalarField(tetra_v, tetra_f, tetra_v[:, 2])
    >>> field.n_vertices, field.n_functions, field.column_names
    (4, 1, ('function 0',))
    """

    vertices: np.ndarray
    faces: np.ndarray
    values: np.ndarray
    eigenvalues: np.ndarray | None = None
    vertex_indices: np.ndarray | None = field(default=None, repr=False)
    input_to_kept: np.ndarray | None = field(default=None, repr=False)
    cleaning: CleaningReport | None = field(default=None, repr=False)
    spectrum: np.ndarray | None = field(default=None, repr=False)
    edges: np.ndarray | None = field(default=None, repr=False)
    column_names: tuple[str, ...] | None = field(default=None, repr=False)

    def __post_init__(self):
        vertices = self.vertices
        if isinstance(vertices, np.ndarray) and vertices.ndim == 2 and vertices.shape[1] == 0:
            # A graph: nodes without coordinates.
            if len(vertices) == 0:
                raise ValueError("ScalarField: the graph has no nodes")
            vertices = np.zeros(vertices.shape, dtype=np.float64)
        else:
            vertices = check_vertices(vertices, "ScalarField")
        faces = check_faces(self.faces, len(vertices), "ScalarField")
        values = check_values(self.values, len(vertices), "ScalarField")
        # Own read-only copies: the validation above must still hold when the compiled
        # stages read the field, whatever the caller does to its arrays afterwards (an
        # index set out of range in place would be read out of bounds).
        vertices, faces, values = (_frozen(array) for array in (vertices, faces, values))
        object.__setattr__(self, "vertices", vertices)
        object.__setattr__(self, "faces", faces)
        object.__setattr__(self, "values", values)
        if self.eigenvalues is not None:
            object.__setattr__(
                self, "eigenvalues", np.atleast_1d(np.asarray(self.eigenvalues, np.float64))
            )
        if self.spectrum is not None:
            spectrum = np.asarray(self.spectrum, dtype=np.float64)
            if spectrum.ndim != 1 or not np.isfinite(spectrum).all():
                raise ValueError("ScalarField: spectrum must be a finite 1-D array")
            object.__setattr__(self, "spectrum", _frozen(spectrum))
        if self.edges is not None:
            edges = check_edges(self.edges, len(vertices), "ScalarField")
            object.__setattr__(self, "edges", _frozen(edges))
        if self.vertex_indices is not None:
            object.__setattr__(self, "vertex_indices", np.asarray(self.vertex_indices))
        if self.input_to_kept is not None:
            input_to_kept = np.asarray(self.input_to_kept, dtype=np.int64)
            if input_to_kept.ndim != 1 or (
                len(input_to_kept)
                and (input_to_kept.min() < -1 or input_to_kept.max() >= len(vertices))
            ):
                raise ValueError(
                    "ScalarField: input_to_kept must be a 1-D array of indices into the "
                    f"{len(vertices)} vertices or -1"
                )
            object.__setattr__(self, "input_to_kept", _frozen(input_to_kept))
        names = self.column_names
        if names is None:
            names = tuple(f"function {j}" for j in range(self.n_functions))
        elif isinstance(names, str) or not all(isinstance(name, str) for name in names):
            raise ValueError("ScalarField: column_names must be a sequence of str")
        names = tuple(names)
        if len(names) != self.n_functions:
            raise ValueError(
                f"ScalarField: {len(names)} column_names for {self.n_functions} columns"
            )
        object.__setattr__(self, "column_names", names)

    @property
    def is_graph(self) -> bool:
        """Whether the field lives on a graph (``vertices`` of shape ``(n_nodes, 0)``:
        nodes without coordinates, the graph's edges in ``edges``)."""
        return self.vertices.shape[1] == 0

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
        return self.columns_of(self.values)

    @staticmethod
    def columns_of(values: np.ndarray) -> list[np.ndarray]:
        """The columns of a ``(n,)`` or ``(n, k)`` array of vertex values, as 1-D arrays."""
        if values.ndim == 1:
            return [values]
        return [values[:, j] for j in range(values.shape[1])]
