"""Datasets: a folder of meshes, one class per sub-folder, and point clouds sampled from
meshes; the synthetic shapes (:mod:`.shapes`) are exported here too."""

from __future__ import annotations

import math
import os
import warnings
from functools import partial
from numbers import Integral, Real
from pathlib import Path

import numpy as np
from sklearn.utils import Bunch, check_random_state

from ._param_validation import N_JOBS, Interval, Options, validate_params
from ._progress import map_samples
from .mesh.reading import COMPRESSIONS
from .mesh.validation import check_mesh
from .pointcloud.reading import POINT_CLOUD_FORMATS, read_sample_file
from .shapes import SHAPE_CLASSES, make_shapes

__all__ = [
    "SHAPE_CLASSES",
    "SkippedFilesWarning",
    "load_mesh_folder",
    "make_shapes",
    "sample_point_cloud",
]

#: The most points :func:`sample_point_cloud` draws (holes' and outliers included): its
#: arrays take about 150 bytes a point at their peak, 1.5 GB here.
MAX_SAMPLE_POINTS = 10_000_000

_PLAIN_EXTENSIONS = (".obj", ".ply", ".off", ".stl", ".glb")

#: The file name endings :func:`load_mesh_folder` reads by default: each mesh format,
#: plain and compressed with gzip, bzip2 or xz (``.off.gz``, ``.obj.bz2``...).
MESH_EXTENSIONS = _PLAIN_EXTENSIONS + tuple(
    ext + compression for compression in COMPRESSIONS for ext in _PLAIN_EXTENSIONS
)

_CLOUD_EXTENSIONS = tuple("." + f for f in POINT_CLOUD_FORMATS)

#: The endings of the text point-cloud formats, plain and compressed (``.xyz``,
#: ``.pts``, ``.xyz.gz``...). A PLY (or other mesh format) without faces is a point
#: cloud too, under its mesh ending.
POINT_CLOUD_EXTENSIONS = _CLOUD_EXTENSIONS + tuple(
    ext + compression for compression in COMPRESSIONS for ext in _CLOUD_EXTENSIONS
)

#: The file name endings :func:`load_mesh_folder` reads by default: meshes
#: (``MESH_EXTENSIONS``) and point clouds (``POINT_CLOUD_EXTENSIONS``).
SAMPLE_EXTENSIONS = MESH_EXTENSIONS + POINT_CLOUD_EXTENSIONS


class SkippedFilesWarning(UserWarning):
    """:func:`load_mesh_folder` skipped files it could not read (``on_error="skip"``)."""


def _read_item(item, reader):
    """``reader`` on the ``(position, path)`` of one file, naming it ``sample K``."""
    k, path = item
    return reader(path, f"sample {k}")


def _read_or_error(path, place: str):
    """The sample of ``path``, or the ``ValueError`` that says why it cannot be read."""
    try:
        return read_sample_file(path, place)
    except ValueError as exc:
        return exc


