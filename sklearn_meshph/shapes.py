"""Synthetic shapes: six classes of closed genus-0 meshes generated in code, the main
job's built-in data (exported by :mod:`sklearn_meshph.datasets`)."""

from __future__ import annotations

from numbers import Integral, Real

import numpy as np
import trimesh
from sklearn.utils import Bunch, check_random_state

from ._param_validation import Interval, Numbers, validate_params

__all__ = ["MAX_SHAPES", "MAX_SHAPE_NOISE", "SHAPE_CLASSES", "make_shapes"]

#: Most meshes :func:`make_shapes` makes in one call (a million at its default
#: resolution is about 20 GB).
MAX_SHAPES = 100_000


# Each class: body ellipsoid axes, then limbs as (direction, length). Templates are
# asymmetric on purpose: symmetric shapes have repeated eigenvalues, whose
# eigenfunctions are not unique.
def _limbs(*pairs):
    directions = np.array([p[0] for p in pairs], dtype=float).reshape(-1, 3)
    directions /= np.maximum(np.linalg.norm(directions, axis=1, keepdims=True), 1e-300)
    return directions, np.array([p[1] for p in pairs], dtype=float)


_CLASSES = {
    "blob": ((1.0, 1.3, 1.8), _limbs()),
    "snake": ((0.8, 0.9, 1.2), _limbs(([0, 0, 1], 2.4), ([0, 0, -1], 1.8))),
    "tripod": (
        (1.0, 1.1, 0.9),
        _limbs(([1, 0, 0], 1.4), ([-0.5, 0.87, 0], 1.0), ([-0.5, -0.87, 0], 0.7)),
    ),
    "quadruped": (
        (1.0, 0.9, 1.7),
        _limbs(
            ([0.6, -1, 0.6], 0.9),
            ([-0.6, -1, 0.6], 0.9),
            ([0.6, -1, -0.6], 0.9),
            ([-0.6, -1, -0.6], 0.9),
            ([0, 0.3, 1], 0.7),
        ),
    ),
    "star": (
        (1.0, 1.0, 1.1),
        _limbs(
            ([1, 0, 0], 0.5),
            ([-1, 0, 0], 0.6),
            ([0, 1, 0], 0.7),
            ([0, -1, 0], 0.8),
            ([0, 0, 1], 0.9),
            ([0, 0, -1], 1.0),
        ),
    ),
    "hand": (
        (1.0, 0.45, 1.1),
        _limbs(
            ([0.5, 0, 1], 0.8),
            ([0.17, 0, 1], 1.0),
            ([-0.17, 0, 1], 0.95),
            ([-0.5, 0, 1], 0.75),
            ([1, 0, 0.1], 0.6),
        ),
    ),
}

#: The classes of :func:`make_shapes`, in label order.
SHAPE_CLASSES = tuple(_CLASSES)


def _rotation_towards(rng, directions, max_angle):
    """Each direction turned by a random angle up to ``max_angle`` (radians)."""
    out = np.empty_like(directions)
    for k, d in enumerate(directions):
        axis = np.cross(d, rng.normal(size=3))
        axis /= np.linalg.norm(axis)
        angle = rng.uniform(0, max_angle)
        out[k] = d * np.cos(angle) + np.cross(axis, d) * np.sin(angle)
    return out


def _shape(name, rng, resolution):
    body, (directions, lengths) = _CLASSES[name]
    n_lat = int(rng.integers(resolution[0], resolution[1] + 1))
    n_lon = int(rng.integers(resolution[0], resolution[1] + 1))
    sphere = trimesh.creation.uv_sphere(radius=1.0, count=[n_lat, n_lon])
    # A random orientation of the tessellation relative to the limbs: poles anywhere.
    base = trimesh.transformations.random_rotation_matrix(rng.random(3))[:3, :3]
    unit = sphere.vertices @ base.T
    unit /= np.linalg.norm(unit, axis=1, keepdims=True)
    axes = np.asarray(body) * rng.uniform(0.92, 1.08, size=3)
    radius = 1.0 / np.sqrt(((unit / axes) ** 2).sum(axis=1))
    limbs = _rotation_towards(rng, directions, np.radians(15)) if len(directions) else directions
    for d, length in zip(limbs, lengths, strict=True):
        angle = np.arccos(np.clip(unit @ d, -1.0, 1.0))
        radius = radius + length * rng.uniform(0.9, 1.1) * np.exp(-((angle / 0.3) ** 2))
    vertices = unit * radius[:, None]
    return trimesh.Trimesh(vertices, sphere.faces, process=False)


