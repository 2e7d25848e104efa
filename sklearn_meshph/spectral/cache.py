"""The eigen stage's cache: data only, checked on read, versioned, written atomically.

Each entry is a folder ``<location>/sklearn_meshph_eigen/<key>/`` holding
``header.json`` (the format, the key, the cleaning report) and one ``.npy`` file per
array (the cleaned vertices, faces and index maps, the eigenvalues and eigenvectors,
and a point cloud's complex: the edges of its operator's triangles).
A point cloud's entry has no faces (an empty ``(0, 3)`` array) and a graph's neither,
with nodes of no coordinates (``(n, 0)`` vertices): each is accepted only where its kind
is looked up, and a mesh's entry only where a mesh is. A graph is keyed on its node
count, edges and edge weights.
Nothing is unpickled: arrays are read from their ``.npy`` header, whose dtype and shape
are checked against what the key's mesh allows before a byte of data is read, then
checked against the SHA-256 of its data that the header holds (an array replaced by
another well-formed one, a bit flipped on disk), for finiteness and for consistency.
A corrupt, truncated, oversized or mismatched entry is recomputed and replaced, with a
:class:`CacheWarning`; so is a tampered header (a wrong type, ``Infinity``, deep
nesting) and anything but a regular file in place of one (a FIFO, a folder, a symbolic
link), which is never opened. The key hashes the
input mesh's bytes, the solver settings, the package version and
:data:`NUMERICS_VERSION`, which any change to cleaning, assembly or the eigensolver
must bump (a test fails when those modules change and it does not), so an upgrade
never reads stale results. Entries are written in a temporary folder and renamed into
place; temporary folders left by a killed process are removed by later writers, by
:func:`remove_path` (links never followed, read-only folders made writable, trees
deeper than any writer makes left alone). A folder that cannot be written is used
read-only, with one warning.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import os
import shutil
import stat
import time
import uuid
import warnings
from pathlib import Path

import numpy as np

from .._version import VERSION
from ..mesh.cleaning import CleaningReport, CleanMesh
from ..pointcloud.laplacians import LOCAL_NEIGHBORS

__all__ = [
    "NUMERICS_FILES",
    "NUMERICS_VERSION",
    "CacheWarning",
    "EigenCache",
    "cache_of",
    "numerics_digest",
    "remove_path",
    "sweep_orphans",
]

#: Bumped whenever the numbers a solve gives may change (cleaning, assembly, solver).
NUMERICS_VERSION = 38

#: The modules whose changes must bump NUMERICS_VERSION (relative to the package).
NUMERICS_FILES = (
    "mesh/cleaning.py",
    "mesh/welding.py",
    "mesh/_geometry.py",
    "mesh/graph.py",
    "mesh/graph_laplacians.py",
    "spectral/laplacians.py",
    "spectral/_assembly.py",
    "spectral/eigensolver.py",
    "spectral/factorization.py",
    "spectral/_cholesky.py",
    "spectral/_triangular.py",
    "spectral/lanczos.py",
    "spectral/_ordering.py",
    "spectral/solve.py",
    "pointcloud/cleaning.py",
    "pointcloud/graph.py",
    "pointcloud/laplacians.py",
    "pointcloud/_triangulation.py",
)

_FORMAT = "sklearn-meshph eigen cache 3"  # 3: digests of the arrays in the header
_FOLDER = "sklearn_meshph_eigen"
# The arrays of an entry, each a .npy file whose data's SHA-256 the header holds.
_ARRAYS = ("vertices", "faces", "vertex_indices", "input_to_kept", "edges", "values", "vectors")
_MAX_HEADER = 1 << 16  # bytes
_STALE_TEMPORARY = 3600.0  # seconds after which a temporary folder is an orphan


class CacheWarning(UserWarning):
    """A cache entry was unusable (and recomputed), or the folder cannot be written."""


def numerics_digest() -> str:
    """SHA-256 of the sources of :data:`NUMERICS_FILES`, in order."""
    root = Path(__file__).resolve().parents[1]
    digest = hashlib.sha256()
    for name in NUMERICS_FILES:
        digest.update(name.encode())
        digest.update((root / name).read_bytes())
    return digest.hexdigest()


# Opening never blocks (a FIFO without a writer) nor follows a link, where the system
# allows it; what is opened is checked to be a regular file before a byte is read.
_OPEN_FLAGS = (
    os.O_RDONLY
    | getattr(os, "O_NONBLOCK", 0)
    | getattr(os, "O_NOFOLLOW", 0)
    | getattr(os, "O_BINARY", 0)
)


def _open_regular(path: Path):
    """``path`` opened for binary reading if it is a regular file (not a link, a FIFO,
    a device or a folder), else a ``ValueError``."""
    if not stat.S_ISREG(os.lstat(path).st_mode):
        raise ValueError(f"{path.name} is not a regular file")
    descriptor = os.open(path, _OPEN_FLAGS)
    try:
        if not stat.S_ISREG(os.fstat(descriptor).st_mode):  # swapped since the lstat
            raise ValueError(f"{path.name} is not a regular file")
        return os.fdopen(descriptor, "rb")
    except BaseException:
        os.close(descriptor)
        raise


def _refuse_constant(name: str):
    raise ValueError(f"the header holds {name}")


def _count(header: dict, name: str) -> int:
    """A non-negative int of the header (a JSON integer, not a string or a float)."""
    value = header[name]
    if not isinstance(value, int) or isinstance(value, bool) or value < 0:
        raise ValueError(f"{name} is {value!r}, not a count")
    return value


def _report(fields) -> CleaningReport:
    """The cleaning report of a header, each field of the type it is declared with."""
    if not isinstance(fields, dict):
        raise ValueError("the cleaning report is not a mapping")
    values = {}
    for spec in dataclasses.fields(CleaningReport):
        value = fields[spec.name]
        number = isinstance(value, int | float) and not isinstance(value, bool)
        if not number or not math.isfinite(value) or value < 0:
            raise ValueError(f"report field {spec.name} is {value!r}")
        values[spec.name] = int(value) if spec.type in ("int", int) else float(value)
        if values[spec.name] != value:
            raise ValueError(f"report field {spec.name} is {value!r}, not an int")
    return CleaningReport(**values)


#: Folders nested deeper than this are left where they are by :func:`remove_path`
#: (the caches' own are one level deep): a hostile tree never exhausts the stack.
_MAX_REMOVAL_DEPTH = 16
# Removal relative to a folder's descriptor, where the system has it (not Windows).
_SAFE_REMOVAL = hasattr(os, "O_DIRECTORY") and {
    os.open,
    os.stat,
    os.unlink,
    os.rmdir,
}.issubset(os.supports_dir_fd)


def remove_path(path) -> None:
    """Remove whatever is at ``path`` (a file, a link, a FIFO, a folder and what it
    holds), if anything, never following a link (nor a link in place of the folder
    holding it): each folder is opened relative to its parent's descriptor, without
    following links, and checked to be the one looked at.
    A folder its owner may not write (an entry copied read-only) is given the owner's
    permissions first. Folders nested more than 16 levels deep are left."""
    path = Path(path)
    if not _SAFE_REMOVAL:  # no descriptor-relative calls on this system
        try:
            if stat.S_ISDIR(os.lstat(path).st_mode):
                shutil.rmtree(path, ignore_errors=True)
            else:
                os.unlink(path)
        except (OSError, RecursionError):
            pass
        return
    try:  # the folder holding it is not followed either (a cache folder made a link)
        parent = os.open(path.parent, os.O_RDONLY | os.O_DIRECTORY | os.O_NOFOLLOW)
    except OSError:
        return
    try:
        _remove_at(parent, path.name, 0)
    finally:
        os.close(parent)


def _remove_at(folder: int, name: str, depth: int) -> None:
    try:
        info = os.stat(name, dir_fd=folder, follow_symlinks=False)
        if not stat.S_ISDIR(info.st_mode):
            os.unlink(name, dir_fd=folder)
            return
        if depth >= _MAX_REMOVAL_DEPTH:
            return
        inner = _open_folder(folder, name, info)
    except OSError:
        return
    if inner is None:
        return
    try:
        with os.scandir(inner) as listing:
            names = [item.name for item in listing]
        for child in names:
            _remove_at(inner, child, depth + 1)
    except OSError:
        return
    finally:
        os.close(inner)
    try:
        os.rmdir(name, dir_fd=folder)
    except OSError:
        pass


def _same(found, info) -> bool:
    return stat.S_ISDIR(found.st_mode) and (found.st_dev, found.st_ino) == (
        info.st_dev,
        info.st_ino,
    )


def _owner_may_write(descriptor: int, found) -> None:
    """The folder behind ``descriptor`` given its owner's read, write and search
    permission (and nothing else: no set-id bit passes), if it lacks them. Through the
    descriptor, never a name: a name may have been swapped for a link since."""
    mode = stat.S_IMODE(found.st_mode) & 0o777
    if mode & stat.S_IRWXU != stat.S_IRWXU:
        try:
            os.fchmod(descriptor, mode | stat.S_IRWXU)
        except OSError:  # another user's folder, an O_PATH descriptor
            os.chmod(f"/proc/self/fd/{descriptor}", mode | stat.S_IRWXU)


def _open_folder(folder: int, name: str, info):
    """A descriptor of the folder ``name`` that ``info`` describes (None if it was
    swapped since), opened without following links, writable by its owner. A folder
    its owner may not even read is reached by an ``O_PATH`` descriptor (Linux) and
    its permissions set through ``/proc/self/fd``."""
    flags = os.O_RDONLY | os.O_DIRECTORY | os.O_NOFOLLOW
    try:
        inner = os.open(name, flags, dir_fd=folder)
    except PermissionError:
        if not hasattr(os, "O_PATH"):
            raise
        handle = os.open(name, os.O_PATH | os.O_DIRECTORY | os.O_NOFOLLOW, dir_fd=folder)
        try:
            found = os.fstat(handle)
            if not _same(found, info):
                return None
            _owner_may_write(handle, found)
        finally:
            os.close(handle)
        inner = os.open(name, flags, dir_fd=folder)
    found = os.fstat(inner)
    if not _same(found, info):  # swapped since the stat
        os.close(inner)
        return None
    try:
        _owner_may_write(inner, found)
    except OSError:
        pass  # what cannot be removed stays
    return inner


def _read_array(path: Path, dtype, max_size: int, ndim: int, digest=None) -> np.ndarray:
    """An array from a ``.npy`` file whose header says ``dtype``, ``ndim`` dimensions
    and at most ``max_size`` elements, checked before the data is read; with
    ``digest``, its data's SHA-256 must be that."""
    with _open_regular(path) as stream:
        version = np.lib.format.read_magic(stream)
        if version == (1, 0):
            shape, fortran, found = np.lib.format.read_array_header_1_0(stream)
        elif version == (2, 0):
            shape, fortran, found = np.lib.format.read_array_header_2_0(stream)
        else:
            raise ValueError(f"{path.name}: unsupported .npy version {version}")
        if found != np.dtype(dtype) or fortran or len(shape) != ndim:
            raise ValueError(f"{path.name}: dtype {found}, shape {shape}, not {dtype}")
        size = int(np.prod(shape, dtype=np.int64))
        if size > max_size:
            raise ValueError(f"{path.name}: {size} elements, at most {max_size} expected")
        data = stream.read(size * np.dtype(dtype).itemsize + 1)
    if len(data) != size * np.dtype(dtype).itemsize:
        raise ValueError(f"{path.name}: {len(data)} bytes of data for shape {shape}")
    if digest is not None and hashlib.sha256(data).hexdigest() != digest:
        raise ValueError(f"{path.name}: its data is not what was stored (checksum)")
    return np.frombuffer(data, dtype=dtype).reshape(shape).copy()


