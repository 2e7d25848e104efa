"""Learning quality: leave-one-out 1-NN accuracy of descriptors on real collections.

    python benchmarks/learning_quality.py [--collections watertight_dev sumner shapes]
                                          [--n-jobs 2] [--cache DIR] [--clouds]
                                          [--no-models] [--no-features] [--no-gh]
    python benchmarks/learning_quality.py --clouds-only [--densities 1000 3000 10000]
                                          [--noises 0 0.005] [--cloud-subset N]
                                          [--scans noise density holes outliers]
                                          [--scan-densities 3000 10000]

Every configuration is a scikit-learn pipeline from meshes to a precomputed distance
matrix, scored by leave-one-out 1-NN on the full matrix (each mesh classified by its
nearest other mesh), with the time of each configuration beside it (loading excluded,
eigensolves cached across configurations with the same eigen stage: the time of the
first one includes the solves). Collections: the SHREC'07 Watertight development half
and the Sumner meshes (from SKLEARN_MESHPH_DATA, default ../shared/data) and
``make_shapes``. The baselines (Shape-DNA, and the Gromov-Hausdorff signatures of
``gh_signatures.py`` that the paper compares itself with, unless ``--no-gh``) run in the
same process; learned models on the default's diagrams are scored by nested
cross-validation (unless ``--no-models``), and so is the linear-cost path
``make_mesh_features()`` (``linear_path.py``: 1-NN with its configuration chosen inside
each training split, linear models; unless ``--no-features``). The retrieval measures
of the SHREC contests (``retrieval_scores``: nearest neighbour, first and second tier,
DCG, mean average precision) of the default and of the ``"features"`` preset are
printed after the tables.

With ``--clouds`` (after the mesh tables) or ``--clouds-only`` (alone), the point-cloud
section: points sampled on each mesh's surface with ``sample_point_cloud`` at each of
``--densities``, with Gaussian noise of each of ``--noises`` (relative to the bounding-box
diagonal; seed = the mesh's index, so every run draws the same clouds), run through the
default pipeline ``make_mesh_distance()`` and scored by the same leave-one-out and
10 x 5-fold 1-NN, beside the default pipeline on the meshes themselves. ``--scans``
adds clouds with the defects of real scans (``SCANS``: noise of 1% of the diagonal,
one half four times denser, three holes, five outliers), at each of
``--scan-densities``; the cleaning warnings of their far points are silenced.
``--cloud-subset N`` keeps the first N meshes of each class (all by default).
"""

from __future__ import annotations

import argparse
import resource
import tempfile
import time
import tracemalloc
import warnings

import joblib
import numpy as np
from _common import DATA, collection, cv_1nn, folds, loo_1nn
from linear_path import nested_features, print_nested_features, print_rows
from sklearn.base import clone
from sklearn.model_selection import (
    GridSearchCV,
    StratifiedKFold,
    cross_val_score,
)
from sklearn.pipeline import make_pipeline

from sklearn_meshph import (
    DiagramDistance,
    FeatureDistance,
    LaplacianEigenTransformer,
    LowerStarPersistence,
    MeshCleaningWarning,
    ShapeDNA,
    make_mesh_distance,
    retrieval_scores,
    sample_point_cloud,
)
from sklearn_meshph.mesh import check_mesh
from sklearn_meshph.spectral.solve import SolveSettings, mesh_eigenpairs


def split(pipeline):
    """A preset's (eigen stage, distance stage)."""
    return pipeline.named_steps["eigen"], pipeline.named_steps["distance"]


def alone(signature, n_jobs, memory, **eigen):
    """One signature's extended persistence (ordinary superlevel pairs, ranges and
    essential H1), W1 with each function's distance median-normalized."""
    stage = LaplacianEigenTransformer(
        signature=signature, memory=memory, n_jobs=n_jobs, random_state=0, **eigen
    )
    return stage, make_pipeline(
        LowerStarPersistence(filtration="extended", parts=KINDS, n_jobs=n_jobs),
        DiagramDistance(
            metric="wasserstein", order=1.0, internal_p=2.0, normalization="median", n_jobs=n_jobs
        ),
    )


KINDS = ("superlevel H0 (saddle, max)", "(min, max)", "essential H1")


