"""LowerStarPersistence: vertex functions on meshes, point clouds and graphs to
persistence diagrams."""

from __future__ import annotations

from functools import partial
from numbers import Integral, Real

import numpy as np

from .._base import ObjectOutput, SampleTransformer
from .._param_validation import N_JOBS, Interval, Options
from .._progress import map_samples, sample_blocks
from ..graph.validation import Graph
from ..inputs import check_input
from ..mesh.graph import mesh_edges
from ..mesh.scalar_field import ScalarField
from ..mesh.validation import check_values, where
from ..pointcloud.graph import edge_adjacency, surface_graph
from .extended import closed_surface
from .filtrations import ESSENTIAL_POLICIES, FILTRATIONS, function_diagrams
from .graph_extended import GraphCycles, batch_diagrams, check_cycle_table

__all__ = ["LowerStarPersistence"]


def _sample_arrays(sample, index):
    """Faces, extra edges, vertex count and values of a sample, validated once, and
    whether it is a graph: a ScalarField was validated when it was made, a ``(mesh,
    values)`` pair is validated here (a point cloud gets the edges of its local
    triangles, a graph its own edges)."""
    if isinstance(sample, ScalarField):
        return sample.faces, sample.edges, sample.n_vertices, sample.values, sample.is_graph
    if isinstance(sample, tuple | list) and len(sample) == 2:
        mesh, values = sample
        first, faces = (mesh, None) if isinstance(mesh, Graph) else check_input(mesh, index=index)
        if isinstance(first, Graph):
            values = check_values(values, first.n_nodes, where(index))
            return np.empty((0, 3), dtype=np.int64), first.edges, first.n_nodes, values, True
        values = check_values(values, len(first), where(index))
        if faces is None:
            edges = surface_graph(first, where(index, "point cloud"))
            return np.empty((0, 3), dtype=np.int64), edges, len(first), values, False
        return faces, None, len(first), values, False
    raise TypeError(
        f"sample {index}: expected a ScalarField or a (mesh, values) pair, "
        f"got {type(sample).__name__}"
    )


def _complex_adjacency(faces, edges, n_vertices):
    """The vertex adjacency of the edges of ``faces`` and of ``edges`` (when not None)."""
    if edges is None:
        return mesh_edges(faces, n_vertices)
    if len(faces):
        pairs = np.vstack([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]], edges])
        return edge_adjacency(pairs, n_vertices)
    return edge_adjacency(edges, n_vertices)


def _graph_edges(edges):
    return np.empty((0, 2), dtype=np.int64) if edges is None else edges


def _complex(arrays, entry, keep):
    """Adjacency and closed surface (``surface`` of :func:`function_diagrams`) of a
    sample's arrays. Essential H1 of a mesh needs a closed surface of triangles; a point
    cloud has none (the cycles of its local triangles' edges are artefacts of the
    sampling), a graph's cycles go through :func:`.graph_extended.batch_diagrams`."""
    faces, edges, n_vertices, _, is_graph = arrays
    if is_graph:
        return edge_adjacency(_graph_edges(edges), n_vertices), None
    adjacency = _complex_adjacency(faces, edges, n_vertices)
    needs_surface = set(entry.surface_diagrams) & set(keep)
    surface = closed_surface(faces, adjacency) if needs_surface and edges is None else None
    return adjacency, surface


def _per_sample(per_function, keep):
    """One sample's output from the diagrams of each of its functions."""
    diagrams = [diagram[k] for diagram in per_function for k in keep]
    return diagrams[0] if len(diagrams) == 1 else tuple(diagrams)


def _diagrams_of(arrays, *, filtration, essential, min_persistence, keep):
    adjacency, surface = _complex(arrays, FILTRATIONS[filtration].value, keep)
    per_function = [
        function_diagrams(
            adjacency,
            np.ascontiguousarray(column),
            filtration=filtration,
            essential=essential,
            min_persistence=min_persistence,
            surface=surface,
            wanted=keep,
        )
        for column in ScalarField.columns_of(arrays[3])
    ]
    return _per_sample(per_function, keep)


def _diagrams_one(item, **options):
    index, sample = item
    return _diagrams_of(_sample_arrays(sample, index), **options)


def _diagrams_block(block, **options):
    """The diagrams of a block ``(start, samples)``: those of graphs, under a filtration
    computed from the graph alone (``"extended"``), in one compiled call; the others
    one by one."""
    start, samples = block
    out, graphs, positions = [], [], []
    for index, sample in enumerate(samples, start):
        arrays = _sample_arrays(sample, index)
        _, edges, n_vertices, values, is_graph = arrays
        if is_graph:
            edges = _graph_edges(edges)
            check_cycle_table(n_vertices, edges, f"sample {index}")
            graphs.append((GraphCycles(n_vertices, edges), values))
            positions.append(len(out))
            out.append(None)
        else:
            out.append(_diagrams_of(arrays, **options))
    batch = batch_diagrams(graphs, options["min_persistence"], lower_first=True)
    for position, per_function in zip(positions, batch, strict=True):
        out[position] = _per_sample(per_function, options["keep"])
    return out


