"""Can a cloud's normals be oriented where its parts touch? (issue 27)

    python benchmarks/cloud_orientation.py [--points 3000] [--noise 0] [--neighbours 10]

The sheet tests that would keep a cloud operator from joining two touching parts need
outward normals (docs/point_clouds.md, "Same points, no faces": with the mesh's, the
Shape-DNA of the Sumner clouds goes from 0.867 to 0.950). This measures how many of a
cloud's points two global orientations get right, against the mesh's outward normals:

- ``mst``: Hoppe et al. (SIGGRAPH 1992), the sign propagated along a minimum spanning
  tree of the k-nearest-neighbour graph weighted ``1 - |n_i . n_j|`` (Open3D's and
  PCL's method; the anchor);
- ``spectral``: the signs of the leading eigenvector of the normalized signed
  adjacency ``n_i . n_j`` over the same graph, the orientation that disagrees least
  with all the neighbour pairs at once (a relaxation of the smallest frustration),
  rather than along one tree.

``--graph operator`` orients over the edges of our cloud operator's fans (the
neighbours its sheet tests keep) instead of the ``--neighbours`` nearest.

Each Sumner mesh is sampled uniformly (``trimesh.sample.sample_surface``, seed 0; the
true normal of a point is its face's), optionally with Gaussian noise of ``--noise``
times the bounding box's diagonal; the normals are the principal axes of the
``--neighbours`` nearest points. A point is right when its oriented normal is on the
side of its face's (the better of the two global signs). Printed per class: the mean
share of points right, and the worst pose; then how much each orientation, the mesh's
included, disagrees with the neighbour pairs (the quantity both methods minimize).
"""

import argparse
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp
import trimesh
from _common import DATA
from scipy.sparse.csgraph import breadth_first_order, connected_components, minimum_spanning_tree
from scipy.sparse.linalg import eigsh
from scipy.spatial import cKDTree

from sklearn_meshph.pointcloud.laplacians import point_cloud_laplacian


def principal_normals(points, k):
    """Unoriented normals: the least principal axis of each point's ``k`` nearest."""
    tree = cKDTree(points)
    _, nearest = tree.query(points, k)
    centred = points[nearest] - points[nearest].mean(axis=1, keepdims=True)
    _, axes = np.linalg.eigh(np.einsum("nki,nkj->nij", centred, centred))
    return axes[:, :, 0], tree


def neighbour_pairs(points, tree, k, graph):
    """The pairs of neighbours ``(rows, cols)``: each point's ``k`` nearest, or the
    edges of our cloud operator's fans (``point_cloud_laplacian``'s stiffness)."""
    if graph == "operator":
        stiffness = sp.triu(point_cloud_laplacian(points)[0], 1).tocoo()
        keep = stiffness.data != 0
        return stiffness.row[keep], stiffness.col[keep]
    _, nearest = tree.query(points, k + 1)
    return np.repeat(np.arange(len(points)), k), nearest[:, 1:].ravel()


def _dots(pairs, normals):
    rows, cols = pairs
    return np.einsum("ij,ij->i", normals[rows], normals[cols])


def mst_signs(pairs, normals):
    rows, cols = pairs
    n = len(normals)
    weights = sp.csr_matrix((1.0 - np.abs(_dots(pairs, normals)) + 1e-9, (rows, cols)), (n, n))
    tree_graph = minimum_spanning_tree(weights.maximum(weights.T))
    tree_graph = tree_graph + tree_graph.T
    signs = np.zeros(n)
    _, component = connected_components(tree_graph, directed=False)
    for label in np.unique(component):
        root = np.flatnonzero(component == label)[0]
        order, parent = breadth_first_order(tree_graph, root, directed=False)
        signs[root] = 1.0
        for node in order[1:]:
            turn = normals[node] @ normals[parent[node]]
            signs[node] = signs[parent[node]] * (1.0 if turn >= 0 else -1.0)
    return signs


