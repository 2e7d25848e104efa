"""Where a cloud's signature departs from its mesh's, and what moves it (issue 27).

    python benchmarks/cloud_signature_error.py [--collection watertight_dev] [--points 3000]
    python benchmarks/cloud_signature_error.py --open-fans [--collection sumner] [--points 10000]
    python benchmarks/cloud_signature_error.py --open-fans --operator [--sizes 3000 10000]

The default's signature (log-HKS at 5 times from 48 eigenpairs, the eigen stage of
``make_mesh_distance()``) on each mesh, and on three point sets of about ``--points``
points: the mesh decimated to that many vertices (``trimesh``'s quadric edge collapse),
its vertices as a cloud, and a uniform cloud (``sample_point_cloud``, seed = the mesh's
index, as ``learning_quality.py``). Printed, first:

- per time, the mean over the shapes of the correlation between the set's signature
  and the mesh's at the nearest mesh vertex, the five classes of lowest correlation at
  the first time, and (uniform clouds) how far the set's largest value lies above the
  mesh's, relative to the mesh's range;
- the share of the uniform clouds' points whose fan is open (their surface neighbours
  all within a half-plane of their tangent plane: the sheet tests cut the rest), and
  the share of clouds whose signature is largest, at the first time, on such a point.

Then the uniform clouds through the default's distance (leave-one-out 1-NN of each
part, ``ord1``, ``ext0``, the Shape-DNA, and all of them without ``ext1``), their
signature recomputed five ways: from the cloud's own eigenpairs (the pipeline's,
as a check), at the mesh's times, at fixed times (the median of the meshes' own), from
the cloud's eigenvectors with the mesh's eigenvalues, and from robust-laplacian's
eigenpairs (30 neighbours); then the signature averaged over the complex's neighbours
1, 2 and 4 times, on meshes and clouds alike.

``--open-fans``: the operator with the tests relaxed at open fans (the plane of the
10 nearest, neighbours low over it for a slope of 1, whatever their normals),
patched into this process: the clouds' accuracy beside the operator's of today.
``--operator`` with it runs ``bench_cloud_operator.py --no-anchor`` with that patch
(the eigenvalue errors against the meshes').
"""

import argparse
import dataclasses
import sys
import warnings

import numpy as np
import scipy.sparse as sp
import trimesh
from _common import collection
from cloud_oracle import PARTS, part_scores
from joblib import parallel_backend
from scipy.spatial import cKDTree

from sklearn_meshph import make_mesh_distance, point_cloud_laplacian, sample_point_cloud
from sklearn_meshph.pointcloud import _triangulation
from sklearn_meshph.spectral.eigensolver import generalized_eigenpairs
from sklearn_meshph.spectral.signatures import heat_kernel_signature, hks_times

TIMES = 5
EIGENPAIRS = 48


def fields_of(samples):
    """The default's eigen stage (threads, so that a patch of this process holds)."""
    with warnings.catch_warnings(), parallel_backend("threading", n_jobs=2):
        warnings.simplefilter("ignore")
        return make_mesh_distance(n_jobs=2).named_steps["eigen"].fit_transform(samples)


def log_hks(values, vectors, times):
    hks = heat_kernel_signature(values, vectors, times)
    trace = np.exp(-np.outer(values, times)).sum(axis=0)
    return np.log(np.maximum(hks, np.finfo(float).tiny) / trace)


def eigenpairs(L, M):
    """The first eigenpairs at unit area, or None where the pencil splits."""
    L, M = sp.csr_matrix(L), sp.dia_matrix(M)
    try:
        return generalized_eigenpairs(L, M / M.diagonal().sum(), EIGENPAIRS)
    except ValueError:
        return None


def robust_pencil(points):
    import robust_laplacian

    return robust_laplacian.point_cloud_laplacian(points, n_neighbors=30)


def open_fans(points):
    """Whether each point's surface neighbours leave a half-turn open around it."""
    points = np.ascontiguousarray(points, dtype=np.float64)
    neighbors, usable, _, basis = ORIGINAL(points)
    return _open(points, neighbors, usable, basis)


