"""One sample's cleaning and eigensolve, mesh or point cloud: the unit of work the eigen
cache stores.

A change here changes the numbers a solve gives: bump
:data:`sklearn_meshph.spectral.cache.NUMERICS_VERSION` (a test checks).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..mesh.cleaning import clean_checked
from ..mesh.validation import where
from ..pointcloud.cleaning import clean_cloud
from .eigensolver import generalized_eigenpairs
from .laplacians import LAPLACIANS

__all__ = ["cloud_eigenpairs", "mesh_eigenpairs", "unit_box"]


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
    sizes = f"{len(clean.vertices)} vertices, {len(clean.faces)} faces"
    values, vectors = _eigenpairs(
        L, M, points, laplacian, normalization, n_eigs, seed, index, solver, scale, "mesh", sizes
    )
    return clean, values, vectors


def cloud_eigenpairs(
    points,
    laplacian,
    normalization,
    components,
    n_eigs,
    seed,
    index,
    solver="auto",
    weld=True,
):
    """Clean one validated point cloud and solve its eigenpairs, as
    :func:`mesh_eigenpairs` does for a mesh.

    The cloud is cleaned by :func:`sklearn_meshph.pointcloud.cleaning.clean_cloud`
    (coincident points merged, one component) and its operator is the point-cloud
    discretization of ``laplacian``, both in the unit box and in a canonical point
    order: a permuted cloud gives the permuted eigenvectors, bit for bit. The returned
    :class:`CleanMesh` has no faces; its vertices are the kept input points, in input
    order. ``normalization="area"`` divides the mass by its sum (the area the local
    triangulations estimate), as for meshes.
    """
    unit, scale = unit_box(points)
    clean, L, M, solve_points, to_output = clean_cloud(
        points, unit, laplacian=laplacian, components=components, index=index, weld=weld
    )
    sizes = f"{len(clean.vertices)} points"
    values, vectors = _eigenpairs(
        L,
        M,
        solve_points,
        laplacian,
        normalization,
        n_eigs,
        seed,
        index,
        solver,
        scale,
        "point cloud",
        sizes,
    )
    return clean, values, np.ascontiguousarray(vectors[to_output])


def _eigenpairs(
    L, M, points, laplacian, normalization, n_eigs, seed, index, solver, scale, kind, sizes
):
    """The eigenpairs of an operator built in the unit box, normalized as asked."""
    if normalization == "area":
        M = M / M.diagonal().sum()
    n_eigs = min(n_eigs, L.shape[0])
    try:
        values, vectors = generalized_eigenpairs(
            L, M, n_eigs, seed=seed, points=points, solver=solver
        )
    except (ValueError, RuntimeError, ArithmeticError) as error:  # ARPACK, the factorization
        raise ValueError(
            f"{where(index)}: the eigensolver failed on the cleaned {kind} ({sizes}): {error}"
        ) from error
    if normalization == "none" and laplacian == "cotangent":
        # The mass matrix of the input as given is scale^2 times the unit box's: the
        # eigenvalues divide by scale^2, M-orthonormal eigenvectors by scale.
        with np.errstate(over="ignore", under="ignore"):
            values, vectors = values / scale / scale, vectors / scale
        if not (np.isfinite(values).all() and np.isfinite(vectors).all()) or (
            len(values) > 1 and values[1:].max() < np.finfo(np.float64).tiny
        ):
            raise ValueError(
                f"{where(index)}: with normalization='none' the eigenpairs of this {kind} "
                f"(extent about {scale:.3g}) are beyond float64's range; use "
                "normalization='area', which gives the same functions at any scale"
            )
    return values, vectors
