"""One sample's cleaning and eigensolve, mesh, point cloud or graph: the unit of work the
eigen cache stores.

A change here changes the numbers a solve gives: bump
:data:`sklearn_meshph.spectral.cache.NUMERICS_VERSION` (a test checks).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, replace

import numpy as np

from ..graph.validation import Graph
from ..mesh import unit_box
from ..mesh.cleaning import CleaningReport, CleanMesh, MeshCleaningWarning, clean_checked
from ..mesh.graph import connected_components
from ..mesh.validation import where
from ..pointcloud.cleaning import clean_cloud
from ..pointcloud.graph import cloud_unit_box
from .eigensolver import COMPONENTS, DENSE_MAX_NODES, DENSE_MAX_VERTICES, generalized_eigenpairs
from .laplacians import GRAPH_LAPLACIANS, LAPLACIANS

__all__ = [
    "COMPONENTS",
    "SolveSettings",
    "cloud_eigenpairs",
    "graph_components",
    "graph_eigenpairs",
    "kept_edges",
    "mesh_eigenpairs",
    "refuse_all_components",
    "warn_graph_components",
]


@dataclass(frozen=True)
class SolveSettings:
    """What a solve depends on besides the sample, the number of eigenpairs and the
    seed: the parameters of :class:`LaplacianEigenTransformer` of the same names."""

    laplacian: str = "cotangent"
    normalization: str = "area"
    components: str = "largest"
    solver: str = "auto"
    weld: bool = True


def mesh_eigenpairs(
    vertices, faces, settings: SolveSettings, n_eigenpairs, seed, index, *, exact=False
):
    """Clean one validated mesh and solve its eigenpairs: the unit ``memory`` caches.

    The cache key is the input mesh's content and the settings (``index``, the sample's
    position, is ignored), so a hit skips the cleaning too. With
    ``normalization="area"`` the cotangent mass matrix is divided by the total area (the
    mesh scaled to unit area) and the graph Laplacian gets ``M = I / n``, so that
    eigenvectors have unit mean square whatever the scale and the vertex count.
    """
    refuse_all_components(settings.components, index, "mesh")
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
        L, M, points, settings, n_eigenpairs, seed, index, scale, "mesh", sizes, exact=exact
    )
    return clean, values, vectors


def cloud_eigenpairs(points, settings: SolveSettings, n_eigenpairs, seed, index, *, exact=False):
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
    refuse_all_components(settings.components, index, "point cloud")
    unit, scale, unresolved = cloud_unit_box(points)
    clean, L, M, solve_points, to_output = clean_cloud(
        points,
        unit,
        unresolved=unresolved,
        laplacian=settings.laplacian,
        components=settings.components,
        index=index,
        weld=settings.weld,
    )
    sizes = f"{len(clean.vertices)} points"
    values, vectors = _eigenpairs(
        L,
        M,
        solve_points,
        settings,
        n_eigenpairs,
        seed,
        index,
        scale,
        "point cloud",
        sizes,
        exact=exact,
    )
    return clean, values, np.ascontiguousarray(vectors[to_output])


def refuse_all_components(components: str, index, kind: str) -> None:
    """``components="all"`` is for graphs: a ``ValueError`` for a mesh or a cloud."""
    if components == "all":
        raise ValueError(
            f"{where(index, kind)}: components='all' keeps every connected component of a "
            f"graph; a {kind} takes components='largest' or 'error'"
        )


def kept_edges(graph: Graph, input_to_kept: np.ndarray) -> np.ndarray:
    """The edges of ``graph`` between kept nodes, renumbered by ``input_to_kept`` (-1 for
    a dropped node): still each once, ``i < j``, rows sorted, since kept nodes keep
    their order."""
    ends = input_to_kept[graph.edges]
    return np.ascontiguousarray(ends[(ends >= 0).all(axis=1)])


def warn_graph_components(report: CleaningReport, place: str, stacklevel: int) -> None:
    """A :class:`MeshCleaningWarning` when ``components="largest"`` dropped more than
    ``LOSS_THRESHOLD`` of a graph's nodes or edge weight, saying what was dropped."""
    if report.significant:
        warnings.warn(
            f"{place}: components='largest' dropped {report.n_other_components} other "
            f"components of the graph: {report.n_component_vertices} of its "
            f"{report.n_input_vertices} nodes ({100 * report.vertex_share:.3g}%) and "
            f"{100 * report.area_share:.3g}% of its edge weight; components='all' keeps "
            "every component",
            MeshCleaningWarning,
            stacklevel=stacklevel + 1,
        )


