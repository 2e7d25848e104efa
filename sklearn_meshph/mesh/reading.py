"""Reading mesh files (through trimesh), with errors that name the file.

Only the formats of ``MESH_FORMATS`` are read (OBJ, PLY, OFF, STL, GLB): trimesh also
opens archives and containers (``.zip``, ``.tar``, 3MF, which is a zip), whose content
could expand without bound, so any other format is refused before trimesh sees it, and
so is a file whose content is a zip archive whatever its name. Compressed files
(``.gz``, ``.bz2``, ``.xz``, e.g. ``bunny.off.gz``) are decompressed in memory with the
standard library, never to more than ``MAX_DECOMPRESSED_SIZE`` bytes, and handed to
trimesh with the format of the inner name (``.off``). :class:`LimitedReader` (a stream)
and :func:`decompress` (the whole content) are that bounded decompression, shared with
the point-cloud reader.

A file that is not a mesh of its format (text, an image, an empty file) is refused with
one line naming it and saying it is not a valid mesh; the parser's own message is kept
as the exception's cause only.
"""

from __future__ import annotations

import bz2
import gzip
import io
import lzma
import os
import zlib

import numpy as np

from ._off import read_off
from .text import long_line_offset

__all__ = [
    "COMPRESSIONS",
    "MAX_DECOMPRESSED_SIZE",
    "MAX_PLY_ROWS",
    "MAX_TEXT_LINE",
    "MAX_TEXT_LINES",
    "MAX_TEXT_TOKENS",
    "MESH_FORMATS",
    "LimitedReader",
    "decompress",
    "count_text",
    "count_tokens",
    "read_mesh_file",
    "split_compression",
]

#: The mesh formats read (file name endings without the dot), each possibly compressed.
MESH_FORMATS = ("obj", "ply", "off", "stl", "glb")

# The first bytes of a zip archive (also of 3MF, and of empty or spanned archives).
_ZIP_MAGIC = (b"PK\x03\x04", b"PK\x05\x06", b"PK\x07\x08")

#: Largest decompressed size of a compressed mesh file, in bytes (2 GiB). A file that
#: decompresses beyond it is refused (decompression stops at the limit), so that a
#: small hostile file (a "compression bomb") cannot exhaust memory.
MAX_DECOMPRESSED_SIZE = 2 * 1024**3

#: Most values (whitespace-separated tokens) and lines of a mesh file that trimesh
#: parses as text (OBJ, ASCII PLY and STL): 16 Mi values and 8 Mi lines (a PLY of 1.2
#: million vertices and 2.4 million faces fits) bound the parser's memory to about 3 GB
#: whatever the content. OFF files are read by our own reader (``_off.py``), whose
#: memory is that of the mesh.
MAX_TEXT_TOKENS = 16 * 1024**2
MAX_TEXT_LINES = 8 * 1024**2
#: Longest line of a text mesh parsed by trimesh (OBJ, ASCII PLY and STL), in bytes: its
#: parsers copy a line several times over (a 291 KB .obj.gz of one 300 MB line of spaces
#: took 890 MB), and no face or vertex line comes near it.
MAX_TEXT_LINE = 1 << 22

#: Most rows an element of a PLY file may declare (vertices, faces): 16 Mi. trimesh
#: reads a binary PLY into arrays several times over (a 2 MB .ply.gz of 180 million
#: vertices took 12.5 GB before it was refused): the counts its header declares are
#: checked before the file is decompressed or parsed, as the bytes are.
MAX_PLY_ROWS = 1 << 24
# Bytes of a PLY file's start read for its header (a longer header is refused).
_PLY_HEADER = 1 << 16

#: File name endings of the compressed formats read, and their standard-library openers.
COMPRESSIONS = {".gz": gzip.open, ".bz2": bz2.open, ".xz": lzma.open}

_CHUNK = 1 << 20  # bytes per read while decompressing


def split_compression(path) -> tuple[str, str | None]:
    """``(mesh format, compression)`` of a file name, both lower case without the dot.

    >>> split_compression("a/bunny.OFF.gz")
    ('off', '.gz')
    >>> split_compression("bunny.ply")
    ('ply', None)
    """
    name = os.path.basename(os.fspath(path)).lower()
    compression = next((c for c in COMPRESSIONS if name.endswith(c)), None)
    if compression is not None:
        name = name[: -len(compression)]
    return os.path.splitext(name)[1].lstrip("."), compression


