"""Cloud Laplacians against their mesh's operator, on shapes with thin and close parts.

    nice -n 10 python benchmarks/bench_cloud_operator.py [--sizes 1000 3000 10000 30000]
        [--shapes cat-01 hand-181 ...] [--eigenpairs 50] [--diagrams] [--quick]

Each mesh (the shared Sumner figures and Watertight dev meshes with fingers, legs,
tentacles, handles and jaws, and the unit sphere) is sampled uniformly
(:func:`sklearn_meshph.sample_point_cloud`, seed = the size) at each size, and the
cloud's operator is compared with the mesh's cotangent operator
(:func:`sklearn_meshph.cotangent_laplacian` on the mesh as cleaned by
:func:`sklearn_meshph.clean_mesh`), both in the mesh's own units, so the cloud's
eigenvalues are compared with the surface's directly. Per shape, size and operator:

- ``mass``: the sum of the cloud's mass over the mesh's area;
- ``l1``: the first non-zero eigenvalue over the mesh's;
- ``med20``, ``med50``: median relative error of eigenvalues 1-20 and 1-50;
- ``align10``, ``align20``: the mean squared cosine of the principal angles between
  the span of the mesh's eigenfunctions 1-k, interpolated at the cloud's points
  (barycentric, in the triangle each point was drawn from), and the span of the
  cloud's, in the cloud's mass inner product (1: the same subspace);
- with ``--diagrams``: the largest bottleneck distance, over the default's log-HKS
  columns and their ordinary H0, superlevel H0 and ``(min, max)`` diagrams, between
  the cloud's and the mesh's extended persistence (the eigen stage of
  ``make_mesh_distance()``), relative to the range of the mesh's values;
- ``build s``: the operator's build time; ``peak MB``: the memory it allocates
  (tracemalloc, NumPy and numba arrays) in a second build.

Operators: ``ours`` (:func:`sklearn_meshph.point_cloud_laplacian`) and
``robust-laplacian`` (``robust_laplacian.point_cloud_laplacian``, 30 neighbours, the
anchor; the ``bench`` extra), built in the same process, and their ratio (ours over the
anchor) of the median errors. Run it with ``nice -n 10``: it is single-threaded.
"""

from __future__ import annotations

import argparse
import time
import tracemalloc

import numpy as np
import scipy.sparse as sp
import trimesh
from _common import DATA
from sklearn.utils import check_random_state

from sklearn_meshph import (
    LowerStarPersistence,
    check_mesh,
    clean_mesh,
    cotangent_laplacian,
    make_mesh_distance,
    point_cloud_laplacian,
    sample_point_cloud,
)
from sklearn_meshph.diagrams import bottleneck_distance
from sklearn_meshph.spectral.eigensolver import generalized_eigenpairs

#: Sumner figures (one pose of each) and Watertight dev meshes with thin or close parts.
SHAPES = (
    "sumner/cat/cat-01.obj",
    "sumner/elephant/elephant-poses_1.obj",
    "sumner/horse/horse-01.obj",
    "sumner/lion/lion-01.obj",
    "sumner/face/face-poses_1.obj",
    "sumner/head/head-01-anger.obj",
    "watertight_dev/hand/181.off.gz",
    "watertight_dev/octopus/121.off.gz",
    "watertight_dev/ant/081.off.gz",
    "watertight_dev/chair/101.off.gz",
    "watertight_dev/plier/201.off.gz",
    "watertight_dev/fourleg/381.off.gz",
    "watertight_dev/human/001.off.gz",
    "sphere",
)

QUICK = ("sumner/cat/cat-01.obj", "watertight_dev/hand/181.off.gz", "sphere")


def anchor(points):
    import robust_laplacian

    return robust_laplacian.point_cloud_laplacian(points, n_neighbors=30)


def load(shape):
    """The cleaned mesh ``(vertices, faces)`` of a shape's path under DATA (or the sphere)."""
    if shape == "sphere":
        sphere = trimesh.creation.icosphere(6)
        vertices, faces = np.asarray(sphere.vertices), np.asarray(sphere.faces)
    else:
        vertices, faces = check_mesh(DATA / shape)
    clean = clean_mesh(vertices, faces)
    return np.asarray(clean.vertices, dtype=float), np.asarray(clean.faces)


def sample(vertices, faces, n, seed):
    """``sample_point_cloud``'s points, and for each the triangle and barycentric
    coordinates it was drawn with (the same draws, checked against the points)."""
    points = sample_point_cloud((vertices, faces), n, random_state=seed)
    rng = np.random.default_rng(check_random_state(seed).randint(2**31))
    corners = vertices[faces]
    areas = np.linalg.norm(
        np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1
    )
    chosen = rng.choice(len(faces), size=n, p=areas / areas.sum())
    u, v = rng.random(n), rng.random(n)
    flip = u + v > 1
    u[flip], v[flip] = 1 - u[flip], 1 - v[flip]
    weights = np.column_stack([1 - u - v, u, v])
    again = np.einsum("nk,nki->ni", weights, corners[chosen])
    if not np.allclose(again, points):
        raise RuntimeError("sample_point_cloud's draws changed: update sample() here")
    interpolation = sp.csr_matrix(
        (weights.ravel(), (np.repeat(np.arange(n), 3), faces[chosen].ravel())),
        shape=(n, len(vertices)),
    )
    return points, interpolation