def graph_components(graph: Graph, components: str, index) -> tuple[Graph, CleanMesh]:
    """The part of ``graph`` that ``components`` keeps, and its :class:`CleanMesh`.

    ``"all"`` keeps the graph whole; ``"largest"`` the component of most nodes (ties:
    the one holding the lowest node), an isolated node being a component of its own;
    ``"error"`` raises for several components. The clean sample has nodes without
    coordinates (``vertices`` of shape ``(n_kept, 0)``) and no faces; its report counts
    the dropped components and nodes, and, as ``area_share``, the share of the total
    edge weight dropped (a graph has no area).
    """
    n = graph.n_nodes
    n_components, labels = connected_components(n, graph.edges)
    keep = np.ones(n, dtype=bool)
    weight_share = 0.0
    if n_components > 1 and components == "error":
        isolated = n - len(np.unique(graph.edges))
        raise ValueError(
            f"{where(index, 'graph')}: the graph has {n_components} connected components "
            f"({isolated} of them isolated nodes); pass components='largest' to keep the "
            "one of most nodes, or components='all' to keep them all"
        )
    if n_components > 1 and components == "largest":
        keep = labels == np.argmax(np.bincount(labels))  # labels follow the lowest nodes
        if graph.n_edges:  # relative to the largest weight: no overflow in the sums
            scaled = graph.weights / graph.weights.max()
            weight_share = 1.0 - scaled[keep[graph.edges[:, 0]]].sum() / scaled.sum()
    vertex_indices = np.flatnonzero(keep)
    input_to_kept = np.full(n, -1, dtype=np.int64)
    input_to_kept[vertex_indices] = np.arange(len(vertex_indices))
    on_kept = keep[graph.edges[:, 0]]
    kept = Graph(
        len(vertex_indices),
        kept_edges(graph, input_to_kept),
        graph.weights[on_kept],
        None if graph.node_values is None else graph.node_values[keep],
    )
    dropped = n - kept.n_nodes
    report = CleaningReport(
        n_input_vertices=n,
        n_welded=0,
        n_degenerate_faces=0,
        n_repeated_faces=0,
        n_unreferenced_vertices=0,
        n_other_components=n_components - 1 if dropped else 0,
        n_component_vertices=dropped,
        n_component_faces=0,
        vertex_share=dropped / n,
        area_share=max(float(weight_share), 0.0),
    )
    clean = CleanMesh(
        vertices=np.zeros((kept.n_nodes, 0)),
        faces=np.empty((0, 3), dtype=np.int64),
        vertex_indices=vertex_indices,
        input_to_kept=input_to_kept,
        report=report,
    )
    return kept, clean


def graph_eigenpairs(
    graph: Graph, settings: SolveSettings, n_eigenpairs, seed, index, *, exact=False
):
    """Keep the components of one validated graph that ``settings.components`` says and
    solve its eigenpairs, as :func:`mesh_eigenpairs` does for a mesh.

    The operator is the graph discretization of ``settings.laplacian``
    (:data:`.laplacians.GRAPH_LAPLACIANS`) on the kept graph's edge weights; a
    Laplacian of surfaces (``"cotangent"``) is a ``ValueError`` naming the sample.
    ``normalization="area"`` divides the mass by its sum, as for a mesh's graph
    Laplacian (``M = I / n`` for ``"graph"`` and ``"normalized"``, ``D / vol`` for
    ``"random_walk"``: eigenvectors of unit mean square, eigenvalues multiplied by the
    mass's sum); ``"none"`` keeps the plain operator (unit-norm eigenvectors of
    ``"normalized"``, eigenvalues in ``[0, 2]``, as PersLay). Operators of at most
    :data:`.eigensolver.DENSE_MAX_NODES` nodes are solved densely under
    ``solver="auto"``. Returns ``(clean, values, vectors)``, ``clean`` as
    :func:`graph_components` makes it.
    """
    if settings.laplacian not in GRAPH_LAPLACIANS:
        raise ValueError(
            f"{where(index, 'graph')}: the {settings.laplacian!r} Laplacian is a surface's (a "
            f"mesh's or a point cloud's); a graph takes laplacian="
            + ", ".join(repr(name) for name in GRAPH_LAPLACIANS.names)
        )
    kept, clean = graph_components(graph, settings.components, index)
    # Twice the total weight bounds every degree, their sum and the largest eigenvalue
    # of "graph": finite, so is everything the operators and the solve compute.
    with np.errstate(over="ignore"):
        volume = 2.0 * kept.weights.sum()
    if not np.isfinite(volume):
        raise ValueError(
            f"{where(index, 'graph')}: the graph's edge weights sum beyond float64's range; "
            "scale them down"
        )
    L, M = GRAPH_LAPLACIANS[settings.laplacian].value(kept)
    sizes = f"{kept.n_nodes} nodes, {kept.n_edges} edges"
    values, vectors = _eigenpairs(
        L,
        M,
        None,
        settings,
        n_eigenpairs,
        seed,
        index,
        1.0,
        "graph",
        sizes,
        DENSE_MAX_NODES,
        exact=exact,
    )
    return clean, values, vectors


#: What the rows of each kind of sample are, in messages.
_ROWS = {"mesh": "vertices", "point cloud": "points", "graph": "nodes"}


def _eigenpairs(
    L,
    M,
    points,
    settings,
    n_eigenpairs,
    seed,
    index,
    scale,
    kind,
    sizes,
    dense_max=None,
    *,
    exact=False,
):
    """The eigenpairs of an operator built in the unit box, normalized as asked: as many
    as asked, or all of them where the cleaned sample has fewer rows (with ``exact``,
    that is a ``ValueError`` before anything is solved)."""
    if exact and n_eigenpairs > L.shape[0]:
        raise ValueError(
            f"n_eigenpairs must be between 1 and {L.shape[0]} (the kept {_ROWS[kind]}), "
            f"got {n_eigenpairs}"
        )
    if settings.normalization == "area":
        M = M / M.diagonal().sum()
    n_eigenpairs = min(n_eigenpairs, L.shape[0])
    try:
        values, vectors = generalized_eigenpairs(
            L,
            M,
            n_eigenpairs,
            seed=seed,
            points=points,
            solver=settings.solver,
            dense_max=DENSE_MAX_VERTICES if dense_max is None else dense_max,
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
                "normalization='area' (LaplacianEigenTransformer's default), which gives "
                "the same functions at any scale"
            )
    return values, vectors
