"""The eigen stage's cache: data only, checked on read, versioned, written atomically.

Each entry is a folder ``<location>/sklearn_meshph_eigen/<key>/`` holding
``header.json`` (the format, the key, the cleaning report) and one ``.npy`` file per
array (the cleaned vertices, faces and index maps, the eigenvalues and eigenvectors).
A point cloud's entry has no faces (an empty ``(0, 3)`` array): it is accepted only
where a point cloud is looked up, and a mesh's entry only where a mesh is.
Nothing is unpickled: arrays are read from their ``.npy`` header, whose dtype and shape
are checked against what the key's mesh allows before a byte of data is read, then
checked for finiteness and consistency. A corrupt, truncated, oversized or mismatched
entry is recomputed and replaced, with a :class:`CacheWarning`. The key hashes the
input mesh's bytes, the solver settings, the package version and
:data:`NUMERICS_VERSION`, which any change to cleaning, assembly or the eigensolver
must bump (a test fails when those modules change and it does not), so an upgrade
never reads stale results. Entries are written in a temporary folder and renamed into
place; temporary folders left by a killed process are removed by later writers. A
folder that cannot be written is used read-only, with one warning.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import time
import uuid
import warnings
from pathlib import Path

import numpy as np

from ..mesh.cleaning import CleaningReport, CleanMesh

__all__ = ["NUMERICS_FILES", "NUMERICS_VERSION", "CacheWarning", "EigenCache", "numerics_digest"]

#: Bumped whenever the numbers a solve gives may change (cleaning, assembly, solver).
NUMERICS_VERSION = 2

#: The modules whose changes must bump NUMERICS_VERSION (relative to the package).
NUMERICS_FILES = (
    "mesh/cleaning.py",
    "mesh/welding.py",
    "mesh/_geometry.py",
    "mesh/_graph.py",
    "spectral/laplacians.py",
    "spectral/_assembly.py",
    "spectral/eigensolver.py",
    "spectral/factorization.py",
    "spectral/_cholesky.py",
    "spectral/_ordering.py",
    "spectral/solve.py",
    "pointcloud/cleaning.py",
    "pointcloud/graph.py",
    "pointcloud/laplacians.py",
    "pointcloud/_triangulation.py",
)

_FORMAT = "sklearn-meshph eigen cache 1"
_FOLDER = "sklearn_meshph_eigen"
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


def _read_array(path: Path, dtype, max_size: int, ndim: int) -> np.ndarray:
    """An array from a ``.npy`` file whose header says ``dtype``, ``ndim`` dimensions
    and at most ``max_size`` elements, checked before the data is read."""
    with open(path, "rb") as stream:
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
    return np.frombuffer(data, dtype=dtype).reshape(shape).copy()


class EigenCache:
    """Eigensolves stored under ``location`` (see the module's docstring)."""

    def __init__(self, location):
        self.folder = Path(location) / _FOLDER
        self._read_only = False

    @staticmethod
    def key(vertices, faces, settings: dict) -> str:
        """The entry's name: a hash of the input mesh and every setting of the solve."""
        from .. import __version__

        digest = hashlib.sha256()
        head = {"format": _FORMAT, "version": __version__, "numerics": NUMERICS_VERSION}
        digest.update(json.dumps({**head, **settings}, sort_keys=True, default=str).encode())
        for array in (vertices, faces):
            array = np.ascontiguousarray(array)
            digest.update(f"{array.dtype.str}{array.shape}".encode())
            digest.update(array.tobytes())
        return digest.hexdigest()

    def load(self, key: str, n_input: int, max_pairs: int, *, points: bool = False):
        """``(clean, values, vectors)`` of the entry, or None (missing or unusable).

        ``points``: the entry is a point cloud's, whose cleaned sample has no faces
        (a mesh's has at least one)."""
        entry = self.folder / key
        if not entry.is_dir():
            return None
        try:
            return self._read(entry, key, n_input, max_pairs, points)
        except (OSError, ValueError, KeyError, TypeError) as error:
            warnings.warn(
                f"eigen cache entry {entry} is unusable and is recomputed: {error}",
                CacheWarning,
                stacklevel=3,
            )
            return None

    def _read(self, entry: Path, key: str, n_input: int, max_pairs: int, points: bool):
        with open(entry / "header.json", "rb") as stream:
            text = stream.read(_MAX_HEADER + 1)
        if len(text) > _MAX_HEADER:
            raise ValueError("header.json is too large")
        header = json.loads(text)
        if header.get("format") != _FORMAT or header.get("key") != key:
            raise ValueError("the header does not belong to this key")
        n = int(header["n_vertices"])
        k = int(header["n_pairs"])
        faces_size = int(header["n_faces"]) * 3
        if not (0 < n <= n_input and 0 < k <= min(n, max_pairs) and (faces_size == 0) == points):
            raise ValueError(
                f"sizes {n} vertices, {k} pairs, {faces_size // 3} faces do not fit the "
                f"{'point cloud' if points else 'mesh'}"
            )
        vertices = _read_array(entry / "vertices.npy", np.float64, 3 * n, 2)
        faces = _read_array(entry / "faces.npy", np.int64, faces_size, 2)
        indices = _read_array(entry / "vertex_indices.npy", np.int64, n, 1)
        to_kept = _read_array(entry / "input_to_kept.npy", np.int64, n_input, 1)
        values = _read_array(entry / "values.npy", np.float64, k, 1)
        vectors = _read_array(entry / "vectors.npy", np.float64, n * k, 2)
        checks = {
            "vertices": vertices.shape == (n, 3) and np.isfinite(vertices).all(),
            "faces": faces.shape == (faces_size // 3, 3)
            and (points or (faces.min() >= 0 and faces.max() < n)),
            "vertex_indices": indices.shape == (n,)
            and ((indices >= 0) & (indices < n_input)).all(),
            "input_to_kept": to_kept.shape == (n_input,)
            and ((to_kept >= -1) & (to_kept < n)).all(),
            "values": values.shape == (k,) and np.isfinite(values).all(),
            "vectors": vectors.shape == (n, k) and np.isfinite(vectors).all(),
        }
        bad = [name for name, ok in checks.items() if not ok]
        if bad:
            raise ValueError(f"inconsistent arrays: {', '.join(bad)}")
        report = CleaningReport(**header["report"])
        clean = CleanMesh(vertices, faces, indices, input_to_kept=to_kept, report=report)
        return clean, values, vectors

    def store(self, key: str, result) -> None:
        """Write an entry atomically; warn once and go on if the folder is read-only."""
        if self._read_only:
            return
        clean, values, vectors = result
        temporary = self.folder / f".{key}.{os.getpid()}.{uuid.uuid4().hex}.tmp"
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
            self._sweep()
            temporary.mkdir()
            header = {
                "format": _FORMAT,
                "key": key,
                "n_vertices": len(clean.vertices),
                "n_faces": len(clean.faces),
                "n_pairs": len(values),
                "report": {
                    name: getattr(clean.report, name) for name in clean.report.__dataclass_fields__
                },
            }
            (temporary / "header.json").write_text(json.dumps(header))
            arrays = {
                "vertices": clean.vertices,
                "faces": clean.faces,
                "vertex_indices": clean.vertex_indices,
                "input_to_kept": clean.input_to_kept,
                "values": values,
                "vectors": vectors,
            }
            dtypes = {"faces": np.int64, "vertex_indices": np.int64, "input_to_kept": np.int64}
            for name, array in arrays.items():
                array = np.ascontiguousarray(array, dtype=dtypes.get(name, np.float64))
                np.save(temporary / f"{name}.npy", array, allow_pickle=False)
            entry = self.folder / key
            if entry.exists():  # an unusable entry being replaced
                shutil.rmtree(entry, ignore_errors=True)
            try:
                os.rename(temporary, entry)
            except OSError:  # another writer got there first: theirs is as good
                shutil.rmtree(temporary, ignore_errors=True)
        except OSError as error:
            shutil.rmtree(temporary, ignore_errors=True)
            self._read_only = True
            warnings.warn(
                f"the eigen cache {self.folder} cannot be written ({error}); computing "
                "without storing",
                CacheWarning,
                stacklevel=3,
            )

    def _sweep(self) -> None:
        """Remove temporary folders that a killed writer left behind."""
        now = time.time()
        for path in self.folder.glob(".*.tmp"):
            try:
                if now - path.stat().st_mtime > _STALE_TEMPORARY:
                    shutil.rmtree(path, ignore_errors=True)
            except OSError:
                pass
