"""Grid search over the eigen index: the eigen cache makes it cost about one CV.

    python benchmarks/bench_grid_search.py [--n-jobs 2]

On the Sumner meshes ($SKLEARN_MESHPH_DATA/sumner, or synthetic shapes when absent):
a single 3-fold cross-validation of the default pipeline with a fresh cache, then a
GridSearchCV over eigen_index 1..5 (15 fits) with a fresh cache, and the same grid
without a cache (the anchor: what scikit-learn's Pipeline memory would leave you with,
since it never caches transform at predict time).
"""

from __future__ import annotations

import argparse
import os
import resource
import tempfile
import time
import warnings
from pathlib import Path

from sklearn.model_selection import GridSearchCV, StratifiedKFold, cross_val_score
from sklearn.neighbors import KNeighborsClassifier
from sklearn.pipeline import make_pipeline

from sklearn_meshph import (
    DiagramDistance,
    LaplacianEigenTransformer,
    LowerStarPersistence,
    load_mesh_folder,
    make_shapes,
)


def pipeline(memory, n_jobs):
    return make_pipeline(
        LaplacianEigenTransformer(memory=memory, n_jobs=n_jobs),
        LowerStarPersistence(n_jobs=n_jobs),
        DiagramDistance(n_jobs=n_jobs),
        KNeighborsClassifier(n_neighbors=1, metric="precomputed"),
    )


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--n-jobs", type=int, default=2)
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    folder = Path(os.environ.get("SKLEARN_MESHPH_DATA", "../shared/data")) / "sumner"
    if folder.is_dir():
        data = load_mesh_folder(folder)
        source = "Sumner, 60 meshes"
    else:
        data = make_shapes(n_per_class=20, random_state=0)
        source = "make_shapes, 120 meshes"
    meshes, y = list(data.data), data.target
    cv = StratifiedKFold(3, shuffle=True, random_state=0)
    grid = {"laplacianeigentransformer__eigen_index": [1, 2, 3, 4, 5]}
    pipeline(None, args.n_jobs).fit(meshes[:6], y[:6])  # compile and start workers

    times = {}
    with tempfile.TemporaryDirectory() as cache:
        start = time.perf_counter()
        cross_val_score(pipeline(cache, args.n_jobs), meshes, y, cv=cv)
        times["single 3-fold CV, cache"] = time.perf_counter() - start
    with tempfile.TemporaryDirectory() as cache:
        start = time.perf_counter()
        GridSearchCV(pipeline(cache, args.n_jobs), grid, cv=cv).fit(meshes, y)
        times["grid 5 x 3 folds, cache"] = time.perf_counter() - start
    start = time.perf_counter()
    GridSearchCV(pipeline(None, args.n_jobs), grid, cv=cv).fit(meshes, y)
    times["grid 5 x 3 folds, no cache (anchor)"] = time.perf_counter() - start

    base = times["single 3-fold CV, cache"]
    print(f"{source}, n_jobs={args.n_jobs}")
    print("| run | time s | / single CV |")
    print("|---|---|---|")
    for name, seconds in times.items():
        print(f"| {name} | {seconds:.2f} | {seconds / base:.2f} |")
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"\npeak resident memory: {peak:.0f} MB")


if __name__ == "__main__":
    main()