def configurations(memory, n_jobs):
    """Name -> (eigen stage, distance stage on its fields)."""
    preset = {"memory": memory, "n_jobs": n_jobs, "random_state": 0}
    dna = {"signature": "hks", "n_eigenpairs": 50}
    default = make_mesh_distance(**preset)
    without_dna = clone(default).set_params(distance__weights={"ext0": 0.5, "dna": 0.0})
    without_ext1 = clone(default).set_params(
        distance__weights={"ext0": 0.5, "ext1": 0.0, "dna": 0.5}
    )
    return {
        DEFAULT: split(default),
        '"eigenfunctions", 0.1\'s default (eigenfunctions 1-3, symmetric H0, bottleneck)': split(
            make_mesh_distance("eigenfunctions", **preset)
        ),
        "paper literal (graph Laplacian, Fiedler vector, sublevel H0, bottleneck)": split(
            make_mesh_distance("paper", **preset)
        ),
        "Shape-DNA 7, Euclidean": (
            LaplacianEigenTransformer(random_state=0, memory=memory, n_jobs=n_jobs, **dna),
            make_pipeline(ShapeDNA(n_eigenpairs=8), FeatureDistance(metric="euclidean")),
        ),
        "Shape-DNA 30, Canberra (preset shape-dna)": split(
            make_mesh_distance("shape-dna", **preset)
        ),
        "Shape-DNA 49, Canberra": (
            LaplacianEigenTransformer(random_state=0, memory=memory, n_jobs=n_jobs, **dna),
            make_pipeline(ShapeDNA(n_eigenpairs=50), FeatureDistance()),
        ),
        "eigenfunctions 1-5 alone, extended, W1": alone(
            "eigenfunctions", n_jobs, memory, eigen_index=(1, 2, 3, 4, 5), n_eigenpairs=56
        ),
        "HKS x5 alone, extended, W1": alone("hks", n_jobs, memory, n_eigenpairs=56, n_scales=5),
        "log-HKS x5 alone, extended, W1": alone(
            "log-hks", n_jobs, memory, n_eigenpairs=56, n_scales=5
        ),
        "WKS x5 alone, extended, W1": alone("wks", n_jobs, memory, n_eigenpairs=56, n_scales=5),
        "default without Shape-DNA": split(without_dna),
        "default without essential H1": split(without_ext1),
        FEATURES: split(make_mesh_distance("features", **preset)),
    }


DEFAULT = "default (make_mesh_distance())"
# The default's eigenpairs (the solve whose peak memory is reported).
DEFAULT_EIGENPAIRS = make_mesh_distance().named_steps["eigen"].n_eigenpairs
FEATURES = 'linear-cost features, Euclidean (make_mesh_distance("features"))'
#: The configurations whose retrieval measures are printed.
RETRIEVED = (DEFAULT, FEATURES)


def median_scale(block):
    off = block[~np.eye(len(block), dtype=bool)]
    off = off[np.isfinite(off) & (off > 0)]
    return float(np.median(off)) if off.size else 1.0


WEIGHT_GRID = [
    {"ext0": e0, "ext1": e1, "dna": d}
    for e0 in (0.5, 1.0)
    for e1 in (0.0, 1.0, 2.0)
    for d in (0.0, 0.25, 0.5, 1.0)
]


def combined(parts, weights):
    return sum(weights.get(name, 1.0) * m for name, m in parts.items())


def nested_weights(fields, distance, y):
    """An honest estimate of choosing the default's weights by cross-validation: for each
    outer split, the weights of WEIGHT_GRID with the best leave-one-out 1-NN on the
    training meshes (each part normalized by its median there) classify the test meshes.
    Returns the mean outer accuracy and how often each weight setting won."""
    parts = {
        name: np.asarray(part.fit_transform(fields)) for name, part in distance.transformer_list
    }
    scores, chosen = [], {}
    for train, test in folds(y):
        scaled = {name: m / median_scale(m[np.ix_(train, train)]) for name, m in parts.items()}

        inner = [loo_1nn(combined(scaled, w)[np.ix_(train, train)], y[train]) for w in WEIGHT_GRID]
        best = WEIGHT_GRID[int(np.argmax(inner))]
        chosen[str(best)] = chosen.get(str(best), 0) + 1
        matrix = combined(scaled, best)
        scores.append(np.mean(y[train][np.argmin(matrix[np.ix_(test, train)], axis=1)] == y[test]))
    return float(np.mean(scores)), chosen


