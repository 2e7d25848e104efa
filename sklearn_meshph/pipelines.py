"""Ready-made pipelines from meshes to a precomputed distance matrix: the library's
default, chosen by cross-validation, and the settings it is compared with; and every
option family of the package, for the documentation's tables."""

from __future__ import annotations

import os
from numbers import Integral

from sklearn.pipeline import Pipeline

from ._param_validation import HasMethods, Interval, Options, validate_params
from ._registry import Option, Registry
from .combine import CombinedDistance, FeatureDistance
from .diagrams import DiagramDistance
from .diagrams.distances import METRICS
from .persistence import LowerStarPersistence
from .persistence.filtrations import FILTRATIONS
from .spectral import LAPLACIANS, SIGNATURES, SOLVERS, LaplacianEigenTransformer, ShapeDNA
from .spectral.cache import cache_of

__all__ = ["PRESETS", "all_registries", "make_mesh_distance"]

# The extended-persistence diagrams of the default (ids of LowerStarPersistence's parts:
# the superlevel pairs (saddle, max), the components' ranges, the essential H1 of closed
# surfaces) and their weights.
_KINDS = {"ord1": 1.0, "ext0": 0.5, "ext1": 1.0}
_DNA_WEIGHT = 0.5
# The signature's eigenpairs, and the spectrum's (the constant pair included): the
# values cross-validation chose (docs/learning.md).
_EIGENPAIRS = 56
_DNA_EIGENPAIRS = 50
_SCALES = 5


def _default(common):
    eigen = LaplacianEigenTransformer(
        signature="log-hks", n_eigenpairs=_EIGENPAIRS, n_scales=_SCALES, **common["eigen"]
    )
    n_jobs, verbose = common["n_jobs"], common["verbose"]
    parts = [
        (
            kind,
            Pipeline(
                [
                    (
                        "persistence",
                        LowerStarPersistence(
                            filtration="extended", parts=(kind,), n_jobs=n_jobs, verbose=verbose
                        ),
                    ),
                    (
                        "distance",
                        DiagramDistance(
                            metric="wasserstein",
                            order=1.0,
                            internal_p=2.0,
                            normalization="median",
                            n_jobs=n_jobs,
                            verbose=verbose,
                        ),
                    ),
                ]
            ),
        )
        for kind in _KINDS
    ]
    parts.append(
        (
            "dna",
            Pipeline(
                [
                    ("spectrum", ShapeDNA(n_eigenpairs=_DNA_EIGENPAIRS)),
                    ("distance", FeatureDistance(metric="canberra", n_jobs=n_jobs)),
                ]
            ),
        )
    )
    weights = _KINDS | {"dna": _DNA_WEIGHT}
    return eigen, CombinedDistance(parts, weights=weights)


def _chain(eigen, persistence, distance):
    return eigen, Pipeline([("persistence", persistence), ("distance", distance)])


def _eigenfunctions(common):
    n_jobs, verbose = common["n_jobs"], common["verbose"]
    return _chain(
        LaplacianEigenTransformer(**common["eigen"]),
        LowerStarPersistence(n_jobs=n_jobs, verbose=verbose),
        DiagramDistance(n_jobs=n_jobs, verbose=verbose),
    )


def _paper(common):
    n_jobs, verbose = common["n_jobs"], common["verbose"]
    return _chain(
        LaplacianEigenTransformer(
            eigen_index=1, laplacian="graph", normalization="none", **common["eigen"]
        ),
        LowerStarPersistence(filtration="sublevel", n_jobs=n_jobs, verbose=verbose),
        DiagramDistance(metric="bottleneck", n_jobs=n_jobs, verbose=verbose),
    )


def _shape_dna(common):
    eigen = LaplacianEigenTransformer(signature="hks", n_eigenpairs=31, **common["eigen"])
    return eigen, Pipeline(
        [
            ("spectrum", ShapeDNA(n_eigenpairs=31)),
            ("distance", FeatureDistance(metric="canberra", n_jobs=common["n_jobs"])),
        ]
    )


PRESETS = Registry(
    "preset",
    [
        Option(
            "default",
            _default,
            "the library's default, chosen by cross-validation on SHREC'07 Watertight: "
            f"`log-hks` at {_SCALES} times from {_EIGENPAIRS} eigenpairs, extended "
            "persistence, W1 (Euclidean ground metric) per diagram kind, each time "
            "median-normalized, `ord1` + 0.5 `ext0` + `ext1` + 0.5 Shape-DNA "
            f"(the {_DNA_EIGENPAIRS - 1} non-zero eigenvalues, Canberra)",
        ),
        Option(
            "eigenfunctions",
            _eigenfunctions,
            "the estimators' own defaults (version 0.1's pipeline, formerly named "
            '`"0.1"`): eigenfunctions 1-3 of the cotangent Laplacian at unit area, '
            "symmetric H0, bottleneck",
        ),
        Option(
            "paper",
            _paper,
            "the paper's literal setting: Fiedler vector of the graph Laplacian, no "
            "normalization, sublevel H0 with essential classes, bottleneck",
        ),
        Option(
            "shape-dna",
            _shape_dna,
            "the spectral baseline: the first 30 non-zero eigenvalues at unit area, "
            "Canberra distance (sum of differences relative to their sums)",
        ),
    ],
    aliases={"0.1": "eigenfunctions"},
)


