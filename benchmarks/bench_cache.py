"""The eigen cache against joblib's pickles: time of a miss and of a hit, and disk use.

    python benchmarks/bench_cache.py [--collection watertight_dev] [--n-jobs 2]

The same LaplacianEigenTransformer fits a collection twice with each cache: ours (a
folder: data-only entries checked on read) and a joblib.Memory handed over as a plain
caching object (pickles, today's format before this cache). Loading is excluded.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import joblib
from _common import DATA

from sklearn_meshph import LaplacianEigenTransformer, load_mesh_folder


class PickleCache:
    """A joblib.Memory seen only through its ``cache`` method (no ``location``), which
    the eigen stage then uses as it is."""

    def __init__(self, folder):
        self.cache = joblib.Memory(folder, verbose=0).cache


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--collection", default="watertight_dev")
    parser.add_argument("--n-jobs", type=int, default=2)
    args = parser.parse_args()
    meshes = list(load_mesh_folder(DATA / args.collection, n_jobs=args.n_jobs).data)
    print(f"| cache ({len(meshes)} meshes of {args.collection}) | miss s | hit s | MB on disk |")
    print("|---|---|---|---|")
    rows = {}
    for label, make in (("joblib pickles", PickleCache), ("sklearn-meshph data-only", str)):
        with tempfile.TemporaryDirectory() as folder:
            est = LaplacianEigenTransformer(random_state=0, n_jobs=args.n_jobs, memory=make(folder))
            start = time.perf_counter()
            est.fit_transform(meshes)
            miss = time.perf_counter() - start
            start = time.perf_counter()
            est.fit_transform(meshes)
            hit = time.perf_counter() - start
            size = sum(f.stat().st_size for f in Path(folder).rglob("*") if f.is_file())
        rows[label] = hit
        print(f"| {label} | {miss:.1f} | {hit:.2f} | {size / 2**20:.1f} |")
    ratio = rows["sklearn-meshph data-only"] / rows["joblib pickles"]
    print(f"\nhit time, ours / joblib: {ratio:.2f}")


if __name__ == "__main__":
    main()