def learned_models(n_jobs):
    """Name -> (model on the default's diagrams, its grid): vectorizations with a linear
    model and with gradient boosting, a kernel with an SVM."""
    from sklearn.ensemble import HistGradientBoostingClassifier
    from sklearn.linear_model import LogisticRegression
    from sklearn.pipeline import make_union
    from sklearn.preprocessing import StandardScaler
    from sklearn.svm import SVC

    from sklearn_meshph import DiagramStatistics, PersistenceEntropy, PersistenceImage

    models = {
        "persistence images + logistic regression": (
            make_pipeline(
                PersistenceImage(resolution=(10, 10), weight="persistence", n_jobs=n_jobs),
                StandardScaler(),
                LogisticRegression(max_iter=3000),
            ),
            {
                "persistenceimage__bandwidth": [0.05, 0.2],
                "logisticregression__C": [0.01, 0.1, 1.0],
            },
        ),
        "statistics + entropy + gradient boosting": (
            make_pipeline(
                make_union(DiagramStatistics(n_jobs=n_jobs), PersistenceEntropy(n_jobs=n_jobs)),
                HistGradientBoostingClassifier(max_iter=100, random_state=0),
            ),
            {"histgradientboostingclassifier__learning_rate": [0.05, 0.2]},
        ),
    }
    try:
        from sklearn_meshph.vectorization.kernels import SlicedWassersteinKernel
    except ImportError:
        return models
    models["sliced Wasserstein kernel + SVM"] = (
        make_pipeline(
            SlicedWassersteinKernel(n_directions=10, n_jobs=n_jobs), SVC(kernel="precomputed")
        ),
        {
            "slicedwassersteinkernel__bandwidth": [0.3, 1.0, 3.0],
            "svc__C": [1.0, 10.0, 100.0],
        },
    )
    return models


def nested_models(fields, y, n_jobs):
    """Nested 5-fold accuracy of each learned model on the default's diagrams: the grid
    search runs on each outer training split (3-fold inside), the outer test split scores
    the refitted best model. The diagrams come from unsupervised stages that learn
    nothing, so they are computed once."""
    diagrams = LowerStarPersistence(
        filtration="extended", parts=KINDS, n_jobs=n_jobs
    ).fit_transform(fields)
    n_splits = min(5, int(np.bincount(y).min()))
    outer = StratifiedKFold(n_splits=n_splits, shuffle=True, random_state=0)
    inner = StratifiedKFold(n_splits=min(3, n_splits), shuffle=True, random_state=1)
    results = {}
    for name, (model, grid) in learned_models(n_jobs).items():
        start = time.perf_counter()
        search = GridSearchCV(model, grid, cv=inner)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            scores = cross_val_score(search, diagrams, y, cv=outer)
        results[name] = (float(scores.mean()), float(scores.std()), time.perf_counter() - start)
        print(f"    {name}: nested CV {scores.mean():.3f} +/- {scores.std():.3f}", flush=True)
    return results


GH_ROWS = {
    "H0+H1": "GH comparator (Chazal et al. 2009): Rips H0+H1 of geodesics, bottleneck",
    "H1": "GH comparator, Rips H1 only",
    "H0": "GH comparator, Rips H0 only",
}


def gh_comparator(meshes, y, n_jobs, results, name):
    """The metric-based signatures the paper compares itself with (gh_signatures.py):
    scored with the same protocol, timed per mesh."""
    try:
        from gh_signatures import N_SAMPLES, gh_distance_matrices, rips_backend

        backend = rips_backend()
    except ImportError as error:
        print(f"  no GH comparator: {error} (needs ripser or gudhi, the bench extra)")
        return
    start = time.perf_counter()
    found = gh_distance_matrices(meshes, n_jobs=n_jobs)
    seconds = time.perf_counter() - start
    for key, row in GH_ROWS.items():
        results[row, name] = (loo_1nn(found[key], y), cv_1nn(found[key], y), seconds)
        print(f"  {name:15s} {row}: {results[row, name][0]:.3f}", flush=True)
    print(f"  ({N_SAMPLES} farthest-point samples per mesh, {backend[0]} {backend[1]})")