def all_registries() -> dict[str, Registry]:
    """Every option family, by name: what the documentation's tables are made from
    (``python docs/update_tables.py``)."""
    families = (LAPLACIANS, SOLVERS, SIGNATURES, FILTRATIONS, METRICS, PRESETS)
    return {registry.family: registry for registry in families}


@validate_params(
    {
        "preset": [Options(PRESETS), Options(PRESETS.aliases)],
        "memory": [None, str, os.PathLike, HasMethods(["cache"])],
        "n_jobs": [Integral, None],
        "random_state": ["random_state"],
        "verbose": [Interval(Integral, 0, None, closed="left")],
    }
)
def make_mesh_distance(preset="default", *, memory=None, n_jobs=None, random_state=0, verbose=0):
    """A pipeline from meshes to their precomputed distance matrix.

    Two steps, ``"eigen"`` (a :class:`LaplacianEigenTransformer`, one eigensolve per
    mesh, cached in ``memory``) and ``"distance"`` (everything after it), so that
    ``make_pipeline(make_mesh_distance(), KNeighborsClassifier(metric="precomputed"))``
    classifies meshes and ``make_mesh_distance().fit_transform(meshes)`` feeds
    ``TSNE(metric="precomputed", init="random")``. Every parameter of every stage stays
    reachable for ``set_params`` and grid searches (``distance__ext1__distance__order``,
    ``distance__weights``...).

    Parameters
    ----------
    preset : str, default="default"
        Which pipeline (the table of ``PRESETS``, also in the documentation, with each
        one's measured accuracy in ``docs/learning.md``):

        - ``"default"``: the library's best invariant configuration, chosen by
          cross-validation on the development half of SHREC'07 Watertight. The
          scale-invariant heat kernel signature ``log(HKS / heat trace)`` at 5 times
          from 56 eigenpairs, its extended persistence split by kind (ordinary
          superlevel pairs, the components' ranges, the essential H1 classes of closed
          surfaces), 1-Wasserstein distances with each time's distance divided by its
          median (the persistence of the signature shrinks with the time), the kinds
          and the Shape-DNA spectrum of the first 50 eigenpairs added with weights 1,
          0.5, 1 and 0.5 after median normalization (:class:`CombinedDistance`).
        - ``"eigenfunctions"``: the three estimators at their own defaults
          (eigenfunctions 1-3, version 0.1's pipeline); ``"0.1"``, its former name, is
          accepted with a ``FutureWarning``.
        - ``"paper"``: the paper's literal setting.
        - ``"shape-dna"``: the spectral baseline.
    memory : str, path, joblib.Memory or None, default=None
        Cache of the eigensolves (see :class:`LaplacianEigenTransformer`): with it, a
        second call or a grid search over the pipeline's parameters solves each mesh
        once. An empty path is refused.
    n_jobs : int, default=None
        Parallel jobs of every stage (joblib).
    random_state : int, RandomState or None, default=0
        Seed of the eigensolver's start vector, part of the cache's key: the fixed
        default makes results repeat and the cache hit; ``None`` draws a new start
        vector per call (results differ by rounding only), so the cache never hits.
    verbose : int, default=0
        Progress bars of the stages that have them.

    Returns
    -------
    sklearn.pipeline.Pipeline

    Examples
    --------
    >>> from sklearn.neighbors import KNeighborsClassifier
    >>> from sklearn.pipeline import make_pipeline
    >>> from sklearn_meshph import make_mesh_distance
    >>> model = make_pipeline(make_mesh_distance(), KNeighborsClassifier(1, metric="precomputed"))
    >>> make_mesh_distance("paper").named_steps["eigen"].laplacian
    'graph'
    """
    cache_of(memory)  # refuses an empty path before anything runs
    common = {
        "eigen": {
            "memory": memory,
            "n_jobs": n_jobs,
            "random_state": random_state,
            "verbose": verbose,
        },
        "n_jobs": n_jobs,
        "verbose": verbose,
    }
    eigen, distance = PRESETS[preset].value(common)  # a former name warns
    return Pipeline([("eigen", eigen), ("distance", distance)])