@validate_params(
    {
        "extensions": [tuple, list],
        "load": ["boolean"],
        "n_jobs": N_JOBS,
        "verbose": [Interval(Integral, 0, None, closed="left")],
        "on_error": [Options(("raise", "skip"))],
    }
)
def load_mesh_folder(
    path, *, extensions=SAMPLE_EXTENSIONS, load=True, n_jobs=None, verbose=0, on_error="raise"
) -> Bunch:
    """Load a folder of meshes or point clouds with one class per sub-folder.

    Like :func:`sklearn.datasets.load_files`: every sub-folder of ``path`` is a class
    (sorted by name), every mesh or point-cloud file in it a sample (sorted by name).
    Sub-folders whose names start with ``_`` or ``.`` are ignored, and so are hidden
    files (names starting with ``.``: macOS's ``._`` companions, editors' backups) and
    files whose names do not end with one of ``extensions``. A sub-folder without such files is not
    a class. An entry named like a sample that is not a regular file (a FIFO, a folder,
    a broken link) is a sample that cannot be read: refused, or skipped and listed with
    ``on_error="skip"``, never left out without a word.

    Point clouds are ``.xyz`` and ``.pts`` text files and files of a mesh format without
    faces (a PLY of vertices); they load as ``(n, 3)`` float64 arrays, which every
    estimator takes as point clouds. A folder may mix meshes and clouds.

    Compressed files (``.gz``, ``.bz2``, ``.xz``, e.g. ``ant/081.off.gz``) are
    decompressed in memory, in the format of the inner name; a file that decompresses
    beyond ``sklearn_meshph.mesh.reading.MAX_DECOMPRESSED_SIZE`` bytes, or a text point
    cloud beyond ``sklearn_meshph.pointcloud.reading.MAX_TEXT_SIZE`` bytes, is refused.
    Only the formats of ``MESH_FORMATS`` and ``POINT_CLOUD_FORMATS`` are read, whatever
    ``extensions`` says (no archives).

    Parameters
    ----------
    path : str or os.PathLike
        The root folder.
    extensions : tuple of str, default=SAMPLE_EXTENSIONS
        File name endings that count as samples (case-insensitive). The default holds
        ``.obj``, ``.ply``, ``.off``, ``.stl``, ``.glb``, ``.xyz`` and ``.pts``, each
        also followed by ``.gz``, ``.bz2`` or ``.xz``; ``MESH_EXTENSIONS`` keeps the
        mesh formats only.
    load : bool, default=True
        Load the samples: meshes as ``trimesh.Trimesh`` (``process=False``, vertex order
        kept), point clouds as ``(n, 3)`` arrays. With ``False``, ``data`` holds the file
        paths, which every estimator accepts too: files are then read inside the
        workers, which saves memory.
    n_jobs : int, default=None
        Files read in parallel through joblib: ``None`` means 1 unless in a
        :func:`joblib.parallel_backend` context, ``-1`` means all processors. The
        result is the same for any ``n_jobs`` and backend, in file order. Each worker
        holds at most one decompressed file at a time.
    verbose : int, default=0
        With ``verbose > 0`` and ``load=True``, a progress bar over the files on stderr
        (needs tqdm, the ``progress`` extra); nothing is printed at 0.
    on_error : {"raise", "skip"}, default="raise"
        What a file that cannot be read does (not a valid mesh or point cloud, too
        large...): ``"raise"`` stops with its error; ``"skip"`` leaves it out, lists
        it in ``skipped`` and says so in one :class:`SkippedFilesWarning`. A class
        whose files are all skipped is not a class. With ``load=False`` no file is
        read, so none is skipped.

    Returns
    -------
    data : Bunch
        ``data`` (meshes, point clouds or paths), ``target`` (int labels),
        ``target_names``, ``filenames``, ``skipped`` (the files left out, each with the
        reason, as ``(file, message)`` pairs; empty unless ``on_error="skip"``) and
        ``DESCR``.

    Raises
    ------
    ValueError
        If ``path`` is not a folder, holds no mesh or point-cloud file in its
        sub-folders, or (with ``on_error="raise"``) a file cannot be read (the message
        names the sample and the file); with ``on_error="skip"``, if no file can be
        read.

    Examples
    --------
    >>> import tempfile, pathlib, trimesh
    >>> from sklearn_meshph import load_mesh_folder
    >>> root = pathlib.Path(tempfile.mkdtemp())
    >>> for name in ("box", "ball"):
    ...     (root / name).mkdir()
    ...     mesh = trimesh.creation.box() if name == "box" else trimesh.creation.icosphere()
    ...     _ = mesh.export(root / name / "a.ply")
    >>> data = load_mesh_folder(root)
    >>> data.target_names.tolist(), data.target.tolist()
    (['ball', 'box'], [0, 1])
    """
    root = Path(path)
    if not root.is_dir():
        problem = "is not a folder" if os.path.lexists(path) else "does not exist"
        raise ValueError(f"mesh folder {os.fspath(path)!r} {problem}")
    endings = tuple(e.lower() for e in extensions)
    classes = sorted(d for d in root.iterdir() if d.is_dir() and not d.name.startswith(("_", ".")))
    names, filenames, target = [], [], []
    for folder in classes:
        files = sorted(
            f
            for f in folder.iterdir()
            # Not only regular files: a FIFO, a folder or a broken link under a mesh's
            # name is a sample that cannot be read, refused or skipped by name, not
            # silently left out of its class.
            if not f.name.startswith(".") and f.name.lower().endswith(endings)
        )
        if not files:
            continue
        target.extend([len(names)] * len(files))
        names.append(folder.name)
        filenames.extend(files)
    if not filenames:
        raise ValueError(
            f"no mesh or point-cloud files ({', '.join(endings)}) in sub-folders of "
            f"{os.fspath(path)!r}"
        )
    skipped = []
    if load:
        reader = read_sample_file if on_error == "raise" else _read_or_error
        data = map_samples(
            partial(_read_item, reader=reader),
            enumerate(filenames),
            n_jobs=n_jobs,
            desc="reading files",
            verbose=verbose,
        )
        skipped = [(str(f), _reason(x)) for f, x in zip(filenames, data, strict=True) if _bad(x)]
        if len(skipped) == len(data):
            raise ValueError(
                f"none of the {len(data)} files of {os.fspath(path)!r} can be read; the "
                f"first: {skipped[0][1]}"
            )
        if skipped:
            data, filenames, target, names = _without_skipped(data, filenames, target, names)
            _warn_skipped(skipped, os.fspath(path))
    else:
        data = [str(f) for f in filenames]
    return Bunch(
        data=data,
        target=np.asarray(target, dtype=int),
        target_names=np.asarray(names),
        filenames=np.asarray([str(f) for f in filenames]),
        skipped=skipped,
        DESCR=f"Samples from {os.fspath(path)}: {len(filenames)} files, {len(names)} classes.",
    )