def solve_memory(mesh, n_eigenpairs):
    """Peak traced memory (MB) of one mesh's cleaning and eigensolve of n_eigenpairs pairs."""
    vertices, faces = check_mesh(mesh)
    mesh_eigenpairs(vertices, faces, SolveSettings(), n_eigenpairs, 0, 0)  # warm
    tracemalloc.start()
    mesh_eigenpairs(vertices, faces, SolveSettings(), n_eigenpairs, 0, 0)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return peak / 2**20


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--collections", nargs="+", default=["watertight_dev", "sumner", "shapes"])
    parser.add_argument("--n-jobs", type=int, default=2)
    parser.add_argument("--cache", default=None, help="eigensolve cache folder (default: temp)")
    parser.add_argument(
        "--no-models", dest="models", action="store_false", help="skip the learned models"
    )
    parser.add_argument(
        "--no-features",
        dest="features",
        action="store_false",
        help="skip the nested cross-validation of the linear-cost features (linear_path.py)",
    )
    parser.add_argument(
        "--no-gh",
        dest="gh",
        action="store_false",
        help="skip the Gromov-Hausdorff comparator (gh_signatures.py; minutes per collection)",
    )
    parser.add_argument(
        "--clouds", action="store_true", help="also the point-cloud section (after the meshes)"
    )
    parser.add_argument("--clouds-only", action="store_true", help="only the point-cloud section")
    parser.add_argument(
        "--cloud-collections",
        nargs="+",
        default=["watertight_dev", "sumner"],
        help="collections of the point-cloud section",
    )
    parser.add_argument(
        "--densities", type=int, nargs="*", default=[1000, 3000, 10000], help="points per cloud"
    )
    parser.add_argument(
        "--noises",
        type=float,
        nargs="+",
        default=[0.0, 0.005],
        help="noise of the clouds, relative to the bounding-box diagonal",
    )
    parser.add_argument(
        "--cloud-subset",
        type=int,
        default=None,
        help="the first N meshes of each class in the point-cloud section (default: all)",
    )
    parser.add_argument(
        "--scans",
        nargs="*",
        choices=list(SCANS),
        default=[],
        help="clouds with the defects of real scans (SCANS) in the point-cloud section",
    )
    parser.add_argument(
        "--scan-densities",
        type=int,
        nargs="+",
        default=[3000],
        help="points per cloud of the --scans conditions",
    )
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as temporary:
        memory = joblib.Memory(args.cache or temporary, verbose=0)
        if not args.clouds_only:
            run(args, memory)
        if args.clouds or args.clouds_only:
            run_clouds(args, memory)