class LowerStarPersistence(ObjectOutput, SampleTransformer, auto_wrap_output_keys=None):
    """Persistence diagrams of the lower-star filtrations of vertex functions.

    The second stage of the mesh-learning pipeline: each sample, a :class:`ScalarField`
    or a ``(mesh, values)`` pair, becomes its persistence diagram(s), computed exactly
    in float64 by union-find over the vertices in value order (elder rule, ties broken by
    vertex index), the edge adjacency built once per mesh and shared by its functions.
    On a point cloud (a field without faces, or a ``(points, values)`` pair) the complex
    is the edges of the local triangles its operator is made of (``ScalarField.edges``,
    :func:`~sklearn_meshph.pointcloud.graph.surface_graph`): every H0 diagram is
    computed on it exactly as on a mesh's edges, and the essential H1 diagram of
    ``"extended"`` is empty (that graph's cycles come from the sampling, not from the
    surface). On a graph (a field with ``is_graph``, or a ``(graph,
    values)`` pair) the complex is the graph's nodes and edges, and ``"extended"``
    gives all of its extended persistence, the cycles included (see Notes).

    Parameters
    ----------
    filtration : {"symmetric", "sublevel", "superlevel", "extended"}, default="symmetric"
        What each function ``f`` contributes (``ess`` are the pairs
        ``(min, max)`` of ``f`` over each connected component):

        - ``"symmetric"`` (default): two diagrams, ``H0(f) + H0(-f)`` (the finite
          sublevel pairs of ``f`` and of ``-f``, each in its own function's values,
          merged into one diagram) and ``ess + R(ess)`` with the reflection
          ``R(b, d) = (-d, -b)``. Replacing ``f`` by ``-f`` gives exactly the same
          diagrams: the output does not depend on the eigenvector's sign.
        - ``"sublevel"``: one diagram, the sublevel H0 of ``f`` with its essential
          classes treated by ``essential``: the paper's setting [1]_.
        - ``"superlevel"``: the same for ``-f`` (superlevel sets of ``f``, reported
          as the sublevel pairs of ``-f``).
        - ``"extended"``: four diagrams, the finite sublevel pairs of ``f``
          (``Ord0``), the finite superlevel pairs of ``f`` as ``R`` of those of ``-f``
          (pairs ``(saddle, max)``; ``Ord1`` on a closed surface), ``ess``
          (``Ext0``) and, on a closed surface (every edge in exactly two triangles),
          the essential H1 pairs with birth below death (``Ext1+``; empty on other
          meshes and on point clouds), on a graph one pair ``(min, max)`` per
          independent cycle. For ``-f`` the four become ``R`` of the second, ``R`` of
          the first, ``R`` of the third and ``R`` of the fourth.
    essential : {"keep", "drop", "max"}, default="keep"
        Essential classes of ``"sublevel"`` and ``"superlevel"`` (one per component):
        kept with death ``inf``, dropped, or closed at the component's maximum (the
        extended pairing). Distances match infinite points only among themselves.
    min_persistence : float, default=0.0
        Pairs with ``death - birth <= min_persistence`` are dropped (zero-persistence
        pairs always are).
    parts : tuple of str, default=None
        Keep only these diagrams of each function (``None``: all), by short id or by
        the name :meth:`diagram_names` gives for one function: ``"ord0"``, ``"ord1"``,
        ``"ext0"`` and ``"ext1"`` for ``"extended"`` (ordinary H0, superlevel
        ``(saddle, max)`` pairs, components' ``(min, max)``, essential H1), ``"h0"`` and
        ``"ext0"`` for ``"symmetric"``, ``"h0"`` for ``"sublevel"`` and
        ``"superlevel"``. For example ``filtration="extended", parts=("ord1", "ext1")``
        drops the ordinary H0 pairs and the components' ranges; several
        ``LowerStarPersistence`` with different parts, in a :class:`CombinedDistance`,
        weigh each kind of diagram on its own. Diagrams keep the filtration's order.
    n_jobs : int, default=None
        Samples processed in parallel. ``None`` means 1 unless in a
        :func:`joblib.parallel_backend` context; ``-1`` means all processors.
    verbose : int, default=0
        With ``verbose > 0``, a progress bar over the samples on stderr (needs tqdm,
        the ``progress`` extra); nothing is printed at 0.

    See Also
    --------
    lower_star_persistence : The H0 diagram of one function.
    extended_persistence : The four diagrams of one function on a graph, gudhi's way.
    DiagramDistance : The next stage: distances between diagrams.

    Notes
    -----
    Output per sample: one function and one diagram (``"sublevel"``/``"superlevel"``)
    gives an ``(n, 2)`` float64 array; otherwise a tuple of arrays, function-major: for
    ``ScalarField.values`` of shape ``(n, k)`` and ``"symmetric"``, the tuple is
    ``(H0_1, ess_1, ..., H0_k, ess_k)``. :class:`DiagramDistance` compares tuples
    position by position.

    Extended persistence [2]_ on a closed surface: the ordinary H1 pairs of ``f`` are
    exactly the ``(saddle, max)`` pairs (EP symmetry: ``Ord1(f) = R(Ord0(-f))``), and
    the remaining diagrams are transposes of those returned (duality: ``Rel2``,
    ``Rel1``, ``Ext2`` and ``Ext1-``), so ``"extended"`` holds all of it. ``Ext1`` (the
    ``2g`` essential H1 classes of a genus-``g`` surface) is computed exactly over Z/2
    from a tree-cotree decomposition (intersection numbers with dual loops) and the
    relative position of the sublevel and superlevel flags of H1. On a mesh with
    boundary the first three diagrams are exactly the H0 diagrams named above and the
    fourth is empty; they are then not the whole of extended persistence.

    On a graph the four diagrams are the whole of extended persistence: gudhi's
    ordinary H0, relative H1, extended H0 and extended H1 (as
    :func:`extended_persistence` returns them), with the relative H1 pairs and the
    cycles turned lower value first: ``ord1`` holds gudhi's ``rel1`` pairs ``(max,
    saddle)`` as ``(saddle, max)`` and ``ext1`` its ``ext1`` pairs ``(birth, death)``
    as ``(death, birth)``.

    The accuracy of each filtration on the Sumner meshes is measured by
    ``python benchmarks/bench_persistence.py --accuracy`` (figures in
    ``docs/persistence.md``).

    References
    ----------
    .. [1] Y. Zhang, H. Liu, P. Rosen and M. Hajij, "Mesh Learning Using Persistent
       Homology on the Laplacian Eigenfunctions", 2019.
    .. [2] D. Cohen-Steiner, H. Edelsbrunner and J. Harer, "Extending Persistence Using
       Poincare and Lefschetz Duality", Foundations of Computational Mathematics 9, 2009.

    Examples
    --------
    >>> import numpy as np, trimesh
    >>> from sklearn_meshph import LowerStarPersistence
    >>> sphere = trimesh.creation.icosphere(2)
    >>> height = sphere.vertices[:, 2]
    >>> sub = LowerStarPersistence(filtration="sublevel").fit_transform([(sphere, height)])
    >>> sub[0]
    array([[-1., inf]])
    >>> h0, ess = LowerStarPersistence().fit_transform([(sphere, height)])[0]
    >>> ess
    array([[-1.,  1.],
           [-1.,  1.]])
    """

    _sample_kind = "scalar fields"
    _parameter_constraints: dict = {
        "filtration": [Options(FILTRATIONS)],
        "essential": [Options(ESSENTIAL_POLICIES)],
        "min_persistence": [Interval(Real, 0, None, closed="left")],
        "n_jobs": N_JOBS,
        "verbose": [Interval(Integral, 0, None, closed="left")],
        "parts": [tuple, None],
    }

    def __init__(
        self,
        filtration="symmetric",
        essential="keep",
        min_persistence=0.0,
        n_jobs=None,
        verbose=0,
        parts=None,
    ):
        self.filtration = filtration
        self.essential = essential
        self.min_persistence = min_persistence
        self.n_jobs = n_jobs
        self.verbose = verbose
        self.parts = parts

    def _keep(self) -> list[int]:
        """Positions, among one function's diagrams, of those ``parts`` keeps."""
        entry = FILTRATIONS[self.filtration].value
        if self.parts is None:
            return list(range(len(entry.diagram_names)))
        try:
            return entry.positions(self.parts)
        except ValueError as error:
            raise ValueError(f"filtration={self.filtration!r}: {error}") from None

    def _check_params(self) -> None:
        super()._check_params()
        self._keep()

    def transform(self, X):
        """Compute the persistence diagram(s) of every sample.

        Parameters
        ----------
        X : sequence of ScalarField or (mesh, values) or (graph, values) pairs

        Returns
        -------
        diagrams : list
            One entry per sample: an ``(n, 2)`` float64 array, or a tuple of them (see
            Notes).
        """
        self._check_params()
        samples = self._check_samples(X)
        options = {
            "filtration": self.filtration,
            "essential": self.essential,
            "min_persistence": float(self.min_persistence),
            "keep": self._keep(),
        }
        run = partial(map_samples, n_jobs=self.n_jobs, desc="persistence", verbose=self.verbose)
        if not FILTRATIONS[self.filtration].value.from_graph:
            return run(partial(_diagrams_one, **options), enumerate(samples))
        # Graphs are small and many: blocks of samples, each graph's functions in one
        # compiled call with the others of its block.
        blocks = run(
            partial(_diagrams_block, **options),
            [(a, samples[a:b]) for a, b in sample_blocks(len(samples), self.n_jobs)],
        )
        return [diagrams for block in blocks for diagrams in block]

    def diagram_names(self, n_functions: int = 1) -> list[str]:
        """Names of the diagrams of one sample, in output order.

        Parameters
        ----------
        n_functions : int, default=1
            Number of functions per sample (columns of ``ScalarField.values``).

        Returns
        -------
        list of str
        """
        names = FILTRATIONS[self.filtration].value.diagram_names
        per_function = [names[k] for k in self._keep()]
        if n_functions == 1:
            return per_function
        return [f"f{k + 1}: {name}" for k in range(n_functions) for name in per_function]
