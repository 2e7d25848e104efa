"""A strict OFF reader whose memory is that of the mesh it returns.

trimesh's OFF reader decodes the whole file to one string, splits it into lines, then
every line into tokens: up to 40 bytes of memory per byte of file (a 218 KB ``.off.gz``
of short lines took 5.6 GB), and a file cut short loads as part of a mesh without a
word. This one reads the file a block of lines at a time into arrays sized from the
header (after checking that the file can hold that many lines), and refuses a file
that ends before the vertices and faces its header declares.

The format: an optional ``#`` comment anywhere on a line; blank lines are ignored; the
keyword ``OFF`` (with the prefixes ``ST``, ``C``, ``N`` for texture coordinates, colours
and normals, whose values follow each vertex's three coordinates and are ignored), then
the counts of vertices, faces and edges (on the keyword's line or the next), each
vertex's coordinates on a line, each face as its number of corners then the corners'
indices (0-based) on a line, optionally followed by a colour. Polygons are cut into a
fan of triangles from their first corner, as trimesh does.
"""

from __future__ import annotations

import io
import re

import numpy as np

__all__ = ["read_off"]

_KEYWORD = re.compile(rb"(ST)?C?N?OFF")
# Lines converted at once: bounds the memory of the tokens held as Python objects.
_BLOCK = 1 << 15
# Fewest bytes a vertex line ("0 0 0") and a face line ("3 0 1 2") take, line end
# excluded: a header cannot declare more of them than the file can hold.
_VERTEX_BYTES, _FACE_BYTES = 5, 7
# Lines a file may hold per vertex or face it declares, and beyond them (comments).
_LINES_PER_ELEMENT, _SPARE_LINES = 16, 4096
#: Most corners of one face (a polygon of more is refused, not split into tokens).
MAX_FACE_CORNERS = 1 << 16


class _Lines:
    """The content lines of an OFF file (comments cut, blank lines skipped), with the
    number of the file line each came from. Lines are split into at most the tokens
    asked for, so a long line costs its own bytes, not a Python object per value."""

    def __init__(self, data: bytes, where: str):
        self._lines = iter(io.BytesIO(data))
        self._comments = b"#" in data
        self.number = 0
        self.where = where

    def next_line(self) -> bytes | None:
        for line in self._lines:
            self.number += 1
            if self._comments:
                comment = line.find(b"#")
                if comment >= 0:
                    line = line[:comment]
            if line and not line.isspace():
                return line
        return None

    def error(self, problem: str) -> ValueError:
        return ValueError(f"{self.where}, line {self.number}: {problem}")

    def ended(self, done: int, total: int, what: str) -> ValueError:
        return ValueError(
            f"{self.where}: the file ends at line {self.number}, after {done} of the "
            f"{total} {what} its header declares (is it cut short?)"
        )


def _counts(lines: _Lines, size: int) -> tuple[int, int]:
    line = lines.next_line()
    if line is None:
        raise lines.error("no OFF keyword: the file holds only comments or blank lines")
    tokens = line.split(None, 4)
    if not _KEYWORD.fullmatch(tokens[0]):
        shown = tokens[0][:40].decode("latin-1")
        raise lines.error(f"the file starts with {shown!r}, not the keyword OFF")
    counts = tokens[1:]
    if not counts:
        line = lines.next_line()
        counts = [] if line is None else line.split(None, 3)
    try:
        if len(counts) < 2:
            raise ValueError
        n_vertices, n_faces = int(counts[0]), int(counts[1])
    except ValueError:
        raise lines.error(
            "the header must give the numbers of vertices and faces (as in 'OFF' then '8 12 0')"
        ) from None
    if n_vertices < 0 or n_faces < 0:
        raise lines.error(f"negative counts in the header ({n_vertices} vertices, {n_faces} faces)")
    if n_vertices * _VERTEX_BYTES + n_faces * _FACE_BYTES > size:
        raise lines.error(
            f"the header declares {n_vertices} vertices and {n_faces} faces, more than the "
            f"file's {size} bytes can hold (is it cut short?)"
        )
    return n_vertices, n_faces


def _numbers(rows: list[list[bytes]], dtype, where: str, first: int, what: str) -> np.ndarray:
    """``rows`` of equal length as an array of ``dtype``; a bad value names its row."""
    try:
        return np.array(rows, dtype=bytes).astype(dtype)
    except (ValueError, OverflowError):
        for k, row in enumerate(rows):  # name the first bad row (rare path)
            try:
                np.array(row, dtype=bytes).astype(dtype)
            except (ValueError, OverflowError):
                shown = b" ".join(row)[:80].decode("latin-1")
                raise ValueError(
                    f"{where}: {what} {first + k} holds a value that is not a number of "
                    f"that kind: {shown!r}"
                ) from None
        raise