def run(args, memory):
    results, loading, n_meshes = {}, {}, {}
    for name in args.collections:
        start = time.perf_counter()
        loaded = collection(name, args.n_jobs)
        if loaded is None:
            print(f"skipping {name}: not found in {DATA}")
            continue
        meshes, y, _ = loaded
        loading[name] = time.perf_counter() - start
        for config, (stage, distances) in configurations(memory, args.n_jobs).items():
            start = time.perf_counter()
            fields = stage.fit_transform(meshes)
            matrix = distances.fit_transform(fields)
            seconds = time.perf_counter() - start
            results[config, name] = (loo_1nn(matrix, y), cv_1nn(matrix, y), seconds)
            print(f"  {name:15s} {config}: {results[config, name][0]:.3f}", flush=True)
            if config in RETRIEVED:
                results["retrieval", config, name] = retrieval_scores(matrix, y)
            if config == DEFAULT:
                default_fields, default_distance = fields, distances
        if args.gh:
            gh_comparator(meshes, y, args.n_jobs, results, name)
        n_meshes[name] = len(meshes)
        nested, chosen = nested_weights(default_fields, default_distance, y)
        print(f"  {name:15s} nested CV of the default's weights: {nested:.3f}; chosen {chosen}")
        results["nested", name] = nested
        if args.models:
            results["models", name] = nested_models(default_fields, y, args.n_jobs)
        if args.features:
            results["features", name] = nested_features(default_fields, y)
        largest = max(meshes, key=lambda m: len(m.vertices))
        results["memory", name] = (
            len(largest.vertices),
            solve_memory(largest, 8),
            solve_memory(largest, DEFAULT_EIGENPAIRS),
        )
    names = [n for n in args.collections if ("nested", n) in results]
    print("\nLeave-one-out and 10 x 5-fold 1-NN accuracy; seconds from loaded meshes to the")
    print("matrix (the first configuration of an eigen stage includes its eigensolves), and")
    print("milliseconds per mesh:\n")
    print(
        "| configuration | "
        + " | ".join(f"{n} LOO | {n} 5-fold | {n} s | {n} ms/mesh" for n in names)
        + " |"
    )
    print("|---|" + "---|---|---|---|" * len(names))
    rows = list(configurations(memory, args.n_jobs))
    rows += [row for row in GH_ROWS.values() if any((row, n) in results for n in names)]
    for config in rows:
        cells = []
        for n in names:
            loo, cv, seconds = results.get((config, n), (float("nan"),) * 3)
            cells += [f"{loo:.3f}", f"{cv:.3f}", f"{seconds:.1f}"]
            cells.append(f"{1000 * seconds / n_meshes[n]:.0f}")
        print(f"| {config} | " + " | ".join(cells) + " |")
    baseline = "Shape-DNA 30, Canberra (preset shape-dna)"
    print(
        "\n| collection | default / Shape-DNA 30 (LOO) | nested CV of the default's weights "
        "| loading s | largest mesh | solve MB, 8 pairs (0.1) "
        f"| solve MB, {DEFAULT_EIGENPAIRS} pairs (default) |"
    )
    print("|---|---|---|---|---|---|---|")
    for n in names:
        ratio = results[DEFAULT, n][0] / results[baseline, n][0]
        vertices, small, large = results["memory", n]
        print(
            f"| {n} | {ratio:.3f} | {results['nested', n]:.3f} | {loading[n]:.1f} | "
            f"{vertices} vertices | {small:.0f} | {large:.0f} |"
        )
    if args.models:
        print(
            "\nLearned models on the default's diagrams, nested 5-fold accuracy (grid search "
            "inside each training split), beside the default's 10 x 5-fold 1-NN:\n"
        )
        print("| model | " + " | ".join(f"{n} nested | {n} s" for n in names) + " |")
        print("|---|" + "---|---|" * len(names))
        rows = {
            "default 1-NN (10 x 5-fold, no tuning)": {
                n: (results[DEFAULT, n][1], 0.0, float("nan")) for n in names
            }
        }
        for n in names:
            for model, value in results["models", n].items():
                rows.setdefault(model, {})[n] = value
        print_rows(rows, names)
    print_retrieval(results, names)
    if args.features:
        print_nested_features(results, names)
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"\npeak resident memory of this process: {peak:.0f} MB")


def print_retrieval(results, names):
    """The retrieval measures of the SHREC contests (``retrieval_scores``) of the
    configurations of RETRIEVED, each mesh querying all the others of the full matrix."""
    print("\nRetrieval measures (each mesh queries all the others):\n")
    measures = ("nearest_neighbor", "first_tier", "second_tier", "dcg", "mean_average_precision")
    print("| collection | configuration | " + " | ".join(measures) + " |")
    print("|---|---|" + "---|" * len(measures))
    for n in names:
        for config in RETRIEVED:
            scores = results.get(("retrieval", config, n))
            if scores is not None:
                cells = " | ".join(f"{scores[m]:.3f}" for m in measures)
                print(f"| {n} | {config} | {cells} |")


def subset(y, per_class):
    """Indices of the first ``per_class`` samples of each class (all with None)."""
    if per_class is None:
        return np.arange(len(y))
    return np.concatenate([np.flatnonzero(y == c)[:per_class] for c in np.unique(y)])


def score_default(samples, y, memory, n_jobs, **params):
    """(LOO, 10 x 5-fold, seconds) of ``make_mesh_distance()`` (with ``params`` set) on
    ``samples``."""
    start = time.perf_counter()
    pipeline = make_mesh_distance(memory=memory, n_jobs=n_jobs, random_state=0)
    matrix = pipeline.set_params(**params).fit_transform(samples)
    seconds = time.perf_counter() - start
    return loo_1nn(matrix, y), cv_1nn(matrix, y), seconds


