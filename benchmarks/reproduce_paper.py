"""Reproduce the paper's experiment on the 60 Sumner meshes, and go beyond it.

    python benchmarks/reproduce_paper.py [--data DIR] [--n-jobs 2] [--output DIR]

For each configuration: 5-fold stratified and leave-one-out 1-NN accuracy from the
diagram distance matrix, time per stage, and a t-SNE picture. Configurations: the paper's
literal one (graph Laplacian, unit-norm Fiedler vector, sublevel H0, bottleneck), the
eigenfunction pipeline (the estimators' own defaults), the best one found, and a
Shape-DNA baseline (first non-zero eigenvalues at unit area, Euclidean). A last table
checks invariance: rescaled, rotated and subdivided copies of every mesh classified by
a model fitted on the originals.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import joblib
import numpy as np
import trimesh
from scipy.spatial.distance import cdist
from scipy.spatial.transform import Rotation
from sklearn.model_selection import LeaveOneOut, StratifiedKFold
from sklearn.neighbors import KNeighborsClassifier

from sklearn_meshph import (
    DiagramDistance,
    LaplacianEigenTransformer,
    LowerStarPersistence,
    load_mesh_folder,
)


def knn_accuracy(matrix: np.ndarray, y: np.ndarray, cv) -> float:
    correct = 0
    for train, test in cv.split(matrix, y):
        knn = KNeighborsClassifier(n_neighbors=1, metric="precomputed")
        knn.fit(matrix[np.ix_(train, train)], y[train])
        correct += int((knn.predict(matrix[np.ix_(test, train)]) == y[test]).sum())
    return correct / len(y)


def accuracies(matrix, y):
    return (
        knn_accuracy(matrix, y, StratifiedKFold(5, shuffle=True, random_state=0)),
        knn_accuracy(matrix, y, LeaveOneOut()),
    )


def run_configuration(name, meshes, y, eigen, persistence, distance):
    times = {}
    t = time.perf_counter()
    fields = eigen.fit_transform(meshes)
    times["eigen"] = time.perf_counter() - t
    t = time.perf_counter()
    diagrams = persistence.fit_transform(fields)
    times["persistence"] = time.perf_counter() - t
    t = time.perf_counter()
    matrix = distance.fit_transform(diagrams)
    times["distances"] = time.perf_counter() - t
    t = time.perf_counter()
    five_fold, loo = accuracies(matrix, y)
    times["cv"] = time.perf_counter() - t
    return {"name": name, "5-fold": five_fold, "LOO": loo, "matrix": matrix, **times}


def shape_dna(meshes, y, n_jobs, memory):
    t = time.perf_counter()
    eigen = LaplacianEigenTransformer(eigen_index=tuple(range(1, 8)), n_jobs=n_jobs, memory=memory)
    spectra = np.array([f.eigenvalues for f in eigen.fit_transform(meshes)])
    elapsed = time.perf_counter() - t
    matrix = cdist(spectra, spectra)
    five_fold, loo = accuracies(matrix, y)
    return {
        "name": "Shape-DNA (7 eigenvalues, unit area)",
        "5-fold": five_fold,
        "LOO": loo,
        "matrix": matrix,
        "eigen": elapsed,
        "persistence": 0.0,
        "distances": 0.0,
        "cv": 0.0,
    }


def transformed_copies(meshes, seed=0):
    """Each mesh rotated, moved, rescaled (x0.1 to x10) and subdivided once."""
    rng = np.random.default_rng(seed)
    copies = []
    for mesh in meshes:
        vertices, faces = trimesh.remesh.subdivide(mesh.vertices, mesh.faces)
        rotation = Rotation.random(random_state=int(rng.integers(1 << 31))).as_matrix()
        scale = 10.0 ** rng.uniform(-1, 1)
        copies.append((vertices @ rotation.T * scale + rng.normal(size=3), faces))
    return copies


def main():
    default_data = Path(os.environ.get("SKLEARN_MESHPH_DATA", "../shared/data")) / "sumner"
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", type=Path, default=default_data)
    parser.add_argument("--n-jobs", type=int, default=2)
    parser.add_argument("--output", type=Path, default=Path("reproduce-output"))
    parser.add_argument("--no-invariance", action="store_true", help="skip the last table")
    args = parser.parse_args()
    if not args.data.is_dir():
        raise SystemExit(f"Sumner meshes not found at {args.data} (set SKLEARN_MESHPH_DATA)")

    memory = joblib.Memory(tempfile.mkdtemp(prefix="meshph-"), verbose=0)
    n_jobs = args.n_jobs
    t = time.perf_counter()
    data = load_mesh_folder(args.data)
    meshes, y = list(data.data), np.asarray(data.target)
    names = [str(n) for n in data.target_names]
    load_time = time.perf_counter() - t
    print(f"{len(meshes)} meshes, classes {', '.join(names)}; loading {load_time:.2f} s")

    configurations = [
        (
            "eigenfunction pipeline (eigenfunctions 1-3, cotangent, sign-invariant diagrams, "
            "bottleneck)",
            LaplacianEigenTransformer(n_jobs=n_jobs, memory=memory),
            LowerStarPersistence(n_jobs=n_jobs),
            DiagramDistance(n_jobs=n_jobs),
        ),
        (
            "paper literal (graph, unit L2, sublevel H0, bottleneck)",
            LaplacianEigenTransformer(laplacian="graph", normalization="none", n_jobs=n_jobs),
            LowerStarPersistence(filtration="sublevel", n_jobs=n_jobs),
            DiagramDistance(n_jobs=n_jobs),
        ),
        (
            "cotangent, Fiedler, sublevel H0 only, bottleneck",
            LaplacianEigenTransformer(eigen_index=1, n_jobs=n_jobs, memory=memory),
            LowerStarPersistence(filtration="sublevel", n_jobs=n_jobs),
            DiagramDistance(n_jobs=n_jobs),
        ),
        (
            "cotangent, Fiedler, sign-invariant diagrams, bottleneck",
            LaplacianEigenTransformer(eigen_index=1, n_jobs=n_jobs, memory=memory),
            LowerStarPersistence(n_jobs=n_jobs),
            DiagramDistance(n_jobs=n_jobs),
        ),
        (
            "cotangent, Fiedler, extended (typed) diagrams, bottleneck",
            LaplacianEigenTransformer(eigen_index=1, n_jobs=n_jobs, memory=memory),
            LowerStarPersistence(filtration="extended", n_jobs=n_jobs),
            DiagramDistance(n_jobs=n_jobs),
        ),
        (
            "eigenfunctions 1-3, sign-invariant diagrams, Wasserstein q=2",
            LaplacianEigenTransformer(eigen_index=(1, 2, 3), n_jobs=n_jobs, memory=memory),
            LowerStarPersistence(n_jobs=n_jobs),
            DiagramDistance(metric="wasserstein", order=2.0, n_jobs=n_jobs),
        ),
    ]
    results = [run_configuration(name, meshes, y, *stages) for name, *stages in configurations]
    results.append(shape_dna(meshes, y, n_jobs, memory))

    print("\n| configuration | 5-fold 1-NN | LOO 1-NN | eigen s | persistence s | distances s |")
    print("|---|---|---|---|---|---|")
    for r in results:
        print(
            f"| {r['name']} | {r['5-fold']:.3f} | {r['LOO']:.3f} | {r['eigen']:.2f} | "
            f"{r['persistence']:.2f} | {r['distances']:.2f} |"
        )
    default = results[0]
    total = load_time + sum(default[k] for k in ("eigen", "persistence", "distances", "cv"))
    print(
        f"\nthe eigenfunction pipeline end to end, loading included: {total:.1f} s "
        f"on n_jobs={n_jobs}"
    )

    try:
        from sklearn.manifold import TSNE

        from sklearn_meshph import plotting

        plt = plotting.pyplot()
        args.output.mkdir(parents=True, exist_ok=True)
        for k, r in enumerate(results):
            matrix = r["matrix"]
            matrix = np.where(np.isfinite(matrix), matrix, 2 * matrix[np.isfinite(matrix)].max())
            emb = TSNE(
                metric="precomputed", init="random", perplexity=15, random_state=0
            ).fit_transform(matrix)
            fig, ax = plt.subplots(figsize=(5.5, 4.5))
            plotting.plot_embedding(emb, y, names, ax=ax)
            ax.set_title(r["name"], fontsize=8)
            fig.tight_layout()
            fig.savefig(args.output / f"tsne_{k}.png", dpi=110)
            plt.close(fig)
        print(f"t-SNE pictures in {args.output}/")
    except ImportError as exc:
        print(f"pictures skipped: {exc}")

    if args.no_invariance:
        return
    copies = transformed_copies(meshes)
    print("\ninvariance: originals fit, rotated + rescaled + subdivided copies predicted")
    print("| configuration | copies classified as their original's class |")
    print("|---|---|")
    for name, eigen, persistence, distance in configurations[:2]:
        from sklearn.pipeline import make_pipeline

        eigen.set_params(memory=None)
        pipe = make_pipeline(
            eigen, persistence, distance, KNeighborsClassifier(n_neighbors=1, metric="precomputed")
        )
        pipe.fit(meshes, y)
        print(f"| {name} | {np.mean(pipe.predict(copies) == y):.3f} |")


if __name__ == "__main__":
    main()
