"""The cleaning policy of point clouds: what the eigen stage does before solving.

A change here changes the numbers a solve gives: bump
:data:`sklearn_meshph.spectral.cache.NUMERICS_VERSION` (a test checks).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..mesh.cleaning import CleaningReport, CleanMesh
from ..mesh.graph import connected_components
from ..mesh.validation import where
from ..mesh.welding import WELD_RTOL, weld_vertices
from .graph import canonical_order
from .laplacians import CLOUD_LAPLACIANS
from .validation import MIN_POINTS

__all__ = ["clean_cloud"]


def clean_cloud(points, unit, *, laplacian: str, components: str, index: int | None, weld: bool):
    """Merge coincident points, build the operator, keep one connected component.

    The policy, in order (the analogue of :func:`sklearn_meshph.clean_mesh`):

    0. points are taken in :func:`.graph.canonical_order`, so that a permuted cloud
       gives bit for bit the same operator and eigenpairs, permuted;
    1. coincident points are merged into the first of them in that order: exactly
       equal ones always, and with ``weld=True`` those whose coordinates all differ by
       at most ``1e-10`` times the bounding-box diagonal, as meshes are welded (the
       local triangulations need distinct points). They are not losses: the kept-index
       map sends each to the point it was merged into;
    2. the operator of ``laplacian`` (:data:`.laplacians.CLOUD_LAPLACIANS`) is built on
       the distinct points in the unit box;
    3. points in no local triangle (zero mass: all their neighbours on a line) are
       dropped as unreferenced;
    4. connected components of the operator (clusters farther apart than their
       neighbourhoods): ``components="largest"`` keeps the one of largest mass (area;
       ties: the lowest), ``"error"`` raises.

    Returns ``(clean, L, M, solve_points, to_output)``: ``clean`` a
    :class:`CleanMesh` without faces whose vertices are the kept input points in input
    order, the operator on the kept points in solve (canonical) order, their unit-box
    coordinates, and the permutation taking solve order to output order.
    """
    place = where(index, "point cloud")
    n_input = len(points)
    order = canonical_order(points)
    canonical = unit[order]
    representative = weld_vertices(canonical, WELD_RTOL if weld else 0.0)
    distinct = np.flatnonzero(representative == np.arange(n_input))
    if len(distinct) < MIN_POINTS:
        raise ValueError(
            f"{place}: the point cloud has {len(distinct)} distinct points; at least "
            f"{MIN_POINTS} are needed"
        )
    solve_points = canonical[distinct]
    L, M = CLOUD_LAPLACIANS[laplacian].value(solve_points)
    mass = M.diagonal()
    referenced = mass > 0
    structure = L.tocoo()
    pairs = np.column_stack([structure.row, structure.col]).astype(np.int64)
    _, labels = connected_components(len(distinct), pairs)
    real = np.unique(labels[referenced])
    kept = referenced.copy()
    n_other = 0
    area_share = 0.0
    if len(real) > 1:
        if components == "error":
            raise ValueError(
                f"{place}: the point cloud's operator has {len(real)} connected components "
                "(clusters of points farther apart than their neighbourhoods); pass "
                "components='largest' to keep the one of largest area"
            )
        area = np.bincount(labels, weights=mass)
        largest = int(np.argmax(area))
        kept &= labels == largest
        n_other = len(real) - 1
        area_share = max(1.0 - float(area[largest]) / float(area.sum()), 0.0)
    n_kept = int(np.count_nonzero(kept))
    if not kept.all():
        L = L[kept][:, kept].tocsr()
        M = sp.diags(mass[kept])
        solve_points = solve_points[kept]

    # Back to input order: each kept point is named by its input index.
    inputs = order[distinct[kept]]
    to_output = np.argsort(inputs, kind="stable")
    vertex_indices = inputs[to_output]
    output_of_solve = np.empty(n_kept, dtype=np.int64)
    output_of_solve[to_output] = np.arange(n_kept)
    output_of_distinct = np.full(len(distinct), -1, dtype=np.int64)
    output_of_distinct[np.flatnonzero(kept)] = output_of_solve
    input_to_kept = np.empty(n_input, dtype=np.int64)
    input_to_kept[order] = output_of_distinct[np.searchsorted(distinct, representative)]

    n_unreferenced = int(np.count_nonzero(~referenced))
    report = CleaningReport(
        n_input_vertices=n_input,
        n_welded=n_input - len(distinct),
        n_degenerate_faces=0,
        n_repeated_faces=0,
        n_unreferenced_vertices=n_unreferenced,
        n_other_components=n_other,
        n_component_vertices=len(distinct) - n_unreferenced - n_kept,
        n_component_faces=0,
        vertex_share=(len(distinct) - n_kept) / len(distinct),
        area_share=area_share,
    )
    clean = CleanMesh(
        vertices=np.ascontiguousarray(points[vertex_indices]),
        faces=np.empty((0, 3), dtype=np.int64),
        vertex_indices=vertex_indices,
        input_to_kept=input_to_kept,
        report=report,
    )
    return clean, L, M, solve_points, to_output
