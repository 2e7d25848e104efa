"""Triangle geometry in one place: the unit box every solve works in, and compiled
per-triangle edge vectors, areas, smallest angles, degenerate and repeated faces."""

from __future__ import annotations

import numba
import numpy as np

__all__ = [
    "face_double_areas",
    "first_of_duplicate_faces",
    "nondegenerate_faces",
    "smallest_angle_sines",
    "triangle",
    "unit_box",
    "unit_box_mass",
    "within_tukey_fences",
]


def unit_box(vertices: np.ndarray, box: np.ndarray | None = None) -> tuple[np.ndarray, float]:
    """``vertices`` moved and scaled into ``[-1, 1]^3``, and the length ``scale`` with
    ``vertices ~ center + scale * unit``, computed without overflow or underflow for
    any finite float64 coordinates (halves first, then one division), so that what
    follows (areas, cotangents, the mass matrix) sees numbers near 1 whatever the
    mesh's scale. A mesh of one point (no extent) is returned as it is.

    With ``box`` (some of the points), the unit box is that of ``box``: the other
    vertices may land far outside it, overflowing to infinity beyond float64."""
    box = vertices if box is None else box
    lo, hi = box.min(axis=0), box.max(axis=0)
    center = (lo / 2 + hi / 2) / 2
    extent = float(np.abs(box / 2 - center).max()) if len(box) else 0.0
    if not 0.0 < extent < np.inf:
        return vertices, 1.0
    with np.errstate(over="ignore"):
        return (vertices / 2 - center) / extent, 2.0 * extent


def within_tukey_fences(points: np.ndarray) -> np.ndarray:
    """The mask of the points within Tukey's fences: three interquartile ranges beyond
    the quartiles, per coordinate (a few far points barely move the quartiles)."""
    low, high = np.percentile(points, [25, 75], axis=0)
    reach = 3.0 * (high - low)
    return np.all((points >= low - reach) & (points <= high + reach), axis=1)


def unit_box_mass(mass: np.ndarray, scale: float, place: str) -> np.ndarray:
    """Lumped masses computed in :func:`unit_box` brought back to the input's units
    (times ``scale`` squared), or a ``ValueError`` naming ``place`` when float64 cannot
    hold them there (areas above about 1e308 or below 2.2e-308: coordinates beyond
    about 1e154 or under 1e-154). The stiffness of a cotangent Laplacian needs no such step:
    its weights are ratios of lengths."""
    with np.errstate(over="ignore", under="ignore"):
        scaled = (mass * scale) * scale
    # Subnormal areas (below float64's smallest normal number) keep too few digits.
    lost = (scaled < np.finfo(np.float64).tiny) & (mass > 0)
    if not np.isfinite(scaled).all() or lost.any():
        raise ValueError(
            f"{place}: the areas do not fit in float64 at this scale (a bounding box of "
            f"{scale:.3g}): rescale the input, or use LaplacianEigenTransformer or "
            "laplacian_eigenfunctions, which solve in a unit box and scale back"
        )
    return scaled


# A face is degenerate when twice its area is below this fraction of its longest edge
# squared: its vertices are (numerically) collinear or coincident, whatever the scale.
DEGENERATE_SINE = 1e-12


@numba.njit(cache=True, inline="always")
def triangle(vertices, a, b, c):
    """Edge vectors a->b and a->c of a triangle and twice its area."""
    ux = vertices[b, 0] - vertices[a, 0]
    uy = vertices[b, 1] - vertices[a, 1]
    uz = vertices[b, 2] - vertices[a, 2]
    vx = vertices[c, 0] - vertices[a, 0]
    vy = vertices[c, 1] - vertices[a, 1]
    vz = vertices[c, 2] - vertices[a, 2]
    nx = uy * vz - uz * vy
    ny = uz * vx - ux * vz
    nz = ux * vy - uy * vx
    return ux, uy, uz, vx, vy, vz, np.sqrt(nx * nx + ny * ny + nz * nz)


@numba.njit(cache=True)
def face_double_areas(vertices, faces):
    """Twice the area of each face."""
    out = np.empty(faces.shape[0])
    for f in range(faces.shape[0]):
        out[f] = triangle(vertices, faces[f, 0], faces[f, 1], faces[f, 2])[6]
    return out


@numba.njit(cache=True)
def nondegenerate_faces(vertices, faces, sine):
    """Faces with three distinct indices and twice the area above ``sine`` times the
    longest edge squared."""
    m = faces.shape[0]
    keep = np.empty(m, dtype=np.bool_)
    for f in range(m):
        a, b, c = faces[f, 0], faces[f, 1], faces[f, 2]
        if a == b or b == c or a == c:
            keep[f] = False
            continue
        ux, uy, uz, vx, vy, vz, double_area = triangle(vertices, a, b, c)
        wx, wy, wz = vx - ux, vy - uy, vz - uz
        longest = max(ux * ux + uy * uy + uz * uz, vx * vx + vy * vy + vz * vz)
        longest = max(longest, wx * wx + wy * wy + wz * wz)
        keep[f] = double_area > sine * longest
    return keep


def smallest_angle_sines(vertices, faces) -> np.ndarray:
    """The sine of each face's smallest angle (0 for a degenerate face), for vertices
    near unit scale (see :func:`unit_box`)."""
    vertices = np.ascontiguousarray(vertices, dtype=np.float64)
    return _smallest_angle_sines(vertices, np.ascontiguousarray(faces, dtype=np.int64))


@numba.njit(cache=True)
def _smallest_angle_sines(vertices, faces):
    """``sin(angle at a corner) = 2 area / (product of its two edges)``: the smallest
    angle is at the corner whose two edges have the largest product."""
    out = np.empty(faces.shape[0])
    for f in range(faces.shape[0]):
        ux, uy, uz, vx, vy, vz, double_area = triangle(
            vertices, faces[f, 0], faces[f, 1], faces[f, 2]
        )
        wx, wy, wz = vx - ux, vy - uy, vz - uz
        u = np.sqrt(ux * ux + uy * uy + uz * uz)
        v = np.sqrt(vx * vx + vy * vy + vz * vz)
        w = np.sqrt(wx * wx + wy * wy + wz * wz)
        largest = max(u * v, u * w, v * w)
        out[f] = double_area / largest if largest > 0.0 else 0.0
    return out


@numba.njit(cache=True, inline="always")
def _sorted_face(faces, f):
    """The three vertex indices of face ``f`` in increasing order."""
    a, b, c = faces[f, 0], faces[f, 1], faces[f, 2]
    if a > b:
        a, b = b, a
    if b > c:
        b, c = c, b
    if a > b:
        a, b = b, a
    return a, b, c


@numba.njit(cache=True)
def first_of_duplicate_faces(faces):
    """Mask keeping the first face of every group listing the same three vertices.

    An open-addressing hash table of the sorted index triples: one pass, no sort.
    """
    m = faces.shape[0]
    size = 1
    while size < 2 * m:
        size *= 2
    table = np.full(size, -1, np.int64)
    keep = np.ones(m, dtype=np.bool_)
    for f in range(m):
        a, b, c = _sorted_face(faces, f)
        h = (a * 0x9E3779B1 + b * 0x85EBCA77 + c * 0xC2B2AE3D) & (size - 1)
        while True:
            g = table[h]
            if g == -1:
                table[h] = f
                break
            x, y, z = _sorted_face(faces, g)
            if x == a and y == b and z == c:
                keep[f] = False
                break
            h = (h + 1) & (size - 1)
    return keep
