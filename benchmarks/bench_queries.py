"""Exact queries against large fitted collections under the default metric.

    python benchmarks/bench_queries.py [--sizes 1000 5000 10000 20000] [--queries 20]
                                       [--brute 3] [--cache DIR] [--base watertight_dev]

The diagrams and Shape-DNA spectra of the base collection (``watertight_dev``, or
``shapes`` for make_shapes) are computed once by the default's stages and cached; the
time per mesh of the eigen stage and of the stages after it (persistence, Shape-DNA:
what a query costs before its search) is printed. A STAND-IN for the 20,000-mesh
collection of issue 29 (item 1): collections of growing size are made of jittered
copies of the base samples (each point of a diagram moved by 5% of its persistence,
essential births by 5% of their spread, each eigenvalue by 1%), labelled by their base
sample's class; queries are other jittered copies. The metric is exactly the default's
last stage (its CombinedDistance: the same parts, weights and median normalization),
reading the cached representations instead of meshes; its scales are learned on 200
samples. For each size: the fit's CPU time, the index's pickled size and the fit's
peak allocation (tracemalloc), the pruned query's CPU time per query on one core
(median and mean; the median wall time beside), the fraction of exact distances
computed, the queries' peak allocation, and the brute-force CPU time per query (every
exact distance) on a few queries, with their ratio; the pruned answers are checked against the
brute-force ones. Last, the peak allocation of ``distance_matrix`` writing rows to a
memory-mapped file (2,000 fitted shapes: the memory per pair does not depend on it).
"""

from __future__ import annotations

import argparse
import pickle
import tempfile
import time
import tracemalloc
from pathlib import Path

import numpy as np
from _common import collection
from sklearn.base import clone
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import FunctionTransformer

from sklearn_meshph import CombinedDistance, ShapeNeighbors, make_mesh_distance


def representations(base, cache):
    """``(parts, y, seconds)`` of the base collection: each part's stateless output per
    sample, the labels, and the eigen and later stages' seconds per mesh."""
    path = Path(cache) / f"bench_queries_{base}.pkl"
    if path.exists():
        return pickle.loads(path.read_bytes())
    meshes, y, _ = collection(base, n_jobs=1)
    pipeline = make_mesh_distance(n_jobs=1)
    start = time.perf_counter()
    fields = pipeline.named_steps["eigen"].fit_transform(meshes)
    eigen = time.perf_counter() - start
    start = time.perf_counter()
    parts = {
        name: part[:-1].fit_transform(fields)
        for name, part in pipeline.named_steps["distance"].transformer_list
    }
    later = time.perf_counter() - start
    found = (parts, y, {"eigen": eigen / len(y), "persistence and dna": later / len(y)})
    path.write_bytes(pickle.dumps(found))
    return found


def _jitter_diagram(rng, diagram, size):
    finite = np.isfinite(diagram[:, 1])
    moved = diagram.copy()
    persistence = diagram[finite, 1] - diagram[finite, 0]
    moved[finite] += rng.normal(0, size, (finite.sum(), 2)) * persistence[:, None]
    moved[finite, 1] = np.maximum(moved[finite, 1], moved[finite, 0])
    spread = np.ptp(diagram[~finite, 0]) if (~finite).sum() > 1 else 1.0
    moved[~finite, 0] += rng.normal(0, size, (~finite).sum()) * spread
    return moved


def copies(parts, y, n, seed):
    """``n`` jittered copies of random base samples (dicts of part rows) and labels."""
    rng = np.random.default_rng(seed)
    chosen = rng.integers(0, len(y), n)
    samples = []
    for b in chosen:
        sample = {}
        for name, rows in parts.items():
            row = rows[b]
            if name == "dna":
                sample[name] = row * (1 + rng.normal(0, 0.01, row.shape))
            else:
                sample[name] = tuple(_jitter_diagram(rng, d, 0.05) for d in row)
        samples.append(sample)
    return samples, y[chosen]


class Pick:
    """Picklable selection of one part's rows from dict samples."""

    def __init__(self, name):
        self.name = name

    def __call__(self, X):
        rows = [sample[self.name] for sample in X]
        return np.array(rows) if self.name == "dna" else rows


