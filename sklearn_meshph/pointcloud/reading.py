"""Reading point-cloud files: ``.xyz`` and ``.pts`` text, and PLY files without faces.

``.xyz`` and ``.pts`` files are plain text, one point per line: at least three numbers,
the first three being the coordinates (further columns, such as normals or colours, are
ignored); blank lines and ``#`` comments are skipped, and so is a first line holding a
single number (the point count that ``.pts`` files start with). They are parsed with
NumPy, never beyond ``MAX_TEXT_SIZE`` bytes (after decompression for ``.gz``, ``.bz2``
and ``.xz``). Every other format goes through
:func:`sklearn_meshph.mesh.reading.read_mesh_file`, whose safety checks apply; a file
it reads without triangles (a PLY of vertices only) is a point cloud.
"""

from __future__ import annotations

import io
import os

import numpy as np

from ..mesh.reading import _decompress, read_mesh_file, split_compression

__all__ = ["MAX_TEXT_SIZE", "POINT_CLOUD_FORMATS", "read_point_cloud_file", "read_sample_file"]

#: The text point-cloud formats read (file name endings without the dot).
POINT_CLOUD_FORMATS = ("xyz", "pts")

#: Largest size of a text point-cloud file, in bytes (512 MiB, about 20 million points),
#: decompressed: NumPy parses the whole text in memory.
MAX_TEXT_SIZE = 512 * 1024**2


def read_point_cloud_file(path, place: str = "point cloud") -> np.ndarray:
    """The points ``(n, 3)`` of an ``.xyz`` or ``.pts`` file (possibly compressed).

    Raises
    ------
    ValueError
        If the file does not exist, is empty, is larger than ``MAX_TEXT_SIZE`` (once
        decompressed), or a line does not hold at least three numbers (the same count
        on every line). The message names the file.
    """
    path = os.fspath(path)
    if not os.path.isfile(path):
        raise ValueError(f"{place}: point cloud file {path!r} does not exist")
    _, compression = split_compression(path)
    if compression is None:
        if os.path.getsize(path) > MAX_TEXT_SIZE:
            raise ValueError(
                f"{place}: point cloud file {path!r} is larger than {MAX_TEXT_SIZE} bytes "
                "(the limit, MAX_TEXT_SIZE); refusing to parse it"
            )
        with open(path, "rb") as stream:
            data = stream.read()
    else:
        data = _decompress(path, compression, place, MAX_TEXT_SIZE).getvalue()
    lines = [line.split(b"#")[0].strip() for line in data.splitlines()]
    lines = [line for line in lines if line]
    if lines and len(lines[0].split()) == 1:
        lines = lines[1:]  # the point count of a .pts file
    if not lines:
        raise ValueError(f"{place}: point cloud file {path!r} holds no points")
    try:
        table = np.loadtxt(io.BytesIO(b"\n".join(lines)), dtype=np.float64, ndmin=2)
    except ValueError as exc:
        raise ValueError(f"{place}: cannot read point cloud file {path!r}: {exc}") from exc
    if table.shape[1] < 3:
        raise ValueError(
            f"{place}: point cloud file {path!r} has {table.shape[1]} numbers per line; "
            "expected at least 3 (x y z)"
        )
    return np.ascontiguousarray(table[:, :3])


def read_sample_file(path, place: str = "mesh"):
    """A mesh file as a ``trimesh.Trimesh``, or a point-cloud file as an ``(n, 3)``
    array (``.xyz``, ``.pts``, or a file of a mesh format without triangles)."""
    file_type, _ = split_compression(path)
    if file_type in POINT_CLOUD_FORMATS:
        return read_point_cloud_file(path, place)
    mesh = read_mesh_file(path, place, allow_points=True)
    if len(getattr(mesh, "faces", ())) == 0:
        return np.asarray(mesh.vertices, dtype=np.float64)
    return mesh