#: Largest radial noise of :func:`make_shapes`: beyond, a radius ``1 + noise N(0, 1)``
#: turns negative somewhere and the surface folds through itself (at 0.1 that takes a
#: normal deviate below -10).
MAX_SHAPE_NOISE = 0.1


@validate_params(
    {
        "n_per_class": [Interval(Integral, 1, None, closed="left")],
        "classes": [tuple, list, None],
        "resolution": [Numbers(2)],
        "noise": [Interval(Real, 0, MAX_SHAPE_NOISE, closed="both")],
        "random_state": ["random_state"],
        "return_X_y": ["boolean"],
    }
)
def make_shapes(
    n_per_class: int = 10,
    *,
    classes=None,
    resolution=(18, 40),
    noise: float = 0.005,
    random_state=None,
    return_X_y: bool = False,
):
    """Generate a labelled set of synthetic closed meshes.

    Six classes of genus-0 shapes, each an ellipsoidal body with smooth limbs:
    ``"blob"`` (no limb), ``"snake"`` (two opposite long limbs), ``"tripod"`` (three in
    a plane), ``"quadruped"`` (four legs below and a head), ``"star"`` (six short ones)
    and ``"hand"`` (five on one side). Every mesh gets a random pose (limb directions turned
    by up to 15 degrees, limb lengths and body axes varied by 10-15%), a random rotation,
    a random uniform scale between 0.1 and 10, small radial noise, and a random
    resolution: a UV sphere tessellation whose ring and segment counts are drawn from
    ``resolution``, randomly oriented. Every class draws its resolutions from the same
    range, so the vertex count does not reveal the class.

    Parameters
    ----------
    n_per_class : int, default=10
        Meshes per class; at most ``MAX_SHAPES`` (100,000) meshes in all.
    classes : tuple of str, optional
        A subset of the class names above, each at most once (default: all six).
    resolution : (int, int), default=(18, 40)
        Range of the UV sphere's ring and segment counts.
    noise : float, default=0.005
        Standard deviation of the radial noise, relative to the shape's size, from 0 to
        ``MAX_SHAPE_NOISE`` (0.1).
    random_state : int, RandomState instance or None, default=None
        Makes the set reproducible.
    return_X_y : bool, default=False
        Return ``(meshes, target)`` instead of a Bunch.

    Returns
    -------
    data : Bunch
        ``data`` (list of ``trimesh.Trimesh``), ``target``, ``target_names``, ``DESCR``;
        or ``(data, target)`` with ``return_X_y=True``.

    Examples
    --------
    >>> from sklearn_meshph import make_shapes
    >>> meshes, y = make_shapes(n_per_class=2, random_state=0, return_X_y=True)
    >>> len(meshes), y.tolist()
    (12, [0, 0, 1, 1, 2, 2, 3, 3, 4, 4, 5, 5])
    """
    low, high = resolution  # rings and segments of a UV sphere: at most 1000
    if not (isinstance(low, Integral) and isinstance(high, Integral) and 3 <= low <= high <= 1000):
        raise ValueError(
            f"resolution must be two ints 3 <= low <= high <= 1000, got {resolution!r}"
        )
    names = tuple(_CLASSES) if classes is None else tuple(classes)
    unknown = [c for c in names if not isinstance(c, str) or c not in _CLASSES]
    if unknown or not names or len(set(names)) < len(names):
        raise ValueError(
            f"classes must be distinct names of {tuple(_CLASSES)}, at least one, got "
            f"{classes!r}" + (f" (unknown: {unknown})" if unknown else "")
        )
    if n_per_class * len(names) > MAX_SHAPES:
        raise ValueError(
            f"n_per_class={n_per_class} for {len(names)} classes is {n_per_class * len(names)} "
            f"meshes, more than MAX_SHAPES ({MAX_SHAPES})"
        )
    rng = np.random.default_rng(check_random_state(random_state).randint(2**31))
    meshes, target = [], []
    for label, name in enumerate(names):
        for _ in range(n_per_class):
            mesh = _shape(name, rng, resolution)
            vertices = mesh.vertices * (1 + noise * rng.normal(size=(len(mesh.vertices), 1)))
            rotation = trimesh.transformations.random_rotation_matrix(rng.random(3))[:3, :3]
            scale = 10.0 ** rng.uniform(-1, 1)
            vertices = vertices @ rotation.T * scale + rng.normal(scale=scale, size=3)
            meshes.append(trimesh.Trimesh(vertices, mesh.faces, process=False))
            target.append(label)
    target = np.asarray(target)
    if return_X_y:
        return meshes, target
    return Bunch(
        data=meshes,
        target=target,
        target_names=np.asarray(names),
        DESCR=make_shapes.__doc__.split("\n\n")[1],
    )
