"""make_graph_classifier: the graph pipeline, PersLay's heat kernel signatures of the
normalized Laplacian (every eigenpair) and their extended persistence, then a kernel SVM
on small training sets and extremely randomized trees on large ones (docs/graphs.md)."""

from __future__ import annotations

import os
from numbers import Integral

from sklearn.ensemble import ExtraTreesClassifier
from sklearn.pipeline import FeatureUnion, Pipeline

from ._param_validation import N_JOBS, HasMethods, Interval, Numbers, Options, validate_params
from .leaf_forest import LeafSizeForest
from .persistence import LowerStarPersistence
from .size_switch import SizeSwitchClassifier
from .spectral import LaplacianEigenTransformer
from .spectral.cache import cache_of
from .vectorization import (
    DiagramStatistics,
    GraphFeatures,
    GraphPairDistances,
    KernelSumSVC,
)
from .vectorization.graph_pairs import GRAPH_MIN_PERSISTENCE

__all__ = ["GRAPH_KINDS", "GRAPH_TIMES", "graph_eigen", "make_graph_classifier"]

#: PersLay's signature times (the ``"graph"`` preset's).
GRAPH_TIMES = (0.1, 10.0)
#: The four extended diagrams of a graph.
GRAPH_KINDS = ("ord0", "ord1", "ext0", "ext1")
# The classifier adds t = 1 between PersLay's times: a scale the two miss
# (docs/graphs.md).
_CLASSIFIER_TIMES = (0.1, 1.0, 10.0)
_TREES = 300
# Weisfeiler-Lehman iterations of the trees' GraphFeatures.
_WL_ITERATIONS = 3
# The largest training set of the kernel SVM (classifier="auto"): its distances grow as
# the square of the training graphs (2,000 graphs: 2 million pairs, a 0.4 GB stack,
# about 2 minutes on 2 cores for graphs of 400 nodes); the trees above
# (docs/graphs.md, benchmarks/bench_graph_classifier_cost.py).
_KERNEL_SAMPLES = 2000


def graph_eigen(eigen: dict, times=GRAPH_TIMES) -> LaplacianEigenTransformer:
    """PersLay's eigen stage: heat kernel signatures at ``times`` of the symmetric
    normalized Laplacian from every eigenpair, whole graphs, no normalization;
    ``eigen`` holds ``memory``, ``n_jobs``, ``random_state`` and ``verbose``."""
    return LaplacianEigenTransformer(
        laplacian="normalized",
        normalization="none",
        components="all",
        signature="hks",
        times=times,
        **eigen,
    )