NO_EXT1 = "meshes, without essential H1"

#: The defects of real scans (issue 27): name -> (row label, sample_point_cloud options).
SCANS = {
    "noise": ("noise 0.01", {"noise": 0.01}),
    "density": ("one half 4x denser", {"density": 4.0}),
    "holes": ("3 holes (10% of the points)", {"holes": 3, "hole_fraction": 0.1}),
    "outliers": ("5 outliers", {"outliers": 5}),
}


def cloud_conditions(args):
    """(row label, n_points, sample_point_cloud options) of every cloud row."""
    conditions = [
        (f"{n} points, noise {noise:g}", n, {"noise": noise})
        for n in args.densities
        for noise in args.noises
    ]
    for n in args.scan_densities:
        for scan in args.scans:
            label, options = SCANS[scan]
            conditions.append((f"{n} points, {label}", n, options))
    return conditions


def run_clouds(args, memory):
    """The point-cloud section: the default pipeline on clouds sampled from each
    collection's meshes, beside the same pipeline on the meshes."""
    rows, sizes = {}, {}
    names = []
    for name in args.cloud_collections:
        loaded = collection(name, args.n_jobs)
        if loaded is None:
            print(f"skipping {name}: not found in {DATA}")
            continue
        meshes, y, _ = loaded
        keep = subset(y, args.cloud_subset)
        meshes, y = [meshes[i] for i in keep], y[keep]
        names.append(name)
        vertices = np.array([len(m.vertices) for m in meshes])
        sizes[name] = (
            len(meshes),
            int(np.median(vertices)),
            int(vertices.min()),
            int(vertices.max()),
        )
        rows.setdefault("meshes", {})[name] = score_default(meshes, y, memory, args.n_jobs)
        print(f"  {name:15s} meshes: {rows['meshes'][name][0]:.3f}", flush=True)
        # A cloud has no essential H1 (its kNN graph's cycles are not the surface's):
        # the same pipeline on the meshes without that part.
        rows.setdefault(NO_EXT1, {})[name] = score_default(
            meshes, y, memory, args.n_jobs, distance__weights={"ext0": 0.5, "ext1": 0.0, "dna": 0.5}
        )
        print(f"  {name:15s} {NO_EXT1}: {rows[NO_EXT1][name][0]:.3f}", flush=True)
        for row, n_points, options in cloud_conditions(args):
            clouds = [
                sample_point_cloud(m, n_points, random_state=k, **options)
                for k, m in enumerate(meshes)
            ]
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", MeshCleaningWarning)
                rows.setdefault(row, {})[name] = score_default(clouds, y, memory, args.n_jobs)
            loo, cv, seconds = rows[row][name]
            print(f"  {name:15s} {row}: {loo:.3f} ({seconds:.0f} s)", flush=True)
    if not names:
        return
    print(
        "\nPoint clouds sampled from the meshes (noise: standard deviation relative to the "
        "bounding-box diagonal;\nscans: sample_point_cloud's density, holes and outliers), "
        "through make_mesh_distance():\nleave-one-out and 10 x 5-fold 1-NN accuracy, seconds "
        "from the samples to the matrix\n(eigensolves included) and milliseconds per sample:\n"
    )
    for name in names:
        n, median, low, high = sizes[name]
        print(f"- {name}: {n} meshes of {low} to {high} vertices (median {median})")
    print(
        "\n| input | "
        + " | ".join(f"{n} LOO | {n} 5-fold | {n} s | {n} ms/sample" for n in names)
        + " |"
    )
    print("|---|" + "---|---|---|---|" * len(names))
    for row, per in rows.items():
        cells = []
        for n in names:
            loo, cv, seconds = per.get(n, (float("nan"),) * 3)
            cells += [f"{loo:.3f}", f"{cv:.3f}", f"{seconds:.1f}"]
            cells.append(f"{1000 * seconds / sizes[n][0]:.0f}")
        label = "meshes (the default pipeline)" if row == "meshes" else row
        print(f"| {label} | " + " | ".join(cells) + " |", flush=True)
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"\npeak resident memory of this process: {peak:.0f} MB")


if __name__ == "__main__":
    main()
