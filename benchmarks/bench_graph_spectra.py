"""Graph spectra: the dense eigensolver against shift-invert Lanczos, and the crossover.

    python benchmarks/bench_graph_spectra.py [--sizes 50 100 200 400 800 1600] [--k 8 24]
                                             [--repeats 3] [--tu MUTAG PROTEINS ...]

Part 1, synthetic graphs of each size: "sparse" (a random tree plus 10% more edges: the
degree of molecules) and "social" (Erdos-Renyi of mean degree 10), the normalized
Laplacian with ``M = I / n`` (``normalization="area"``). For each size and each ``k``,
the time of one graph's ``k`` lowest eigenpairs by the dense path (LAPACK ``evr``, a
subset of eigenpairs), by the sparse path (our Cholesky and ARPACK, as
``generalized_eigenpairs`` runs it), and of *every* eigenpair by the dense path
(``evd``, PersLay's setting). The best of ``--repeats`` is kept, BLAS on one thread
(as the eigen stage runs). ``DENSE_MAX_NODES`` (``sklearn_meshph/spectral/eigensolver.py``)
is the largest size measured at which the dense path is the faster on both kinds for the
eigen stage's block of 8 eigenpairs; results in ``docs/eigenfunctions.md``.

Part 2, the TU datasets of ``SKLEARN_MESHPH_DATA/tu`` (parsed here in a few lines):
time per graph of every eigenpair (dense), and of ``k`` eigenpairs by ``solver="auto"``
and by the sparse path where it applies (graphs of more than ``k + 1`` nodes).

Timings depend on the machine and on its load: run it on a quiet machine.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from _common import DATA

from sklearn_meshph import load_tu_dataset
from sklearn_meshph.graph.validation import Graph
from sklearn_meshph.spectral.eigensolver import generalized_eigenpairs
from sklearn_meshph.spectral.laplacians import GRAPH_LAPLACIANS


def _graph(n_nodes, pairs):
    pairs = np.sort(np.asarray(pairs, dtype=np.int64).reshape(-1, 2), axis=1)
    pairs = np.unique(pairs[pairs[:, 0] != pairs[:, 1]], axis=0)
    return Graph(n_nodes, pairs, np.ones(len(pairs)))


def synthetic(kind, n, rng):
    """A random connected graph of ``n`` nodes: ``"sparse"`` or ``"social"``."""
    parents = [rng.integers(0, i) for i in range(1, n)]
    tree = np.column_stack([np.arange(1, n), parents])
    extra = n // 10 if kind == "sparse" else 5 * n
    return _graph(n, np.vstack([tree, rng.integers(0, n, size=(extra, 2))]))


def operator(graph):
    L, M = GRAPH_LAPLACIANS["normalized"].value(graph)
    return L, M / M.diagonal().sum()


def best_time(repeats, solve, operators, count):
    """Best of ``repeats`` times of ``solve(L, M, count(n))`` over ``operators``."""
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        for L, M in operators:
            solve(L, M, count(L.shape[0]))
        times.append(time.perf_counter() - start)
    return min(times)


def dense(L, M, k):
    return generalized_eigenpairs(L, M, k, solver="dense")


def sparse(L, M, k):
    return generalized_eigenpairs(L, M, k, solver="cholesky", dense_max=0)


def auto(L, M, k):
    from sklearn_meshph.spectral.eigensolver import DENSE_MAX_NODES

    return generalized_eigenpairs(L, M, k, dense_max=DENSE_MAX_NODES)


def part_synthetic(sizes, ks, repeats):
    print("## Synthetic graphs: one graph's eigenpairs, best of", repeats, "(ms)\n")
    print("| kind | nodes | k | dense k | sparse k | dense, all |")
    print("|---|---|---|---|---|---|")
    rng = np.random.default_rng(0)
    for kind in ("sparse", "social"):
        for n in sizes:
            one = [operator(synthetic(kind, n, rng))]
            every = 1e3 * best_time(repeats, dense, one, int)
            for k in ks:
                if k >= n - 1:
                    continue
                fixed = lambda n, k=k: k  # noqa: E731
                d = 1e3 * best_time(repeats, dense, one, fixed)
                s = 1e3 * best_time(repeats, sparse, one, fixed)
                print(f"| {kind} | {n} | {k} | {d:.3g} | {s:.3g} | {every:.3g} |")


def part_tu(names, k, repeats):
    print(f"\n## TU datasets: mean time per graph (ms), k = {k}\n")
    print("| dataset | graphs | max nodes | dense, all | auto, k | sparse, k (graphs of > k + 1) |")
    print("|---|---|---|---|---|---|")
    for name in names:
        folder = DATA / "tu" / name
        if not folder.is_dir():
            print(f"| {name} | missing: {folder} | | | | |")
            continue
        operators = [operator(graph) for graph in load_tu_dataset(folder)[0]]
        big = [(L, M) for L, M in operators if L.shape[0] > k + 1]
        every = 1e3 * best_time(repeats, dense, operators, int) / len(operators)
        automatic = best_time(repeats, auto, operators, lambda n: min(k, n))
        shift_invert = best_time(repeats, sparse, big, lambda n: k) / max(len(big), 1)
        largest = max(L.shape[0] for L, _ in operators)
        print(
            f"| {name} | {len(operators)} | {largest} | {every:.3g} | "
            f"{1e3 * automatic / len(operators):.3g} | {1e3 * shift_invert:.3g} ({len(big)}) |"
        )


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[50, 100, 200, 400, 800, 1600])
    parser.add_argument("--k", type=int, nargs="+", default=[8, 24], help="eigenpairs")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument(
        "--tu", nargs="*", default=["MUTAG", "COX2", "DHFR", "PROTEINS", "NCI1", "IMDB-BINARY"]
    )
    args = parser.parse_args()
    part_synthetic(args.sizes, args.k, args.repeats)
    if args.tu:
        part_tu(args.tu, args.k[0], args.repeats)


if __name__ == "__main__":
    main()
