"""One sample's cleaning and eigensolve, mesh or point cloud: the unit of work the eigen
cache stores.

A change here changes the numbers a solve gives: bump
:data:`sklearn_meshph.spectral.cache.NUMERICS_VERSION` (a test checks).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..mesh import unit_box
from ..mesh.cleaning import clean_checked
from ..mesh.validation import where
from ..pointcloud.cleaning import clean_cloud
from .eigensolver import generalized_eigenpairs
from .laplacians import LAPLACIANS

__all__ = ["SolveSettings", "cloud_eigenpairs", "mesh_eigenpairs"]


@dataclass(frozen=True)
class SolveSettings:
    """What a solve depends on besides the sample, the number of eigenpairs and the
    seed: the parameters of :class:`LaplacianEigenTransformer` of the same names."""

    laplacian: str = "cotangent"
    normalization: str = "area"
    components: str = "largest"
    solver: str = "auto"
    weld: bool = True


def mesh_eigenpairs(vertices, faces, settings: SolveSettings, n_eigenpairs, seed, index):
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
    clean = clean_checked(
        unit, faces, components=settings.components, index=index, weld=settings.weld
    )
    points = clean.vertices  # in the unit box: for the factorization's ordering
    L, M = LAPLACIANS[settings.laplacian].value(points, clean.faces)
    clean = replace(clean, vertices=np.ascontiguousarray(vertices[clean.vertex_indices]))
    sizes = f"{len(clean.vertices)} vertices, {len(clean.faces)} faces"
    values, vectors = _eigenpairs(
        L, M, points, settings, n_eigenpairs, seed, index, scale, "mesh", sizes
    )
    return clean, values, vectors


def cloud_eigenpairs(points, settings: SolveSettings, n_eigenpairs, seed, index):
    """Clean one validated point cloud and solve its eigenpairs, as
    :func:`mesh_eigenpairs` does for a mesh.

    The cloud is cleaned by :func:`sklearn_meshph.pointcloud.cleaning.clean_cloud`
    (coincident points merged, one component) and its operator is the point-cloud
    discretization of ``settings.laplacian``, both in the unit box and in a canonical
    point order: a permuted cloud gives the permuted eigenvectors, bit for bit. The
    returned :class:`CleanMesh` has no faces; its vertices are the kept input points,
    in input order. ``normalization="area"`` divides the mass by its sum (the area the
    local triangulations estimate), as for meshes.
    """
    unit, scale = unit_box(points)
    clean, L, M, solve_points, to_output = clean_cloud(
        points,
        unit,
        laplacian=settings.laplacian,
        components=settings.components,
        index=index,
        weld=settings.weld,
    )
    sizes = f"{len(clean.vertices)} points"
    values, vectors = _eigenpairs(
        L, M, solve_points, settings, n_eigenpairs, seed, index, scale, "point cloud", sizes
    )
    return clean, values, np.ascontiguousarray(vectors[to_output])


def _eigenpairs(L, M, points, settings, n_eigenpairs, seed, index, scale, kind, sizes):
    """The eigenpairs of an operator built in the unit box, normalized as asked."""
    if settings.normalization == "area":
        M = M / M.diagonal().sum()
    n_eigenpairs = min(n_eigenpairs, L.shape[0])
    try:
        values, vectors = generalized_eigenpairs(
            L, M, n_eigenpairs, seed=seed, points=points, solver=settings.solver
        )
    except (ValueError, RuntimeError, ArithmeticError) as error:  # ARPACK, the factorization
        raise ValueError(
            f"{where(index)}: the eigensolver failed on the cleaned {kind} ({sizes}): {error}"
        ) from error
    if settings.normalization == "none" and settings.laplacian == "cotangent":
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
