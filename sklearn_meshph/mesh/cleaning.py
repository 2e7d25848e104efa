"""The cleaning policy: what the spectral stage does with imperfect meshes."""

from __future__ import annotations

import os
import warnings
from dataclasses import dataclass, field

import numpy as np

from .._param_validation import Options, validate_params
from ._geometry import (
    DEGENERATE_SINE,
    face_double_areas,
    first_of_duplicate_faces,
    nondegenerate_faces,
    within_tukey_fences,
)
from .graph import connected_components
from .validation import check_mesh, where
from .welding import WELD_RTOL, weld_vertices

__all__ = [
    "COMPONENT_POLICIES",
    "LOSS_THRESHOLD",
    "CleanMesh",
    "CleaningReport",
    "MeshCleaningWarning",
    "clean_mesh",
]

COMPONENT_POLICIES = ("largest", "error")
# Cleaning that drops more than this share of the vertices or of the area warns.
LOSS_THRESHOLD = 0.01


class MeshCleaningWarning(UserWarning):
    """Cleaning dropped a noticeable part of a mesh (see :class:`CleaningReport`)."""


@dataclass(frozen=True)
class CleaningReport:
    """What the cleaning policy of :func:`clean_mesh` did to one mesh.

    Welded vertices are not losses: the shares count vertices after welding.

    Attributes
    ----------
    n_input_vertices : int
        Vertices of the input mesh.
    n_welded : int
        Input vertices merged into a lower-indexed vertex at the same position.
    n_degenerate_faces : int
        Faces dropped for a repeated vertex or zero area.
    n_repeated_faces : int
        Faces dropped for listing the same three vertices as an earlier face.
    n_unreferenced_vertices : int
        Vertices (after welding) that no remaining face uses.
    n_other_components : int
        Connected components dropped (all but the one of largest area).
    n_component_vertices : int
        Vertices of the dropped components.
    n_component_faces : int
        Faces of the dropped components.
    vertex_share : float
        Share of the vertices (after welding) dropped, unreferenced ones included.
    area_share : float
        Share of the surface area dropped (degenerate and repeated faces add none). For
        a point cloud, the area of its operator's mass; a dropped far component counts
        its own area at most its points' worth of the kept points' area per point, an
        outlier one point's worth (a few stray points span more area than the shape).
    n_far_points : int
        Points of a point cloud dropped for lying far from the rest for the cloud's own
        sampling (stray points, small far clusters; counted among the other components).
        Input points that coincide with a far point are far points, not welded ones.
        Always warned about, whatever their share: an outlier is a fact about the data.
    n_unresolved_points : int
        Points of a point cloud that float64 cannot resolve at the whole cloud's scale:
        a cluster over 4.5e9 times smaller than the cloud's box, with over 10% of the
        points outside it (too many to drop as far points; see
        :func:`sklearn_meshph.pointcloud.graph.cloud_unit_box`). Either the shape with
        too many far points around it, or near-copies of one point: they may merge
        into few points, which is not reported as a loss. Always warned about.
    """

    n_input_vertices: int
    n_welded: int
    n_degenerate_faces: int
    n_repeated_faces: int
    n_unreferenced_vertices: int
    n_other_components: int
    n_component_vertices: int
    n_component_faces: int
    vertex_share: float
    area_share: float
    n_far_points: int = 0
    n_unresolved_points: int = 0

    @property
    def dropped(self) -> bool:
        """Whether anything was dropped (welding is not dropping) or left unresolved."""
        return bool(
            self.n_degenerate_faces
            or self.n_repeated_faces
            or self.n_unreferenced_vertices
            or self.n_other_components
            or self.n_unresolved_points
        )

    @property
    def significant(self) -> bool:
        """Whether more than :data:`LOSS_THRESHOLD` of the vertices or area was dropped,
        or any far or unresolved point of a cloud."""
        return (
            self.vertex_share > LOSS_THRESHOLD
            or self.area_share > LOSS_THRESHOLD
            or self.n_far_points > 0
            or self.n_unresolved_points > 0
        )

    def message(self, place: str = "mesh") -> str:
        """A sentence naming ``place`` and what was dropped, for a warning."""
        return (
            f"{place}: cleaning dropped {100 * self.vertex_share:.3g}% of the vertices "
            f"and {100 * self.area_share:.3g}% of the area: "
            f"{self.n_degenerate_faces} degenerate faces, "
            f"{self.n_repeated_faces} repeated faces, "
            f"{self.n_unreferenced_vertices} unreferenced vertices, "
            f"{self.n_other_components} other components "
            f"({self.n_component_vertices} vertices, {self.n_component_faces} faces)"
            + (
                f", of which {self.n_far_points} far points (outliers for the cloud's sampling)"
                if self.n_far_points
                else ""
            )
            + (
                f"; {self.n_unresolved_points} points lie in a cluster that float64 "
                "resolves to worse than 1e-6 of its size at the cloud's scale (it may "
                "have merged into few points; over 10% of the points lie far from it: "
                "if the cluster is the shape, drop those)"
                if self.n_unresolved_points
                else ""
            )
        )


