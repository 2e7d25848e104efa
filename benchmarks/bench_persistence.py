"""Lower-star H0 persistence: sklearn-meshph against gudhi and ripser, same process.

    python benchmarks/bench_persistence.py [--quick]

Icospheres of 2.5k to 655k vertices, two functions (smooth + noise, random). Times are
medians of repeats; "ours" is the union-find over a prebuilt adjacency (built once per
mesh and shared by every function on it, timed separately), the anchors get the same
edge list. Peak memory is the growth of the resident set during one run (peak reset before it).
giotto-ph is not run: giotto-tda pins scikit-learn < 1.4 and numpy < 2 (see ANCHORS.md).
"""

from __future__ import annotations

import argparse
import resource

import numpy as np
import trimesh
from _common import median_time

from sklearn_meshph.persistence import edge_adjacency, sublevel_h0


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


def _status_mb(field):
    with open("/proc/self/status") as status:
        for line in status:
            if line.startswith(field):
                return int(line.split()[1]) / 1024
    return float("nan")


def peak_memory(func, *args):
    """Peak resident-set growth (MB) while ``func`` runs (Linux: resets VmHWM first)."""
    try:
        with open("/proc/self/clear_refs", "w") as refs:
            refs.write("5")
    except OSError:
        return float("nan")
    before = _status_mb("VmRSS")
    func(*args)
    return _status_mb("VmHWM") - before


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="sizes up to 41k vertices")
    args = parser.parse_args()
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
