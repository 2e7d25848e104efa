"""Reading mesh files (through trimesh), with errors that name the file."""

from __future__ import annotations

import os

__all__ = ["read_mesh_file"]


def read_mesh_file(path, place: str = "mesh"):
    """A mesh file as a ``trimesh.Trimesh``, loaded with ``process=False`` (order kept).

    ``place`` names the sample in error messages, which also name the file.
    """
    import trimesh

    path = os.fspath(path)
    if not os.path.isfile(path):
        raise ValueError(f"{place}: mesh file {path!r} does not exist")
    try:
        loaded = trimesh.load(path, process=False, force="mesh")
    except Exception as exc:  # trimesh raises many types on malformed files
        raise ValueError(f"{place}: cannot read mesh file {path!r}: {exc}") from exc
    if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
        raise ValueError(f"{place}: mesh file {path!r} contains no triangles")
    return loaded
