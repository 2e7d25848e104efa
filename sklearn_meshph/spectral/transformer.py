"""LaplacianEigenTransformer: meshes, point clouds and graphs to Laplacian eigenfunctions
or signatures, one cached solve each."""

from __future__ import annotations

import os
import warnings
from dataclasses import asdict
from functools import partial
from numbers import Integral

import numpy as np
import scipy.sparse as sp
from sklearn.utils import check_random_state

from .._base import ObjectOutput, SampleTransformer
from .._param_validation import N_JOBS, HasMethods, Interval, Options
from .._progress import map_samples
from .._threads import one_blas_thread
from ..graph.validation import Graph
from ..inputs import check_input
from ..mesh.cleaning import describe, warn_if_lossy
from ..mesh.scalar_field import ScalarField
from .cache import EigenCache, cache_of
from .eigensolver import COMPONENTS, DENSE_LIMIT
from .factorization import SOLVERS
from .laplacians import LAPLACIANS
from .multiplicity import solve_covering, warn_if_repeated
from .quality import warn_if_needles
from .signatures import HEAT_SIGNATURES, MAX_SCALES, SIGNATURES, check_times
from .solve import (
    SolveSettings,
    cloud_eigenpairs,
    graph_eigenpairs,
    kept_edges,
    mesh_eigenpairs,
    warn_graph_components,
)

__all__ = ["ConstantEigenfunctionWarning", "LaplacianEigenTransformer"]

# Eigenpairs are solved in blocks of this many, whatever the requested number, so that
# a grid search over small indices or eigenpair counts reuses one cached solve per
# mesh; what is solved beyond the request is dropped before anything sees it.
_EIGENPAIR_BLOCK = 8
# Eigenpairs behind a signature unless n_eigenpairs says otherwise.
_SIGNATURE_EIGENPAIRS = 100


class ConstantEigenfunctionWarning(UserWarning):
    """``eigen_index`` asks for eigenfunction 0, the constant one: its diagram is
    trivial (one point) and carries nothing about the shape."""


def _size_hint(mesh) -> int:
    """A cheap estimate of a mesh's size, for scheduling only."""
    try:
        if isinstance(mesh, str | os.PathLike):
            return os.path.getsize(mesh)
        if isinstance(mesh, np.ndarray):  # a point cloud
            return len(mesh)
        if isinstance(mesh, Graph):
            return mesh.n_nodes
        if sp.issparse(mesh):  # an adjacency matrix
            return mesh.shape[0]
        if isinstance(mesh, tuple | list) and isinstance(mesh[0], Integral):  # (n_nodes, edges)
            return int(mesh[0])
        if hasattr(mesh, "number_of_nodes"):  # a networkx graph
            return mesh.number_of_nodes()
        return len(mesh.vertices if hasattr(mesh, "vertices") else mesh[0])
    except (OSError, TypeError, IndexError, KeyError):
        return 0  # invalid input: check_input reports it in the worker