class LimitedReader:
    """A binary stream of a compressed file's content, decompressed as it is read, that
    refuses to yield more than ``limit`` bytes in all.

    ``read``, ``readline`` and iteration over lines raise ``ValueError`` (naming
    ``place`` and the file) when the content goes beyond ``limit``, or when the file is
    not valid data of its compression format; a context manager that closes the file.
    """

    def __init__(self, path, compression: str, place: str, limit: int, what: str = "mesh file"):
        self.path, self.compression, self.place, self.what = (
            os.fspath(path),
            compression,
            place,
            what,
        )
        self.limit, self.count = int(limit), 0
        self._stream = COMPRESSIONS[compression](self.path, "rb")

    def __enter__(self):
        return self

    def __exit__(self, *exc_info):
        self.close()

    def close(self) -> None:
        self._stream.close()

    def _take(self, method, size: int) -> bytes:
        # One byte past the limit tells "exactly at the limit" from "beyond it".
        room = self.limit + 1 - self.count
        size = room if size is None or size < 0 else min(size, room)
        try:
            data = method(size)
        except (OSError, EOFError, lzma.LZMAError, zlib.error) as exc:  # bad or truncated
            raise ValueError(
                f"{self.place}: cannot decompress {self.what} {self.path!r}: it is not valid "
                f"{self.compression} data, so not a valid "
                f"{'mesh' if self.what == 'mesh file' else self.what}"
            ) from exc
        self.count += len(data)
        if self.count > self.limit:
            raise ValueError(
                f"{self.place}: {self.what} {self.path!r} decompresses to more than "
                f"{self.limit} bytes (the limit); refusing to read it"
            )
        return data

    def read(self, size: int = -1) -> bytes:
        return self._take(self._stream.read, size)

    def readline(self, size: int = -1) -> bytes:
        return self._take(self._stream.readline, size)

    def __iter__(self):
        while line := self.readline():
            yield line


def decompress(path, compression: str, place: str, limit: int, what: str = "mesh file"):
    """The whole decompressed content of ``path`` in an ``io.BytesIO``, read in chunks
    and refused beyond ``limit`` bytes (see :class:`LimitedReader`)."""
    buffer = io.BytesIO()
    with LimitedReader(path, compression, place, limit, what) as stream:
        while chunk := stream.read(_CHUNK):
            buffer.write(chunk)
    buffer.seek(0)
    return buffer


def _check_ply_header(path: str, compression, place: str) -> None:
    """Refuse a PLY file whose header declares an element of more than
    ``MAX_PLY_ROWS`` rows, reading (decompressing) only its first ``_PLY_HEADER`` bytes."""
    if compression is None:
        with open(path, "rb") as stream:
            head = stream.read(_PLY_HEADER)
    else:
        with LimitedReader(path, compression, place, _PLY_HEADER, "mesh file") as stream:
            head = b""
            while len(head) < _PLY_HEADER:
                try:
                    chunk = stream.read(_PLY_HEADER - len(head))
                except ValueError:
                    return  # not valid compressed data: reported when decompressed
                if not chunk:
                    break
                head += chunk
    end = head.find(b"end_header")
    if end < 0:
        if len(head) < _PLY_HEADER:
            return  # no header at all: trimesh refuses the file
        # Comments could push the counts past what is read: trimesh would read them.
        raise ValueError(
            f"{place}: mesh file {path!r} is not a valid .ply mesh: no end_header in its "
            f"first {_PLY_HEADER} bytes"
        )
    for line in head[:end].splitlines():
        words = line.split()
        if len(words) == 3 and words[0] == b"element" and words[2].isdigit():
            if int(words[2]) > MAX_PLY_ROWS:
                raise ValueError(
                    f"{place}: mesh file {path!r} declares {int(words[2])} "
                    f"{words[1].decode('latin-1')} rows, more than MAX_PLY_ROWS "
                    f"({MAX_PLY_ROWS}); refusing to read it"
                )


def _is_text(buffer, file_type: str) -> bool:
    """Whether trimesh parses this content as text (into Python objects per value and
    per line), decided as trimesh decides."""
    if file_type == "ply":  # trimesh: "ascii" anywhere in the second line
        head = bytes(buffer[: 1 << 16])
        first = head.find(b"\n")
        second = head.find(b"\n", first + 1)
        return first < 0 or second < 0 or b"ascii" in head[first + 1 : second].lower()
    if file_type == "stl":  # a binary STL's size is fixed by its triangle count
        size = buffer.nbytes
        return size < 84 or size != 84 + 50 * int.from_bytes(bytes(buffer[80:84]), "little")
    return file_type == "obj"


