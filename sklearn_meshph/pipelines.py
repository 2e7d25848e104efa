"""Ready-made pipelines from meshes (or graphs) to a precomputed distance matrix: the
library's default, chosen by cross-validation, and the settings it is compared with; the
default's diagrams and spectrum as fixed-length features (the linear-cost path); and
every option family of the package, for the documentation's tables. The graph
classifier is in :mod:`sklearn_meshph.graph_classifier` (re-exported here)."""

from __future__ import annotations

import math
import os
from numbers import Integral

import numpy as np
from sklearn.pipeline import FeatureUnion, Pipeline
from sklearn.preprocessing import FunctionTransformer

from ._param_validation import N_JOBS, HasMethods, Interval, Options, validate_params
from ._registry import Option, Registry
from .combine import CombinedDistance, FeatureDistance
from .diagrams import DiagramDistance
from .diagrams.distances import METRICS
from .graph_classifier import GRAPH_KINDS, graph_eigen, make_graph_classifier
from .persistence import LowerStarPersistence
from .persistence.filtrations import FILTRATIONS
from .spectral import LAPLACIANS, SIGNATURES, SOLVERS, LaplacianEigenTransformer, ShapeDNA
from .spectral.cache import cache_of
from .vectorization import (
    DistanceScaler,
    GraphFeatures,
    PersistenceLandscape,
)

__all__ = [
    "PRESETS",
    "all_registries",
    "make_graph_classifier",
    "make_mesh_distance",
    "make_mesh_features",
]

# The extended-persistence diagrams of the default (ids of LowerStarPersistence's parts:
# the superlevel pairs (saddle, max), the components' ranges, the essential H1 of closed
# surfaces) and their weights.
_KINDS = {"ord1": 1.0, "ext0": 0.5, "ext1": 1.0}
_DNA_WEIGHT = 0.5
# The signature's eigenpairs, and the spectrum's (the constant pair included): the
# fewest at which cross-validation on watertight_dev keeps the accuracy of the 56 and
# 50 chosen first (docs/learning.md, docs/scale.md), one solve of 48 for both.
_EIGENPAIRS = 48
_DNA_EIGENPAIRS = 48
_SCALES = 5
# The linear-cost preset: landscapes per diagram and their grid points (docs/scale.md).
_LANDSCAPES = 5
_LANDSCAPE_RESOLUTION = 20


def _kind_persistence(kind, common):
    """The extended diagrams of one kind, one per signature time."""
    return LowerStarPersistence(
        filtration="extended", parts=(kind,), n_jobs=common["n_jobs"], verbose=common["verbose"]
    )