def cache_of(memory):
    """The eigen cache of a ``memory`` parameter: an :class:`EigenCache` in a folder (a
    path, or the location of a ``joblib.Memory``), a caching object of the user's (one
    with ``cache`` but no location: used as joblib's would be), or None. An empty path
    is refused (it is not taken as the current folder)."""
    if memory is None:
        return None
    if isinstance(memory, str | os.PathLike):
        if not os.fspath(memory):
            raise ValueError(
                "memory must be a folder, a joblib.Memory or None, got an empty path "
                "(write '.' for the current folder)"
            )
        return EigenCache(memory)
    if hasattr(memory, "location"):  # a joblib.Memory: its folder, or no cache at all
        return None if memory.location is None else EigenCache(memory.location)
    return memory


def sweep_orphans(folder: Path) -> None:
    """Remove the temporary files and folders (``.*.tmp``) that killed writers left in
    a cache folder, once they are older than an hour (a writer at work keeps its own).
    Links are removed, never followed."""
    now = time.time()
    try:  # a cache folder that is a link: someone else's files, never swept
        if not stat.S_ISDIR(os.lstat(folder).st_mode):
            return
    except OSError:
        return
    for path in folder.glob(".*.tmp"):
        try:
            if now - path.lstat().st_mtime > _STALE_TEMPORARY:
                remove_path(path)
        except OSError:
            pass


