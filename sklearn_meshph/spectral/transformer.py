"""LaplacianEigenTransformer: meshes and point clouds to Laplacian eigenfunctions, one
cached solve each."""

from __future__ import annotations

import os
import warnings
from dataclasses import asdict
from functools import partial
from numbers import Integral

import numpy as np
from sklearn.utils import check_random_state

from .._base import SampleTransformer
from .._param_validation import HasMethods, Interval, Options
from .._progress import map_samples
from .._threads import one_blas_thread
from ..inputs import check_input
from ..mesh.cleaning import COMPONENT_POLICIES, describe, warn_if_lossy
from ..mesh.scalar_field import ScalarField
from ..pointcloud.graph import knn_graph
from .cache import EigenCache, cache_of
from .factorization import SOLVERS
from .laplacians import LAPLACIANS
from .multiplicity import solve_covering, warn_if_repeated
from .quality import warn_if_needles
from .signatures import SIGNATURES
from .solve import SolveSettings, cloud_eigenpairs, mesh_eigenpairs

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
        return len(mesh.vertices if hasattr(mesh, "vertices") else mesh[0])
    except (OSError, TypeError, IndexError, KeyError):
        return 0  # invalid input: check_input reports it in the worker


def _block(n: int) -> int:
    """``n`` rounded up to whole blocks of eigenpairs."""
    return _EIGENPAIR_BLOCK * (-(-n // _EIGENPAIR_BLOCK))


# The faces a point cloud is keyed and stored with.
_NO_FACES = np.empty((0, 3), dtype=np.int64)


def _cached_solve(cache, vertices, faces, settings, n_eigenpairs, seed, index):
    """One sample's solve through the cache; ``faces`` is None for a point cloud."""
    points = faces is None
    solve = cloud_eigenpairs if points else mesh_eigenpairs
    inputs = (vertices,) if points else (vertices, faces)
    arguments = (*inputs, settings, n_eigenpairs, seed, index)
    if cache is None:
        return solve(*arguments)
    if not isinstance(cache, EigenCache):  # the user's own caching object
        return cache.cache(solve, ignore=["index"])(*arguments)
    # A cloud is keyed with no faces, which no mesh has: the two kinds never collide.
    key = cache.key(
        vertices,
        _NO_FACES if points else faces,
        {**asdict(settings), "n_eigenpairs": n_eigenpairs, "seed": seed},
    )
    found = cache.load(key, len(vertices), n_eigenpairs, points=points)
    if found is None:
        found = solve(*arguments)
        cache.store(key, found)
    return found


def _eigen_one(item, *, indices, n_eigenpairs, settings, seed, memory):
    """Clean and solve one mesh; ``indices`` are the eigenfunctions whose multiplicity
    the solve must cover (none for signatures, which do not depend on the basis)."""
    index, mesh = item
    with one_blas_thread():
        vertices, faces = check_input(mesh, index=index)
        (clean, values, vectors), complete = solve_covering(
            lambda n: _cached_solve(memory, vertices, faces, settings, n, seed, index),
            _block(n_eigenpairs),
            indices,
            _EIGENPAIR_BLOCK,
        )
    # The cleaning report travels back with the results: the parent warns, not the
    # worker, whose warnings joblib would not show.
    return clean, values, vectors, complete


class LaplacianEigenTransformer(SampleTransformer):
    """Compute a Laplacian eigenfunction on each mesh or point cloud.

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
    field has no faces and the symmetric 10-nearest-neighbour graph as ``edges``: the
    complex :class:`LowerStarPersistence` filters.

    Parameters
    ----------
    eigen_index : int or tuple of int, default=(1, 2, 3)
        Which eigenfunction: 0 is the constant one, 1 the Fiedler vector, and so on. A
        tuple gives several eigenfunctions, as columns of ``ScalarField.values``. The
        default, the first three non-constant ones, is the paper's suggested extension
        (its accuracy against the Fiedler vector alone is in ``docs/eigenfunctions.md``);
        ``eigen_index=1`` is the paper's setting.
    laplacian : {"cotangent", "graph"}, default="cotangent"
        ``"cotangent"``: finite-element Laplace-Beltrami operator (cotangent stiffness,
        barycentric lumped mass), solved as ``L phi = lambda M phi``; it depends on the
        geometry only, not on the triangulation. ``"graph"``: combinatorial graph
        Laplacian of the edges; it ignores geometry and depends on the resolution.
    normalization : {"area", "none"}, default="area"
        ``"area"``: the mesh is scaled to unit area and eigenvectors are M-orthonormal,
        so eigenfunctions have unit mean square and do not depend on the mesh's scale
        or resolution (for the graph Laplacian, ``M = I / n``: unit mean square).
        ``"none"``: the mesh as given, cotangent eigenvectors M-orthonormal at its own
        scale and graph eigenvectors of unit Euclidean norm; with the graph Laplacian
        this is the paper's literal setting (whose values shrink like ``1/sqrt(n)``).
    components : {"largest", "error"}, default="largest"
        A mesh of several connected components keeps only the component of largest
        area (``"largest"``) or raises (``"error"``). See :func:`clean_mesh` for the
        whole cleaning policy. Cleaning that drops more than 1% of a mesh's vertices or
        area emits a :class:`MeshCleaningWarning` naming the sample (and its file).
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
    solver : {"auto", "cholesky", "superlu"}, default="auto"
        Factorization backend of the shift-invert eigensolver: our supernodal Cholesky
        (``"auto"`` and ``"cholesky"``) or SciPy's SuperLU. Both give the same
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
        values reuses one cached solve per mesh (``memory``).
    n_scales : int, default=5
        Times (``"hks"``) or energies (``"wks"``) of a signature, chosen from each
        mesh's eigenvalues (scale-free at unit area); ignored for ``"eigenfunctions"``.

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

    _sample_kind = "meshes"
    _parameter_constraints: dict = {
        "eigen_index": [Interval(Integral, 0, None, closed="left"), tuple],
        "laplacian": [Options(LAPLACIANS)],
        "normalization": [Options(("area", "none"))],
        "components": [Options(COMPONENT_POLICIES)],
        "weld": ["boolean"],
        "memory": [None, str, os.PathLike, HasMethods(["cache"])],
        "n_jobs": [Integral, None],
        "random_state": ["random_state"],
        "solver": [Options(SOLVERS)],
        "verbose": [Interval(Integral, 0, None, closed="left")],
        "signature": [Options(SIGNATURES)],
        "n_eigenpairs": [Interval(Integral, 2, None, closed="left"), None],
        "n_scales": [Interval(Integral, 1, None, closed="left")],
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
        """Compute the eigenfunction(s) of every mesh.

        Parameters
        ----------
        X : sequence of meshes or point clouds
            Each a trimesh.Trimesh, a (vertices, faces) pair, a path, an (n, 3) array
            or a trimesh.PointCloud.

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
            signature t=..."``).

        Warns
        -----
        MeshCleaningWarning
            When cleaning drops more than 1% of a mesh's vertices or area.
        RepeatedEigenvalueWarning
            When a requested eigenvalue is repeated.
        ConstantEigenfunctionWarning
            When ``eigen_index`` holds 0, the constant eigenfunction.
        """
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
                stacklevel=2,
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
            n_kept = n_solve = self.n_eigenpairs or _SIGNATURE_EIGENPAIRS
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
                work,
                [(i, meshes[i]) for i in order],
                n_jobs=self.n_jobs,
                desc="eigensolves",
                verbose=self.verbose,
            )
        results = [None] * len(meshes)
        for i, result in zip(order, solved, strict=True):
            results[i] = result
        fields = []
        column = indices[0] if not isinstance(self.eigen_index, tuple) else list(indices)
        for i, (clean, values, vectors, complete) in enumerate(results):
            report = clean.report
            # First: a mesh reduced to a few vertices is explained before it is refused.
            warn_if_lossy(report, describe(i, meshes[i]), stacklevel=3)
            warn_if_needles(clean, i, stacklevel=3)
            if signature is not None:
                # Exactly the eigenpairs asked for: the solve's block is not seen.
                values, vectors = values[:n_kept], vectors[:, :n_kept]
                if len(values) < 2:
                    raise ValueError(f"sample {i}: the cleaned mesh has too few vertices")
                field_values, names = signature(values, vectors, self.n_scales)
                field_eigenvalues = None
            elif max(indices) >= len(values):
                raise ValueError(
                    f"sample {i}: eigen_index {max(indices)} needs at least "
                    f"{max(indices) + 1} vertices, the cleaned mesh has {len(values)}"
                )
            else:
                warn_if_repeated(values, indices, i, complete)
                field_values, field_eigenvalues = vectors[:, column], values[column]
                names = tuple(f"eigenfunction {k}" for k in indices)
                values = values[:n_kept]
            identity = len(clean.vertices) == report.n_input_vertices
            # A cloud's complex is its kNN graph, built here from the kept points (cheap,
            # and the same whether the solve came from the cache or not).
            points = len(clean.faces) == 0
            fields.append(
                ScalarField(
                    vertices=clean.vertices,
                    faces=clean.faces,
                    edges=knn_graph(clean.vertices) if points else None,
                    values=field_values,
                    eigenvalues=field_eigenvalues,
                    vertex_indices=None if identity else clean.vertex_indices,
                    input_to_kept=None if identity else clean.input_to_kept,
                    cleaning=report if report.dropped else None,
                    spectrum=values,
                    column_names=names,
                )
            )
        return fields