def spectral_signs(pairs, normals):
    rows, cols = pairs
    n = len(normals)
    signed = sp.csr_matrix((_dots(pairs, normals), (rows, cols)), shape=(n, n))
    signed = (signed + signed.T) / 2
    degree = np.asarray(abs(signed).sum(axis=1)).ravel()
    scale = sp.diags(1.0 / np.sqrt(np.maximum(degree, 1e-12)))
    _, vector = eigsh(scale @ signed @ scale, k=1, which="LA", v0=np.ones(n))
    return np.where(vector[:, 0] >= 0, 1.0, -1.0)


def disagreement(signs, pairs, normals):
    """The sum of ``|n_i . n_j|`` over the pairs whose oriented normals point apart:
    what both methods make small."""
    rows, cols = pairs
    dots = _dots(pairs, normals)
    return float(np.abs(dots)[signs[rows] * signs[cols] * dots < 0].sum())


def share_right(signs, normals, truth):
    right = np.mean(signs * np.einsum("ij,ij->i", normals, truth) > 0)
    return max(right, 1.0 - right)


METHODS = (mst_signs, spectral_signs)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=3000)
    parser.add_argument("--noise", type=float, default=0.0)
    parser.add_argument("--neighbours", type=int, default=10)
    parser.add_argument(
        "--graph",
        choices=("knn", "operator"),
        default="knn",
        help="the pairs oriented: the --neighbours nearest, or our operator's fan edges",
    )
    parser.add_argument("--data", default=str(DATA / "sumner"), help="the Sumner folder")
    args = parser.parse_args()
    if not 3 <= args.neighbours < args.points:
        parser.error("--neighbours must be at least 3 and fewer than --points")
    if not 0 <= args.noise < float("inf"):
        parser.error("--noise must be finite and at least 0")
    start = time.perf_counter()
    shares, disagreements = {}, []
    for path in sorted(Path(args.data).glob("[!_]*/*.obj")):
        mesh = trimesh.load(path, process=False, force="mesh")
        points, faces = trimesh.sample.sample_surface(mesh, args.points, seed=0)
        if args.noise:
            scale = args.noise * np.linalg.norm(mesh.extents)
            points = points + np.random.default_rng(0).normal(scale=scale, size=points.shape)
        normals, tree = principal_normals(points, args.neighbours)
        truth = mesh.face_normals[faces]
        pairs = neighbour_pairs(points, tree, args.neighbours, args.graph)
        signs = [method(pairs, normals) for method in METHODS]
        shares.setdefault(path.parent.name, []).append(
            [share_right(s, normals, truth) for s in signs]
        )
        true_signs = np.where(np.einsum("ij,ij->i", normals, truth) >= 0, 1.0, -1.0)
        disagreements.append([disagreement(s, pairs, normals) for s in [true_signs, *signs]])
    if not shares:
        raise SystemExit(f"no Sumner meshes under {args.data}")
    print(
        f"{args.points} points, noise {args.noise}, normals of {args.neighbours} "
        f"neighbours, pairs: {args.graph}"
    )
    print("| class | mst: mean | mst: worst | spectral: mean | spectral: worst |")
    print("|---|---|---|---|---|")
    for name, rows in shares.items():
        rows = np.array(rows)
        mean, worst = rows.mean(axis=0), rows.min(axis=0)
        print(f"| {name} | {mean[0]:.3f} | {worst[0]:.3f} | {mean[1]:.3f} | {worst[1]:.3f} |")
    everything = np.vstack(list(shares.values()))
    print(
        f"| all | {everything[:, 0].mean():.3f} | {everything[:, 0].min():.3f} | "
        f"{everything[:, 1].mean():.3f} | {everything[:, 1].min():.3f} |"
    )
    disagreements = np.array(disagreements)
    mean = disagreements.mean(axis=0)
    highest = int(np.sum(disagreements[:, 0] > disagreements[:, 1:].max(axis=1)))
    print(
        f"disagreement (sum of |n_i . n_j| over neighbour pairs oriented apart), mean: the "
        f"mesh's orientation {mean[0]:.0f}, mst {mean[1]:.0f}, spectral {mean[2]:.0f}; the "
        f"mesh's is the highest of the three on {highest} of {len(disagreements)} shapes"
    )
    print(f"{time.perf_counter() - start:.0f} s")


if __name__ == "__main__":
    main()
