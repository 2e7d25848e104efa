"""Learning quality: leave-one-out 1-NN accuracy of descriptors on real collections.

    python benchmarks/learning_quality.py [--collections watertight_dev sumner shapes]
                                          [--n-jobs 2] [--cache DIR]

Every configuration is a scikit-learn pipeline from meshes to a precomputed distance
matrix, scored by leave-one-out 1-NN on the full matrix (each mesh classified by its
nearest other mesh), with the time of each configuration beside it (loading excluded,
eigensolves cached across configurations with the same eigen stage: the time of the
first one includes the solves). Collections: the SHREC'07 Watertight development half
and the Sumner meshes (from SKLEARN_MESHPH_DATA, default ../shared/data) and
``make_shapes``. The baselines (Shape-DNA) run in the same process.
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import joblib
import numpy as np
from sklearn.pipeline import make_pipeline

from sklearn_meshph import (
    CombinedDistance,
    DiagramDistance,
    FeatureDistance,
    LaplacianEigenTransformer,
    LowerStarPersistence,
    ShapeDNA,
    load_mesh_folder,
    make_shapes,
)

DATA = Path(
    os.environ.get("SKLEARN_MESHPH_DATA", Path(__file__).parents[1] / ".." / "shared" / "data")
)


def eigen(memory, n_jobs, **params):
    return LaplacianEigenTransformer(memory=memory, n_jobs=n_jobs, **params)


def diagrams(n_jobs, parts=None, filtration="extended", order=1.0):
    return make_pipeline(
        LowerStarPersistence(filtration=filtration, parts=parts, n_jobs=n_jobs),
        DiagramDistance(metric="wasserstein", order=order, n_jobs=n_jobs),
    )


def configurations(memory, n_jobs):
    """Name -> (eigen stage, distance stage on its fields)."""
    hks = {"signature": "log-hks", "n_eigenpairs": 50, "n_scales": 5}
    dna = {"signature": "hks", "n_eigenpairs": 50}
    return {
        "default of 0.1 (eigenfunctions 1-3, symmetric H0, bottleneck)": (
            eigen(memory, n_jobs),
            make_pipeline(LowerStarPersistence(n_jobs=n_jobs), DiagramDistance(n_jobs=n_jobs)),
        ),
        "paper literal (graph Laplacian, Fiedler vector, sublevel H0, bottleneck)": (
            eigen(memory, n_jobs, eigen_index=1, laplacian="graph", normalization="none"),
            make_pipeline(
                LowerStarPersistence(filtration="sublevel", n_jobs=n_jobs),
                DiagramDistance(n_jobs=n_jobs),
            ),
        ),
        "Shape-DNA 7, Euclidean": (
            eigen(memory, n_jobs, **dna),
            make_pipeline(ShapeDNA(n_eigenvalues=7), FeatureDistance(metric="euclidean")),
        ),
        "Shape-DNA 30, Canberra": (
            eigen(memory, n_jobs, **dna),
            make_pipeline(ShapeDNA(n_eigenvalues=30), FeatureDistance()),
        ),
        "Shape-DNA 49, Canberra": (
            eigen(memory, n_jobs, **dna),
            make_pipeline(ShapeDNA(n_eigenvalues=49), FeatureDistance()),
        ),
        "log-HKS x5, superlevel pairs, W1": (
            eigen(memory, n_jobs, **hks),
            diagrams(n_jobs, parts=("superlevel H0 (saddle, max)",)),
        ),
        "log-HKS x5, extended, W1": (eigen(memory, n_jobs, **hks), diagrams(n_jobs)),
        "log-HKS x5 extended parts + Shape-DNA 49 (1, .5, 2, .5)": (
            eigen(memory, n_jobs, **hks),
            CombinedDistance(
                [
                    ("ord1", diagrams(n_jobs, parts=("superlevel H0 (saddle, max)",))),
                    ("ext0", diagrams(n_jobs, parts=("(min, max)",))),
                    ("ext1", diagrams(n_jobs, parts=("essential H1",))),
                    ("dna", make_pipeline(ShapeDNA(n_eigenvalues=49), FeatureDistance())),
                ],
                weights={"ext0": 0.5, "ext1": 2.0, "dna": 0.5},
            ),
        ),
    }


def loo_1nn(matrix, y):
    """Leave-one-out 1-NN accuracy of a full distance matrix (ties: lowest index)."""
    matrix = np.array(matrix, dtype=float)
    np.fill_diagonal(matrix, np.inf)
    return float(np.mean(y[np.argmin(matrix, axis=1)] == y))


def collection(name, n_jobs):
    if name == "shapes":
        data = make_shapes(n_per_class=10, random_state=0)
        return list(data.data), np.asarray(data.target)
    data = load_mesh_folder(DATA / name, n_jobs=n_jobs)
    return list(data.data), np.asarray(data.target)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--collections", nargs="+", default=["watertight_dev", "sumner", "shapes"])
    parser.add_argument("--n-jobs", type=int, default=2)
    parser.add_argument("--cache", default=None, help="eigensolve cache folder (default: temp)")
    args = parser.parse_args()
    memory = joblib.Memory(args.cache or os.path.join(os.getcwd(), ".learning-cache"), verbose=0)
    results = {}
    for name in args.collections:
        if name != "shapes" and not (DATA / name).is_dir():
            print(f"skipping {name}: not found in {DATA}")
            continue
        meshes, y = collection(name, args.n_jobs)
        for config, (stage, distances) in configurations(memory, args.n_jobs).items():
            start = time.perf_counter()
            matrix = distances.fit_transform(stage.fit_transform(meshes))
            results[config, name] = (loo_1nn(matrix, y), time.perf_counter() - start)
            print(f"  {name:15s} {config}: {results[config, name][0]:.3f}", flush=True)
    names = [n for n in args.collections if any(k[1] == n for k in results)]
    print("\n| configuration | " + " | ".join(f"{n} LOO | {n} s" for n in names) + " |")
    print("|---|" + "---|---|" * len(names))
    for config in configurations(memory, args.n_jobs):
        cells = []
        for n in names:
            accuracy, seconds = results.get((config, n), (float("nan"), float("nan")))
            cells += [f"{accuracy:.3f}", f"{seconds:.1f}"]
        print(f"| {config} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