def _open(points, neighbors, usable, basis):
    relative = points[neighbors] - points[:, None, :]
    x = np.einsum("nkr,nr->nk", relative, basis[:, :, 0])
    y = np.einsum("nkr,nr->nk", relative, basis[:, :, 1])
    angles = np.sort(np.where(usable, np.arctan2(y, x), np.inf), axis=1)
    counts = usable.sum(axis=1)
    gaps = np.full(len(points), 2 * np.pi)
    for i in np.flatnonzero(counts >= 2):
        a = angles[i, : counts[i]]
        gaps[i] = np.diff(np.r_[a, a[0] + 2 * np.pi]).max()
    return gaps > np.pi


ORIGINAL = _triangulation.surface_neighbours


def relaxed_at_open_fans(points, n_neighbors=_triangulation.LOCAL_NEIGHBORS, knn=None):
    """``surface_neighbours`` with the tests relaxed where a fan is open."""
    neighbors, usable, normal, basis = ORIGINAL(points, n_neighbors, knn)
    points = np.ascontiguousarray(points, dtype=np.float64)
    rows = _open(points, neighbors, usable, basis)
    if rows.any():
        distances = np.linalg.norm(points[neighbors] - points[:, None, :], axis=2)
        first = min(_triangulation.NORMAL_NEIGHBORS, neighbors.shape[1])
        reach = np.maximum(distances, distances[:, first - 1 : first])
        indices = np.ascontiguousarray(neighbors, dtype=np.int64)
        turned, turned_basis = _triangulation._sheet_frames(
            points, indices, reach, first, first, np.inf
        )
        normal, basis, usable = normal.copy(), basis.copy(), usable.copy()
        normal[rows], basis[rows] = turned[rows], turned_basis[rows]
        kept = _triangulation._kept_on_sheet(points, indices, reach, normal, 1.0, 0.0)
        usable[rows] = kept[rows]
    return neighbors, usable, normal, basis


