"""One mesh's cleaning and eigensolve: the unit of work the eigen cache stores.

A change here changes the numbers a solve gives: bump
:data:`sklearn_meshph.spectral.cache.NUMERICS_VERSION` (a test checks).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..mesh.cleaning import clean_checked
from ..mesh.validation import where
from .eigensolver import generalized_eigenpairs
from .laplacians import LAPLACIANS

__all__ = ["mesh_eigenpairs", "unit_box"]


def unit_box(vertices: np.ndarray) -> tuple[np.ndarray, float]:
    """``vertices`` moved and scaled into ``[-1, 1]^3``, and the length ``scale`` with
    ``vertices ~ center + scale * unit``, computed without overflow or underflow for
    any finite float64 coordinates (halves first, then one division), so that what
    follows (areas, cotangents, the mass matrix) sees numbers near 1 whatever the
    mesh's scale. A mesh of one point (no extent) is returned as it is."""
    lo, hi = vertices.min(axis=0), vertices.max(axis=0)
    half = vertices / 2 - (lo / 2 + hi / 2) / 2
    extent = float(np.abs(half).max()) if len(vertices) else 0.0
    if not 0.0 < extent < np.inf:
        return vertices, 1.0
    return half / extent, 2.0 * extent


def mesh_eigenpairs(
    vertices,
    faces,
    laplacian,
    normalization,
    components,
    n_eigs,
    seed,
    index,
    solver="auto",
    weld=True,
):
    """Clean one validated mesh and solve its eigenpairs: the unit ``memory`` caches.

    The cache key is the input mesh's content and the settings (``index``, the sample's
    position, is ignored), so a hit skips the cleaning too. With
    ``normalization="area"`` the cotangent mass matrix is divided by the total area (the
    mesh scaled to unit area) and the graph Laplacian gets ``M = I / n``, so that
    eigenvectors have unit mean square whatever the scale and the vertex count.
    """
    # Everything below works on the mesh in a unit box: the same numbers for any uniform
    # scale float64 can represent (1e-150 or 1e150), no underflow in areas or overflow in
    # squared lengths. The kept vertices are then taken back from the input, exactly.
    unit, scale = unit_box(vertices)
    clean = clean_checked(unit, faces, components=components, index=index, weld=weld)
    points = clean.vertices  # in the unit box: for the factorization's ordering
    L, M = LAPLACIANS[laplacian].value(points, clean.faces)
    clean = replace(clean, vertices=np.ascontiguousarray(vertices[clean.vertex_indices]))
    if normalization == "area":
        M = M / M.diagonal().sum()
    n_eigs = min(n_eigs, len(clean.vertices))
    try:
        values, vectors = generalized_eigenpairs(
            L, M, n_eigs, seed=seed, points=points, solver=solver
        )
    except (ValueError, RuntimeError, ArithmeticError) as error:  # ARPACK, the factorization
        raise ValueError(
            f"{where(index)}: the eigensolver failed on the cleaned mesh "
            f"({len(clean.vertices)} vertices, {len(clean.faces)} faces): {error}"
        ) from error
    if normalization == "none" and laplacian == "cotangent":
        # The mass matrix of the mesh as given is scale^2 times the unit box's: the
        # eigenvalues divide by scale^2, M-orthonormal eigenvectors by scale.
        with np.errstate(over="ignore", under="ignore"):
            values, vectors = values / scale / scale, vectors / scale
        if not (np.isfinite(values).all() and np.isfinite(vectors).all()) or (
            len(values) > 1 and values[1:].max() < np.finfo(np.float64).tiny
        ):
            raise ValueError(
                f"{where(index)}: with normalization='none' the eigenpairs of this mesh "
                f"(extent about {scale:.3g}) are beyond float64's range; use "
                "normalization='area', which gives the same functions at any scale"
            )
    return clean, values, vectors