def eigenpairs(L, M, points, k):
    """The first ``k + 1`` eigenpairs; points of zero mass (in no triangle: the eigen
    stage drops them) get zero in every eigenvector."""
    mass = np.asarray(M.diagonal(), dtype=float)
    kept = mass > 0
    L = sp.csr_matrix(L)[kept][:, kept]
    values, vectors = generalized_eigenpairs(L, sp.diags(mass[kept]), k + 1, points=points[kept])
    full = np.zeros((len(mass), vectors.shape[1]))
    full[kept] = vectors
    return values, full


def alignment(reference, vectors, mass, k):
    """Mean squared cosine of the principal angles between two k-dimensional spans."""
    a = reference[:, 1 : k + 1] * np.sqrt(mass)[:, None]
    b = vectors[:, 1 : k + 1] * np.sqrt(mass)[:, None]
    qa, qb = np.linalg.qr(a)[0], np.linalg.qr(b)[0]
    return float((np.linalg.svd(qa.T @ qb, compute_uv=False) ** 2).mean())


def timed(build, points):
    start = time.perf_counter()
    L, M = build(points)
    seconds = time.perf_counter() - start
    tracemalloc.start()
    build(points)
    peak = tracemalloc.get_traced_memory()[1] / 2**20
    tracemalloc.stop()
    return L, M, seconds, peak


class Diagrams:
    """Extended persistence of the default's log-HKS columns, without essential H1."""

    def __init__(self):
        self.eigen = make_mesh_distance(n_jobs=1, random_state=0).named_steps["eigen"]
        self.persistence = LowerStarPersistence(filtration="extended", n_jobs=1)

    def __call__(self, sample):
        field = self.eigen.fit_transform([sample])[0]
        diagrams = self.persistence.fit_transform([field])[0]
        per_function = len(diagrams) // field.values.shape[1]
        return diagrams, np.ptp(field.values), per_function

    @staticmethod
    def distance(mesh, cloud):
        """The largest bottleneck distance over the columns' H0, superlevel H0 and
        (min, max) diagrams, relative to the range of the mesh's values (all columns:
        the last log-HKS column is nearly constant)."""
        (mesh_diagrams, spread, per_function), (cloud_diagrams, _, _) = mesh, cloud
        return max(
            float(bottleneck_distance(mesh_diagrams[i], cloud_diagrams[i])) / spread
            for i in range(len(mesh_diagrams))
            if i % per_function < 3
        )


def rows(shape, sizes, builders, n_eigenpairs, diagrams=None):
    vertices, faces = load(shape)
    L, M = cotangent_laplacian(vertices, faces)
    area = M.diagonal().sum()
    values, vectors = eigenpairs(L, M, vertices, n_eigenpairs)
    mesh_diagrams = diagrams((vertices, faces)) if diagrams else None
    for n in sizes:
        points, interpolation = sample(vertices, faces, n, seed=n)
        reference = interpolation @ vectors
        results = {}
        for name, build in builders.items():
            Lc, Mc, seconds, peak = timed(build, points)
            cloud_values, cloud_vectors = eigenpairs(Lc, Mc, points, n_eigenpairs)
            mass = np.asarray(Mc.diagonal(), dtype=float)
            error = np.abs(cloud_values[1:] - values[1:]) / values[1:]
            row = {
                "mass": mass.sum() / area,
                "l1": cloud_values[1] / values[1],
                "med20": float(np.median(error[:20])),
                "med50": float(np.median(error[:50])),
                "align10": alignment(reference, cloud_vectors, mass, 10),
                "align20": alignment(reference, cloud_vectors, mass, 20),
                "s": seconds,
                "MB": peak,
            }
            if diagrams and name == "ours":
                row["bottleneck"] = diagrams.distance(mesh_diagrams, diagrams(points))
            results[name] = row
        yield n, len(vertices), results


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[1000, 3000, 10000, 30000])
    parser.add_argument("--shapes", nargs="+", help="substrings of the shapes to run")
    parser.add_argument("--eigenpairs", type=int, default=50)
    parser.add_argument("--diagrams", action="store_true", help="bottleneck distances too")
    parser.add_argument("--no-anchor", action="store_true", help="ours only")
    parser.add_argument("--quick", action="store_true", help="cat, hand and sphere")
    args = parser.parse_args()
    shapes = QUICK if args.quick else SHAPES
    if args.shapes:
        shapes = [s for s in SHAPES if any(part in s for part in args.shapes)]
    builders = {"ours": point_cloud_laplacian}
    if not args.no_anchor:
        builders["robust-laplacian"] = anchor
    diagrams = Diagrams() if args.diagrams else None
    columns = ["mass", "l1", "med20", "med50", "align10", "align20", "s", "MB"]
    if diagrams:
        columns.insert(6, "bottleneck")
    print("| shape | points | operator | " + " | ".join(columns) + " | med20 ours/anchor |")
    print("|---" * (len(columns) + 4) + "|")
    for shape in shapes:
        for n, n_vertices, results in rows(shape, args.sizes, builders, args.eigenpairs, diagrams):
            for name, row in results.items():
                ratio = ""
                if name == "ours" and "robust-laplacian" in results:
                    ratio = f"{row['med20'] / results['robust-laplacian']['med20']:.2f}"
                cells = [f"{row[c]:.3f}" if c in row else "" for c in columns]
                print(
                    f"| {shape.split('/')[-1]} ({n_vertices}) | {n} | {name} | "
                    + " | ".join(cells)
                    + f" | {ratio} |",
                    flush=True,
                )


if __name__ == "__main__":
    main()
