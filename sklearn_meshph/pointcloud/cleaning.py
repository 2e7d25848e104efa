"""The cleaning policy of point clouds: what the eigen stage does before solving.

A change here changes the numbers a solve gives: bump
:data:`sklearn_meshph.spectral.cache.NUMERICS_VERSION` (a test checks).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..mesh import DEGENERATE_SINE
from ..mesh.cleaning import CleaningReport, CleanMesh
from ..mesh.graph import connected_components
from ..mesh.validation import where
from ..mesh.welding import WELD_RTOL, exact_representatives, weld_groups
from ._triangulation import LOCAL_NEIGHBORS, nearest, nearest_within
from .graph import (
    canonical_order,
    neighbourhood_components,
    sparse_outliers,
    unique_edges,
    within_fences,
)
from .laplacians import CLOUD_LAPLACIANS
from .validation import MIN_POINTS

__all__ = ["clean_cloud"]


def _refuse_few(n_distinct: int, place: str) -> None:
    """A ``ValueError`` naming the sample when fewer than ``MIN_POINTS`` are distinct."""
    if n_distinct < MIN_POINTS:
        raise ValueError(
            f"{place}: the point cloud has {n_distinct} distinct points; at least "
            f"{MIN_POINTS} are needed"
        )


def _refuse_degenerate(points: np.ndarray, place: str) -> None:
    """A ``ValueError`` naming the sample when the distinct points lie on one line."""
    spread = np.linalg.svd(points - points.mean(axis=0), compute_uv=False)
    if spread[1] <= DEGENERATE_SINE * spread[0]:
        raise ValueError(
            f"{place}: the point cloud is degenerate: its {len(points)} distinct points "
            "lie on one line, which bounds no surface"
        )


#: Points closer than this times the cloud's reach (the median distance from a point to
#: its ``REACH_NEIGHBOR``-th nearest other point: twins do not shrink it much) are one
#: point, as coincident ones are. A cloud with its own copy rounded to float32 or to 6
#: decimals appended has a twin within 1e-6 spacings of every point: the local
#: triangulations around twins disagree, lose 9% of the area, and the eigenvalues came
#: out 13% low. A uniform sample has a pair that close about once in 100,000 points.
NEAR_DUPLICATE = 1e-3
REACH_NEIGHBOR = 8


def _weld_rtol(points: np.ndarray, distances: np.ndarray) -> float:
    """The welding tolerance of a cloud, as a fraction of its box's diagonal: the
    larger of :func:`_surface_rtol` and ``NEAR_DUPLICATE`` reaches. ``distances``:
    :func:`._triangulation.nearest`'s distances among the distinct ``points`` (exact
    duplicates are welded anyway), at least ``REACH_NEIGHBOR`` columns for a reach."""
    rtol = _surface_rtol(points)
    if distances.shape[1] >= REACH_NEIGHBOR:
        reach = float(np.median(distances[:, REACH_NEIGHBOR - 1]))
        diagonal = float(np.linalg.norm(points.max(axis=0) - points.min(axis=0)))
        rtol = max(rtol, NEAR_DUPLICATE * reach / diagonal)
    return rtol


def _surface_rtol(points: np.ndarray) -> float:
    """``WELD_RTOL`` of the surface's extent, as a fraction of the whole box's diagonal.

    Far points have not been dropped yet when points are welded: one outlier at 1e9
    times the shape's size would make the whole box's diagonal, and the tolerance, large
    enough to weld the surface into a few points. The surface's extent is taken as
    twice the diagonal of the box between the coordinates' quartiles (which outliers
    barely move), when that is smaller than the whole box's.
    """
    low, high = points.min(axis=0), points.max(axis=0)
    diagonal = float(np.linalg.norm(high - low))
    quartiles = np.percentile(points, [25, 75], axis=0)
    extent = 2.0 * float(np.linalg.norm(quartiles[1] - quartiles[0]))
    if not (0 < extent < diagonal):
        return WELD_RTOL
    return WELD_RTOL * extent / diagonal


def _largest(labels: np.ndarray, area: np.ndarray, size=None) -> tuple[np.ndarray, int, float]:
    """The mask of the component of largest ``area`` (ties: the lowest label), or with
    ``size`` (points per component) of most points (ties: the largest area, then the
    lowest label); the number of other components and their share of the area."""
    if size is None:
        largest = int(np.argmax(area))
    else:
        largest = int(np.lexsort((np.arange(len(area)), -area, -size))[0])
    total = float(area.sum())
    share = 1.0 - float(area[largest]) / total if total > 0 else 0.0
    return labels == largest, len(area) - 1, max(share, 0.0)


def _far_components(points, knn, laplacian, components, place):
    """Drop the points far from the rest (:func:`.graph.neighbourhood_components`): the
    component of most points is kept (not of largest area: a scatter of stray points
    spans more area than the dense surface it surrounds), its operator built without
    the others; then the
    outliers of that component (:func:`.graph.sparse_outliers`), each a component of its
    own. ``knn``: the points' ``LOCAL_NEIGHBORS`` nearest. Returns
    ``(kept, L, M, triangles, n_other, share)``."""
    # One neighbour search serves every step: where points are dropped, only the points
    # that lose a neighbour are searched again.
    n_components, labels = neighbourhood_components(points, knn)
    build = CLOUD_LAPLACIANS[laplacian].value
    kept, operator, n_other = np.ones(len(points), dtype=bool), None, 0
    if n_components > 1:
        if components == "error":
            raise ValueError(
                f"{place}: the point cloud has {n_components} connected components (points "
                "far from each other for the cloud's sampling); pass components='largest' "
                "to keep the one of most points"
            )
        operators, area = {}, np.zeros(n_components)
        for label in range(n_components):
            members = labels == label
            if np.count_nonzero(members) >= MIN_POINTS:
                within = nearest_within(points, knn, members, LOCAL_NEIGHBORS)
                operators[label] = build(points[members], knn=within)
                area[label] = operators[label][1].diagonal().sum()
        if not operators:
            raise ValueError(
                f"{place}: the point cloud falls apart into {n_components} groups of fewer "
                f"than {MIN_POINTS} points far from each other"
            )
        size = np.bincount(labels)
        kept, n_other, _ = _largest(labels, area, size)
        largest = int(labels[np.argmax(kept)])
        operator = operators[largest]
    knn = knn if kept.all() else nearest_within(points, knn, kept, LOCAL_NEIGHBORS)
    alone = sparse_outliers(points[kept], knn)  # a mask over the kept points
    outliers = np.flatnonzero(kept)[alone]
    if len(outliers):
        if components == "error":
            raise ValueError(
                f"{place}: the point cloud has {len(outliers)} outliers (points off the "
                "surface for the sampling around them); pass components='largest' to drop "
                "them"
            )
        knn = nearest_within(points[kept], knn, ~alone, LOCAL_NEIGHBORS)
        kept[outliers] = False
        operator, n_other = None, n_other + len(outliers)
    if operator is None:
        operator = build(points[kept], knn=knn)
    # The dropped points' area at the kept surface's sampling: a far component's own
    # area at most its points' worth of the kept area per point (a scatter of stray
    # points spans more area than the whole shape: it is not that much surface), one
    # too small for an operator and an outlier their points' worth.
    kept_area = float(operator[1].diagonal().sum())
    per_point = kept_area / np.count_nonzero(kept)
    dropped = per_point * len(outliers)
    if n_components > 1:
        worth = size * per_point
        own = np.where(size >= MIN_POINTS, np.minimum(area, worth), worth)
        dropped += float(own[np.arange(n_components) != largest].sum())
    share = dropped / (kept_area + dropped) if kept_area + dropped > 0 else 0.0
    return kept, *operator, n_other, float(share)


def _edges(triangles: np.ndarray, renumber: np.ndarray) -> np.ndarray:
    """The edges ``(m, 2)`` (``a < b``, sorted, each once) of ``triangles`` renumbered by
    ``renumber`` (-1: a dropped point, whose triangles are left out)."""
    corners = renumber[triangles]
    corners = corners[(corners >= 0).all(axis=1)]
    a = corners[:, [0, 1, 2]].ravel()
    b = corners[:, [1, 2, 0]].ravel()
    return unique_edges(a, b, int(renumber.max()) + 1)


def clean_cloud(
    points,
    unit,
    *,
    laplacian: str,
    components: str,
    index: int | None,
    weld: bool,
    unresolved=None,
):
    """Merge coincident points, drop far ones, build the operator, keep one component.

    The policy, in order (the analogue of :func:`sklearn_meshph.clean_mesh`):

    0. points are taken in :func:`.graph.canonical_order`, so that a permuted cloud
       gives bit for bit the same operator and eigenpairs, permuted;
    1. coincident points are merged into the first of them in that order: exactly
       equal ones always, and with ``weld=True`` those whose coordinates all differ by
       at most :data:`sklearn_meshph.mesh.welding.WELD_RTOL` times the bounding-box
       diagonal, as meshes are welded, or by ``NEAR_DUPLICATE`` times the cloud's reach
       (the local triangulations need distinct points, and twins make them disagree).
       They are not losses: the kept-index map sends each to the point it was merged
       into. Fewer than ``MIN_POINTS`` distinct points, or distinct points all on one
       line, are refused (a ``ValueError`` naming the sample);
    2. points far from the rest for the cloud's own sampling (a stray point, a small
       far cluster: :func:`.graph.neighbourhood_components`) are other components, as
       a mesh's: ``components="largest"`` keeps the one of most points (ties: the
       largest area, the mass of its own operator; then the lowest), ``"error"``
       raises; so are, each alone, the
       outliers of the kept points (points off the surface for the sampling around
       them, nearer than the far ones: :func:`.graph.sparse_outliers`);
    3. the operator of ``laplacian`` (:data:`.laplacians.CLOUD_LAPLACIANS`) is built on
       the kept points in the unit box;
    4. points in no local triangle (their neighbours on their own sheet too few or on
       a line; zero mass for the cotangent operator) are dropped as unreferenced,
       whatever the operator;
    5. connected components of the complex (clusters that no local triangle joins)
       follow ``components`` as in step 2. A graph operator is then built again on the
       points kept (restricted to some of its nodes, a graph Laplacian is not theirs).

    ``unresolved``: :func:`.graph.cloud_unit_box`'s mask of the points its ``unit``
    box cannot resolve, counted in the report (``n_unresolved_points``, always warned
    about).

    Returns ``(clean, L, M, solve_points, to_output)``: ``clean`` a
    :class:`CleanMesh` without faces whose vertices are the kept input points in input
    order and whose ``edges`` are the cloud's persistence complex (the edges of the
    local triangles the operator was built from, between kept points), the operator
    on the kept points in solve (canonical) order, their unit-box coordinates, and the
    permutation taking solve order to output order.
    """
    place = where(index, "point cloud")
    n_input = len(points)
    order = canonical_order(points)
    canonical = unit[order]
    # One neighbour search among the distinct points serves the welding tolerance and
    # every later step (where welding merges more, only the points that lose a
    # neighbour are searched again).
    exact = exact_representatives(canonical)
    distinct = np.flatnonzero(exact[0] == np.arange(n_input))
    _refuse_few(len(distinct), place)
    knn = nearest(canonical[distinct], LOCAL_NEIGHBORS)
    rtol = _weld_rtol(canonical, knn[0]) if weld else 0.0
    representative = weld_groups(canonical, exact, rtol)
    still = representative[distinct] == distinct
    if not still.all():
        knn = nearest_within(canonical[distinct], knn, still, LOCAL_NEIGHBORS)
        distinct = distinct[still]
        _refuse_few(len(distinct), place)
    _refuse_degenerate(within_fences(canonical[distinct]), place)
    near, L, M, triangles, n_far, far_share = _far_components(
        canonical[distinct], knn, laplacian, components, place
    )
    solve_points = canonical[distinct[near]]
    mass = M.diagonal()
    # A point in no local triangle is on no surface: the complex leaves it alone (and a
    # graph Laplacian, whose mass is 1 everywhere, would keep it).
    in_triangle = np.zeros(len(solve_points), dtype=bool)
    in_triangle[triangles.ravel()] = True
    referenced = (mass > 0) & in_triangle
    if np.count_nonzero(referenced) < MIN_POINTS:
        raise ValueError(
            f"{place}: the point cloud is degenerate: fewer than {MIN_POINTS} of its "
            "points are in a local triangle (their neighbourhoods lie on lines)"
        )
    # The components of the complex (for the cotangent operator, those of its
    # couplings: the same edges); a graph operator may join what no triangle joins.
    rebuild = getattr(CLOUD_LAPLACIANS[laplacian].value, "build", None)
    if rebuild is None:
        structure = L.tocoo()
        pairs = np.column_stack([structure.row, structure.col]).astype(np.int64)
    else:
        pairs = _edges(triangles, np.arange(len(solve_points)))
    _, labels = connected_components(len(solve_points), pairs)
    real = np.unique(labels[referenced])
    kept = referenced.copy()
    n_other, area_share = 0, 0.0
    if len(real) > 1:
        if components == "error":
            raise ValueError(
                f"{place}: the point cloud's operator has {len(real)} connected components "
                "(clusters of points that no local triangle joins); pass "
                "components='largest' to keep the one of largest area"
            )
        in_largest, n_other, area_share = _largest(labels, np.bincount(labels, weights=mass))
        kept &= in_largest
    # The shares of both steps, over the area of the points the far ones were cut from.
    area_share = far_share + (1.0 - far_share) * area_share
    n_kept = int(np.count_nonzero(kept))
    if not kept.all():
        solve_points = solve_points[kept]
        if rebuild is None:
            L = L[kept][:, kept].tocsr()
            M = sp.diags(mass[kept])
        else:
            L, M = rebuild(solve_points)
    kept_distinct = np.flatnonzero(near)[kept]  # positions among the distinct points

    # Back to input order: each kept point is named by its input index.
    inputs = order[distinct[kept_distinct]]
    to_output = np.argsort(inputs, kind="stable")
    vertex_indices = inputs[to_output]
    output_of_solve = np.empty(n_kept, dtype=np.int64)
    output_of_solve[to_output] = np.arange(n_kept)
    output_of_distinct = np.full(len(distinct), -1, dtype=np.int64)
    output_of_distinct[kept_distinct] = output_of_solve
    input_to_kept = np.empty(n_input, dtype=np.int64)
    input_to_kept[order] = output_of_distinct[np.searchsorted(distinct, representative)]

    # The complex: the edges of the operator's triangles between kept points, numbered
    # as the output (the triangles are numbered as the points the operator was built on).
    output_of_built = np.full(len(referenced), -1, dtype=np.int64)
    output_of_built[kept] = output_of_solve
    edges = _edges(triangles, output_of_built)

    n_unreferenced = int(np.count_nonzero(~referenced))
    # Points merged into a far point are far points too, not welded ones (far points
    # clipped to the same coordinates, or a stray point listed twice).
    far = np.flatnonzero(~near)
    n_far_inputs = int(np.count_nonzero(np.isin(representative, distinct[far])))
    n_far_merged = n_far_inputs - len(far)
    n_vertices = len(distinct) + n_far_merged  # after welding
    report = CleaningReport(
        n_input_vertices=n_input,
        n_welded=n_input - n_vertices,
        n_degenerate_faces=0,
        n_repeated_faces=0,
        n_unreferenced_vertices=n_unreferenced,
        n_other_components=n_far + n_other,
        n_component_vertices=n_vertices - n_unreferenced - n_kept,
        n_component_faces=0,
        vertex_share=(n_vertices - n_kept) / n_vertices,
        area_share=area_share,
        n_far_points=n_far_inputs,
        n_unresolved_points=0 if unresolved is None else int(np.count_nonzero(unresolved)),
    )
    clean = CleanMesh(
        vertices=np.ascontiguousarray(points[vertex_indices]),
        faces=np.empty((0, 3), dtype=np.int64),
        vertex_indices=vertex_indices,
        input_to_kept=input_to_kept,
        report=report,
        edges=edges,
    )
    return clean, L, M, solve_points, to_output