def _kind_distances(kinds, common):
    """One part per extended diagram kind: its persistence, then W1 (Euclidean ground
    metric) between the samples, median-normalized."""
    n_jobs, verbose = common["n_jobs"], common["verbose"]
    return [
        (
            kind,
            Pipeline(
                [
                    ("persistence", _kind_persistence(kind, common)),
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
        for kind in kinds
    ]


def _default_eigen(common):
    return LaplacianEigenTransformer(
        signature="log-hks", n_eigenpairs=_EIGENPAIRS, n_scales=_SCALES, **common["eigen"]
    )


def _default(common):
    eigen = _default_eigen(common)
    parts = _kind_distances(_KINDS, common)
    parts.append(
        (
            "dna",
            Pipeline(
                [
                    ("spectrum", ShapeDNA(n_eigenpairs=_DNA_EIGENPAIRS)),
                    ("distance", FeatureDistance(metric="canberra", n_jobs=common["n_jobs"])),
                ]
            ),
        )
    )
    weights = _KINDS | {"dna": _DNA_WEIGHT}
    return eigen, CombinedDistance(parts, weights=weights)


def _feature_union(common):
    """The default's parts as blocks of features: the landscapes of each diagram kind
    (every time a block of its own) and the logarithm of the Shape-DNA spectrum, each
    scaled to a root-mean-square distance of 1, weighted by the square roots of the
    default's weights (squared Euclidean distances add the parts as the default adds
    its distances)."""
    parts = [
        (
            kind,
            Pipeline(
                [
                    ("persistence", _kind_persistence(kind, common)),
                    (
                        "landscape",
                        PersistenceLandscape(
                            n_landscapes=_LANDSCAPES,
                            resolution=_LANDSCAPE_RESOLUTION,
                            n_jobs=common["n_jobs"],
                        ),
                    ),
                    ("scale", DistanceScaler(n_blocks=_SCALES)),
                ]
            ),
        )
        for kind in _KINDS
    ]
    spectrum = Pipeline(
        [
            ("spectrum", ShapeDNA(n_eigenpairs=_DNA_EIGENPAIRS)),
            ("log", FunctionTransformer(np.log, feature_names_out="one-to-one")),
            ("scale", DistanceScaler()),
        ]
    )
    weights = {name: math.sqrt(w) for name, w in (_KINDS | {"dna": _DNA_WEIGHT}).items()}
    return FeatureUnion([*parts, ("dna", spectrum)], transformer_weights=weights)


def _features(common):
    distance = FeatureDistance(metric="euclidean", n_jobs=common["n_jobs"])
    return _default_eigen(common), Pipeline(
        [("features", _feature_union(common)), ("distance", distance)]
    )


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


def _graph(common):
    parts = _kind_distances(GRAPH_KINDS, common)
    features = Pipeline(
        [
            ("graph", GraphFeatures()),
            ("distance", FeatureDistance(metric="canberra", n_jobs=common["n_jobs"])),
        ]
    )
    return graph_eigen(common["eigen"]), CombinedDistance([*parts, ("features", features)])


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
        Option(
            "features",
            _features,
            "the default's diagrams and spectrum as fixed-length features "
            "(`make_mesh_features()`, for linear models and approximate nearest-neighbour "
            f"indexes), Euclidean distance: {_LANDSCAPES} landscapes of {_LANDSCAPE_RESOLUTION} "
            "points per diagram, the spectrum's logarithm, each part and time scaled to a "
            "root-mean-square distance of 1 (`DistanceScaler`), weighted by the square roots "
            "of the default's weights",
        ),
        Option(
            "graph",
            _graph,
            "graphs (PersLay's signatures): heat kernel signatures of the normalized "
            "Laplacian at t = 0.1 and 10 from every eigenpair, whole graphs, the four "
            "diagrams of extended persistence on the graph, W1 per diagram kind, plus "
            "`GraphFeatures` (size, spectrum, signature quantiles, pair distances; "
            "Canberra), each median-normalized, equal weights",
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
        "n_jobs": N_JOBS,
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
          from 48 eigenpairs, its extended persistence split by kind (ordinary
          superlevel pairs, the components' ranges, the essential H1 classes of closed
          surfaces), 1-Wasserstein distances with each time's distance divided by its
          median (the persistence of the signature shrinks with the time), the kinds
          and the Shape-DNA spectrum of the first 48 eigenpairs added with weights 1,
          0.5, 1 and 0.5 after median normalization (:class:`CombinedDistance`).
        - ``"eigenfunctions"``: the three estimators at their own defaults
          (eigenfunctions 1-3, version 0.1's pipeline); ``"0.1"``, its former name, is
          accepted with a ``FutureWarning``.
        - ``"paper"``: the paper's literal setting.
        - ``"shape-dna"``: the spectral baseline.
        - ``"features"``: the Euclidean distance between the fixed-length features of
          :func:`make_mesh_features` (the default's diagrams and spectrum, vectorized).
        - ``"graph"``: for graphs (what the main job runs on a TU dataset folder):
          the diagrams and features of :func:`make_graph_classifier` as distances.
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
    common = _common(memory, n_jobs, random_state, verbose)
    eigen, distance = PRESETS[preset].value(common)  # a former name warns
    return Pipeline([("eigen", eigen), ("distance", distance)])


def _common(memory, n_jobs, random_state, verbose):
    cache_of(memory)  # refuses an empty path before anything runs
    return {
        "eigen": {
            "memory": memory,
            "n_jobs": n_jobs,
            "random_state": random_state,
            "verbose": verbose,
        },
        "n_jobs": n_jobs,
        "verbose": verbose,
    }


@validate_params(
    {
        "memory": [None, str, os.PathLike, HasMethods(["cache"])],
        "n_jobs": N_JOBS,
        "random_state": ["random_state"],
        "verbose": [Interval(Integral, 0, None, closed="left")],
    }
)
def make_mesh_features(*, memory=None, n_jobs=None, random_state=0, verbose=0):
    """A pipeline from meshes to fixed-length feature vectors: the linear-cost path.

    The default's eigen stage and diagrams (:func:`make_mesh_distance`), vectorized:
    for each extended diagram kind (``"ord1"``, ``"ext0"``, ``"ext1"``), the first 5
    persistence landscapes of each time's diagram on a grid of 20 points learned by
    ``fit`` (:class:`PersistenceLandscape`), and the logarithm of the Shape-DNA
    spectrum (the 47 non-zero eigenvalues: differences of logarithms are relative
    differences, as Canberra's are). Each part, and each time within a part, is scaled
    to a root-mean-square distance of 1 among the fitted meshes (:class:`DistanceScaler`,
    one pass over the rows), and the parts are weighted by the square roots of the
    default's weights, so that the squared Euclidean distance adds the parts as the
    default adds its distances. The result is the same length for every mesh, finite,
    and its Euclidean distance is what ``make_mesh_distance("features")`` computes:
    rows for linear models (after ``StandardScaler``), and for approximate
    nearest-neighbour indexes, whose cost grows linearly with the collection where a
    precomputed distance matrix grows as its square.

    Two steps, ``"eigen"`` and ``"features"`` (a ``FeatureUnion`` of ``"ord1"``,
    ``"ext0"``, ``"ext1"`` and ``"dna"``), every parameter reachable for
    ``set_params`` and grid searches (``features__ord1__landscape__n_landscapes``,
    ``features__transformer_weights``...).

    Parameters
    ----------
    memory : str, path, joblib.Memory or None, default=None
        Cache of the eigensolves (see :class:`LaplacianEigenTransformer`), shared with
        :func:`make_mesh_distance`: the same solve serves both.
    n_jobs : int, default=None
        Parallel jobs of every stage (joblib).
    random_state : int, RandomState or None, default=0
        Seed of the eigensolver's start vector, part of the cache's key.
    verbose : int, default=0
        Progress bars of the stages that have them.

    Returns
    -------
    sklearn.pipeline.Pipeline
        A transformer: ``fit_transform(meshes)`` returns an array of shape
        ``(n_meshes, 1547)`` (3 kinds x 5 times x 5 landscapes x 20 points, and 47
        eigenvalues).

    See Also
    --------
    make_mesh_distance : ``make_mesh_distance("features")``, the same features'
        Euclidean distances as a precomputed matrix.

    Examples
    --------
    >>> from sklearn.linear_model import LogisticRegression
    >>> from sklearn.pipeline import make_pipeline
    >>> from sklearn.preprocessing import StandardScaler
    >>> from sklearn_meshph import make_mesh_features
    >>> model = make_pipeline(make_mesh_features(), StandardScaler(), LogisticRegression())
    >>> make_mesh_features().named_steps["features"].transformer_weights["ext0"] ** 2
    0.5...
    """
    common = _common(memory, n_jobs, random_state, verbose)
    return Pipeline([("eigen", _default_eigen(common)), ("features", _feature_union(common))])
