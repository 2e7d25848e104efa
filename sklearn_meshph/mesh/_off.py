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

from .text import long_line_offset

__all__ = ["read_off"]

_KEYWORD = re.compile(rb"(ST)?C?N?OFF")
# Lines (vertices) or values (faces' corners) converted at once: bounds the memory of
# the values held as Python objects.
_BLOCK = 1 << 15
_BLOCK_VALUES = 1 << 17
# Fewest bytes a vertex line ("0 0 0") and a face line ("3 0 1 2") take, line end
# excluded: a header cannot declare more of them than the file can hold.
_VERTEX_BYTES, _FACE_BYTES = 5, 7
# Lines a file may hold per vertex or face it declares, and beyond them (comments).
_LINES_PER_ELEMENT, _SPARE_LINES = 16, 4096
#: Most corners of one face (a polygon of more is refused, not split into tokens).
MAX_FACE_CORNERS = 1 << 16
#: Longest value, in bytes: a block of values is converted as fixed-width byte strings,
#: as wide as its longest value (one zero-padded value of 40 KB made a block of vertex
#: lines take 3.7 GB).
MAX_VALUE_LENGTH = 64
#: Longest line, in bytes: a face of ``MAX_FACE_CORNERS`` corners of values of
#: ``MAX_VALUE_LENGTH``, and a few more values. A file of one line of 2 GB of spaces (9 MB
#: compressed) was read into a second copy of itself, then out of memory.
MAX_LINE_LENGTH = (MAX_FACE_CORNERS + 16) * (MAX_VALUE_LENGTH + 1)


class _Lines:
    """The content lines of an OFF file (comments cut, blank lines skipped), with the
    number of the file line each came from. A line ends at ``\\n``, ``\\r\\n`` or a lone
    ``\\r`` (as trimesh and Python read them); no copy of the file is made (``read_off``
    refuses a line longer than ``MAX_LINE_LENGTH`` first). Lines are split into at most
    the tokens asked for, so a long line costs its own bytes, not a Python object per
    value."""

    def __init__(self, data: bytes, where: str, start: int = 0):
        self._data, self._pos, self._start = data, start, start
        self._cr = data.find(b"\r", start)  # the next \r at or after the position, or -1
        self._raw_lines = None
        # \n or \r\n ends alone (the \r is then white space at a line's end): read by
        # the C iterator, a third faster than finding the ends one by one.
        if self._cr < 0 or data.count(b"\r", start) == data.count(b"\r\n", start):
            stream = io.BytesIO(data)
            stream.seek(start)
            self._raw_lines = iter(stream)
        self._comments = b"#" in data
        self.number = self.held = 0
        self.where = where

    def count(self) -> int:
        """The line ends of the whole file (``\\r\\n`` once), as if none was read yet."""
        data, start = self._data, self._start
        ends = data.count(b"\n", start)
        if data.find(b"\r", start) >= 0:
            ends += data.count(b"\r", start) - data.count(b"\r\n", start)
        return ends

    def _raw_line(self) -> bytes | None:
        if self._raw_lines is not None:
            return next(self._raw_lines, None)
        data, pos = self._data, self._pos
        if pos >= len(data):
            return None
        if 0 <= self._cr < pos:
            self._cr = data.find(b"\r", pos)
        newline = data.find(b"\n", pos)
        cr = self._cr
        if newline < 0 and cr < 0:
            stop = after = len(data)
        elif cr < 0 or 0 <= newline < cr:
            stop, after = newline, newline + 1
        else:
            stop, after = cr, cr + 2 if data[cr + 1 : cr + 2] == b"\n" else cr + 1
        self._pos = after
        return data[pos:stop]

    def next_line(self) -> bytes | None:
        while (line := self._raw_line()) is not None:
            self.number += 1
            if self._comments:
                comment = line.find(b"#")
                if comment >= 0:
                    line = line[:comment]
            if line and not line.isspace():
                self.held += 1
                return line
            if self.number - self.held > _SPARE_LINES + _LINES_PER_ELEMENT * self.held:
                # Each is read on its own: gigabytes of them would take minutes.
                raise self.error(
                    f"{self.number - self.held} of its first {self.number} lines are blank "
                    f"or comments, more than {_SPARE_LINES} plus {_LINES_PER_ELEMENT} per "
                    "line of data"
                )
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


def _check_lines(lines: _Lines, n_vertices: int, n_faces: int) -> None:
    """Before anything is allocated from the header: the file must have a line per
    declared vertex and face after the header, and not more than ``_LINES_PER_ELEMENT``
    per vertex or face (blank and comment lines are skipped one by one: gigabytes of
    them would take minutes to tell from a file that is cut short)."""
    held = lines.count()
    if held > _LINES_PER_ELEMENT * (n_vertices + n_faces) + _SPARE_LINES:
        raise ValueError(
            f"{lines.where}: it holds {held} lines for the {n_vertices} vertices and "
            f"{n_faces} faces its header declares: more than {_LINES_PER_ELEMENT} per vertex "
            "or face (blank or comment lines beyond any use)"
        )
    remaining = held + 1 - lines.number
    if remaining < n_vertices + n_faces:
        raise lines.error(
            f"the header declares {n_vertices} vertices and {n_faces} faces, and {remaining} "
            "lines follow it (is it cut short?)"
        )