def correlations(meshes, mesh_fields, sets, names):
    for label, fields in sets.items():
        per_shape, excess = [], []
        for mesh, field in zip(mesh_fields, fields, strict=True):
            nearest = cKDTree(mesh.vertices).query(field.vertices)[1]
            reference = mesh.values[nearest]
            per_shape.append(
                [np.corrcoef(field.values[:, t], reference[:, t])[0, 1] for t in range(TIMES)]
            )
            excess.append((field.values.max(0) - mesh.values.max(0)) / np.ptp(mesh.values, 0))
        per_shape = np.array(per_shape)
        by_class = {}
        for name, row in zip(names, per_shape, strict=True):
            by_class.setdefault(name, []).append(row[0])
        worst = sorted(by_class, key=lambda c: np.mean(by_class[c]))[:5]
        print(
            f"| {label} | {' / '.join(f'{c:.3f}' for c in per_shape.mean(0))} | "
            + ", ".join(f"{c} {np.mean(by_class[c]):.2f}" for c in worst)
            + f" | {' / '.join(f'{e:.3f}' for e in np.median(excess, 0))} |"
        )


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--collection", default="watertight_dev")
    parser.add_argument("--points", type=int, default=3000)
    parser.add_argument("--open-fans", action="store_true", help="the relaxed operator")
    parser.add_argument("--operator", action="store_true", help="its eigenvalue errors")
    parser.add_argument("--sizes", default=["3000", "10000"], nargs="+")
    args = parser.parse_args()
    if args.operator:
        import bench_cloud_operator

        _triangulation.surface_neighbours = relaxed_at_open_fans
        sys.argv = ["bench_cloud_operator.py", "--no-anchor", "--sizes", *args.sizes]
        bench_cloud_operator.main()
        return
    loaded = collection(args.collection, 2)
    if loaded is None:
        sys.exit(f"{args.collection} not found")
    meshes, y, target_names = loaded
    names = [target_names[c] for c in y]
    clouds = [sample_point_cloud(m, args.points, random_state=k) for k, m in enumerate(meshes)]
    print(f"{args.collection}, {len(meshes)} meshes, {args.points} points\n")
    if args.open_fans:
        print("| operator | " + " | ".join(PARTS) + " |\n" + "|---" * (len(PARTS) + 1) + "|")
        for label, patch in (("ours", ORIGINAL), ("relaxed at open fans", relaxed_at_open_fans)):
            _triangulation.surface_neighbours = patch
            row = part_scores(fields_of(clouds), y)
            print(f"| {label} | " + " | ".join(f"{s:.3f}" for s in row.values()) + " |")
        _triangulation.surface_neighbours = ORIGINAL
        return
    mesh_fields = fields_of(meshes)
    decimated = []
    for m in meshes:
        full = trimesh.Trimesh(m.vertices, m.faces, process=False)
        if len(full.faces) > 2 * args.points:
            full = full.simplify_quadric_decimation(face_count=2 * args.points)
        decimated.append(full)
    cloud_fields = fields_of(clouds)
    sets = {
        "decimated mesh": fields_of(decimated),
        "its vertices as a cloud": fields_of([np.asarray(d.vertices) for d in decimated]),
        "uniform cloud": cloud_fields,
    }
    print(
        "| points | correlation with the mesh's signature, per time | lowest at the first | "
        "largest value above the mesh's (of its range) |\n|---|---|---|---|"
    )
    correlations(meshes, mesh_fields, sets, names)
    opened = [open_fans(f.vertices) for f in cloud_fields]
    at_max = [o[np.argmax(f.values[:, 0])] for o, f in zip(opened, cloud_fields, strict=True)]
    print(
        f"\nopen fans: {np.mean([o.mean() for o in opened]):.3f} of the points; the "
        f"signature's largest value (first time) on one in {np.mean(at_max):.3f} of the clouds\n"
    )
    grid = np.median([hks_times(f.spectrum, TIMES) for f in mesh_fields], axis=0)
    variants = {
        name: []
        for name in (
            "the cloud's own eigenpairs",
            "the mesh's times",
            "fixed times",
            "the mesh's eigenvalues, the cloud's eigenvectors",
            "robust-laplacian's eigenpairs",
        )
    }
    for mesh, field in zip(mesh_fields, cloud_fields, strict=True):
        pairs = eigenpairs(*point_cloud_laplacian(field.vertices))
        robust = eigenpairs(*robust_pencil(field.vertices))
        values = {}
        if pairs is not None:
            vals, vecs = pairs
            values["the cloud's own eigenpairs"] = log_hks(vals, vecs, hks_times(vals, TIMES))
            values["the mesh's times"] = log_hks(vals, vecs, hks_times(mesh.spectrum, TIMES))
            values["fixed times"] = log_hks(vals, vecs, grid)
            if len(mesh.spectrum) == len(vals):
                values["the mesh's eigenvalues, the cloud's eigenvectors"] = log_hks(
                    mesh.spectrum, vecs, hks_times(mesh.spectrum, TIMES)
                )
        if robust is not None:
            values["robust-laplacian's eigenpairs"] = log_hks(*robust, hks_times(robust[0], TIMES))
        for name, kept in variants.items():  # the pipeline's own where a pencil split
            kept.append(
                dataclasses.replace(field, values=values[name]) if name in values else field
            )
    print(
        "| uniform clouds' signature | "
        + " | ".join(PARTS)
        + " |\n"
        + "|---" * (len(PARTS) + 1)
        + "|"
    )
    for label, fields in {"the pipeline's": cloud_fields, **variants}.items():
        row = part_scores(fields, y)
        print(f"| {label} | " + " | ".join(f"{s:.3f}" for s in row.values()) + " |")
    print(
        "\n| averaged over the neighbours | meshes: "
        + ", ".join(PARTS)
        + " | clouds: "
        + ", ".join(PARTS)
        + " |\n|---|---|---|"
    )
    for steps in (0, 1, 2, 4):
        rows = [
            part_scores([smoothed(f, steps) for f in fields], y)
            for fields in (mesh_fields, cloud_fields)
        ]
        cells = [" / ".join(f"{s:.3f}" for s in row.values()) for row in rows]
        print(f"| {steps} | " + " | ".join(cells) + " |", flush=True)


def smoothed(field, steps):
    """The field's values averaged ``steps`` times, half with the mean of the neighbours
    over the complex's edges."""
    pieces = [field.edges] if field.edges is not None and len(field.edges) else []
    if len(field.faces):
        f = field.faces
        pieces.append(np.vstack([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]))
    edges = np.vstack(pieces)
    n = len(field.values)
    adjacency = sp.coo_matrix((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(n, n))
    adjacency = ((adjacency + adjacency.T) > 0).astype(float).tocsr()
    degree = np.maximum(np.asarray(adjacency.sum(axis=1)).ravel(), 1)[:, None]
    values = field.values.copy()
    for _ in range(steps):
        values = 0.5 * values + 0.5 * (adjacency @ values) / degree
    return dataclasses.replace(field, values=values)


if __name__ == "__main__":
    main()