# Bytes that may end a line for Python's str.splitlines (in UTF-8, U+0085, U+2028 and
# U+2029 end with 0x85, 0xA8 and 0xA9: counting those bytes over-counts, never under).
_LINE_ENDS = np.frombuffer(b"\n\r\x0b\x0c\x1c\x1d\x1e\x85\xa8\xa9", np.uint8)


def count_text(buffer) -> tuple[int, int]:
    """Upper bounds of the values (whitespace-separated tokens) and lines that Python's
    ``str.split`` and ``str.splitlines`` find in ``buffer`` decoded, counted a chunk at a
    time (no copy of the content): every byte at most 32 or above 127 is taken for a
    separator (Unicode spaces and line ends are non-ASCII in UTF-8)."""
    data = np.frombuffer(buffer, np.uint8)
    tokens = lines = 0
    previous_blank = True
    for start in range(0, len(data), _CHUNK * 16):
        chunk = data[start : start + _CHUNK * 16]
        blank = (chunk <= 32) | (chunk >= 128)
        tokens += int(np.count_nonzero(blank[1:] < blank[:-1])) + (previous_blank and not blank[0])
        lines += int(np.count_nonzero(np.isin(chunk, _LINE_ENDS)))
        previous_blank = bool(blank[-1])
    return tokens, lines + 1


def count_tokens(buffer) -> int:
    """The values of :func:`count_text`."""
    return count_text(buffer)[0]


def _check_text_size(buffer, file_type: str, place: str, path: str) -> None:
    """Refuse a text mesh with more than ``MAX_TEXT_TOKENS`` values or
    ``MAX_TEXT_LINES`` lines before trimesh parses it: its text parsers hold Python
    objects per value (about 150 bytes each for OBJ) and per line (170 to 420 bytes for
    an ASCII PLY, whatever the line holds, blank lines included)."""
    if not _is_text(buffer, file_type):
        return
    long = long_line_offset(buffer, MAX_TEXT_LINE)
    if long is not None:
        raise ValueError(
            f"{place}: mesh file {path!r} has a line longer than {MAX_TEXT_LINE} bytes "
            f"(MAX_TEXT_LINE) at byte {long}; refusing to parse it"
        )
    tokens, lines = count_text(buffer)
    for count, limit, what, name in (
        (tokens, MAX_TEXT_TOKENS, "values", "MAX_TEXT_TOKENS"),
        (lines, MAX_TEXT_LINES, "lines", "MAX_TEXT_LINES"),
    ):
        if count > limit:
            raise ValueError(
                f"{place}: mesh file {path!r} holds {count} {what} as text, more than "
                f"{name} ({limit}); refusing to parse it (a binary .ply holds any size)"
            )


def _check_ply_counts(loaded, invalid: str) -> None:
    """A PLY whose elements hold fewer rows than its header declares is cut short:
    trimesh loads what is there without a word."""
    raw = loaded.metadata.get("_ply_raw", {}) if hasattr(loaded, "metadata") else {}
    for name, element in raw.items():
        declared, data = element.get("length"), element.get("data")
        if not isinstance(data, dict) or declared is None:
            continue
        for column in data.values():
            if len(column) != declared:
                raise ValueError(
                    f"{invalid}: its header declares {declared} {name} rows and it holds "
                    f"{len(column)} (is it cut short?)"
                )