@validate_params(
    {
        "times": [Numbers()],
        "classifier": [Options(("auto", "kernels", "trees"))],
        "n_estimators": [Interval(Integral, 1, None, closed="left")],
        "min_samples_leaf": [Interval(Integral, 1, None, closed="left"), tuple, list],
        "memory": [None, str, os.PathLike, HasMethods(["cache"])],
        "n_jobs": N_JOBS,
        "random_state": ["random_state"],
        "verbose": [Interval(Integral, 0, None, closed="left")],
    }
)
def make_graph_classifier(
    *,
    times=_CLASSIFIER_TIMES,
    classifier="auto",
    n_estimators=_TREES,
    min_samples_leaf=1,
    memory=None,
    n_jobs=None,
    random_state=0,
    verbose=0,
):
    """A classifier of graphs: signatures, their extended persistence, a kernel SVM or trees.

    The steps, each searchable like any pipeline's (``GridSearchCV`` over
    ``classifier__small__classifier__C``, ``classifier__large__features__graph__n_bins``,
    ``eigen__times``...):

    - ``"eigen"``: a :class:`LaplacianEigenTransformer` with PersLay's setting, the
      heat kernel signatures of the symmetric normalized Laplacian at fixed ``times``
      from every eigenpair (a dense solve), whole graphs (``components="all"``: a
      graph's components are part of it), no normalization;
    - ``"classifier"``: a :class:`~sklearn_meshph.size_switch.SizeSwitchClassifier`
      fitting, on at most 2,000 training graphs, its ``small`` pipeline, the kernel
      SVM:

      - ``"distances"`` (:class:`GraphPairDistances`): the sliced Wasserstein distance
        of each of the four extended diagrams (:class:`LowerStarPersistence` with
        ``filtration="extended"``) of each signature, the Weisfeiler-Lehman patterns'
        distance of the degrees, the maximum mean discrepancy of the nodes' signatures,
        the distance of the features (below) log-scaled and standardized on the
        training graphs;
      - ``"classifier"`` (:class:`KernelSumSVC`): the diagrams' kernels averaged into
        one, the nodes' and the features' into another, which of the three kernels to
        sum and ``C`` chosen by internal cross-validation on the training graphs;

      and on more training graphs (where the distances between every pair, which grow
      as their square, would cost minutes to hours) its ``large`` pipeline, trees:

      - ``"features"``: a ``FeatureUnion`` of ``"diagrams"`` (the four extended
        diagrams of each signature, then :class:`DiagramStatistics`) and ``"graph"``
        (:class:`GraphFeatures`: size, degrees, the spectrum's histogram, the
        signatures' quantiles, histograms of the distances between pairs of nodes, and
        hashed counts of the Weisfeiler-Lehman patterns of the degrees);
      - ``"classifier"``: an ``ExtraTreesClassifier``, which needs no scaling of these
        features of very different ranges and no tuning (or, given candidate leaf
        sizes, a :class:`~sklearn_meshph.leaf_forest.LeafSizeForest` choosing one per
        fit by out-of-bag accuracy on the training graphs).

    Edge weights enter the Laplacian only (the features and patterns read the edges);
    node labels or attributes are not used. Nothing in it is tuned per dataset;
    ``docs/graphs.md`` has its accuracy under PersLay's protocol on six TU datasets
    (the kernel SVM ahead of the trees on MUTAG, COX2, DHFR and PROTEINS, behind on
    NCI1 and IMDB-BINARY).

    Parameters
    ----------
    times : tuple of float, default=(0.1, 1.0, 10.0)
        Times of the heat kernel signatures: PersLay's 0.1 and 10, and 1 between them.
    classifier : {"auto", "kernels", "trees"}, default="auto"
        ``"auto"``: the switch above. ``"kernels"``: the kernel SVM at any size, its
        two steps after ``"eigen"`` (``"distances"``, ``"classifier"``).
        ``"trees"``: the trees at any size, their two steps after ``"eigen"``
        (``"features"``, ``"classifier"``).
    n_estimators : int, default=300
        Trees of the forest (of each candidate forest); unused by ``"kernels"``.
    min_samples_leaf : int or tuple of int, default=1
        The forest's leaf size, or candidate sizes chosen per fit out of bag (a
        :class:`~sklearn_meshph.leaf_forest.LeafSizeForest`; ``docs/graphs.md``
        compares them).
    memory : str, path, joblib.Memory or None, default=None
        Cache of the eigensolves (see :class:`LaplacianEigenTransformer`).
    n_jobs : int, default=None
        Parallel jobs of the eigen stage, persistence, the distances and the forest
        (joblib).
    random_state : int, RandomState or None, default=0
        Seed of the SVM's internal folds, of the nodes' random Fourier features, of the
        forest (and of the eigen stage's start vector, which a dense solve does not use).
    verbose : int, default=0
        Progress bars of the stages that have them.

    Returns
    -------
    sklearn.pipeline.Pipeline
        A classifier: ``fit(graphs, y)``, ``predict(graphs)``, ``score(graphs, y)``, on
        any graphs :func:`check_graph` reads.

    See Also
    --------
    make_mesh_distance : ``make_mesh_distance("graph")``, the same kinds of diagrams and
        features (at PersLay's two times) as a precomputed distance matrix (nearest
        neighbours, t-SNE).

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_meshph import make_graph_classifier
    >>> def cycle(n):
    ...     return n, np.array([[i, (i + 1) % n] for i in range(n)])
    >>> def path(n):
    ...     return n, np.array([[i, i + 1] for i in range(n - 1)])
    >>> graphs = [cycle(n) for n in range(5, 11)] + [path(n) for n in range(5, 11)]
    >>> model = make_graph_classifier(n_estimators=20).fit(graphs, [0] * 6 + [1] * 6)
    >>> model.predict([cycle(12), path(12)]).tolist()
    [0, 1]
    """
    cache_of(memory)  # refuses an empty path before anything runs
    eigen = graph_eigen(
        {"memory": memory, "n_jobs": n_jobs, "random_state": random_state, "verbose": verbose},
        tuple(times),
    )
    kernels = [
        ("distances", GraphPairDistances(n_jobs=n_jobs, random_state=random_state)),
        (
            "classifier",
            KernelSumSVC("graph", random_state=random_state),
        ),
    ]
    diagrams = Pipeline(
        [
            (
                "persistence",
                LowerStarPersistence(
                    filtration="extended",
                    min_persistence=GRAPH_MIN_PERSISTENCE,
                    n_jobs=n_jobs,
                    verbose=verbose,
                ),
            ),
            ("statistics", DiagramStatistics(n_jobs=n_jobs)),
        ]
    )
    graph = GraphFeatures(wl_iterations=_WL_ITERATIONS)
    if isinstance(min_samples_leaf, tuple | list):
        forest = LeafSizeForest(
            n_estimators, tuple(min_samples_leaf), n_jobs=n_jobs, random_state=random_state
        )
    else:
        forest = ExtraTreesClassifier(
            n_estimators,
            min_samples_leaf=min_samples_leaf,
            n_jobs=n_jobs,
            random_state=random_state,
        )
    trees = [
        ("features", FeatureUnion([("diagrams", diagrams), ("graph", graph)])),
        ("classifier", forest),
    ]
    if classifier == "kernels":
        return Pipeline([("eigen", eigen), *kernels])
    if classifier == "trees":
        return Pipeline([("eigen", eigen), *trees])
    switch = SizeSwitchClassifier(
        Pipeline(kernels), Pipeline(trees), max_small_samples=_KERNEL_SAMPLES
    )
    return Pipeline([("eigen", eigen), ("classifier", switch)])
