"""Point-cloud Laplacians on the unit sphere: relative eigenvalue errors and build times;
and the default pipeline's time on a point cloud against the mesh it comes from.

    python benchmarks/bench_point_clouds.py [--sizes 2000 5000 20000 100000]
    python benchmarks/bench_point_clouds.py --pipeline-only [--watertight 20]

The unit sphere's Laplace-Beltrami eigenvalues are l (l + 1) with multiplicity 2 l + 1:
0, 2 (x3), 6 (x5), 12 (x7). Each operator is built on uniformly random points, with 1%
Gaussian noise (standard deviation 0.01, the radius being 1), and with uneven sampling
(four times as dense on the upper hemisphere), and the first 16 eigenpairs are solved
by the library's eigensolver. The table gives the largest relative error in each
eigenspace (l = 1, 2, 3), the mass's sum against 4 pi, and the time to build the
operator. Rows:

- ``sklearn-meshph``: :func:`sklearn_meshph.point_cloud_laplacian` (local Delaunay
  cotangent, 30 neighbours);
- ``robust-laplacian``: ``robust_laplacian.point_cloud_laplacian`` (Sharp & Crane 2020,
  tufted cover; the anchor, the ``bench`` extra) at 30 and 45 neighbours;
- ``kNN heat kernel``: a Belkin-Niyogi graph Laplacian written here for comparison:
  Gaussian weights over 60 nearest neighbours, bandwidth ``4 t = 0.2 median(r_60)^2``
  (the best of 0.1 to 0.5 on 5,000 clean points), local areas ``pi r_60^2 / 60`` as
  the mass and quadrature weights, scaled by ``1 / (4 pi t^2)``.

With noise the sampled surface is rough at the scale of the sampling (1% of the radius
is 40% of the spacing of 20,000 points): every operator then sees more area and lower
eigenvalues; that is geometry, not a defect of one operator.

With ``--pipeline`` (after the sphere table) or ``--pipeline-only``: the time per sample
of the default pipeline's eigen stage (``make_mesh_distance()``: 48 eigenpairs, log-HKS
at 5 times) and of its persistence (``LowerStarPersistence(filtration="extended")``) on
a mesh and on the cloud of its vertices (same vertex count: the cloud's operator and
kNN graph against the mesh's cotangent operator and edges), one process, ``n_jobs=1``,
with the cloud / mesh ratio and the peak memory of each stage (what it allocates through
NumPy and Python, traced by tracemalloc in a second run, numba's arrays included; the
larger of the two stages; with several meshes, that of the largest). Meshes:
``make_shapes`` snakes at about 2,000, 10,000 and 30,000 vertices, and the first
``--watertight`` meshes of SHREC'07 Watertight (one per class first; from
SKLEARN_MESHPH_DATA).
"""

from __future__ import annotations

import argparse
import time
import tracemalloc

import numpy as np
import scipy.sparse as sp
from _common import DATA
from scipy.spatial import cKDTree

from sklearn_meshph import (
    LowerStarPersistence,
    load_mesh_folder,
    make_mesh_distance,
    make_shapes,
    point_cloud_laplacian,
)
from sklearn_meshph.spectral.eigensolver import generalized_eigenpairs

EXPECTED = np.repeat([2.0, 6.0, 12.0], [3, 5, 7])


def sphere(n, rng, *, uneven=False, noise=0.0):
    """``n`` points on the unit sphere: uniform, or 80% of them on the upper half."""
    counts = ((n - int(0.8 * n), -1), (int(0.8 * n), 1)) if uneven else ((n, 0),)
    parts = []
    for count, side in counts:
        points = rng.normal(size=(count, 3))
        points /= np.linalg.norm(points, axis=1)[:, None]
        if side:
            points[:, 2] = side * np.abs(points[:, 2])
        parts.append(points)
    points = np.vstack(parts)
    return points + noise * rng.normal(size=points.shape)


def heat_kernel_laplacian(points, k=60, bandwidth=0.2):
    """Belkin-Niyogi point-cloud Laplacian with kNN support and local-area weights."""
    distances, indices = cKDTree(points).query(points, k + 1)
    radius = distances[:, -1]
    area = np.pi * radius**2 / k
    t = bandwidth * np.median(radius) ** 2 / 4
    rows = np.repeat(np.arange(len(points)), k)
    weights = np.exp(-(distances[:, 1:].ravel() ** 2) / (4 * t))
    W = sp.csr_matrix((weights, (rows, indices[:, 1:].ravel())), shape=(len(points),) * 2)
    W = W.maximum(W.T)
    A = sp.diags(area) @ W @ sp.diags(area) / (4 * np.pi * t * t)
    return (sp.diags(np.asarray(A.sum(axis=1)).ravel()) - A).tocsr(), sp.diags(area)


def operators():
    yield "sklearn-meshph", point_cloud_laplacian
    try:
        import robust_laplacian
    except ImportError:
        print("(robust-laplacian is not installed: pip install sklearn-meshph[bench])")
    else:
        for k in (30, 45):
            yield (
                f"robust-laplacian k={k}",
                lambda p, k=k: robust_laplacian.point_cloud_laplacian(p, n_neighbors=k),
            )
    yield "kNN heat kernel", heat_kernel_laplacian


