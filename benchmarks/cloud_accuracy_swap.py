"""Which of issue 27's two changes moves the accuracy of clouds: the operator or the complex.

    python benchmarks/cloud_accuracy_swap.py OPERATOR COMPLEX [--points 3000]
        [--collection watertight_dev] [--per-class N] [--cache DIR]

``OPERATOR`` is ``new`` (the operator on each point's own sheet), ``old`` (commit
``2eb9ede``'s: the Delaunay fan of all 30 neighbours in the principal plane of all 30,
measured in that plane), ``chord`` (the new operator's triangles measured by their
chords in space, not on the fitted quadric) or ``robust`` (robust-laplacian's, 30
neighbours, in place of ``point_cloud_laplacian``; the complex stays ours); ``COMPLEX``
is ``new`` (the edges of the operator's local triangles: with ``old``, the old fans'),
``knn`` (the symmetric 10-nearest-neighbour graph of ``2eb9ede``) or ``sheet`` (the
triangles' edges and each point's 10 nearest neighbours that the operator keeps on its
sheet), put in place of each field's edges after the eigen stage. The same clouds as
``learning_quality.py`` (seed = the mesh's index) go through ``make_mesh_distance()``;
printed: leave-one-out 1-NN, and, beside the meshes' distance matrix without essential
H1 (what a cloud's diagrams can hold), the Spearman correlation of the two matrices and
the share of each sample's 5 nearest that they have in common. The swapped operators'
solves are cached in folders of their own (``DIR/old-operator``, ``DIR/chord-operator``,
``DIR/robust-operator``): the cache's key does not know the operator was swapped.
"""

import argparse
import dataclasses
import warnings
from pathlib import Path

import numpy as np
from _common import DATA, loo_1nn
from scipy.stats import spearmanr

from sklearn_meshph import load_mesh_folder, make_mesh_distance, sample_point_cloud
from sklearn_meshph._registry import Option
from sklearn_meshph.mesh import DEGENERATE_SINE, unit_box
from sklearn_meshph.mesh.cleaning import MeshCleaningWarning
from sklearn_meshph.pointcloud import graph as cloud_graph
from sklearn_meshph.pointcloud import laplacians as cloud_laplacians
from sklearn_meshph.pointcloud._triangulation import (
    local_delaunay_fans,
    nearest,
    surface_neighbours,
)

NO_EXT1 = {"ext0": 0.5, "ext1": 0.0, "dna": 0.5}
NEW_TANGENT_FANS = cloud_laplacians.tangent_fans


def old_tangent_fans(points, n_neighbors=30, knn=None):
    """The fans of commit 2eb9ede, with a zero height (the new operator's 3-D edges)."""
    _, neighbors = nearest(points, n_neighbors)
    relative = points[neighbors] - points[:, None, :]
    basis = np.linalg.eigh(np.einsum("nki,nkj->nij", relative, relative))[1][:, :, 1:]
    coords = np.ascontiguousarray(np.einsum("nki,nij->nkj", relative, basis))
    fans = local_delaunay_fans(coords, np.ones(coords.shape[:2], dtype=bool))
    i, ja, jb = fans.T
    a, b = coords[i, ja], coords[i, jb]
    double_area = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    longest = np.maximum(np.maximum((a * a).sum(1), (b * b).sum(1)), ((b - a) ** 2).sum(1))
    keep = double_area > DEGENERATE_SINE * longest
    zero = np.zeros((int(keep.sum()), 1))
    triangles = np.column_stack([i, neighbors[i, ja], neighbors[i, jb]])[keep]
    return triangles, np.hstack([a[keep], zero]), np.hstack([b[keep], zero])


def chord_tangent_fans(points, n_neighbors=30, knn=None):
    """The new operator's triangles, their edges the chords between the points."""
    triangles, _, _ = NEW_TANGENT_FANS(points, n_neighbors, knn)
    points = np.asarray(points, dtype=np.float64)
    i, j, k = triangles.T
    return triangles, points[j] - points[i], points[k] - points[i]


