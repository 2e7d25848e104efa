"""Where a cloud's operator loses area: the mass per point against the part's thickness.

    python benchmarks/cloud_thin_mass.py [--collection sumner] [--shapes cat lion horse]
        [--points 3000 10000]

For the first mesh of each class named (Sumner's cat, lion and horse by default, the
figures whose clouds are confused at 10,000 points), a uniform sample of the surface
(``trimesh.sample.sample_surface``, seed = the mesh's index; each point knows its
triangle, so its normal) and our operator on it (``point_cloud_laplacian``). Each
point's mass is divided by its expected area, the mesh's area over the number of
points; the points are grouped by how far the other side of the surface is: the
distance to the nearest point whose normal faces away from its own (cosine below
-0.3; none among the 200 nearest: infinite), in spacings ``sqrt(area / points)``, a
thin part's diameter. Printed per group:
its share of the points, their mean mass ratio, and its share of all the area lost.
"""

import argparse

import numpy as np
import trimesh
from _common import collection
from scipy.spatial import cKDTree

from sklearn_meshph import point_cloud_laplacian

EDGES = (0.0, 2.0, 4.0, 8.0, np.inf)  # the groups' bounds, in spacings
FACING_AWAY = -0.3  # cosine of normals below which a point is on the other side
SEARCH = 200  # neighbours searched for the other side


def other_side(points, normals, spacing):
    """Each point's distance to the nearest point facing away from it, in spacings."""
    distances, neighbors = cKDTree(points).query(points, SEARCH)
    away = np.einsum("nkd,nd->nk", normals[neighbors], normals) < FACING_AWAY
    first = np.argmax(away, axis=1)
    found = away[np.arange(len(points)), first]
    return np.where(found, distances[np.arange(len(points)), first], np.inf) / spacing


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--collection", default="sumner")
    parser.add_argument("--shapes", nargs="+", default=["cat", "lion", "horse"])
    parser.add_argument("--points", nargs="+", type=int, default=[3000, 10000])
    args = parser.parse_args()
    loaded = collection(args.collection, 2)
    if loaded is None:
        raise SystemExit(f"{args.collection}: not found (set SKLEARN_MESHPH_DATA)")
    meshes, y, names = loaded
    print(
        "| shape | points | mass / area | other side within | share of the points | "
        "mass ratio | share of the area lost |"
    )
    print("|---|---|---|---|---|---|---|")
    for shape in args.shapes:
        index = int(np.flatnonzero(y == names.index(shape))[0])
        mesh = meshes[index]
        for n_points in args.points:
            points, faces = trimesh.sample.sample_surface(mesh, n_points, seed=index)
            points = np.asarray(points, dtype=np.float64)
            ratio = point_cloud_laplacian(points)[1].diagonal() / (mesh.area / n_points)
            thickness = other_side(points, mesh.face_normals[faces], np.sqrt(mesh.area / n_points))
            lost = np.sum(1.0 - ratio)
            for low, high in zip(EDGES[:-1], EDGES[1:], strict=True):
                group = (thickness >= low) & ((thickness < high) | (high == np.inf))
                if group.any():
                    print(
                        f"| {shape} | {n_points} | {ratio.mean():.3f} | {low:g} to {high:g} "
                        f"spacings | {group.mean():.3f} | {ratio[group].mean():.3f} | "
                        f"{np.sum(1.0 - ratio[group]) / lost:.2f} |"
                    )


if __name__ == "__main__":
    main()
