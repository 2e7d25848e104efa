"""What kind of sample this is: the one place where a sample's kind is decided.

Every function and estimator that takes samples (the eigen stage, ``LowerStarPersistence``
with ``(mesh, values)`` pairs, ``laplacian_eigenfunctions``, ``lower_star_persistence``)
calls :func:`check_input`, which reads a path first, then asks :data:`KINDS` in turn
which kind the sample is and validates it as that kind:

- a **graph** is a :class:`~sklearn_meshph.Graph`, an ``(n_nodes, edges)`` pair (an
  integer first), a scipy sparse adjacency matrix or a networkx graph; it is checked by
  :func:`~sklearn_meshph.check_graph` and returned as ``(Graph, None)``: callers test
  for a ``Graph`` before reading ``faces is None`` as a point cloud;
- a **point cloud** is a NumPy array (a mesh is never one array), a
  ``trimesh.PointCloud``, any object with ``vertices`` and no ``faces``, or a file
  holding points without triangles (``.xyz``, ``.pts``, a PLY without faces);
- a **mesh** is a ``trimesh.Trimesh`` (anything with ``vertices`` and ``faces``), a
  ``(vertices, faces)`` pair or a mesh file.

A nested list of points is not a cloud: a list of two points would read as a
``(vertices, faces)`` pair; pass ``np.asarray(points)``. A new kind of sample is a
reader for its files in its own package, one :class:`InputKind` in
:data:`KINDS` (the test that recognises it and the validator that returns its arrays),
and its solve in the eigen stage.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .graph.validation import check_graph, is_graph
from .mesh.validation import check_mesh, where
from .pointcloud.reading import read_sample_file
from .pointcloud.validation import check_point_cloud

__all__ = ["KINDS", "InputKind", "check_input", "is_point_cloud", "sample_kind"]


@dataclass(frozen=True)
class InputKind:
    """One kind of sample: its name, the test that recognises it (on an object read
    from its file, never on a path) and the validator that returns its arrays
    ``(vertices, faces or None)``, naming the sample in its errors."""

    name: str
    recognizes: Callable[[object], bool]
    check: Callable[..., tuple[np.ndarray, np.ndarray | None]]


def is_point_cloud(sample) -> bool:
    """Whether ``sample`` (not a path) is a point cloud rather than a mesh."""
    return isinstance(sample, np.ndarray) or (
        hasattr(sample, "vertices") and not hasattr(sample, "faces")
    )


def _is_mesh(sample) -> bool:
    return hasattr(sample, "vertices") or (isinstance(sample, tuple | list) and len(sample) == 2)


def _check_cloud(sample, *, index):
    return check_point_cloud(sample, index=index), None


def _check_graph(sample, *, index):
    return check_graph(sample, index=index), None


#: The kinds of sample, asked in this order; the first that recognises a sample wins.
KINDS = (
    InputKind("graph", is_graph, _check_graph),
    InputKind("point cloud", is_point_cloud, _check_cloud),
    InputKind("mesh", _is_mesh, check_mesh),
)


def _read(sample, index):
    if isinstance(sample, str | os.PathLike):
        return read_sample_file(sample, where(index))
    return sample


def _kind_of(sample, index) -> InputKind:
    for kind in KINDS:
        if kind.recognizes(sample):
            return kind
    raise TypeError(
        f"{where(index)}: expected a trimesh.Trimesh, a (vertices, faces) pair or a "
        "path, a point cloud (an (n, 3) array or a trimesh.PointCloud), or a graph (a "
        "Graph, an (n_nodes, edges) pair, a sparse adjacency or a networkx graph), got "
        f"{type(sample).__name__}"
    )


def sample_kind(sample, *, index: int | None = None) -> str:
    """The name of the kind of ``sample`` in :data:`KINDS` (``"mesh"`` or
    ``"point cloud"``), reading a path first; a ``TypeError`` for none of them."""
    return _kind_of(_read(sample, index), index).name


def check_input(sample, *, index: int | None = None) -> tuple[np.ndarray, np.ndarray | None]:
    """A mesh as ``(vertices, faces)``, a point cloud as ``(points, None)``, or a graph
    as ``(Graph, None)``.

    Paths are read first (:func:`sklearn_meshph.pointcloud.reading.read_sample_file`):
    a file without triangles is a point cloud. Meshes are validated by
    :func:`sklearn_meshph.check_mesh`, with its messages; clouds by
    :func:`sklearn_meshph.check_point_cloud`. Any other object is a ``TypeError``
    naming the sample and the accepted kinds.
    """
    read = _read(sample, index)
    if read is sample:
        return _kind_of(sample, index).check(sample, index=index)
    try:
        return _kind_of(read, index).check(read, index=index)
    except ValueError as exc:  # the problem is the file's: name it
        raise ValueError(f"{exc} (read from {os.fspath(sample)!r})") from exc