def robust_operator(points, n_neighbors=30, *, knn=None):
    """robust-laplacian's point-cloud operator (ours on pieces too small for it), and our
    local triangles (the complex)."""
    import robust_laplacian

    ours = cloud_laplacians.cloud_operator(points, knn=knn)
    if len(points) <= 2 * n_neighbors:
        return ours
    L, M = robust_laplacian.point_cloud_laplacian(points, n_neighbors=n_neighbors)
    return L.tocsr(), M, ours[2]


def sheet_graph(points, width=10):
    """The triangles' edges and each point's ``width`` nearest kept on its sheet."""
    order = cloud_graph.canonical_order(points)
    neighbors, usable, _, _ = surface_neighbours(unit_box(points[order])[0])
    near = usable[:, :width]
    rows = np.broadcast_to(np.arange(len(points))[:, None], near.shape)
    a, b = order[rows[near]], order[neighbors[:, :width][near]]
    extra = np.column_stack([np.minimum(a, b), np.maximum(a, b)])
    return np.unique(np.vstack([cloud_graph.surface_graph(points), extra]), axis=0)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("operator", choices=["new", "old", "chord", "robust"])
    parser.add_argument("complex", choices=["new", "knn", "sheet"])
    parser.add_argument("--points", type=int, default=3000)
    parser.add_argument("--collection", default="watertight_dev")
    parser.add_argument("--per-class", type=int, default=None, help="first N of each class")
    parser.add_argument("--cache", default=None, help="eigensolve cache folder")
    args = parser.parse_args()
    memory = args.cache
    if args.operator == "old":
        cloud_laplacians.tangent_fans = old_tangent_fans
        memory = None if memory is None else str(Path(memory) / "old-operator")
    if args.operator == "chord":
        cloud_laplacians.tangent_fans = chord_tangent_fans
        memory = None if memory is None else str(Path(memory) / "chord-operator")
    if args.operator == "robust":
        cloud_laplacians.CLOUD_LAPLACIANS._options["cotangent"] = Option(
            "cotangent", robust_operator, "robust-laplacian's"
        )
        memory = None if memory is None else str(Path(memory) / "robust-operator")
    bunch = load_mesh_folder(DATA / args.collection)
    y = np.asarray(bunch.target)
    keep = np.arange(len(y))
    if args.per_class is not None:
        keep = np.concatenate([np.flatnonzero(y == c)[: args.per_class] for c in np.unique(y)])
    meshes, y = [bunch.data[i] for i in keep], y[keep]
    clouds = [sample_point_cloud(m, args.points, random_state=k) for k, m in enumerate(meshes)]
    pipeline = make_mesh_distance(memory=memory, n_jobs=1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MeshCleaningWarning)
        fields = pipeline[:1].fit_transform(clouds)
    if args.complex != "new":
        complex_of = cloud_graph.knn_graph if args.complex == "knn" else sheet_graph
        fields = [dataclasses.replace(f, edges=complex_of(f.vertices)) for f in fields]
    matrix = pipeline[1:].fit_transform(fields)
    reference = (
        make_mesh_distance(memory=args.cache, n_jobs=1)
        .set_params(distance__weights=NO_EXT1)
        .fit_transform(meshes)
    )
    upper = np.triu_indices(len(y), 1)
    common = np.mean(
        [
            len(set(np.argsort(matrix[i])[1:6]) & set(np.argsort(reference[i])[1:6])) / 5
            for i in range(len(y))
        ]
    )
    print(
        f"{args.collection}, {args.points} points, operator {args.operator}, complex "
        f"{args.complex}: LOO {loo_1nn(matrix, y):.3f}; against the meshes without essential "
        f"H1 (LOO {loo_1nn(reference, y):.3f}): Spearman "
        f"{spearmanr(matrix[upper], reference[upper])[0]:.3f}, 5 nearest in common {common:.3f}"
    )


if __name__ == "__main__":
    main()
