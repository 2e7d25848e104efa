"""Scale: a 20,000-diagram distance matrix and a 655k-vertex mesh, time and peak memory.

    python benchmarks/bench_scale.py [--n-diagrams 20000] [--n-jobs 2] [--subdivisions 8]

Table 1: the bottleneck distance matrix of N random diagrams of 5 to 30 points (the size
of real Fiedler-vector diagrams), N (N - 1) / 2 pairs, written as float32 into a
``numpy.memmap`` by ``pairwise_diagram_distances`` with joblib workers. Peak memory:
the main process's anonymous memory (sampled; the memory-mapped output's pages are
file-backed, written back and dropped by the kernel as needed, and reported apart) and
the largest resident set of any worker. The anchors, gudhi.hera (delta=0) and gudhi's
exact bottleneck, are timed on 20,000 of the same pairs in this process and extrapolated
to all pairs.

Table 2: one irregular ellipsoid of 655,362 vertices (icosphere subdivision 8) through
``LaplacianEigenTransformer(eigen_index=(1, 2, 3))`` in a fresh process, against
lapy's ``Solver(...).eigs(4)`` on the same mesh; peak resident memory of the whole
process (interpreter and mesh included) and its growth over the loaded mesh.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time

import numpy as np

MATRIX = r"""
import json, resource, sys, threading, time
import numpy as np
from joblib.externals.loky import get_reusable_executor
from sklearn_meshph import pairwise_diagram_distances
from sklearn_meshph.diagrams import check_sample
n, n_jobs, path = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3]
rng = np.random.default_rng(0)
def diagram(k):
    births = rng.random(k)
    return np.column_stack([births, births + rng.random(k) * 0.5])
samples = [check_sample(diagram(int(rng.integers(5, 31))), index=i) for i in range(n)]
warm = pairwise_diagram_distances(samples[:50], n_jobs=n_jobs)  # numba caches, workers
def anonymous_mb():
    with open("/proc/self/status") as status:
        for line in status:
            if line.startswith("RssAnon:"):
                return int(line.split()[1]) / 1024
    return float("nan")
peak_anon = [anonymous_mb()]
running = True
def sample():
    while running:
        peak_anon[0] = max(peak_anon[0], anonymous_mb())
        time.sleep(0.2)
