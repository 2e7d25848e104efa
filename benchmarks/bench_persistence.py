"""Lower-star H0 persistence: sklearn-meshph against gudhi and ripser, same process.

    python benchmarks/bench_persistence.py [--quick] [--accuracy]

Icospheres of 2.5k to 655k vertices, two functions (smooth + noise, random). Times are
medians of repeats; "ours" is the union-find over a prebuilt adjacency (built once per
mesh and shared by every function on it, timed separately), the anchors get the same
edge list. Peak memory is the growth of the resident set during one run (peak reset before it).
giotto-ph is not run: giotto-tda pins scikit-learn < 1.4 and numpy < 2 (see ANCHORS.md).

``--accuracy`` instead measures what each filtration is worth on the 60 Sumner meshes
(path from SKLEARN_MESHPH_DATA, default ../shared/data): leave-one-out 1-NN accuracy from
bottleneck distances between the diagrams of the Fiedler vector (cotangent Laplacian, unit
area), with the eigen stage's sign, with random signs (mean of 5 draws) and with the
minimum of the distance over the sign of one sample.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import resource
from pathlib import Path

import numpy as np
import trimesh
from _common import median_time, peak_memory

from sklearn_meshph.mesh.graph import mesh_edges as edge_adjacency
from sklearn_meshph.persistence.lower_star import sublevel_h0

FILTRATIONS = ("sublevel", "extended", "symmetric")


def functions(vertices, rng):
    return {
        "smooth+noise": vertices[:, 0]
        + 0.3 * np.sin(4 * vertices[:, 1])
        + 0.02 * rng.normal(size=len(vertices)),
        "random": rng.normal(size=len(vertices)),
    }


def gudhi_h0(edges, values):
    import gudhi

    tree = gudhi.SimplexTree()
    tree.insert_batch(np.arange(len(values))[None, :], values)
    tree.insert_batch(edges.T, np.maximum(values[edges[:, 0]], values[edges[:, 1]]))
    tree.compute_persistence(persistence_dim_max=False)
    return tree.persistence_intervals_in_dimension(0)


def ripser_h0(edges, values):
    import scipy.sparse as sp
    from ripser import ripser

    n = len(values)
    weights = np.maximum(values[edges[:, 0]], values[edges[:, 1]])
    matrix = sp.coo_matrix(
        (
            np.concatenate([weights, values]),
            (
                np.concatenate([edges[:, 0], np.arange(n)]),
                np.concatenate([edges[:, 1], np.arange(n)]),
            ),
        ),
        shape=(n, n),
    ).tocsr()
    return ripser(matrix, maxdim=0, distance_matrix=True)["dgms"][0]


def loo_accuracy(matrix, y):
    from sklearn.model_selection import LeaveOneOut
    from sklearn.neighbors import KNeighborsClassifier

    correct = 0
    for train, test in LeaveOneOut().split(matrix, y):
        knn = KNeighborsClassifier(n_neighbors=1, metric="precomputed")
        knn.fit(matrix[np.ix_(train, train)], y[train])
        correct += int(knn.predict(matrix[np.ix_(test, train)])[0] == y[test][0])
    return correct / len(y)


def accuracy_table():
    from sklearn_meshph import (
        DiagramDistance,
        LaplacianEigenTransformer,
        LowerStarPersistence,
        load_mesh_folder,
    )

    root = Path(__file__).resolve().parents[1]
    data_dir = Path(os.environ.get("SKLEARN_MESHPH_DATA", root / ".." / "shared" / "data"))
    data = load_mesh_folder(data_dir / "sumner")
    y = np.asarray(data.target)
    fields = LaplacianEigenTransformer(eigen_index=1, n_jobs=2).fit_transform(data.data)
    flipped = [dataclasses.replace(f, values=-f.values) for f in fields]
    rng = np.random.default_rng(0)
    print("| filtration | LOO, eigen stage's sign | LOO, random signs | LOO, min over sign |")
    print("|---|---|---|---|")
    for filtration in FILTRATIONS:
        persistence = LowerStarPersistence(filtration=filtration)
        plus, minus = persistence.transform(fields), persistence.transform(flipped)
        distance = DiagramDistance(metric="bottleneck")
        matrix = distance.fit_transform(plus)
        across = distance.fit(minus).transform(plus)
        random_signs = []
        for _ in range(5):
            flip = rng.random(len(y)) < 0.5
            mixed = [m if s else p for p, m, s in zip(plus, minus, flip, strict=True)]
            random_signs.append(loo_accuracy(distance.fit_transform(mixed), y))
        print(
            f"| {filtration} | {loo_accuracy(matrix, y):.3f} | {np.mean(random_signs):.3f} "
            f"({min(random_signs):.3f}-{max(random_signs):.3f}) | "
            f"{loo_accuracy(np.minimum(matrix, across), y):.3f} |",
            flush=True,
        )


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="sizes up to 41k vertices")
    parser.add_argument(
        "--accuracy", action="store_true", help="accuracy of each filtration on Sumner data"
    )
    args = parser.parse_args()
    if args.accuracy:
        accuracy_table()
        return
    sizes = (4, 5, 6) if args.quick else (4, 5, 6, 7, 8)
    rng = np.random.default_rng(0)
    print(
        "| vertices | function | pairs | argsort s | adjacency s | ours s | gudhi s | "
        "ripser s | ours/gudhi | ours/ripser | ours/argsort | peak MB ours/gudhi |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for sub in sizes:
        mesh = trimesh.creation.icosphere(sub)
        vertices, faces = np.asarray(mesh.vertices), np.asarray(mesh.faces)
        repeats = 7 if len(vertices) < 100_000 else 3
        adjacency_time = median_time(repeats, edge_adjacency, faces, len(vertices))
        adjacency = edge_adjacency(faces, len(vertices))
        coo = adjacency.tocoo()
        keep = coo.row < coo.col
        edges = np.column_stack([coo.row[keep], coo.col[keep]])
        for name, values in functions(vertices, rng).items():
            pairs, _, _ = sublevel_h0(adjacency, values)
            t_sort = median_time(repeats, np.argsort, values, kind="stable")
            t_ours = median_time(repeats, sublevel_h0, adjacency, values)
            t_gudhi = median_time(max(1, repeats // 2), gudhi_h0, edges, values)
            t_ripser = median_time(max(1, repeats // 2), ripser_h0, edges, values)
            mem_ours = peak_memory(sublevel_h0, adjacency, values)
            mem_gudhi = peak_memory(gudhi_h0, edges, values)
            print(
                f"| {len(vertices):,} | {name} | {len(pairs):,} | {t_sort:.4f} | "
                f"{adjacency_time:.4f} | {t_ours:.4f} | {t_gudhi:.3f} | {t_ripser:.3f} | "
                f"{t_ours / t_gudhi:.3f} | {t_ours / t_ripser:.3f} | {t_ours / t_sort:.2f} | "
                f"{mem_ours:.0f}/{mem_gudhi:.0f} |",
                flush=True,
            )
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"\npeak resident memory of this process: {peak:.0f} MB")


if __name__ == "__main__":
    main()