def _vertices(lines: _Lines, n_vertices: int) -> np.ndarray:
    vertices = np.empty((n_vertices, 3))
    for start in range(0, n_vertices, _BLOCK):
        rows = []
        for k in range(start, min(start + _BLOCK, n_vertices)):
            line = lines.next_line()
            if line is None:
                raise lines.ended(k, n_vertices, "vertices")
            xyz = line.split(None, 3)[:3]
            if len(xyz) < 3:
                raise lines.error(f"vertex {k} has {len(xyz)} coordinates, not 3")
            rows.append(xyz)
        vertices[start : start + len(rows)] = _numbers(
            rows, np.float64, lines.where, start, "vertex"
        )
    return vertices


def _checked_corners(corners: np.ndarray, n_vertices: int, where: str, face: int) -> None:
    bad = (corners < 0) | (corners >= n_vertices)
    if bad.any():
        row = np.flatnonzero(bad.reshape(len(bad), -1).any(axis=1))[0]
        value = corners[row][bad[row]][0] if corners.ndim == 2 else corners[row]
        raise ValueError(
            f"{where}: face {face + (row if corners.ndim == 2 else 0)} uses vertex {value}, "
            f"outside 0..{n_vertices - 1}"
        )


def _polygon(line: bytes, lines: _Lines, face: int, n_vertices: int) -> np.ndarray:
    """The corners of one face line (its count first)."""
    head = line.split(None, 1)
    try:
        count = int(head[0])
    except ValueError:
        raise lines.error(f"face {face} does not start with its number of corners") from None
    if not 3 <= count <= MAX_FACE_CORNERS:
        raise lines.error(
            f"face {face} declares {count} corners; a face has 3 to {MAX_FACE_CORNERS}"
        )
    values = head[1].split(None, count)[:count] if len(head) > 1 else []
    if len(values) < count:
        raise lines.error(f"face {face} declares {count} corners and lists {len(values)}")
    corners = _numbers([values], np.int64, lines.where, face, "face")[0]
    _checked_corners(corners, n_vertices, lines.where, face)
    return corners


def _faces(lines: _Lines, n_faces: int, n_vertices: int) -> np.ndarray:
    blocks = []
    for start in range(0, n_faces, _BLOCK):
        rows, polygons = [], []
        for k in range(start, min(start + _BLOCK, n_faces)):
            line = lines.next_line()
            if line is None:
                raise lines.ended(k, n_faces, "faces")
            tokens = line.split(None, 4)
            if tokens[0] == b"3" and len(tokens) >= 4 and not polygons:
                rows.append(tokens[1:4])
                continue
            if rows:  # from the first polygon on, the block goes face by face
                triangles = _numbers(rows, np.int64, lines.where, start, "face")
                _checked_corners(triangles, n_vertices, lines.where, start)
                polygons.extend(triangles)
                rows = []
            polygons.append(_polygon(line, lines, k, n_vertices))
        if rows:
            triangles = _numbers(rows, np.int64, lines.where, start, "face")
            _checked_corners(triangles, n_vertices, lines.where, start)
            blocks.append(triangles)
        else:
            blocks.extend(
                np.column_stack([np.full(len(p) - 2, p[0]), p[1:-1], p[2:]]) for p in polygons
            )
    return np.concatenate(blocks) if blocks else np.empty((0, 3), np.int64)


def read_off(data: bytes, where: str) -> tuple[np.ndarray, np.ndarray]:
    """Vertices ``(n, 3)`` and triangles ``(m, 3)`` of an OFF file's bytes.

    ``where`` names the file in errors. Raises ``ValueError`` on a file that is not OFF,
    declares more than it holds, ends early, or holds a value that is not a number.
    """
    lines = _Lines(data, where)
    n_vertices, n_faces = _counts(lines, len(data))
    held = data.count(b"\n")
    if held > _LINES_PER_ELEMENT * (n_vertices + n_faces) + _SPARE_LINES:
        # Blank and comment lines are skipped one by one: gigabytes of them would take
        # minutes to tell from a file that is cut short.
        raise ValueError(
            f"{where}: it holds {held} lines for the {n_vertices} vertices and {n_faces} "
            f"faces its header declares: more than {_LINES_PER_ELEMENT} per vertex or face "
            "(blank or comment lines beyond any use)"
        )
    return _vertices(lines, n_vertices), _faces(lines, n_faces, n_vertices)
