"""The cache of :class:`PerDiagramDistance`'s stacks: data only, checked on read,
versioned, written atomically.

Each stack is one ``.npy`` file, ``<location>/sklearn_meshph_distances/<key>.npy``,
whose key hashes the format, the package version, the distance parameters and the
bytes of the diagrams of both sides. Nothing is unpickled: the ``.npy`` header's dtype
and shape are checked against the stack asked for before a byte of data is read, then
the data is read and checked against the SHA-256 of the key and the data that follows
it in the file (another entry's file under this key, a bit flipped on disk), and for
NaN and negative distances. Anything but a regular file in place of an entry (a FIFO, a folder, a
symbolic link) is never opened; an unusable entry is recomputed and replaced, with a
:class:`~sklearn_meshph.spectral.cache.CacheWarning`. Entries are written to a
temporary file in the same folder and renamed into place (temporary files that a
killed writer left are removed by later writers after an hour); a folder that cannot be
written is used read-only, with a warning.
"""

from __future__ import annotations

import hashlib
import json
import os
import stat
import uuid
import warnings
from pathlib import Path

import numpy as np

from .._version import VERSION
from ..spectral.cache import CacheWarning, EigenCache, cache_of, remove_path, sweep_orphans

__all__ = ["StackCache", "stack_cache_of"]

_FORMAT = "sklearn-meshph distance stack 2"
_FOLDER = "sklearn_meshph_distances"

# Opening never blocks (a FIFO swapped in after the check) nor follows a link.
_OPEN_FLAGS = (
    os.O_RDONLY
    | getattr(os, "O_NONBLOCK", 0)
    | getattr(os, "O_NOFOLLOW", 0)
    | getattr(os, "O_BINARY", 0)
)
_DIGEST_SIZE = hashlib.sha256().digest_size
_HEADERS = {
    (1, 0): np.lib.format.read_array_header_1_0,
    (2, 0): np.lib.format.read_array_header_2_0,
}


def stack_cache_of(memory):
    """The stack cache of a ``memory`` parameter: a :class:`StackCache` in a folder (a
    path, or the location of a ``joblib.Memory``), the user's own caching object (one
    with ``cache`` but no location), or None. Read as :func:`cache_of` reads it (an
    empty path is refused); a path that exists and is not a folder is refused."""
    cache = cache_of(memory)
    return StackCache(cache.folder.parent) if isinstance(cache, EigenCache) else cache


class StackCache:
    """Stacks of distances stored under ``location`` (see the module's docstring)."""

    def __init__(self, location):
        try:
            is_folder = stat.S_ISDIR(os.stat(location).st_mode)
        except FileNotFoundError:  # made at the first store
            is_folder = True
        except OSError as error:  # a file on the way, a name too long...
            raise ValueError(
                f"memory must be a folder, a joblib.Memory or None; {os.fspath(location)!r} "
                f"cannot be one: {error}"
            ) from error
        if not is_folder:
            raise ValueError(
                f"memory must be a folder, a joblib.Memory or None; {os.fspath(location)!r} "
                "is not a folder"
            )
        self.folder = Path(location) / _FOLDER

    @staticmethod
    def key(arrays, settings: dict) -> str:
        """The entry's name: a hash of the format, the version, ``settings`` and the
        dtype, shape and bytes of each of ``arrays``."""
        digest = hashlib.sha256()
        head = {"format": _FORMAT, "version": VERSION, "n_arrays": len(arrays)}
        digest.update(json.dumps({**head, **settings}, sort_keys=True, default=str).encode())
        for array in arrays:
            array = np.ascontiguousarray(array)
            digest.update(f"{array.dtype.str}{array.shape}".encode())
            digest.update(array.tobytes())
        return digest.hexdigest()

    def stack(self, key: str, shape: tuple, dtype, compute) -> np.ndarray:
        """The stored stack of ``key``, or ``compute()`` stored under it."""
        stack = self.load(key, shape, dtype)
        if stack is None:
            stack = compute()
            self.store(key, stack)
        return stack

    def load(self, key: str, shape: tuple, dtype) -> np.ndarray | None:
        """The entry's stack if it is usable, else None (with a warning if it exists)."""
        entry = self.folder / f"{key}.npy"
        try:
            mode = os.lstat(entry).st_mode
        except (FileNotFoundError, NotADirectoryError):  # no entry, or no folder yet
            return None
        except OSError as error:
            return _unusable(entry, error)
        try:
            if not stat.S_ISREG(mode):
                raise ValueError("not a regular file")
            return _read(entry, key, tuple(shape), np.dtype(dtype))
        except (OSError, ValueError, SyntaxError, OverflowError) as error:
            return _unusable(entry, error)

    def store(self, key: str, stack: np.ndarray) -> None:
        """Write an entry atomically; warn and go on if the folder cannot be written."""
        entry = self.folder / f"{key}.npy"
        temporary = self.folder / f".{key}.{os.getpid()}.{uuid.uuid4().hex}.tmp"
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
            stack = np.ascontiguousarray(stack)
            with open(temporary, "xb") as stream:
                np.save(stream, stack, allow_pickle=False)
                stream.write(_digest(key, stack))
            if entry.is_dir() and not entry.is_symlink():
                remove_path(entry)  # an unusable entry being replaced
            os.replace(temporary, entry)
            sweep_orphans(self.folder)
        except OSError as error:
            remove_path(temporary)  # if it was made (not when the folder is a file)
            warnings.warn(
                f"the distance cache {self.folder} cannot be written ({error}); computing "
                "without storing",
                CacheWarning,
                stacklevel=3,
            )


def _unusable(entry: Path, error) -> None:
    warnings.warn(
        f"distance cache entry {entry} is unusable and is recomputed: {error}",
        CacheWarning,
        stacklevel=4,
    )


def _digest(key: str, stack: np.ndarray) -> bytes:
    """The SHA-256 of the key and the stack's data: what an entry ends with (another
    entry's file renamed to this key, a bit flipped on disk, do not match)."""
    digest = hashlib.sha256(key.encode())
    if stack.size:  # (a view of an empty array has no bytes to cast)
        digest.update(memoryview(np.ascontiguousarray(stack)).cast("B"))
    return digest.digest()


def _read(entry: Path, key: str, shape: tuple, dtype: np.dtype) -> np.ndarray:
    """The stack of a regular ``.npy`` file of this ``shape`` and ``dtype``, the header
    checked before the data is read, the data read in place and checked against the
    digest that follows it."""
    descriptor = os.open(entry, _OPEN_FLAGS)
    with os.fdopen(descriptor, "rb") as stream:
        if not stat.S_ISREG(os.fstat(descriptor).st_mode):  # swapped since the lstat
            raise ValueError("not a regular file")
        version = np.lib.format.read_magic(stream)
        if version not in _HEADERS:
            raise ValueError(f"unsupported .npy version {version}")
        found_shape, fortran, found = _HEADERS[version](stream)
        if found != dtype or fortran or found_shape != shape:
            raise ValueError(f"dtype {found}, shape {found_shape}, not {dtype}, {shape}")
        stack = np.empty(shape, dtype)
        if stack.size and stream.readinto(memoryview(stack).cast("B")) != stack.nbytes:
            raise ValueError("the file is cut short")
        trailer = stream.read(_DIGEST_SIZE + 1)
    if trailer != _digest(key, stack):
        raise ValueError("its data is not what was stored (checksum)")
    if not (stack >= 0).all():
        raise ValueError("NaN or negative distances")
    return stack