def _bad(sample) -> bool:
    return isinstance(sample, ValueError)


def _reason(error: ValueError) -> str:
    """The error's one line without the ``sample K:`` prefix (the file is named)."""
    text = " ".join(str(error).split())
    head, _, rest = text.partition(": ")
    return rest if head.startswith("sample ") and rest else text


def _without_skipped(data, filenames, target, names):
    """The samples read, their files and labels, and the classes that kept a file."""
    kept = [k for k, x in enumerate(data) if not _bad(x)]
    classes = sorted({target[k] for k in kept})
    relabel = {c: new for new, c in enumerate(classes)}
    return (
        [data[k] for k in kept],
        [filenames[k] for k in kept],
        [relabel[target[k]] for k in kept],
        [names[c] for c in classes],
    )


def _warn_skipped(skipped, path: str) -> None:
    lines = "; ".join(reason for _, reason in skipped)
    warnings.warn(
        f"{len(skipped)} file(s) of {path!r} cannot be read and are skipped: {lines}",
        SkippedFilesWarning,
        stacklevel=3,
    )


class _FiniteInterval(Interval):
    """An :class:`Interval` of finite numbers only (``inf`` is refused)."""

    def __call__(self, value) -> bool:
        return super().__call__(value) and math.isfinite(value)

    def __str__(self) -> str:
        return "a finite " + super().__str__().removeprefix("a ")


