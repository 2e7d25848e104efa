"""Compiled per-triangle geometry: edge vectors, areas, degenerate faces."""

from __future__ import annotations

import numba
import numpy as np

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
