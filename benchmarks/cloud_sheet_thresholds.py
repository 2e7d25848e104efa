"""The thresholds of a cloud's sheet tests, screened by the accuracy of the clouds.

    python benchmarks/cloud_sheet_thresholds.py [--points 3000] [--slopes 0.7]
        [--cosines 0.5 0.0] [--firsts 10] [--noise 0.01] [--density 4] [--holes 3]
        [--outliers 5]

A point's surface neighbours (``pointcloud._triangulation.surface_neighbours``) are
those low over its tangent plane (``MAX_SLOPE``), fitted first to its
``NORMAL_NEIGHBORS`` nearest, and whose own normal is within ``MIN_NORMAL_COSINE`` of
its own (unoriented). Each combination of the values given is set in this process,
clouds of ``--points`` points are sampled on every mesh of Watertight dev and Sumner
(``sample_point_cloud``, seed = the mesh's index, with the scan defects given, as
``learning_quality.py`` samples them), and ``make_mesh_distance()`` is fitted on them
(its eigen stage in this process, where the thresholds are set; no cache). Printed:
the leave-one-out 1-NN accuracy per collection and setting. Watertight dev is where a
setting may be chosen; Sumner plays no part in a choice. The operator's eigenvalue
errors against the meshes' for the same settings: ``bench_cloud_operator.py`` with the
constant set likewise (the docs give both).
"""

import argparse
import itertools
import time
import warnings

from _common import collection, loo_1nn

from sklearn_meshph import MeshCleaningWarning, make_mesh_distance, sample_point_cloud
from sklearn_meshph.pointcloud import _triangulation


def score(clouds, y):
    pipeline = make_mesh_distance(n_jobs=-1, random_state=0)
    fields = pipeline.named_steps["eigen"].set_params(n_jobs=1).fit_transform(clouds)
    return loo_1nn(pipeline.named_steps["distance"].fit_transform(fields), y)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=3000)
    parser.add_argument("--slopes", type=float, nargs="+", default=[_triangulation.MAX_SLOPE])
    parser.add_argument("--cosines", type=float, nargs="+", default=[0.5, 0.0])
    parser.add_argument("--firsts", type=int, nargs="+", default=[10])
    parser.add_argument("--noise", type=float, default=0.0)
    parser.add_argument("--density", type=float, default=1.0)
    parser.add_argument("--holes", type=int, default=0)
    parser.add_argument("--outliers", type=int, default=0)
    args = parser.parse_args()
    options = {"noise": args.noise, "density": args.density, "outliers": args.outliers}
    if args.holes:
        options.update(holes=args.holes, hole_fraction=0.1)
    collections = {}
    for name in ("watertight_dev", "sumner"):
        loaded = collection(name, -1)
        if loaded is None:
            print(f"skipping {name}: not found")
            continue
        meshes, y, _ = loaded
        clouds = [
            sample_point_cloud(m, args.points, random_state=k, **options)
            for k, m in enumerate(meshes)
        ]
        collections[name] = (clouds, y)
    print(f"{args.points} points, {options}\n")
    print("| MAX_SLOPE | MIN_NORMAL_COSINE | NORMAL_NEIGHBORS | " + " | ".join(collections) + " |")
    print("|---|---|---|" + "---|" * len(collections))
    for slope, cosine, first in itertools.product(args.slopes, args.cosines, args.firsts):
        _triangulation.MAX_SLOPE = slope
        _triangulation.MIN_NORMAL_COSINE = cosine
        _triangulation.NORMAL_NEIGHBORS = first
        cells = []
        for clouds, y in collections.values():
            start = time.perf_counter()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", MeshCleaningWarning)
                accuracy = score(clouds, y)
            cells.append(f"{accuracy:.3f} ({time.perf_counter() - start:.0f} s)")
        print(f"| {slope:g} | {cosine:g} | {first} | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main()