def _block(n: int) -> int:
    """``n`` rounded up to whole blocks of eigenpairs."""
    return _EIGENPAIR_BLOCK * (-(-n // _EIGENPAIR_BLOCK))


# The faces a point cloud is keyed and stored with.
_NO_FACES = np.empty((0, 3), dtype=np.int64)


def _cached_solve(cache, vertices, faces, settings, n_eigenpairs, seed, index):
    """One sample's solve through the cache; ``faces`` is None for a point cloud or a
    graph (``vertices`` then a :class:`Graph`)."""
    graph = isinstance(vertices, Graph)
    points = faces is None and not graph
    solve = graph_eigenpairs if graph else cloud_eigenpairs if points else mesh_eigenpairs
    inputs = (vertices,) if faces is None else (vertices, faces)
    arguments = (*inputs, settings, n_eigenpairs, seed, index)
    if cache is None:
        return solve(*arguments)
    if not isinstance(cache, EigenCache):  # the user's own caching object
        return cache.cache(solve, ignore=["index"])(*arguments)
    keyed = {**asdict(settings), "n_eigenpairs": n_eigenpairs, "seed": seed}
    if graph:
        # Edges (m, 2) and weights, with the node count among the settings: no mesh or
        # cloud has either, so the kinds never collide.
        key = cache.key(vertices.weights, vertices.edges, {**keyed, "nodes": vertices.n_nodes})
        n_input = vertices.n_nodes
    else:
        # A cloud is keyed with no faces, which no mesh has.
        key = cache.key(vertices, _NO_FACES if points else faces, keyed)
        n_input = len(vertices)
    found = cache.load(key, n_input, n_eigenpairs, points=points, graph=graph)
    if found is None:
        found = solve(*arguments)
        cache.store(key, found)
    return found


def _eigen_one(item, *, indices, n_eigenpairs, settings, seed, memory):
    """Clean and solve one sample; ``indices`` are the eigenfunctions whose multiplicity
    the solve must cover (none for signatures, which do not depend on the basis).
    ``n_eigenpairs=None``: every eigenpair of a graph (others get the signatures'
    default). Returns the kept graph's edges too (None for a mesh or a cloud)."""
    index, mesh = item
    with one_blas_thread():
        vertices, faces = check_input(mesh, index=index)
        graph = isinstance(vertices, Graph)
        if n_eigenpairs is None and graph:
            if vertices.n_nodes > DENSE_LIMIT:  # before anything the size of the graph
                raise ValueError(
                    f"sample {index}: {vertices.n_nodes} nodes; every eigenpair "
                    f"(components='all' without n_eigenpairs) is a dense solve, for at "
                    f"most {DENSE_LIMIT} nodes: ask for fewer eigenpairs (n_eigenpairs)"
                )
            n_eigenpairs = vertices.n_nodes
        else:
            n_eigenpairs = _block(n_eigenpairs or _SIGNATURE_EIGENPAIRS)
        try:
            (clean, values, vectors), complete = solve_covering(
                lambda n: _cached_solve(memory, vertices, faces, settings, n, seed, index),
                n_eigenpairs,
                indices,
                _EIGENPAIR_BLOCK,
            )
        except MemoryError as exc:  # a bare MemoryError names no sample
            size = vertices.n_nodes if graph else len(vertices)
            raise MemoryError(
                f"sample {index}: not enough memory to solve its {size} "
                f"{'nodes' if graph else 'vertices'} ({str(exc) or 'allocation failed'})"
            ) from None
    edges = kept_edges(vertices, clean.input_to_kept) if graph else None
    # The cleaning report travels back with the results: the parent warns, not the
    # worker, whose warnings joblib would not show.
    return clean, values, vectors, complete, edges


def _or_error(work, item):
    """``work(item)``, or the message of the ``ValueError``, ``TypeError`` or
    ``MemoryError`` (each names the sample) by which it refused the sample."""
    try:
        return work(item)
    except (ValueError, TypeError, MemoryError) as error:
        return str(error)


class LaplacianEigenTransformer(ObjectOutput, SampleTransformer, auto_wrap_output_keys=None):
    """Compute a Laplacian eigenfunction or signature on each mesh, point cloud or graph.

    The first stage of the mesh-learning pipeline: each mesh becomes a
    :class:`ScalarField` holding the requested eigenfunctions of its Laplace-Beltrami
    operator (the first three non-constant ones by default, starting with the Fiedler
    vector), ready for :class:`LowerStarPersistence`.

    Point clouds (an ``(n, 3)`` array, a ``trimesh.PointCloud``, or a ``.xyz``,
    ``.pts`` or face-less PLY file; see :func:`check_point_cloud`) go through the same
    parameters: each Laplacian has a point-cloud discretization
    (:func:`point_cloud_laplacian` for ``"cotangent"``, the graph Laplacian of the
    symmetric 10-nearest-neighbour graph for ``"graph"``), solved in the unit box and in
    a canonical point order (a permuted cloud gives the permuted output, bit for bit).
    Coincident points are merged, as ``weld`` says (exact duplicates always), with the
    index maps of cleaning; a cloud in several clusters follows ``components``. The
    field has no faces and the edges of the operator's local triangles as ``edges``
    (:func:`~sklearn_meshph.pointcloud.graph.surface_graph`): the complex
    :class:`LowerStarPersistence` filters.

    Graphs (a :class:`~sklearn_meshph.graph.validation.Graph`, an ``(n_nodes, edges)``
    pair, a sparse adjacency matrix or a networkx graph; see :func:`check_graph`) take
    the graph Laplacians (``"graph"``, ``"normalized"``, ``"random_walk"``) on their
    edge weights; ``"cotangent"`` is refused for them, naming the sample. Their fields
    have nodes without coordinates (``vertices`` of shape ``(n_kept_nodes, 0)``), no
    faces, and the kept graph's edges (renumbered) as ``edges``. PersLay's signatures
    are ``LaplacianEigenTransformer(laplacian="normalized", normalization="none",
    components="all", signature="hks", times=(0.1, 10))``: every eigenpair of the
    normalized Laplacian, unit-norm eigenvectors.

    Parameters
    ----------
    eigen_index : int or tuple of int, default=(1, 2, 3)
        Which eigenfunction: 0 is the constant one, 1 the Fiedler vector, and so on. A
        tuple gives several eigenfunctions, as columns of ``ScalarField.values``. The
        default, the first three non-constant ones, is the paper's suggested extension
        (its accuracy against the Fiedler vector alone is in ``docs/eigenfunctions.md``);
        ``eigen_index=1`` is the paper's setting.
    laplacian : {"cotangent", "graph", "normalized", "random_walk"}, default="cotangent"
        ``"cotangent"``: finite-element Laplace-Beltrami operator (cotangent stiffness,
        barycentric lumped mass), solved as ``L phi = lambda M phi``; it depends on the
        geometry only, not on the triangulation. ``"graph"``: combinatorial graph
        Laplacian ``D - A`` of the edges (a graph's weighted edges); it ignores geometry
        and depends on the resolution. ``"normalized"``: ``I - D^-1/2 A D^-1/2`` (an
        isolated node has ``L_ii = 0``), eigenvalues in ``[0, 2]``; ``"random_walk"``:
        ``I - D^-1 A``, solved as ``(D - A) phi = lambda D phi`` (the normalized
        Laplacian's eigenvalues, D-orthonormal eigenvectors). See
        :mod:`sklearn_meshph.spectral.laplacians`.
    normalization : {"area", "none"}, default="area"
        ``"area"``: the mesh is scaled to unit area and eigenvectors are M-orthonormal,
        so eigenfunctions have unit mean square and do not depend on the mesh's scale
        or resolution (for the graph Laplacian, ``M = I / n``: unit mean square).
        ``"none"``: the mesh as given, cotangent eigenvectors M-orthonormal at its own
        scale and graph eigenvectors of unit Euclidean norm; with the graph Laplacian
        this is the paper's literal setting (whose values shrink like ``1/sqrt(n)``).
        On a graph, ``"area"`` divides the mass by its sum (``M = I / n`` for
        ``"graph"`` and ``"normalized"``, ``D / vol`` for ``"random_walk"``): unit
        mean square eigenvectors, eigenvalues multiplied by that sum; ``"none"`` keeps
        the plain operator (PersLay's: unit-norm eigenvectors).
    components : {"largest", "error", "all"}, default="largest"
        A mesh of several connected components keeps only the component of largest
        area (``"largest"``) or raises (``"error"``). See :func:`clean_mesh` for the
        whole cleaning policy. Cleaning that drops more than 1% of a mesh's vertices or
        area emits a :class:`MeshCleaningWarning` naming the sample (and its file).
        A graph keeps its component of most nodes (``"largest"``, an isolated node being
        a component; the warning counts nodes and edge weight), raises (``"error"``) or
        is kept whole (``"all"``: one zero eigenvalue per component, isolated nodes
        included); ``"all"`` is for graphs only, a mesh or a cloud given it raises.
    weld : bool, default=True
        Weld vertices at the same position (within ``1e-10`` times the bounding-box
        diagonal) before cleaning, so that STL triangle soups and OBJ files split along
        UV seams become connected surfaces; ``False`` keeps the vertices as given. A
        mesh without coincident vertices is unchanged either way.
    memory : str, path, joblib.Memory or None, default=None
        A folder (or a ``joblib.Memory``, whose location is used) where each mesh's
        eigensolve is cached, keyed on the input mesh's content, the solver settings,
        the package version, its numerics version and the start vector's seed, not on
        ``eigen_index``, the signature or ``n_scales``: a grid search over those, and
        over ``n_eigenpairs`` within one block of the solver, solves each mesh once
        (with a fixed ``random_state``: ``None`` draws a new start vector per call, so
        it never hits). An empty path is refused. Entries are data only
        (``.npy`` arrays and a JSON header, read without unpickling and checked before
        use), so a shared or hostile folder cannot run code; an unusable entry is
        recomputed with a ``CacheWarning``, and a read-only folder is used without
        storing. Another object with a ``cache`` method is used as joblib's would be
        (its format is its own).
    n_jobs : int, default=None
        Meshes solved in parallel. ``None`` means 1 unless in a
        :func:`joblib.parallel_backend` context; ``-1`` means all processors. BLAS is
        limited to one thread inside each solve.
    random_state : int, RandomState instance or None, default=0
        Seeds ARPACK's start vector (the same for every mesh), an int in
        ``[0, 2**32 - 1]``. The default makes results reproducible and cached solves
        reusable; the output does not depend on it beyond rounding. ``None`` or a
        ``RandomState`` draws a new start vector at every call, which ``memory`` then
        never finds in its cache.
    solver : {"auto", "cholesky", "superlu", "dense"}, default="auto"
        Factorization backend of the shift-invert eigensolver: our supernodal Cholesky
        (``"auto"`` and ``"cholesky"``) or SciPy's SuperLU; ``"dense"``: LAPACK's
        dense eigensolver at any size (its memory grows as the square of the size).
        ``"auto"`` solves small operators densely (a few hundred vertices or nodes; the
        measured crossover is in ``docs/eigenfunctions.md``). All give the same
        eigenpairs up to rounding.
    verbose : int, default=0
        With ``verbose > 0``, a progress bar over the meshes on stderr (needs tqdm,
        the ``progress`` extra); nothing is printed at 0.
    signature : {"eigenfunctions", "hks", "log-hks", "wks"}, default="eigenfunctions"
        What each mesh becomes: the eigenfunctions of ``eigen_index``, or a spectral
        signature of the first ``n_eigenpairs`` eigenpairs (heat or wave kernel
        signature, see :mod:`sklearn_meshph.spectral.signatures`), one column per scale.
        Signatures are sums of squared eigenfunctions: independent of eigenvector signs
        and of the basis of a repeated eigenspace (up to the truncation at
        ``n_eigenpairs``, which may cut the last eigenspace).
    n_eigenpairs : int, default=None
        The number of eigenpairs used, the constant one included: exactly the first
        ``n_eigenpairs`` are behind a signature (``None``: 100) and in each field's
        ``spectrum`` (for :class:`ShapeDNA`, whose ``n_eigenpairs`` counts the same
        way). With ``signature="eigenfunctions"`` it must exceed ``max(eigen_index)``
        (``None``: ``max(eigen_index) + 1``). The solver works in blocks of a few
        eigenpairs and drops what it solved beyond the request, so a grid over nearby
        values reuses one cached solve per mesh (``memory``). On a graph, ``None``
        behind a signature means every eigenpair (PersLay's setting: a dense solve,
        refused above a size whose matrices would not fit in memory).
    n_scales : int, default=5
        Times (``"hks"``) or energies (``"wks"``) of a signature, chosen from each
        mesh's eigenvalues (scale-free at unit area); ignored for ``"eigenfunctions"``
        and where ``times`` is given.
    times : array-like of float, default=None
        Fixed times of ``"hks"`` and ``"log-hks"``, the same for every sample (columns
        named ``"heat kernel signature t=10"``), instead of the ``n_scales`` times
        chosen from each sample's eigenvalues; each finite, between ``1e-150`` and
        ``1e150``. Ignored for the other signatures.

    Attributes
    ----------
    n_features_in_ : int
        Not set: the input is a sequence of meshes, not a feature matrix.

    See Also
    --------
    laplacian_eigenfunctions : Raw eigenpairs of one mesh, without normalization.
    LowerStarPersistence : The next stage: persistence diagrams of the eigenfunctions.

    Notes
    -----
    The sign of an eigenvector is arbitrary; it is fixed so that the mass-weighted third
    moment ``sum_i m_i phi_i^3`` is positive (when that vanishes, the entry of largest
    magnitude is made positive). Persistence defaults of :class:`LowerStarPersistence`
    are sign invariant anyway. When the requested eigenvalue is repeated (relative
    spread below 1e-3, as on spheres and tori) its eigenfunction is an arbitrary member
    of an eigenspace and a :class:`RepeatedEigenvalueWarning` says so, with the
    multiplicity; the solve grows by a few blocks of eigenpairs to find it, beyond
    which the warning says "multiplicity at least m". ``eigen_index=0`` (the constant
    function, whose diagram is a single point) is allowed, with a
    :class:`ConstantEigenfunctionWarning`.

    References
    ----------
    .. [1] Y. Zhang, H. Liu, P. Rosen and M. Hajij, "Mesh Learning Using Persistent
       Homology on the Laplacian Eigenfunctions", 2019.
    .. [2] M. Reuter, F.-E. Wolter and N. Peinecke, "Laplace-Beltrami spectra as
       'Shape-DNA' of surfaces and solids", Computer-Aided Design 38, 2006.

    Examples
    --------
    >>> import trimesh
    >>> from sklearn_meshph import LaplacianEigenTransformer
    >>> sphere = trimesh.creation.icosphere(3)
    >>> meshes = [(sphere.vertices * [1.0, 1.0, c], sphere.faces) for c in (2.0, 4.0)]
    >>> fields = LaplacianEigenTransformer(eigen_index=1).fit_transform(meshes)
    >>> [round(float(f.eigenvalues[0]), 2) for f in fields]  # longer: lower, at unit area
    [15.56, 8.44]
    """

    _sample_kind = "meshes, point clouds or graphs"
    _parameter_constraints: dict = {
        "eigen_index": [Interval(Integral, 0, None, closed="left"), tuple],
        "laplacian": [Options(LAPLACIANS)],
        "normalization": [Options(("area", "none"))],
        "components": [Options(COMPONENTS)],
        "weld": ["boolean"],
        "memory": [None, str, os.PathLike, HasMethods(["cache"])],
        "n_jobs": N_JOBS,
        "random_state": ["random_state"],
        "solver": [Options(SOLVERS)],
        "verbose": [Interval(Integral, 0, None, closed="left")],
        "signature": [Options(SIGNATURES)],
        "n_eigenpairs": [Interval(Integral, 2, None, closed="left"), None],
        "n_scales": [Interval(Integral, 1, MAX_SCALES, closed="both")],
        "times": [None, tuple, list, np.ndarray],
    }

    def __init__(
        self,
        eigen_index=(1, 2, 3),
        laplacian="cotangent",
        normalization="area",
        components="largest",
        weld=True,
        memory=None,
        n_jobs=None,
        random_state=0,
        solver="auto",
        verbose=0,
        signature="eigenfunctions",
        n_eigenpairs=None,
        n_scales=5,
        times=None,
    ):
        self.eigen_index = eigen_index
        self.laplacian = laplacian
        self.normalization = normalization
        self.components = components
        self.weld = weld
        self.memory = memory
        self.n_jobs = n_jobs
        self.random_state = random_state
        self.solver = solver
        self.verbose = verbose
        self.signature = signature
        self.n_eigenpairs = n_eigenpairs
        self.n_scales = n_scales
        self.times = times

    def _indices(self) -> tuple[int, ...]:
        if isinstance(self.eigen_index, tuple):
            if not self.eigen_index or not all(
                isinstance(i, Integral) and not isinstance(i, bool) and i >= 0
                for i in self.eigen_index
            ):
                raise ValueError(
                    "eigen_index must be a non-negative int or a non-empty tuple of them, "
                    f"got {self.eigen_index!r}"
                )
            return tuple(int(i) for i in self.eigen_index)
        return (int(self.eigen_index),)

    def _check_params(self) -> None:
        super()._check_params()
        indices = self._indices()
        cache_of(self.memory)  # refuses an empty path
        if self.times is not None:
            check_times(self.times)
        if (
            SIGNATURES[self.signature].value is None
            and self.n_eigenpairs is not None
            and self.n_eigenpairs <= max(indices)
        ):
            raise ValueError(
                f"n_eigenpairs={self.n_eigenpairs} does not reach eigen_index "
                f"{max(indices)}: the eigenpairs are counted from the constant one, "
                f"so it needs n_eigenpairs >= {max(indices) + 1}"
            )

    def transform(self, X):
        """Compute the eigenfunction(s) or signature of every sample.

        Parameters
        ----------
        X : sequence of meshes, point clouds or graphs
            Each a trimesh.Trimesh, a (vertices, faces) pair, a path, an (n, 3) array,
            a trimesh.PointCloud, or a graph (a Graph, an (n_nodes, edges) pair, a
            sparse adjacency matrix or a networkx graph).

        Returns
        -------
        fields : list of ScalarField
            One per mesh, on its cleaned vertex set; ``values`` has shape
            (n_vertices,) for an int ``eigen_index`` and (n_vertices, k) for a tuple of
            k indices, and ``eigenvalues`` the matching eigenvalues. When cleaning
            changed the vertex set, ``vertex_indices`` and ``input_to_kept`` map it to
            the input's vertices and back; ``cleaning`` reports what was dropped.
            ``spectrum`` holds the first ``n_eigenpairs`` eigenvalues and
            ``column_names`` what each column is (``"eigenfunction 1"``, ``"heat kernel
            signature t=..."``). A graph's field has ``vertices`` of shape
            ``(n_kept_nodes, 0)``, no faces and the kept graph's edges as ``edges``.

        Warns
        -----
        MeshCleaningWarning
            When cleaning drops more than 1% of a mesh's vertices or area (of a graph's
            nodes or edge weight, with ``components="largest"``).
        RepeatedEigenvalueWarning
            When a requested eigenvalue is repeated.
        ConstantEigenfunctionWarning
            When ``eigen_index`` holds 0, the constant eigenfunction.
        """
        return self._transform(X)[0]

    def _transform(self, X, skip=False):
        """:meth:`transform`, and with ``skip`` each sample refused by its own checks
        left out instead of raising: ``(fields, errors)``, ``fields[i]`` None for a
        sample left out and ``errors`` its ``(i, message)`` pairs (for the main job's
        ``--skip-unreadable``)."""
        self._check_params()
        meshes = self._check_samples(X)
        indices = self._indices()
        signature = SIGNATURES[self.signature].value
        if signature is None and 0 in indices:
            warnings.warn(
                "eigen_index 0 is the constant eigenfunction: its persistence diagram "
                "is a single point and says nothing about the shape; the Fiedler vector "
                "is eigen_index=1",
                ConstantEigenfunctionWarning,
                stacklevel=3,  # the caller of transform
            )
        if isinstance(self.random_state, Integral):
            seed = int(self.random_state)
        else:  # a RandomState or None: a new start vector, hence a new cache key, per call
            seed = int(check_random_state(self.random_state).randint(np.iinfo(np.int32).max))
        memory = cache_of(self.memory)
        # Largest meshes first: workers that finish early pick up the small ones, so a
        # collection of mixed sizes keeps every worker busy to the end.
        order = sorted(range(len(meshes)), key=lambda i: -_size_hint(meshes[i]))
        if signature is None:
            # Two beyond the last index: a repeated eigenvalue there is seen whole.
            n_solve, tracked = max(max(indices) + 3, self.n_eigenpairs or 0), indices
            n_kept = self.n_eigenpairs or max(indices) + 1
        else:
            # None: every eigenpair of a graph, _SIGNATURE_EIGENPAIRS of others.
            n_kept = n_solve = self.n_eigenpairs
            tracked = ()
        settings = SolveSettings(
            laplacian=self.laplacian,
            normalization=self.normalization,
            components=self.components,
            solver=self.solver,
            weld=self.weld,
        )
        # Held for the whole parallel call: threads of a threading backend then share
        # one limit instead of setting and restoring it under each other's feet.
        with one_blas_thread():
            work = partial(
                _eigen_one,
                indices=tracked,
                n_eigenpairs=n_solve,
                settings=settings,
                seed=seed,
                memory=memory,
            )
            solved = map_samples(
                partial(_or_error, work) if skip else work,
                [(i, meshes[i]) for i in order],
                n_jobs=self.n_jobs,
                desc="eigensolves",
                verbose=self.verbose,
            )
        results = [None] * len(meshes)
        for i, result in zip(order, solved, strict=True):
            results[i] = result
        column = indices[0] if not isinstance(self.eigen_index, tuple) else list(indices)
        fields, errors = [], []
        for i, result in enumerate(results):  # not a comprehension, a frame more to warn
            try:
                if isinstance(result, str):  # a message of _or_error
                    raise ValueError(result)
                fields.append(self._field(i, meshes[i], result, signature, indices, column, n_kept))
            except ValueError as error:
                if not skip:
                    raise
                fields.append(None)
                errors.append((i, str(error)))
        return fields, errors

    def _field(self, i, sample, result, signature, indices, column, n_kept):
        """The :class:`ScalarField` of sample ``i`` from its solve."""
        clean, values, vectors, complete, edges = result
        report = clean.report
        graph = edges is not None
        # First: a sample reduced to a few vertices is explained before it is refused.
        if graph:
            warn_graph_components(report, describe(i, sample), stacklevel=4)
        else:
            warn_if_lossy(report, describe(i, sample), stacklevel=4)
            warn_if_needles(clean, i, stacklevel=4)
        kind, units = ("graph", "nodes") if graph else ("mesh", "vertices")
        if signature is not None:
            # Exactly the eigenpairs asked for: the solve's block is not seen.
            if n_kept is None and not graph:
                n_kept = _SIGNATURE_EIGENPAIRS
            values, vectors = values[:n_kept], vectors[:, :n_kept]
            fixed = self.times is not None and self.signature in HEAT_SIGNATURES
            if len(values) < (1 if fixed else 2):
                raise ValueError(f"sample {i}: the cleaned {kind} has too few {units}")
            try:
                field_values, names = signature(
                    values, vectors, check_times(self.times) if fixed else self.n_scales
                )
            except ValueError as error:  # no positive eigenvalue to choose scales from
                raise ValueError(f"sample {i}: {error}") from None
            field_eigenvalues = None
        elif max(indices) >= len(values):
            raise ValueError(
                f"sample {i}: eigen_index {max(indices)} needs at least "
                f"{max(indices) + 1} {units}, the cleaned {kind} has {len(values)}"
            )
        else:
            warn_if_repeated(values, indices, i, complete)
            field_values, field_eigenvalues = vectors[:, column], values[column]
            names = tuple(f"eigenfunction {k}" for k in indices)
            values = values[:n_kept]
        identity = len(clean.vertices) == report.n_input_vertices
        if not graph and len(clean.faces) == 0:
            # A cloud's complex: the edges of the local triangles its operator was built
            # from (stored with the solve in the cache).
            edges = clean.edges
        return ScalarField(
            vertices=clean.vertices,
            faces=clean.faces,
            edges=edges,
            values=field_values,
            eigenvalues=field_eigenvalues,
            vertex_indices=None if identity else clean.vertex_indices,
            input_to_kept=None if identity else clean.input_to_kept,
            cleaning=report if report.dropped else None,
            spectrum=values,
            column_names=names,
        )