def warn_if_lossy(report: CleaningReport | None, place: str, stacklevel: int = 2) -> None:
    """Emit a :class:`MeshCleaningWarning` if ``report`` is significant."""
    if report is not None and report.significant:
        warnings.warn(report.message(place), MeshCleaningWarning, stacklevel=stacklevel + 1)


def describe(index: int | None, mesh) -> str:
    """How a warning names a sample: its position, and its file when it came from one."""
    place = where(index)
    if isinstance(mesh, str | os.PathLike):
        place += f" (file {os.fspath(mesh)!r})"
    return place


@dataclass(frozen=True, eq=False)
class CleanMesh:
    """A mesh after the cleaning policy of :func:`clean_mesh`.

    Attributes
    ----------
    vertices : ndarray of shape (n, 3)
    faces : ndarray of shape (m, 3)
        Indices into ``vertices``.
    vertex_indices : ndarray of shape (n,)
        For each kept vertex, its index in the input mesh (the lowest index of the
        vertices welded into it).
    input_to_kept : ndarray of shape (n_input_vertices,)
        For each input vertex, the index of the kept vertex it became (welded vertices
        share one), or -1 if it was dropped: ``values[input_to_kept]`` lines values on
        the kept vertices up with the input's vertices (where not -1).
    report : CleaningReport
        What was welded and dropped, and why.
    edges : ndarray of shape (k, 2) or None
        A cleaned point cloud's persistence complex: the edges (``a < b``, sorted, each
        once) of the local triangles its operator was built from. None for a mesh,
        whose complex is its faces.
    """

    vertices: np.ndarray
    faces: np.ndarray
    vertex_indices: np.ndarray
    input_to_kept: np.ndarray = field(default=None, repr=False)
    report: CleaningReport | None = field(default=None, repr=False)
    edges: np.ndarray | None = field(default=None, repr=False)


@validate_params(
    {"components": [Options(COMPONENT_POLICIES)], "index": [int, None], "weld": ["boolean"]},
)
def clean_mesh(
    vertices: np.ndarray,
    faces: np.ndarray,
    *,
    components: str = "largest",
    index: int | None = None,
    weld: bool = True,
) -> CleanMesh:
    """Apply the cleaning policy to a mesh.

    The policy, in order:

    0. with ``weld=True``, vertices at the same position are welded: two vertices
       whose coordinates all differ by at most :data:`WELD_RTOL` times the bounding-box
       diagonal (exactly equal ones always) become one, the one of lowest index
       (transitively), and faces are renumbered to it. This joins the triangle soups of
       STL files and the vertices that OBJ files split along UV seams; a mesh without
       coincident vertices is left exactly as it is;
    1. faces with a repeated vertex index, and degenerate faces (collinear or coincident
       vertices: twice the area at most ``DEGENERATE_SINE`` times the longest edge
       squared) are dropped: they have no area and would make the cotangent weights
       infinite;
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
    weld : bool, default=True
        Weld coincident vertices first (step 0); ``False`` keeps the vertices as given.

    Returns
    -------
    CleanMesh
        The kept vertices and faces, ``vertex_indices`` mapping each kept vertex to its
        index in the input, ``input_to_kept`` mapping each input vertex to its kept
        vertex (or -1), and ``report``, a :class:`CleaningReport`. This function does
        not warn; :class:`LaplacianEigenTransformer` and
        :func:`laplacian_eigenfunctions` emit a :class:`MeshCleaningWarning` when the
        report says more than :data:`LOSS_THRESHOLD` of the vertices or of the
        area was dropped.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_meshph import clean_mesh
    >>> vertices = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [5, 5, 5]], dtype=float)
    >>> clean_mesh(vertices, [[0, 1, 2], [0, 1, 2]]).vertex_indices
    array([0, 1, 2])
    """
    vertices, faces = check_mesh((vertices, faces), index=index)
    return clean_checked(vertices, faces, components=components, index=index, weld=weld)


