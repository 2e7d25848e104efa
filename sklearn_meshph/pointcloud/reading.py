"""Reading point-cloud files: ``.xyz`` and ``.pts`` text, and PLY files without faces.

``.xyz`` and ``.pts`` files are plain text, one point per line: at least three numbers,
the first three being the coordinates (further columns, such as normals or colours, are
ignored); blank lines and ``#`` comments are skipped, and so is a first line holding a
single number (the point count that ``.pts`` files start with). They are read as a
stream, twice (counting the points, then parsing them block by block into an array of
that size), so that the memory held beyond the points themselves stays small whatever
the file's size; never beyond ``MAX_TEXT_SIZE`` bytes (after decompression for ``.gz``,
``.bz2`` and ``.xz``, which goes through
:class:`sklearn_meshph.mesh.reading.LimitedReader`). Every other format goes through
:func:`sklearn_meshph.mesh.reading.read_mesh_file`, whose safety checks apply; a file
it reads without triangles (a PLY of vertices only) is a point cloud.
"""

from __future__ import annotations

import contextlib
import itertools
import os

import numpy as np

from ..mesh.reading import LimitedReader, read_mesh_file, split_compression

__all__ = [
    "MAX_COLUMNS",
    "MAX_LINE_LENGTH",
    "MAX_POINTS",
    "MAX_SKIPPED_LINES",
    "MAX_TEXT_SIZE",
    "POINT_CLOUD_FORMATS",
    "read_point_cloud_file",
    "read_sample_file",
]

#: The text point-cloud formats read (file name endings without the dot).
POINT_CLOUD_FORMATS = ("xyz", "pts")

#: Largest size of a text point-cloud file, in bytes (512 MiB), decompressed.
MAX_TEXT_SIZE = 512 * 1024**2

_BLOCK = 4096  # lines parsed at a time

#: Most blank or comment lines of a text point-cloud file, beyond ``_SKIPPED_PER_POINT``
#: per point: each is read on its own, and 512 MiB of them took 5 minutes to refuse.
MAX_SKIPPED_LINES = 1_000_000
_SKIPPED_PER_POINT = 4

#: Longest line read, in bytes: a hundred numbers, more than a point's columns. A
#: longer line (a file with carriage returns only for line ends, or junk) is refused
#: before it is held in memory; a block of lines parsed at once is at most 16 MiB.
MAX_LINE_LENGTH = 4096

#: Most numbers on a line (coordinates, then normals, colours...): a file of 4,096
#: points of 32,000 numbers each took 1.8 GB to parse.
MAX_COLUMNS = 64

#: Most points of a text point-cloud file (16 Mi): the bytes limit alone let 782 KB of
#: gzip hold 89 million equal points, read in 3 minutes into 2 GB, then 12 GB in the
#: eigen stage. Counted on the first pass, refused as soon as it is passed.
MAX_POINTS = 1 << 24


@contextlib.contextmanager
def _data_lines(path: str, compression, place: str):
    """``(line number, text)`` of each line that holds data, comments stripped."""
    if compression is None:
        stream = open(path, "rb")  # noqa: SIM115 (closed below)
    else:
        stream = LimitedReader(path, compression, place, MAX_TEXT_SIZE, "point cloud file")

    def lines():
        number = held = 0
        while line := stream.readline(MAX_LINE_LENGTH + 1):
            number += 1
            if len(line) > MAX_LINE_LENGTH:
                raise ValueError(
                    f"{place}: cannot read point cloud file {path!r}: line {number} is "
                    f"longer than {MAX_LINE_LENGTH} bytes (line ends other than \\n?)"
                )
            text = line.split(b"#", 1)[0].strip()
            if b"\r" in text:
                raise ValueError(
                    f"{place}: cannot read point cloud file {path!r}: line {number} holds "
                    "carriage returns: its lines must end with \\n (or \\r\\n)"
                )
            if text:
                held += 1
                yield number, text
            elif number - held > MAX_SKIPPED_LINES + _SKIPPED_PER_POINT * held:
                raise ValueError(
                    f"{place}: cannot read point cloud file {path!r}: {number - held} of its "
                    f"first {number} lines are blank or comments, more than "
                    f"{MAX_SKIPPED_LINES} plus {_SKIPPED_PER_POINT} per point (reading "
                    "them would take minutes)"
                )

    try:
        yield lines()
    finally:
        stream.close()


