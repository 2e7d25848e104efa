"""LaplacianEigenTransformer: meshes and point clouds to Laplacian eigenfunctions, one
cached solve each."""

from __future__ import annotations

import os
import warnings
from numbers import Integral

import numpy as np
from joblib import delayed
from sklearn.utils import check_random_state

from .._base import SampleTransformer
from .._param_validation import HasMethods, Interval, Options
from .._progress import parallel, track
from .._threads import one_blas_thread
from ..mesh.cleaning import COMPONENT_POLICIES, describe, warn_if_lossy
from ..mesh.scalar_field import ScalarField
from ..pointcloud.graph import knn_graph
from ..pointcloud.validation import check_input
from .cache import EigenCache
from .factorization import SOLVERS
from .laplacians import LAPLACIANS
from .signatures import SIGNATURES
from .solve import cloud_eigenpairs, mesh_eigenpairs, unit_box

__all__ = ["LaplacianEigenTransformer", "MeshQualityWarning", "RepeatedEigenvalueWarning"]

# Eigenpairs are solved in blocks of this many, whatever the requested index, so that a
# grid search over small indices reuses one cached solve per mesh.
_EIGS_BLOCK = 8
# A repeated eigenvalue that reaches the end of a block makes the block grow, so that the
# warning can state the whole multiplicity, by at most this many eigenpairs: beyond it
# (a "book" of many triangles on one edge) the warning says "at least".
_MAX_GROWTH = 4 * _EIGS_BLOCK
# Eigenpairs behind a signature unless n_eigenpairs says otherwise.
_SIGNATURE_EIGENPAIRS = 100
# Eigenvalues closer than this (relative) count as one repeated eigenvalue.
_REPEATED_RTOL = 1e-3


class RepeatedEigenvalueWarning(UserWarning):
    """The requested eigenvalue is (nearly) repeated: its eigenfunction is not unique."""


class MeshQualityWarning(UserWarning):
    """Most triangles of a mesh are needles: its Laplacian, hence its eigenpairs, mean
    little."""


# A triangle whose smallest angle has a sine below this is a needle: its cotangent
# weight is above 1e6, and a mesh made mostly of them has a meaningless spectrum.
NEEDLE_SINE = 1e-6
# The share of needle triangles from which a mesh is warned about.
NEEDLE_SHARE = 0.5


def needle_share(vertices: np.ndarray, faces: np.ndarray) -> float:
    """The share of triangles whose smallest angle has a sine below ``NEEDLE_SINE``
    (computed in a unit box, so at any scale)."""
    unit = unit_box(np.asarray(vertices, dtype=np.float64))[0]
    a, b, c = (unit[faces[:, k]] for k in range(3))
    lengths = np.stack(
        [
            np.linalg.norm(b - c, axis=1),
            np.linalg.norm(c - a, axis=1),
            np.linalg.norm(a - b, axis=1),
        ]
    )
    double_area = np.linalg.norm(np.cross(b - a, c - a), axis=1)
    # sin(angle at a corner) = 2 area / (product of its two edges): the smallest angle
    # is at the corner whose two edges have the largest product.
    products = np.stack([lengths[1] * lengths[2], lengths[2] * lengths[0], lengths[0] * lengths[1]])
    with np.errstate(divide="ignore", invalid="ignore"):
        sines = double_area / products.max(axis=0)
    return float(np.mean(~(sines >= NEEDLE_SINE))) if len(faces) else 0.0


def _warn_if_needles(clean, sample: int, stacklevel: int) -> None:
    share = needle_share(clean.vertices, clean.faces)
    if share > NEEDLE_SHARE:
        warnings.warn(
            f"sample {sample}: {100 * share:.3g}% of the triangles are needles (an angle "
            f"with sine below {NEEDLE_SINE:g}); the Laplacian of such a mesh is "
            "ill-conditioned and its eigenpairs mean little: remesh it",
            MeshQualityWarning,
            stacklevel=stacklevel + 1,
        )


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


