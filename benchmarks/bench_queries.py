"""Exact queries against large fitted collections under the default metric.

    python benchmarks/bench_queries.py [--sizes 5000 10000 20000] [--queries 300]
                                       [--brute 3] [--folder DIR] [--chunk 200]
                                       [--no-loo] [--matrix]

The collection is ``make_collection.py``'s (seed 0, built first with the same
``--folder`` and ``--chunk``): the default's diagrams and Shape-DNA spectra of its
meshes, read from the cache. The queries are new meshes of the same generator (seed
1, the first ``--queries``), put through the default's stages here on one core (their
representations cached beside the collection's): the CPU time per query mesh of the
eigen stage and of the later ones (persistence, Shape-DNA) is printed apart from the
search's. The metric is exactly the default's last stage (its CombinedDistance: the
same parts, weights and median normalization) reading the cached representations;
``ShapeNeighbors`` learns its scales as it does by default (1,000 fitted shapes).

For each size (the first n shapes of the collection): the fit's CPU time, the index's
pickled size, the CPU time per query on one core (median and mean; the kernels run on
one thread), the fraction of exact distances computed, the 1-NN accuracy of the
queries, and the brute-force CPU time per query (every exact distance) on a few
queries, whose answers are checked against the pruned ones. Then, at the largest
size, the leave-one-out queries of every fitted shape (``kneighbors()``, timed through
``exact_fraction()``, which does the same work and returns the pruning), and the
process's peak resident memory (``ru_maxrss``) beside its resident memory once the
representations were loaded. ``--matrix``: the traced peak of ``distance_matrix``
writing rows to a memory-mapped file (2,000 fitted shapes: the memory per pair does
not depend on it).
"""

from __future__ import annotations

import argparse
import pickle
import resource
import tempfile
import time
import tracemalloc
from pathlib import Path

import numpy as np
from _common import _status_mb
from make_collection import DEFAULT_FOLDER, base_collection, build_chunk, load_collection
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import FunctionTransformer

from sklearn_meshph import CombinedDistance, ShapeNeighbors, make_mesh_distance


def samples_of(parts):
    """One dict of part rows per sample."""
    n = len(next(iter(parts.values())))
    return [{name: rows[i] for name, rows in parts.items()} for i in range(n)]


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


def queries_of(folder, n_queries):
    """``(samples, y, seconds)``: the query meshes' representations (seed 1, made and
    cached here on one core) and the CPU seconds per mesh of their stages."""
    meshes, y = base_collection("watertight_dev")
    build_chunk(folder, meshes, y, 1, 0, n_queries, n_jobs=1)
    parts, info = load_collection(folder, 1, n_queries, n_queries)
    made, eigen, later = info["seconds"][0] / n_queries
    return samples_of(parts), info["y"], {"eigen": eigen, "later": later, "made": made}


def run(train, y, queries, y_queries, sizes, n_brute):
    """One line per size; times are CPU times of this process."""
    print(
        f"{'fitted':>7} {'fit s':>6} {'index MB':>8} {'query ms':>8} {'mean ms':>7} "
        f"{'exact %':>7} {'1-NN':>5} {'brute ms':>8} {'ratio':>5}"
    )
    for n in sizes:
        index = ShapeNeighbors(default_metric(), n_neighbors=1)
        start = time.process_time()
        index.fit(train[:n])
        fit = time.process_time() - start
        stored = len(pickle.dumps(index)) / 2**20
        index.kneighbors(queries[:1])  # compiled kernels warm
        times, found = [], []
        for query in queries:
            start = time.process_time()
            found.append(index.kneighbors([query], return_distance=False)[0, 0])
            times.append(time.process_time() - start)
        fractions = index.exact_fraction(queries)
        start = time.process_time()
        brute = index.distance_matrix(queries[:n_brute], dtype="float64")
        brute_time = (time.process_time() - start) / n_brute
        assert np.array_equal(found[:n_brute], np.argmin(brute, axis=1)), "pruned != brute"
        accuracy = np.mean(y[:n][np.asarray(found)] == y_queries)
        median = float(np.median(times))
        print(
            f"{n:>7} {fit:>6.1f} {stored:>8.1f} {1e3 * median:>8.1f} "
            f"{1e3 * np.mean(times):>7.1f} {100 * np.mean(fractions):>7.2f} {accuracy:>5.3f} "
            f"{1e3 * brute_time:>8.0f} {brute_time / median:>5.0f}",
            flush=True,
        )
    return index


def leave_one_out(index, y):
    """Every fitted shape queried against the others (what ``kneighbors()`` does)."""
    start = time.process_time()
    fractions = index.exact_fraction()
    seconds = time.process_time() - start
    n = index.n_samples_fit_
    print(
        f"leave-one-out at {n}: {1e3 * seconds / n:.1f} ms CPU per query (mean), "
        f"{seconds:.0f} s in all, exact {100 * np.mean(fractions):.2f}% "
        f"(max {100 * np.max(fractions):.1f}%)",
        flush=True,
    )
    return index


def matrix_memory(train):
    """The traced peak of distance_matrix writing rows to a memory-mapped file."""
    small = ShapeNeighbors(default_metric()).fit(train[:2000])
    rows = 2 * small.block_size
    with tempfile.TemporaryDirectory() as folder:
        tracemalloc.start()
        try:
            small.distance_matrix(train[-rows:], path=Path(folder) / "d.npy")
            peak = tracemalloc.get_traced_memory()[1] / 2**20
        finally:
            tracemalloc.stop()
    pairs = small.block_size * small.n_samples_fit_
    print(
        f"distance_matrix of {rows} rows to a memmap file at {small.n_samples_fit_} fitted: "
        f"peak {peak:.0f} MB, {peak * 2**20 / pairs:.0f} bytes per pair of a block of "
        f"{small.block_size} rows"
    )


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[5000, 10000, 20000])
    parser.add_argument("--queries", type=int, default=300)
    parser.add_argument("--brute", type=int, default=3)
    parser.add_argument("--folder", default=str(DEFAULT_FOLDER))
    parser.add_argument("--chunk", type=int, default=200)
    parser.add_argument("--no-loo", action="store_true", help="skip the leave-one-out run")
    parser.add_argument("--matrix", action="store_true", help="distance_matrix's memory")
    args = parser.parse_args()
    started = _status_mb("VmRSS")
    parts, info = load_collection(args.folder, 0, max(args.sizes), args.chunk)
    train, y = samples_of(parts), info["y"]
    queries, y_queries, seconds = queries_of(args.folder, args.queries)
    loaded = _status_mb("VmRSS")
    print(
        f"collection: {len(y)} meshes, vertices median {np.median(info['n_vertices']):.0f} "
        f"(max {info['n_vertices'].max()}), remeshed {100 * info['remeshed'].mean():.1f}%; "
        f"per query mesh (CPU, one core): eigen stage {seconds['eigen']:.3f} s, "
        f"persistence and Shape-DNA {1e3 * seconds['later']:.0f} ms, generation "
        f"{1e3 * seconds['made']:.0f} ms; resident {started:.0f} MB at start, "
        f"{loaded:.0f} MB with the representations",
        flush=True,
    )
    index = run(train, y, queries, y_queries, args.sizes, args.brute)
    if not args.no_loo:
        leave_one_out(index, y)
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(
        f"peak resident {peak:.0f} MB: {peak - loaded:.0f} MB beyond the loaded "
        f"representations, {peak - started:.0f} MB beyond the start"
    )
    if args.matrix:
        matrix_memory(train)


if __name__ == "__main__":
    main()
