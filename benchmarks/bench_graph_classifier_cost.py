"""The graph classifier's cost as the training set grows: kernel SVM against trees.

What sets ``make_graph_classifier``'s switch (``classifier="auto"``: the kernel SVM on
at most 2,000 training graphs, the trees above). Synthetic graphs the size of REDDIT's
threads (trees grown by preferential attachment, ``--nodes`` nodes on average; each
graph's class a coin flip: only the cost is measured). Per training-set size: the
wall time of one fit of ``classifier="kernels"`` and of ``classifier="trees"``, the
ratio (kernels / trees: the trees are the anchor the switch falls back to), each fit's
peak memory, and the time per pair of graphs of ``GraphPairDistances`` (its
``fit_transform`` less its ``fit``, on the graphs' signatures), from which the last
lines extrapolate the pairs of larger training sets (they grow as the square; the
time per pair grows with the diagrams, so with the graphs).

    python benchmarks/bench_graph_classifier_cost.py            # 100, 200, 400, 800 graphs
    python benchmarks/bench_graph_classifier_cost.py --sizes 200 800 --nodes 100
"""

import argparse
import time

import numpy as np
from _common import peak_memory

from sklearn_meshph import GraphPairDistances, make_graph_classifier


def thread(n, rng):
    """A tree of ``n`` nodes grown by preferential attachment (by degree)."""
    degrees = np.zeros(n)
    degrees[0] = 1.0
    edges = np.empty((n - 1, 2), dtype=np.int64)
    for node in range(1, n):
        parent = rng.choice(node, p=degrees[:node] / degrees[:node].sum())
        edges[node - 1] = parent, node
        degrees[parent] += 1
        degrees[node] = 1.0
    return n, edges


def fit_seconds(kind, graphs, y, n_jobs, record=None):
    """Wall time of one fit of ``make_graph_classifier(classifier=kind)``, also stored in
    ``record[kind]`` when given."""
    model = make_graph_classifier(classifier=kind, n_jobs=n_jobs)
    start = time.perf_counter()
    model.fit(graphs, y)
    seconds = time.perf_counter() - start
    if record is not None:
        record[kind] = seconds
    return seconds


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[100, 200, 400, 800])
    parser.add_argument("--nodes", type=int, default=400, help="mean nodes per graph")
    parser.add_argument("--n-jobs", type=int, default=2)
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    graphs = [
        thread(int(rng.integers(args.nodes // 2, 3 * args.nodes // 2 + 1)), rng)
        for _ in range(max(args.sizes))
    ]
    y = rng.integers(0, 2, len(graphs))
    fit_seconds("trees", graphs[:20], y[:20], args.n_jobs)  # numba's compilations
    print(f"graphs of {args.nodes} nodes on average, n_jobs={args.n_jobs}")
    print(
        f"{'graphs':>7} {'kernels s':>10} {'trees s':>8} {'ratio':>6} "
        f"{'kernels MB':>11} {'trees MB':>9} {'us/pair':>8}"
    )
    per_pair = []
    for n in args.sizes:
        seconds, memory = {}, {}
        for kind in ("kernels", "trees"):
            memory[kind] = peak_memory(fit_seconds, kind, graphs[:n], y[:n], args.n_jobs, seconds)
        # The pairs alone: the distances step on the signatures of the n graphs, less
        # its fit (each graph's diagrams, features and patterns: linear in n).
        fields = make_graph_classifier(classifier="kernels")[0].fit_transform(graphs[:n])
        start = time.perf_counter()
        GraphPairDistances(n_jobs=args.n_jobs).fit(fields)
        middle = time.perf_counter()
        GraphPairDistances(n_jobs=args.n_jobs).fit_transform(fields)
        pairs = time.perf_counter() - middle - (middle - start)
        per_pair.append(max(pairs, 0.0) / (n * (n - 1) / 2))
        print(
            f"{n:>7} {seconds['kernels']:>10.1f} {seconds['trees']:>8.1f} "
            f"{seconds['kernels'] / seconds['trees']:>6.1f} {memory['kernels']:>11.0f} "
            f"{memory['trees']:>9.0f} {1e6 * per_pair[-1]:>8.0f}",
            flush=True,
        )
    rate = per_pair[-1]
    for n in (2000, 5000, 12000):
        stack = n * n * 14 * 8 / 2**30
        print(
            f"extrapolated: {n} training graphs, {n * (n - 1) / 2 * rate / 60:.0f} min of "
            f"pairs, a {stack:.1f} GB stack"
        )


if __name__ == "__main__":
    main()