def default_metric():
    """The default's CombinedDistance, its parts reading dict samples."""
    combined = make_mesh_distance().named_steps["distance"]
    parts = [
        (name, Pipeline([("pick", FunctionTransformer(Pick(name))), ("distance", part[-1])]))
        for name, part in combined.transformer_list
    ]
    return CombinedDistance(parts, weights=combined.weights)


def traced(function, *args):
    """``function(*args)``'s result and the peak of the memory it allocated (MB, as
    tracemalloc sees numpy's and Python's allocations)."""
    tracemalloc.start()
    try:
        result = function(*args)
        return result, tracemalloc.get_traced_memory()[1] / 2**20
    finally:
        tracemalloc.stop()


def run(parts, y, sizes, n_queries, n_brute):
    """One line per size; times are CPU times of this process (one core: the kernels
    run on one thread), which a busy machine inflates less than wall times."""
    queries, _ = copies(parts, y, n_queries, seed=1)
    print(
        f"{'fitted':>7} {'fit s':>6} {'index MB':>8} {'fit peak':>8} {'query ms':>8} "
        f"{'mean ms':>7} {'wall ms':>7} {'exact %':>7} {'query peak':>10} {'brute ms':>8} "
        f"{'ratio':>5}"
    )
    for n in sizes:
        train, _ = copies(parts, y, n, seed=2)
        index = ShapeNeighbors(default_metric(), n_neighbors=1, scale_samples=200)
        start = time.process_time()
        index.fit(train)
        fit = time.process_time() - start
        _, fit_peak = traced(clone(index).fit, train)
        stored = len(pickle.dumps(index)) / 2**20
        index.kneighbors(queries[:1])  # compiled kernels warm
        times, walls = [], []
        for query in queries:
            start, wall = time.process_time(), time.perf_counter()
            index.kneighbors([query])
            times.append(time.process_time() - start)
            walls.append(time.perf_counter() - wall)
        fractions, query_peak = traced(index.exact_fraction, queries)
        start = time.process_time()
        brute = index.distance_matrix(queries[:n_brute], dtype="float64")
        brute_time = (time.process_time() - start) / n_brute
        found = index.kneighbors(queries[:n_brute], return_distance=False)[:, 0]
        assert np.array_equal(found, np.argmin(brute, axis=1)), "pruned != brute force"
        query = float(np.median(times))
        print(
            f"{n:>7} {fit:>6.1f} {stored:>8.1f} {fit_peak:>8.0f} {1e3 * query:>8.1f} "
            f"{1e3 * np.mean(times):>7.1f} {1e3 * np.median(walls):>7.1f} "
            f"{100 * np.mean(fractions):>7.2f} {query_peak:>10.1f} {1e3 * brute_time:>8.0f} "
            f"{brute_time / query:>5.0f}",
            flush=True,
        )
    rows = 2 * index.block_size
    small = ShapeNeighbors(default_metric(), scale_samples=200).fit(train[:2000])
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "d.npy"
        _, peak = traced(lambda: small.distance_matrix(train[-rows:], path=path))
    pairs = small.block_size * small.n_samples_fit_
    print(
        f"distance_matrix of {rows} rows to a memmap file at {small.n_samples_fit_} fitted: "
        f"peak {peak:.0f} MB, {peak * 2**20 / pairs:.0f} bytes per pair of a block of "
        f"{small.block_size} rows"
    )


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[1000, 5000, 10000, 20000])
    parser.add_argument("--queries", type=int, default=20)
    parser.add_argument("--brute", type=int, default=3)
    parser.add_argument("--base", default="watertight_dev")
    parser.add_argument("--cache", default=None, help="folder of the cached diagrams")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as temporary:
        parts, y, seconds = representations(args.base, args.cache or temporary)
    points = [len(d) for rows in parts.values() if isinstance(rows, list) for s in rows for d in s]
    print(
        f"base {args.base}: {len(y)} meshes; per mesh: eigen stage {seconds['eigen']:.2f} s, "
        f"persistence and Shape-DNA {1e3 * seconds['persistence and dna']:.0f} ms; points "
        f"per diagram: median {np.median(points):.0f}, max {max(points)}"
    )
    run(parts, y, args.sizes, args.queries, args.brute)


if __name__ == "__main__":
    main()