def _numbers(values: list[bytes], owner: np.ndarray, dtype, where: str, what: str):
    """``values`` as an array of ``dtype``; ``owner[k]`` is the vertex or face that value
    ``k`` belongs to, named (with all its values) when one is too long or not a number."""

    def refuse(k: int, problem: str) -> ValueError:
        shown = b" ".join(values[i] for i in np.flatnonzero(owner == owner[k]))
        return ValueError(
            f"{where}: {what} {owner[k]} holds {problem}: {shown[:80].decode('latin-1')!r}"
        )

    for k, value in enumerate(values):
        if len(value) > MAX_VALUE_LENGTH:
            raise refuse(
                k,
                f"a value of {len(value)} characters, more than {MAX_VALUE_LENGTH} "
                "(MAX_VALUE_LENGTH)",
            )
    try:
        return np.array(values, dtype=bytes).astype(dtype)
    except (ValueError, OverflowError):
        for k, value in enumerate(values):  # name the first bad value (rare path)
            try:
                np.array([value], dtype=bytes).astype(dtype)
            except (ValueError, OverflowError):
                raise refuse(k, "a value that is not a number of that kind") from None
        raise


def _vertices(lines: _Lines, n_vertices: int) -> np.ndarray:
    vertices = np.empty((n_vertices, 3))
    for start in range(0, n_vertices, _BLOCK):
        values = []
        stop = min(start + _BLOCK, n_vertices)
        for k in range(start, stop):
            line = lines.next_line()
            if line is None:
                raise lines.ended(k, n_vertices, "vertices")
            xyz = line.split(None, 3)[:3]
            if len(xyz) < 3:
                raise lines.error(f"vertex {k} has {len(xyz)} coordinates, not 3")
            values.extend(xyz)
        owner = np.repeat(np.arange(start, stop), 3)
        vertices[start:stop] = _numbers(values, owner, np.float64, lines.where, "vertex").reshape(
            -1, 3
        )
    return vertices


def _corner_count(line: bytes, lines: _Lines, face: int) -> tuple[int, list[bytes]]:
    """The number of corners of a face line and its corners' values (as bytes)."""
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
    return count, values


def _fans(values: list[bytes], counts: list[int], first: int, lines: _Lines, n_vertices: int):
    """Triangles of faces ``first...`` given their corners' values and counts: a fan from
    each face's first corner, in the file's order."""
    counts = np.array(counts, dtype=np.int64)
    face_of = np.repeat(np.arange(first, first + len(counts)), counts)
    corners = _numbers(values, face_of, np.int64, lines.where, "face")
    bad = (corners < 0) | (corners >= n_vertices)
    if bad.any():
        at = int(np.flatnonzero(bad)[0])
        raise ValueError(
            f"{lines.where}: face {face_of[at]} uses vertex {corners[at]}, outside "
            f"0..{n_vertices - 1}"
        )
    if (counts == 3).all():
        return corners.reshape(-1, 3)
    n_triangles = counts - 2
    starts = np.cumsum(counts) - counts
    owner = np.repeat(np.arange(len(counts)), n_triangles)
    step = np.arange(len(owner)) - np.repeat(np.cumsum(n_triangles) - n_triangles, n_triangles)
    apex = starts[owner]
    return np.column_stack([corners[apex], corners[apex + step + 1], corners[apex + step + 2]])


def _faces(lines: _Lines, n_faces: int, n_vertices: int) -> np.ndarray:
    blocks, values, counts, first = [], [], [], 0
    for face in range(n_faces):
        line = lines.next_line()
        if line is None:
            raise lines.ended(face, n_faces, "faces")
        tokens = line.split(None, 4)
        if tokens[0] == b"3" and len(tokens) >= 4:
            values.extend(tokens[1:4])
            counts.append(3)
        else:
            count, corners = _corner_count(line, lines, face)
            values.extend(corners)
            counts.append(count)
        if len(values) >= _BLOCK_VALUES or face == n_faces - 1:
            blocks.append(_fans(values, counts, first, lines, n_vertices))
            values, counts, first = [], [], face + 1
    return np.concatenate(blocks) if blocks else np.empty((0, 3), np.int64)


def read_off(data: bytes, where: str) -> tuple[np.ndarray, np.ndarray]:
    """Vertices ``(n, 3)`` and triangles ``(m, 3)`` of an OFF file's bytes.

    ``where`` names the file in errors. Raises ``ValueError`` on a file that is not OFF,
    declares more than it holds, ends early, or holds a value that is not a number.
    """
    # A UTF-8 byte order mark skipped, as trimesh reads it (not sliced off: a copy).
    start = 3 if data.startswith(b"\xef\xbb\xbf") else 0
    long = long_line_offset(data, MAX_LINE_LENGTH, start)
    if long is not None:
        line = data.count(b"\n", start, long) + 1
        if data.find(b"\r", start, long) >= 0:
            line += data.count(b"\r", start, long) - data.count(b"\r\n", start, long)
        raise ValueError(
            f"{where}, line {line}: a line longer than {MAX_LINE_LENGTH} bytes "
            "(MAX_LINE_LENGTH), more than the longest face and its values take"
        )
    lines = _Lines(data, where, start)
    n_vertices, n_faces = _counts(lines, len(data))
    _check_lines(lines, n_vertices, n_faces)
    return _vertices(lines, n_vertices), _faces(lines, n_faces, n_vertices)
