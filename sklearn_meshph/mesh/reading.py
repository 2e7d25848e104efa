"""Reading mesh files (through trimesh), with errors that name the file.

Only the formats of ``MESH_FORMATS`` are read (OBJ, PLY, OFF, STL, GLB): trimesh also
opens archives and containers (``.zip``, ``.tar``, 3MF, which is a zip), whose content
could expand without bound, so any other format is refused before trimesh sees it, and
so is a file whose content is a zip archive whatever its name. Compressed files
(``.gz``, ``.bz2``, ``.xz``, e.g. ``bunny.off.gz``) are decompressed in memory with the
standard library, never to more than ``MAX_DECOMPRESSED_SIZE`` bytes, and handed to
trimesh with the format of the inner name (``.off``).
"""

from __future__ import annotations

import bz2
import gzip
import io
import lzma
import os
import zlib

__all__ = [
    "COMPRESSIONS",
    "MAX_DECOMPRESSED_SIZE",
    "MESH_FORMATS",
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


def _decompress(path: str, compression: str, place: str, limit: int) -> io.BytesIO:
    """The decompressed content of ``path``, read in chunks and refused beyond ``limit``."""
    buffer = io.BytesIO()
    try:
        with COMPRESSIONS[compression](path, "rb") as stream:
            while True:
                # One byte past the limit tells "exactly at the limit" from "beyond it".
                chunk = stream.read(min(_CHUNK, limit + 1 - buffer.tell()))
                if not chunk:
                    break
                buffer.write(chunk)
                if buffer.tell() > limit:
                    raise ValueError(
                        f"{place}: mesh file {path!r} decompresses to more than {limit} "
                        f"bytes (the limit, MAX_DECOMPRESSED_SIZE); refusing to read it"
                    )
    except ValueError:
        raise
    except (OSError, EOFError, lzma.LZMAError, zlib.error) as exc:  # bad or truncated archive
        raise ValueError(f"{place}: cannot decompress mesh file {path!r}: {exc}") from exc
    buffer.seek(0)
    return buffer


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
        Largest decompressed size of a compressed file, in bytes; default
        ``MAX_DECOMPRESSED_SIZE`` (2 GiB). Decompression stops there.
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
        holds a zip archive, the file is empty, cannot be
        decompressed or decompresses beyond the limit, is not a mesh format trimesh
        reads, cannot be parsed, or holds no triangle. The message names the file.
    """
    import trimesh

    path = os.fspath(path)
    if os.path.isdir(path):
        raise ValueError(f"{place}: mesh file {path!r} is a directory, not a file")
    if not os.path.isfile(path):
        raise ValueError(f"{place}: mesh file {path!r} does not exist")
    if os.path.getsize(path) == 0:
        raise ValueError(f"{place}: mesh file {path!r} is empty")
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
    if compression is None:
        with open(path, "rb") as stream:
            head = stream.read(4)
        source = path
    else:
        limit = MAX_DECOMPRESSED_SIZE if max_decompressed_size is None else max_decompressed_size
        source = _decompress(path, compression, place, int(limit))
        if source.getbuffer().nbytes == 0:
            raise ValueError(f"{place}: mesh file {path!r} is empty once decompressed")
        head = bytes(source.getbuffer()[:4])
    if head in _ZIP_MAGIC:
        raise ValueError(f"{place}: mesh file {path!r} is a zip archive; archives are refused")
    try:
        loaded = trimesh.load(source, file_type=file_type, process=False, force="mesh")
    except Exception as exc:  # trimesh raises many types on malformed files
        raise ValueError(f"{place}: cannot read mesh file {path!r}: {exc}") from exc
    if allow_points and isinstance(loaded, trimesh.Trimesh) and len(loaded.faces) == 0:
        # Forced into a mesh, a file of vertices only loses them: read it as points.
        if hasattr(source, "seek"):
            source.seek(0)
        try:
            points = trimesh.load(source, file_type=file_type, process=False)
        except Exception as exc:  # as above
            raise ValueError(f"{place}: cannot read mesh file {path!r}: {exc}") from exc
        if isinstance(points, trimesh.PointCloud | trimesh.Trimesh) and len(points.vertices):
            return points
    if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
        raise ValueError(f"{place}: mesh file {path!r} contains no triangles")
    return loaded