def _repeats(values: np.ndarray, i: int) -> np.ndarray:
    """Indices of the eigenvalues that coincide with ``values[i]`` (relative 1e-3)."""
    return np.flatnonzero(np.abs(values - values[i]) <= _REPEATED_RTOL * abs(values[i]))


def _reaches_end(values: np.ndarray, indices) -> bool:
    """Whether a requested repeated eigenvalue may go on past the last computed one."""
    last = len(values) - 1
    return any(0 < i <= last and _repeats(values, i)[-1] == last for i in indices)


def _block(n: int) -> int:
    """``n`` rounded up to whole blocks of eigenpairs."""
    return _EIGS_BLOCK * (-(-n // _EIGS_BLOCK))


def _cache_of(memory):
    """The eigen cache of a ``memory`` parameter: an :class:`EigenCache` in a folder (a
    path, or the location of a ``joblib.Memory``), a caching object of the user's (one
    with ``cache`` but no location: used as joblib's would be), or None."""
    if memory is None:
        return None
    if isinstance(memory, str | os.PathLike):
        return EigenCache(memory)
    if hasattr(memory, "location"):  # a joblib.Memory: its folder, or no cache at all
        return None if memory.location is None else EigenCache(memory.location)
    return memory


# The faces a point cloud is keyed and stored with.
_NO_FACES = np.empty((0, 3), dtype=np.int64)


def _cached_solve(cache, vertices, faces, settings, n_eigs, seed, index):
    """One sample's solve through the cache; ``faces`` is None for a point cloud."""
    points = faces is None
    solve = cloud_eigenpairs if points else mesh_eigenpairs
    arguments = (
        settings["laplacian"],
        settings["normalization"],
        settings["components"],
        n_eigs,
        seed,
        index,
        settings["solver"],
        settings["weld"],
    )
    inputs = (vertices,) if points else (vertices, faces)
    if cache is None:
        return solve(*inputs, *arguments)
    if not isinstance(cache, EigenCache):  # the user's own caching object
        return cache.cache(solve, ignore=["index"])(*inputs, *arguments)
    # A cloud is keyed with no faces, which no mesh has: the two kinds never collide.
    key = cache.key(
        vertices, _NO_FACES if points else faces, {**settings, "n_eigs": n_eigs, "seed": seed}
    )
    found = cache.load(key, len(vertices), n_eigs, points=points)
    if found is None:
        found = solve(*inputs, *arguments)
        cache.store(key, found)
    return found


def _eigen_one(mesh, index, *, indices, n_eigs, settings, seed, memory):
    """Clean and solve one mesh; ``indices`` are the eigenfunctions whose multiplicity
    the block must cover (none for signatures, which do not depend on the basis)."""
    with one_blas_thread():
        vertices, faces = check_input(mesh, index=index)
        limit = n_eigs + _MAX_GROWTH
        while True:
            clean, values, vectors = _cached_solve(
                memory, vertices, faces, settings, n_eigs, seed, index
            )
            n = len(clean.vertices)
            if n_eigs >= min(n, limit) or not _reaches_end(values, indices):
                break
            n_eigs = min(n_eigs + _EIGS_BLOCK, limit)
    complete = len(values) == n
    # The cleaning report travels back with the results: the parent warns, not the
    # worker, whose warnings joblib would not show.
    return clean, values, vectors, complete


def _warn_if_repeated(values: np.ndarray, indices, sample: int, complete: bool) -> None:
    for i in indices:
        if i == 0:
            continue
        close = _repeats(values, i)
        if len(close) < 2:
            continue
        open_ended = not complete and close[-1] == len(values) - 1
        lam = values[i]
        others = np.delete(values, close)
        gap = np.min(np.abs(others - lam)) / abs(lam) if len(others) else np.inf
        spread = (values[close].max() - values[close].min()) / abs(lam)
        warnings.warn(
            f"sample {sample}: eigenvalue {i} ({lam:.6g}) is repeated with multiplicity "
            f"{'at least ' if open_ended else ''}{len(close)} (eigenvalues {close[0]}-"
            f"{close[-1]} agree within a relative {spread:.1e}; relative gap to the next "
            f"distinct one {gap:.2g}); its eigenfunction is not unique",
            RepeatedEigenvalueWarning,
            stacklevel=4,
        )


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
        the package version and its numerics version, not on ``eigen_index``: a grid
        search over indices and signatures solves each mesh once. Entries are data only
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
        Seeds ARPACK's start vector (the same for every mesh). The default makes
        results reproducible; the output does not depend on it beyond rounding.
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
        Eigenpairs to solve, the constant one included: behind a signature (``None``:
        100), or at least as many as the eigenfunctions need (``None``: the block
        that covers ``eigen_index``). Every field keeps them all as ``spectrum`` (for
        :class:`ShapeDNA`). A grid over signatures, scales and indices with the same
        value reuses one cached solve per mesh (``memory``).
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
    multiplicity; the solve grows by at most 32 eigenpairs to find it, beyond which the
    warning says "multiplicity at least m".

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
        self._indices()

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

        Warns
        -----
        MeshCleaningWarning
            When cleaning drops more than 1% of a mesh's vertices or area.
        RepeatedEigenvalueWarning
            When a requested eigenvalue is repeated.
        """
        self._check_params()
        meshes = self._check_samples(X)
        indices = self._indices()
        if isinstance(self.random_state, Integral):
            seed = int(self.random_state)
        else:
            seed = int(check_random_state(self.random_state).randint(np.iinfo(np.int32).max))
        memory = _cache_of(self.memory)
        # Largest meshes first: workers that finish early pick up the small ones, so a
        # collection of mixed sizes keeps every worker busy to the end.
        order = sorted(range(len(meshes)), key=lambda i: -_size_hint(meshes[i]))
        signature = SIGNATURES[self.signature].value
        if signature is None:
            n_eigs, tracked = _block(max(max(indices) + 3, self.n_eigenpairs or 0)), indices
        else:
            n_eigs, tracked = _block(self.n_eigenpairs or _SIGNATURE_EIGENPAIRS), ()
        settings = {
            "laplacian": self.laplacian,
            "normalization": self.normalization,
            "components": self.components,
            "solver": self.solver,
            "weld": self.weld,
        }
        # Held for the whole parallel call: threads of a threading backend then share
        # one limit instead of setting and restoring it under each other's feet.
        with one_blas_thread():
            tasks = parallel(self.n_jobs)(
                delayed(_eigen_one)(
                    meshes[i],
                    i,
                    indices=tracked,
                    n_eigs=n_eigs,
                    settings=settings,
                    seed=seed,
                    memory=memory,
                )
                for i in order
            )
            solved = list(track(tasks, total=len(order), desc="eigensolves", verbose=self.verbose))
        results = [None] * len(meshes)
        for i, result in zip(order, solved, strict=True):
            results[i] = result
        fields = []
        column = indices[0] if not isinstance(self.eigen_index, tuple) else list(indices)
        for i, (clean, values, vectors, complete) in enumerate(results):
            report = clean.report
            # First: a mesh reduced to a few vertices is explained before it is refused.
            warn_if_lossy(report, describe(i, meshes[i]), stacklevel=3)
            _warn_if_needles(clean, i, stacklevel=3)
            if signature is not None:
                if len(values) < 2:
                    raise ValueError(f"sample {i}: the cleaned mesh has too few vertices")
                field_values, field_eigenvalues = signature(values, vectors, self.n_scales), None
            elif max(indices) >= len(values):
                raise ValueError(
                    f"sample {i}: eigen_index {max(indices)} needs at least "
                    f"{max(indices) + 1} vertices, the cleaned mesh has {len(values)}"
                )
            else:
                _warn_if_repeated(values, indices, i, complete)
                field_values, field_eigenvalues = vectors[:, column], values[column]
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
                )
            )
        return fields
