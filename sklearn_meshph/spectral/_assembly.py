"""Compiled cotangent weights: one pass over the faces, no gathered temporaries."""

from __future__ import annotations

import numba
import numpy as np

from ..mesh import triangle


@numba.njit(cache=True, error_model="numpy")
def cotangent_weights(vertices, faces):
    """Half the cotangent of each corner's angle and twice each face's area.

    ``weights[f, k]`` belongs to the edge opposite corner ``k``, from vertex
    ``faces[f, (k + 1) % 3]`` to ``faces[f, (k + 2) % 3]``. A face of zero area gives
    non-finite weights (NumPy's division rules); callers check ``double_areas``.
    """
    m = faces.shape[0]
    weights = np.empty((m, 3))
    double_areas = np.empty(m)
    for f in range(m):
        a, b, c = faces[f, 0], faces[f, 1], faces[f, 2]
        ux, uy, uz, vx, vy, vz, double_area = triangle(vertices, a, b, c)
        double_areas[f] = double_area
        wx, wy, wz = vx - ux, vy - uy, vz - uz  # from b to c
        # corner a: edges a->b and a->c; corner b: b->c and b->a; corner c: c->a, c->b
        weights[f, 0] = 0.5 * (ux * vx + uy * vy + uz * vz) / double_area
        weights[f, 1] = 0.5 * (-(wx * ux + wy * uy + wz * uz)) / double_area
        weights[f, 2] = 0.5 * (wx * vx + wy * vy + wz * vz) / double_area
    return weights, double_areas