def _parse_block(block, width: int, path: str, place: str) -> np.ndarray:
    """The numbers of a block of lines, ``(len(block), width)``; a line that does not
    hold ``width`` numbers is named."""
    try:
        table = np.loadtxt([text.decode("latin-1") for _, text in block], ndmin=2)
    except ValueError:
        table = None
    if table is not None and table.shape[1] == width:
        return table
    for number, text in block:  # the line to name: each parsed alone, as the block was
        try:
            row = np.loadtxt([text.decode("latin-1")], ndmin=2)
        except ValueError:
            reason = "holds something other than numbers"
        else:
            if row.shape[1] == width:
                continue
            reason = f"holds {row.shape[1]} numbers where the first point has {width}"
        raise ValueError(f"{place}: cannot read point cloud file {path!r}: line {number} {reason}")
    raise ValueError(f"{place}: cannot read point cloud file {path!r}")  # not reached


def read_point_cloud_file(path, place: str = "point cloud") -> np.ndarray:
    """The points ``(n, 3)`` of an ``.xyz`` or ``.pts`` file (possibly compressed).

    Raises
    ------
    ValueError
        If the file does not exist, is empty, is larger than ``MAX_TEXT_SIZE`` (once
        decompressed), holds more than ``MAX_POINTS`` points, a line longer than
        ``MAX_LINE_LENGTH`` bytes or more than ``MAX_COLUMNS`` numbers, or a line does
        not hold at least three numbers (the same count on every line). The message is
        one line naming the file (and the line).
    """
    path = os.fspath(path)
    if not os.path.isfile(path):
        problem = "is not a regular file" if os.path.lexists(path) else "does not exist"
        raise ValueError(f"{place}: point cloud file {path!r} {problem}")
    _, compression = split_compression(path)
    if compression is None and os.path.getsize(path) > MAX_TEXT_SIZE:
        raise ValueError(
            f"{place}: point cloud file {path!r} is larger than {MAX_TEXT_SIZE} bytes "
            "(the limit, MAX_TEXT_SIZE); refusing to parse it"
        )
    n_points, width, skip = 0, 0, 0
    with _data_lines(path, compression, place) as lines:
        for number, text in lines:
            if not n_points and not skip and len(text.split()) == 1:
                skip = number  # the point count of a .pts file
                continue
            if not n_points:
                width = len(text.split())
                if width > MAX_COLUMNS:
                    raise ValueError(
                        f"{place}: cannot read point cloud file {path!r}: line {number} "
                        f"holds {width} numbers, more than MAX_COLUMNS ({MAX_COLUMNS})"
                    )
            n_points += 1
            if n_points > MAX_POINTS:
                raise ValueError(
                    f"{place}: point cloud file {path!r} holds more than MAX_POINTS "
                    f"({MAX_POINTS}) points; refusing to read it"
                )
    if not n_points:
        raise ValueError(f"{place}: point cloud file {path!r} holds no points")
    if width < 3:
        raise ValueError(
            f"{place}: point cloud file {path!r} has {width} numbers per line; "
            "expected at least 3 (x y z)"
        )
    points = np.empty((n_points, 3), dtype=np.float64)
    filled = 0
    with _data_lines(path, compression, place) as lines:
        kept = (item for item in lines if item[0] != skip)
        while block := list(itertools.islice(kept, _BLOCK)):
            if filled + len(block) > n_points:
                break
            points[filled : filled + len(block)] = _parse_block(block, width, path, place)[:, :3]
            filled += len(block)
    if filled != n_points:
        raise ValueError(
            f"{place}: point cloud file {path!r} changed while it was read ({n_points} "
            "points counted, then another number)"
        )
    return points


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