def _far_vertices_hint(vertices: np.ndarray) -> str:
    """Why every face may be degenerate: a few vertices (at most a tenth) outside
    Tukey's fences (three interquartile ranges beyond the quartiles) and over 1e6 times
    farther out than the others extend, at whose scale the others collapse (welding
    merges them). An empty string otherwise."""
    outside = ~within_tukey_fences(vertices)
    if not outside.any() or np.count_nonzero(outside) > 0.1 * len(vertices):
        return ""
    if not np.ptp(vertices, axis=0).max() > 1e6 * np.ptp(vertices[~outside], axis=0).max():
        return ""
    return (
        f": {np.count_nonzero(outside)} vertices (vertex {int(np.flatnonzero(outside)[0])} "
        "first) lie over 1e6 times farther out than the others extend, and at the scale "
        "of the whole mesh the others collapse; remove them"
    )


def clean_checked(
    vertices, faces, *, components: str, index: int | None, weld: bool = True
) -> CleanMesh:
    """:func:`clean_mesh` on arrays that :func:`check_mesh` has already validated."""
    place = where(index)
    n_input = len(vertices)
    welded = np.ones(n_input, dtype=bool)  # the vertices that survive welding
    representative = None
    if weld:
        representative = weld_vertices(vertices, WELD_RTOL)
        welded = representative == np.arange(n_input)
        if welded.all():
            representative = None
        else:
            faces = representative[faces]
    n_welded = n_input - int(np.count_nonzero(welded))

    keep = nondegenerate_faces(vertices, faces, DEGENERATE_SINE)
    n_degenerate = len(faces) - int(np.count_nonzero(keep))
    faces = faces[keep]
    if len(faces) == 0:
        raise ValueError(
            f"{place}: every face is degenerate (zero area); nothing is left"
            + _far_vertices_hint(vertices)
        )
    n_faces = len(faces)
    faces = faces[first_of_duplicate_faces(faces)]
    n_repeated = n_faces - len(faces)

    used = np.zeros(n_input, dtype=bool)
    used[faces.ravel()] = True
    n_referenced = int(np.count_nonzero(used))
    n_unreferenced = n_input - n_welded - n_referenced
    n_other = n_component_faces = 0
    area_share = 0.0
    n_comp, labels = connected_components(n_input, faces)
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
        in_largest = face_labels == largest
        n_other = n_real - 1
        n_component_faces = len(faces) - int(np.count_nonzero(in_largest))
        total = float(area.sum())
        area_share = 1.0 - float(area[largest]) / total if total > 0 else 0.0
        faces = faces[in_largest]
        used[:] = False
        used[faces.ravel()] = True

    vertex_indices = np.flatnonzero(used)
    n_kept = len(vertex_indices)
    new_index = np.full(n_input, -1, dtype=np.int64)
    new_index[vertex_indices] = np.arange(n_kept)
    input_to_kept = new_index if representative is None else new_index[representative]
    n_distinct = n_input - n_welded
    report = CleaningReport(
        n_input_vertices=n_input,
        n_welded=n_welded,
        n_degenerate_faces=n_degenerate,
        n_repeated_faces=n_repeated,
        n_unreferenced_vertices=n_unreferenced,
        n_other_components=n_other,
        n_component_vertices=n_referenced - n_kept,
        n_component_faces=n_component_faces,
        vertex_share=(n_distinct - n_kept) / n_distinct,
        area_share=max(area_share, 0.0),
    )
    return CleanMesh(
        vertices=np.ascontiguousarray(vertices[vertex_indices]),
        faces=np.ascontiguousarray(new_index[faces]),
        vertex_indices=vertex_indices,
        input_to_kept=input_to_kept,
        report=report,
    )