def read_mesh_file(
    path,
    place: str = "mesh",
    *,
    max_decompressed_size: int | None = None,
    allow_points: bool = False,
):
    """A mesh file as a ``trimesh.Trimesh``, loaded with ``process=False`` (order kept).

    Parameters
    ----------
    path : str or os.PathLike
        A mesh file trimesh reads (OBJ, PLY, OFF, STL, GLB...), possibly compressed:
        ``.gz``, ``.bz2`` and ``.xz`` files (``bunny.off.gz``) are decompressed in memory
        and read in the format of the inner name.
    place : str, default="mesh"
        Names the sample in error messages, which also name the file.
    max_decompressed_size : int, optional
        Largest size of the file, decompressed if it is compressed, in bytes; default
        ``MAX_DECOMPRESSED_SIZE``. Decompression stops there. Files the mesh file
        names (an OBJ's materials and textures, a GLB's external buffers) are never
        read.
    allow_points : bool, default=False
        Return a file of vertices without triangles (a point cloud, such as a PLY
        without faces) as a ``trimesh.PointCloud`` instead of refusing it.

    Returns
    -------
    trimesh.Trimesh
        Vertices and faces as in the file (no merging, no reordering).

    Raises
    ------
    ValueError
        If the path does not exist or is not a file, is not one of ``MESH_FORMATS`` or
        holds a zip archive, or decompresses beyond the limit; if a PLY header declares
        an element of more than ``MAX_PLY_ROWS`` rows; or if the file is not a
        valid mesh: empty, not valid compressed data, not parsable in its format, or
        without a triangle. The message is one line naming the file.
    """
    import trimesh

    path = os.fspath(path)
    if os.path.isdir(path):
        raise ValueError(f"{place}: mesh file {path!r} is a directory, not a file")
    if not os.path.isfile(path):
        problem = "is not a regular file" if os.path.lexists(path) else "does not exist"
        raise ValueError(f"{place}: mesh file {path!r} {problem}")
    if os.path.getsize(path) == 0:
        raise ValueError(f"{place}: mesh file {path!r} is empty, not a valid mesh")
    file_type, compression = split_compression(path)
    if not file_type:
        raise ValueError(
            f"{place}: cannot tell the mesh format of {path!r} (no extension, such as .off)"
        )
    if file_type not in MESH_FORMATS:
        raise ValueError(
            f"{place}: {path!r} is a .{file_type} file; the mesh formats read are "
            f"{', '.join('.' + f for f in MESH_FORMATS)} (each possibly .gz, .bz2 or .xz); "
            "archives and containers are refused"
        )
    limit = MAX_DECOMPRESSED_SIZE if max_decompressed_size is None else max_decompressed_size
    if file_type == "ply":
        _check_ply_header(path, compression, place)
    if compression is None:
        if os.path.getsize(path) > limit:
            raise ValueError(
                f"{place}: mesh file {path!r} is larger than {int(limit)} bytes (the limit, "
                "MAX_DECOMPRESSED_SIZE); refusing to parse it"
            )
        # trimesh is given the bytes, never the path: from a path it follows what the
        # file names beside it (an OBJ's mtllib and textures, a PLY's TextureFile, a
        # GLB's buffer uri), and a FIFO or a huge file named there hung or was read.
        with open(path, "rb") as stream:
            source = io.BytesIO(stream.read())
        head = bytes(source.getbuffer()[:4])
    else:
        source = decompress(path, compression, place, int(limit))
        if source.getbuffer().nbytes == 0:
            raise ValueError(
                f"{place}: mesh file {path!r} is empty once decompressed, not a valid mesh"
            )
        head = bytes(source.getbuffer()[:4])
    if head in _ZIP_MAGIC:
        raise ValueError(f"{place}: mesh file {path!r} is a zip archive; archives are refused")
    invalid = f"{place}: mesh file {path!r} is not a valid .{file_type} mesh"
    if file_type == "off":
        vertices, faces = read_off(source.getvalue(), invalid)
        if allow_points and len(faces) == 0 and len(vertices):
            return trimesh.PointCloud(vertices)
        if len(faces) == 0:
            raise ValueError(f"{invalid}: it contains no triangles")
        return trimesh.Trimesh(vertices, faces, process=False)
    _check_text_size(source.getbuffer(), file_type, place, path)
    try:
        loaded = trimesh.load(source, file_type=file_type, process=False, force="mesh")
    except Exception as exc:  # trimesh raises many types on malformed files
        raise ValueError(f"{invalid} (it cannot be parsed)") from exc
    if file_type == "ply":
        _check_ply_counts(loaded, invalid)
    if allow_points and isinstance(loaded, trimesh.Trimesh) and len(loaded.faces) == 0:
        # Forced into a mesh, a file of vertices only loses them: read it as points.
        if hasattr(source, "seek"):
            source.seek(0)
        try:
            points = trimesh.load(source, file_type=file_type, process=False)
        except Exception as exc:  # as above
            raise ValueError(f"{invalid} (it cannot be parsed)") from exc
        if file_type == "ply":  # read again: its own rows against its own header
            _check_ply_counts(points, invalid)
        if isinstance(points, trimesh.PointCloud | trimesh.Trimesh) and len(points.vertices):
            return points
    if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
        raise ValueError(f"{invalid}: it contains no triangles")
    return loaded