sampler = threading.Thread(target=sample, daemon=True)
sampler.start()
out = np.lib.format.open_memmap(path, mode="w+", dtype=np.float32, shape=(n, n))
start = time.perf_counter()
pairwise_diagram_distances(samples, n_jobs=n_jobs, out=out)
out.flush()
elapsed = time.perf_counter() - start
running = False
sampler.join()
check = float(out[n // 2, n // 3])
get_reusable_executor().shutdown(wait=True)
main = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
workers = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
print(json.dumps({"time": elapsed, "main_mb": main, "anon_mb": peak_anon[0], "worker_mb": workers,
                  "check": check}))
"""

MESH = r"""
import json, resource, sys, time
import numpy as np, trimesh
from threadpoolctl import threadpool_limits
method, sub = sys.argv[1], int(sys.argv[2])
mesh = trimesh.creation.icosphere(sub)
rng = np.random.default_rng(0)
V = np.asarray(mesh.vertices) * [1.0, 1.4, 2.1]
V = V + rng.normal(scale=0.1 * 2.0 ** (-sub), size=V.shape)
F = np.asarray(mesh.faces)
del mesh
if method == "ours":
    from sklearn_meshph import LaplacianEigenTransformer
    def run():
        return LaplacianEigenTransformer(eigen_index=(1, 2, 3)).fit_transform([(V, F)])
else:
    import lapy
    def run():
        return lapy.Solver(lapy.TriaMesh(V, F), lump=True).eigs(4)
threadpool_limits(1)
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
start = time.perf_counter()
run()
elapsed = time.perf_counter() - start
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
print(json.dumps({"time": elapsed, "peak_mb": peak, "growth_mb": peak - base, "n": len(V)}))
"""


def run(code, *args):
    env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1")
    out = subprocess.run(
        [sys.executable, "-c", code, *map(str, args)], capture_output=True, text=True, env=env
    )
    if out.returncode != 0:
        raise RuntimeError(out.stderr[-2000:])
    return json.loads(out.stdout.strip().splitlines()[-1])


def anchor_per_pair(n_diagrams, n_pairs=20_000):
    """Per-pair seconds of the anchors on random pairs of the same diagram set."""
    import gudhi
    import gudhi.hera

    rng = np.random.default_rng(0)

    def diagram(k):
        births = rng.random(k)
        return np.column_stack([births, births + rng.random(k) * 0.5])

    samples = [diagram(int(rng.integers(5, 31))) for _ in range(n_diagrams)]
    picks = np.random.default_rng(1).integers(0, n_diagrams, (n_pairs, 2))
    found = {}
    for name, func in {
        "hera bottleneck delta=0": lambda a, b: gudhi.hera.bottleneck_distance(a, b, delta=0),
        "gudhi exact bottleneck": lambda a, b: gudhi.bottleneck_distance(a, b, 0),
    }.items():
        start = time.perf_counter()
        for i, j in picks:
            func(samples[i], samples[j])
        found[name] = (time.perf_counter() - start) / n_pairs
    return found


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--n-diagrams", type=int, default=20_000)
    parser.add_argument("--n-jobs", type=int, default=2)
    parser.add_argument("--subdivisions", type=int, default=8, help="icosphere level")
    parser.add_argument("--skip-mesh", action="store_true")
    parser.add_argument("--skip-matrix", action="store_true")
    args = parser.parse_args()

    if not args.skip_matrix:
        n = args.n_diagrams
        pairs = n * (n - 1) // 2
        with tempfile.TemporaryDirectory() as folder:
            ours = run(MATRIX, n, args.n_jobs, os.path.join(folder, "distances.npy"))
        per_pair = anchor_per_pair(n)
        print(f"bottleneck matrix of {n:,} diagrams (5-30 points): {pairs:,} pairs")
        print(
            f"ours: {ours['time']:.1f} s on {args.n_jobs} workers"
            f" ({ours['time'] / pairs * 1e6 * args.n_jobs:.2f} us per pair per core)\n"
            f"peak memory: main process {ours['anon_mb']:.0f} MB anonymous (sampled every 0.2 s;"
            f" {ours['main_mb']:.0f} MB resident with the output's file-backed pages), largest"
            f" worker {ours['worker_mb']:.0f} MB resident; output {n * n * 4 / 2**20:.0f} MB"
            " float32, memory-mapped"
        )
        print("| anchor (one core, extrapolated) | s per pair | all pairs s | ours / anchor |")
        print("|---|---|---|---|")
        for name, seconds in per_pair.items():
            total = seconds * pairs
            print(f"| {name} | {seconds * 1e6:.1f} us | {total:.0f} | {ours['time'] / total:.4f} |")

    if not args.skip_mesh:
        mine = run(MESH, "ours", args.subdivisions)
        theirs = run(MESH, "lapy", args.subdivisions)
        print(f"\none mesh of {mine['n']:,} vertices, 3 eigenfunctions (1 BLAS thread)")
        print("| method | s | peak resident MB | growth over the mesh MB |")
        print("|---|---|---|---|")
        for name, r in (("ours (transformer)", mine), ("lapy eigs(4)", theirs)):
            print(f"| {name} | {r['time']:.1f} | {r['peak_mb']:.0f} | {r['growth_mb']:.0f} |")
        print(
            f"ours / lapy: time {mine['time'] / theirs['time']:.2f},"
            f" peak memory {mine['peak_mb'] / theirs['peak_mb']:.2f}"
        )
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"\npeak resident memory of this process (anchors): {peak:.0f} MB")


if __name__ == "__main__":
    main()