def pipeline_cases(n_watertight):
    """(name, meshes): make_shapes snakes at three resolutions, Watertight meshes."""
    for resolution in (32, 71, 122):
        mesh = make_shapes(
            n_per_class=1, classes=("snake",), resolution=(resolution, resolution), random_state=0
        ).data[0]
        yield f"make_shapes snake, {len(mesh.vertices)} vertices", [mesh]
    folder = DATA / "watertight_dev"
    if n_watertight and folder.is_dir():
        data = load_mesh_folder(folder, load=False)
        # One per class first, then the next of each class.
        order = np.lexsort((np.arange(len(data.target)), _rank(data.target)))[:n_watertight]
        meshes = load_mesh_folder(folder).data
        meshes = [meshes[i] for i in sorted(order)]
        sizes = [len(m.vertices) for m in meshes]
        yield (
            f"watertight_dev, {len(meshes)} meshes of {min(sizes)} to {max(sizes)} vertices "
            f"(median {int(np.median(sizes))})",
            meshes,
        )


def _rank(target):
    """The rank of each sample within its class."""
    rank = np.empty(len(target), dtype=int)
    for c in np.unique(target):
        where = np.flatnonzero(target == c)
        rank[where] = np.arange(len(where))
    return rank


def timed(func, *args, repeats=3):
    """(result, seconds) of the fastest of ``repeats`` calls (the others were slowed by
    the machine, not by the code: one call moved the ratios by 0.2 between two runs),
    and the peak of the memory it allocates through NumPy and Python (MB, tracemalloc;
    numba's arrays included) in one more call."""
    seconds = np.inf
    for _ in range(repeats):
        start = time.perf_counter()
        result = func(*args)
        seconds = min(seconds, time.perf_counter() - start)
    tracemalloc.start()
    func(*args)
    peak = tracemalloc.get_traced_memory()[1] / 2**20
    tracemalloc.stop()
    return result, seconds, peak


def pipeline_table(n_watertight):
    eigen = make_mesh_distance(n_jobs=1, random_state=0).named_steps["eigen"]
    persistence = LowerStarPersistence(filtration="extended", n_jobs=1)
    warm = make_shapes(n_per_class=1, classes=("blob",), random_state=0).data
    persistence.fit_transform(eigen.fit_transform(warm))  # numba compilation, once
    persistence.fit_transform(eigen.fit_transform([np.asarray(warm[0].vertices)]))
    print(
        "\nThe default pipeline's eigen stage (48 eigenpairs, log-HKS) and extended "
        "persistence,\nper sample, n_jobs=1: a mesh against the point cloud of its "
        "vertices\n"
    )
    print(
        "| meshes | input | eigen s/sample | persistence s/sample | total s/sample "
        "| cloud / mesh | peak MB (traced) |"
    )
    print("|---|---|---|---|---|---|---|")
    for name, meshes in pipeline_cases(n_watertight):
        totals = {}
        for kind, samples in (
            ("mesh", meshes),
            ("cloud", [np.array(m.vertices, dtype=float) for m in meshes]),
        ):
            fields, eigen_s, eigen_mb = timed(eigen.fit_transform, samples)
            _, persistence_s, persistence_mb = timed(persistence.fit_transform, fields)
            n = len(samples)
            totals[kind] = (eigen_s + persistence_s) / n
            ratio = f"{totals['cloud'] / totals['mesh']:.2f}" if kind == "cloud" else ""
            print(
                f"| {name} | {kind} | {eigen_s / n:.3f} | {persistence_s / n:.4f} | "
                f"{totals[kind]:.3f} | {ratio} | {max(eigen_mb, persistence_mb):.0f} |",
                flush=True,
            )


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[2000, 5000, 20000])
    parser.add_argument(
        "--pipeline", action="store_true", help="also the pipeline timing (after the sphere)"
    )
    parser.add_argument("--pipeline-only", action="store_true", help="only the pipeline timing")
    parser.add_argument(
        "--watertight", type=int, default=20, help="Watertight meshes in the pipeline timing"
    )
    args = parser.parse_args()
    if not args.pipeline_only:
        sphere_table(args)
    if args.pipeline or args.pipeline_only:
        pipeline_table(args.watertight)


def sphere_table(args):
    cases = (("uniform", {}), ("1% noise", {"noise": 0.01}), ("uneven 4x", {"uneven": True}))
    print("| points | sampling | operator | l=1 | l=2 | l=3 | mass / 4 pi | build s |")
    print("|---|---|---|---|---|---|---|---|")
    for n in args.sizes:
        for label, options in cases:
            points = sphere(n, np.random.default_rng(n), **options)
            for name, build in operators():
                start = time.perf_counter()
                L, M = build(points)
                elapsed = time.perf_counter() - start
                mass = sp.diags(M.diagonal())
                values, _ = generalized_eigenpairs(sp.csr_matrix(L), mass, 16, points=points)
                error = np.abs(values[1:] - EXPECTED) / EXPECTED
                worst = [100 * error[a:b].max() for a, b in ((0, 3), (3, 8), (8, 15))]
                print(
                    f"| {n} | {label} | {name} | "
                    + " | ".join(f"{e:.2f}%" for e in worst)
                    + f" | {M.diagonal().sum() / 4 / np.pi:.4f} | {elapsed:.2f} |",
                    flush=True,
                )


if __name__ == "__main__":
    main()