@validate_params(
    {
        "n_points": [Interval(Integral, 1, None, closed="left")],
        "noise": [_FiniteInterval(Real, 0, None, closed="left")],
        "density": [_FiniteInterval(Real, 1, None, closed="left")],
        "holes": [Interval(Integral, 0, None, closed="left")],
        "hole_fraction": [Interval(Real, 0, 0.5, closed="right")],
        "outliers": [Interval(Integral, 0, None, closed="left")],
        "random_state": ["random_state"],
    }
)
def sample_point_cloud(
    mesh,
    n_points: int,
    *,
    noise: float = 0.0,
    density: float = 1.0,
    holes: int = 0,
    hole_fraction: float = 0.1,
    outliers: int = 0,
    random_state=None,
):
    """Sample points uniformly on a mesh's surface, optionally as a real scan would be.

    A scan without connectivity, made from a mesh: for benchmarks, tests, and to
    compare a shape's mesh with its point cloud. Beyond Gaussian noise, the defects of
    real scans can be simulated: uneven density (``density``), holes where views are
    missing (``holes``) and stray points (``outliers``). With their defaults the sample
    is uniform, and the same, for the same ``random_state``, as without these options.

    Parameters
    ----------
    mesh : trimesh.Trimesh, (vertices, faces) pair, str or os.PathLike
        See :func:`check_mesh`.
    n_points : int
        Points to draw on the surface (outliers come on top).
    noise : float, default=0.0
        Standard deviation of the Gaussian noise added to every coordinate, relative to
        the length of the mesh's bounding-box diagonal.
    density : float, default=1.0
        Uneven density: the surface is cut in two halves of equal area by a plane of
        random direction, and one half is sampled ``density`` times more densely than
        the other (each triangle is on the side of its centroid). ``1.0``: uniform.
    holes : int, default=0
        Holes, as left by missing views: ``holes`` random points of the sample are
        chosen one after the other, each among the points still there, and the points
        nearest to it (in space) are removed with it, ``hole_fraction`` of the sampled
        points in all, shared equally between the holes. More points are drawn first,
        so that ``n_points`` remain.
    hole_fraction : float, default=0.1
        Fraction of the sampled points the holes remove, in (0, 0.5]; on a uniform
        sample, the fraction of the surface they cover. Used only with ``holes > 0``.
    outliers : int, default=0
        Stray points drawn uniformly in the mesh's bounding box grown by a quarter of
        its diagonal on every side, appended after the surface points.
    random_state : int, RandomState instance or None, default=None
        Makes the sample reproducible.

    Returns
    -------
    points : ndarray of shape (n_points + outliers, 3)
        On the surface, area-weighted (a triangle is drawn with probability
        proportional to its area, times ``density`` on the dense side, then a point
        uniformly inside it), then the outliers.

    Raises
    ------
    ValueError
        If the mesh has no area, if more than :data:`MAX_SAMPLE_POINTS` points would
        be drawn, if ``noise`` or the outliers' box take the points beyond float64's
        range, or if ``hole_fraction`` is too small for every hole
        to remove a point.

    Examples
    --------
    >>> import trimesh
    >>> from sklearn_meshph import sample_point_cloud
    >>> sphere = trimesh.creation.icosphere(3)
    >>> sample_point_cloud(sphere, 1000, random_state=0).shape
    (1000, 3)
    >>> scan = sample_point_cloud(
    ...     sphere, 1000, noise=0.005, density=4.0, holes=2, outliers=5, random_state=0
    ... )
    >>> scan.shape
    (1005, 3)
    """
    vertices, faces = check_mesh(mesh)
    n_removed = round(n_points * hole_fraction / (1 - hole_fraction)) if holes else 0
    if n_removed < holes:
        raise ValueError(
            f"hole_fraction={hole_fraction!r} removes {n_removed} of the points for "
            f"{holes} holes: each hole needs at least one point (a larger hole_fraction, "
            "more points or fewer holes)"
        )
    if n_points + n_removed + outliers > MAX_SAMPLE_POINTS:
        raise ValueError(
            f"n_points={n_points} (with {n_removed} drawn for the holes and "
            f"{outliers} outliers) is more than the {MAX_SAMPLE_POINTS:,} points a sample "
            "may have (its arrays would take several gigabytes)"
        )
    rng = np.random.default_rng(check_random_state(random_state).randint(2**31))
    corners = vertices[faces]
    with np.errstate(over="ignore", under="ignore", invalid="ignore"):
        areas = _areas(corners)
    if not (np.isfinite(areas.sum()) and areas.sum() > 0):
        # Coordinates near float's limits: the areas over- or underflow, their ratios
        # (all that the draw uses) do not with the coordinates scaled to at most 1.
        largest = np.abs(vertices).max()
        areas = _areas(corners / largest) if largest > 0 else areas
    if not areas.sum() > 0:
        raise ValueError("mesh: the surface has no area to sample")
    weights = areas if density == 1 else _uneven(corners, areas, density, rng)
    n_drawn = n_points + n_removed
    chosen = rng.choice(len(faces), size=n_drawn, p=weights / weights.sum())
    # Uniform barycentric coordinates: reflect the unit square's upper triangle.
    u, v = rng.random(n_drawn), rng.random(n_drawn)
    flip = u + v > 1
    u[flip], v[flip] = 1 - u[flip], 1 - v[flip]
    a, b, c = (corners[chosen, k] for k in range(3))
    points = a + u[:, None] * (b - a) + v[:, None] * (c - a)
    low, high = vertices.min(axis=0), vertices.max(axis=0)
    diagonal = math.hypot(*(high - low))  # no overflow for coordinates near the limits
    if noise > 0:
        points = points + rng.normal(scale=noise * diagonal, size=points.shape)
    if holes:
        points = _cut_holes(points, holes, n_removed, rng)
    if outliers:
        margin = diagonal / 4
        with np.errstate(over="ignore"):
            box = (low - margin, high + margin)
            span = box[1] - box[0]
        # numpy's uniform refuses (OverflowError) a box wider than float64's range.
        stray = rng.uniform(*box, size=(outliers, 3)) if np.isfinite(span).all() else np.inf
        points = np.concatenate([points, np.broadcast_to(stray, (outliers, 3))])
    if not np.isfinite(points).all():
        raise ValueError(
            f"the sample is not finite: the mesh's coordinates (bounding-box diagonal "
            f"{diagonal:.3g}) with noise={noise!r} or outliers={outliers!r} leave "
            "float64's range"
        )
    return points


def _areas(corners):
    """Twice the areas of the triangles ``(m, 3, 3)``."""
    return np.linalg.norm(
        np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1
    )


def _uneven(corners, areas, density: float, rng):
    """Triangle weights: areas, times ``density`` on one side of a plane of random
    direction cutting the surface in two halves of equal area."""
    direction = rng.normal(size=3)
    height = corners.mean(axis=1) @ (direction / np.linalg.norm(direction))
    order = np.argsort(height, kind="stable")
    cumulative = np.cumsum(areas[order])
    middle = height[order[np.searchsorted(cumulative, cumulative[-1] / 2)]]
    # The sparse side divided (density >= 1), so that no weight overflows.
    return np.where(height > middle, areas, areas / density)


def _cut_holes(points, holes: int, n_removed: int, rng):
    """``points`` without ``holes`` holes of ``n_removed`` points in all: each around a
    random remaining point, its nearest remaining points (itself included)."""
    sizes = np.full(holes, n_removed // holes) + (np.arange(holes) < n_removed % holes)
    kept = np.ones(len(points), dtype=bool)
    for size in sizes:
        remaining = np.flatnonzero(kept)
        centre = points[remaining[rng.integers(len(remaining))]]
        distances = np.linalg.norm(points[remaining] - centre, axis=1)
        kept[remaining[np.argpartition(distances, size - 1)[:size]]] = False
    return points[kept]