class EigenCache:
    """Eigensolves stored under ``location`` (see the module's docstring)."""

    def __init__(self, location):
        self.folder = Path(location) / _FOLDER
        self._read_only = False
        self._unusable: set[str] = set()  # keys whose entry load() could not use

    @staticmethod
    def key(vertices, faces, settings: dict) -> str:
        """The entry's name: a hash of the input mesh and every setting of the solve."""
        digest = hashlib.sha256()
        head = {"format": _FORMAT, "version": VERSION, "numerics": NUMERICS_VERSION}
        digest.update(json.dumps({**head, **settings}, sort_keys=True, default=str).encode())
        for array in (vertices, faces):
            array = np.ascontiguousarray(array)
            digest.update(f"{array.dtype.str}{array.shape}".encode())
            digest.update(array.tobytes())
        return digest.hexdigest()

    def load(
        self, key: str, n_input: int, max_pairs: int, *, points: bool = False, graph: bool = False
    ):
        """``(clean, values, vectors)`` of the entry, or None (missing or unusable).

        ``points``: the entry is a point cloud's, whose cleaned sample has no faces
        (a mesh's has at least one); ``graph``: a graph's, whose nodes have no
        coordinates (vertices of shape ``(n, 0)``) and which has no faces."""
        entry = self.folder / key
        try:
            if not stat.S_ISDIR(os.lstat(entry).st_mode):  # a link or a file: not ours
                raise ValueError("not a folder")
        except (FileNotFoundError, NotADirectoryError):  # no entry, or no folder yet
            return None
        except (OSError, ValueError) as error:
            return self._unusable_entry(entry, key, error)
        try:
            return self._read(entry, key, n_input, max_pairs, points, graph)
        except (OSError, ValueError, KeyError, TypeError, RecursionError, OverflowError) as error:
            return self._unusable_entry(entry, key, error)

    def _unusable_entry(self, entry: Path, key: str, error) -> None:
        self._unusable.add(key)
        warnings.warn(
            f"eigen cache entry {entry} is unusable and is recomputed: {error}",
            CacheWarning,
            stacklevel=4,
        )

    def _read(self, entry: Path, key: str, n_input: int, max_pairs: int, points: bool, graph: bool):
        with _open_regular(entry / "header.json") as stream:
            text = stream.read(_MAX_HEADER + 1)
        if len(text) > _MAX_HEADER:
            raise ValueError("header.json is too large")
        # Infinity and NaN are not JSON numbers: refused, not read as floats.
        header = json.loads(text, parse_constant=_refuse_constant)
        if not isinstance(header, dict):
            raise ValueError("the header is not a mapping")
        if header.get("format") != _FORMAT or header.get("key") != key:
            raise ValueError("the header does not belong to this key")
        n = _count(header, "n_vertices")
        k = _count(header, "n_pairs")
        faces_size = _count(header, "n_faces") * 3
        edges_size = _count(header, "n_edges") * 2
        faceless = points or graph
        # A fan has at most LOCAL_NEIGHBORS + 4 triangles: at most 3 (k + 4) n edges.
        max_edges = min(n * (n - 1) // 2, 3 * (LOCAL_NEIGHBORS + 4) * n) if points else 0
        if not (
            0 < n <= n_input
            and 0 < k <= min(n, max_pairs)
            and (faces_size == 0) == faceless
            and edges_size // 2 <= max_edges
        ):
            kind = "graph" if graph else "point cloud" if points else "mesh"
            raise ValueError(
                f"sizes {n} vertices, {k} pairs, {faces_size // 3} faces, {edges_size // 2} "
                f"edges do not fit the {kind}"
            )
        digests = header.get("sha256")
        if not isinstance(digests, dict) or set(digests) != set(_ARRAYS):
            raise ValueError("the header has no checksum of each array")

        def read(name, dtype, size, ndim):
            return _read_array(entry / f"{name}.npy", dtype, size, ndim, str(digests[name]))

        vertices = read("vertices", np.float64, 3 * n, 2)
        faces = read("faces", np.int64, faces_size, 2)
        indices = read("vertex_indices", np.int64, n, 1)
        to_kept = read("input_to_kept", np.int64, n_input, 1)
        edges = read("edges", np.int64, edges_size, 2)
        values = read("values", np.float64, k, 1)
        vectors = read("vectors", np.float64, n * k, 2)
        checks = {
            "vertices": vertices.shape == (n, 0 if graph else 3) and np.isfinite(vertices).all(),
            "faces": faces.shape == (faces_size // 3, 3)
            and (faceless or (faces.min() >= 0 and faces.max() < n)),
            "vertex_indices": indices.shape == (n,)
            and ((indices >= 0) & (indices < n_input)).all(),
            "input_to_kept": to_kept.shape == (n_input,)
            and ((to_kept >= -1) & (to_kept < n)).all(),
            "edges": edges.shape == (edges_size // 2, 2)
            and (
                len(edges) == 0
                or (
                    (edges[:, 0] >= 0).all()
                    and (edges[:, 0] < edges[:, 1]).all()
                    and (edges[:, 1] < n).all()
                    and (np.diff(edges[:, 0] * n + edges[:, 1]) > 0).all()
                )
            ),
            "values": values.shape == (k,) and np.isfinite(values).all(),
            "vectors": vectors.shape == (n, k) and np.isfinite(vectors).all(),
        }
        bad = [name for name, ok in checks.items() if not ok]
        if bad:
            raise ValueError(f"inconsistent arrays: {', '.join(bad)}")
        report = _report(header["report"])
        clean = CleanMesh(
            vertices,
            faces,
            indices,
            input_to_kept=to_kept,
            report=report,
            edges=edges if points else None,
        )
        return clean, values, vectors

    def _place(self, temporary: Path, key: str) -> None:
        """Rename a written entry into place. An entry already there is another writer's
        (as good as ours: the same key, the same solve) and is kept, unless ``load``
        found it unusable: then it is moved aside first, so that a reader sees the old
        entry or ours, never a half-removed one (removing it in place made concurrent
        writers delete each other's fresh entries under their readers)."""
        entry = self.folder / key
        try:
            os.rename(temporary, entry)  # fails if an entry (not an empty folder) is there
            return
        except OSError:
            pass
        if key in self._unusable:
            aside = self.folder / f".{key}.{os.getpid()}.{uuid.uuid4().hex}.old.tmp"
            try:
                os.rename(entry, aside)  # a link or a file is moved, never followed
                os.rename(temporary, entry)
                self._unusable.discard(key)
            except OSError:  # another writer placed theirs meanwhile
                pass
            remove_path(aside)
        remove_path(temporary)

    def store(self, key: str, result) -> None:
        """Write an entry atomically; warn once and go on if the folder is read-only."""
        if self._read_only:
            return
        clean, values, vectors = result
        temporary = self.folder / f".{key}.{os.getpid()}.{uuid.uuid4().hex}.tmp"
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
            sweep_orphans(self.folder)
            temporary.mkdir()
            header = {
                "format": _FORMAT,
                "key": key,
                "n_vertices": len(clean.vertices),
                "n_faces": len(clean.faces),
                "n_edges": 0 if clean.edges is None else len(clean.edges),
                "n_pairs": len(values),
                "report": {
                    name: getattr(clean.report, name) for name in clean.report.__dataclass_fields__
                },
            }
            arrays = {
                "vertices": clean.vertices,
                "faces": clean.faces,
                "vertex_indices": clean.vertex_indices,
                "input_to_kept": clean.input_to_kept,
                "edges": np.empty((0, 2)) if clean.edges is None else clean.edges,
                "values": values,
                "vectors": vectors,
            }
            dtypes = {
                "faces": np.int64,
                "vertex_indices": np.int64,
                "input_to_kept": np.int64,
                "edges": np.int64,
            }
            header["sha256"] = {}
            for name, array in arrays.items():
                array = np.ascontiguousarray(array, dtype=dtypes.get(name, np.float64))
                np.save(temporary / f"{name}.npy", array, allow_pickle=False)
                header["sha256"][name] = hashlib.sha256(array.data).hexdigest()
            (temporary / "header.json").write_text(json.dumps(header))
            self._place(temporary, key)
        except OSError as error:
            remove_path(temporary)
            self._read_only = True
            warnings.warn(
                f"the eigen cache {self.folder} cannot be written ({error}); computing "
                "without storing",
                CacheWarning,
                stacklevel=3,
            )
