"""How wide a mesh's holes are, in the spacing of a cloud sampled from it.

    python benchmarks/cloud_slits.py [MESH ...] [--points 3000 10000] [--sew]

A hole narrower than the sampling's spacing (closed lips, a slit) is invisible in a
cloud: the points of its two lips are as close as neighbours across the surface, so any
operator built from the points joins them ("What no cloud operator can know" in
docs/point_clouds.md). For each boundary loop of each mesh (default: one pose of each
Sumner figure with a boundary): its vertices, its length over the mesh's diameter, and
the quantiles of the distance from each of its vertices to the nearest vertex of the
same loop at least 8 steps away along it (across the hole), in spacings
``sqrt(area / points)`` of a uniform cloud of each size.

With ``--sew``, each hole of more than 16 vertices, shorter than twice the diameter, is
sewn shut (its loop split at its two vertices farthest apart, the two halves zipped by
the shorter diagonal), and our cloud operator on ``bench_cloud_operator.py``'s clouds
(seed = the size) is printed against the mesh and against the sewn mesh: the first
eigenvalue's ratio and ``med20``; then where the mesh's first eigenfunction lives (its
vertices above half its largest absolute value: how many, their share of its squared
norm and of the area) and how many of them have another sheet within half a spacing (a
vertex nearer than that whose distance along the edges from the function's peak differs
by more than three times their distance plus a spacing).
"""

import argparse

import numpy as np
import scipy.sparse as sp
import trimesh
from _common import DATA
from bench_cloud_operator import eigenpairs, sample
from scipy.sparse.csgraph import connected_components, dijkstra
from scipy.spatial import cKDTree

from sklearn_meshph import cotangent_laplacian, point_cloud_laplacian

SHAPES = ["face/face-poses_1.obj", "head/head-01-anger.obj"]
QUANTILES = (0.1, 0.25, 0.5, 0.75)
MIN_STEPS = 8


def boundary_loops(faces, n):
    """Each boundary loop's vertices in order along it (the loops that touch no other)."""
    edges = np.sort(np.vstack([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    unique, counts = np.unique(edges, axis=0, return_counts=True)
    border = unique[counts == 1]
    graph = sp.coo_matrix((np.ones(len(border)), border.T), shape=(n, n)).tocsr()
    graph = graph + graph.T
    _, label = connected_components(graph, directed=False)
    loops = []
    for component in np.unique(label[np.unique(border)]):
        start = np.flatnonzero(label == component)[0]
        order, seen = [start], {start}
        while True:  # a vertex where two loops touch ends the walk: the loop is skipped
            following = [w for w in graph[order[-1]].indices if w not in seen]
            if len(following) != 1 and len(order) > 1 or not following:
                break
            order.append(following[0])
            seen.add(following[0])
        if len(order) == np.count_nonzero(label == component):
            loops.append(np.array(order))
    return loops


def across(points):
    """Distance from each vertex of a loop to the nearest at least MIN_STEPS away."""
    distance = np.linalg.norm(points[:, None] - points[None], axis=2)
    steps = np.abs(np.arange(len(points))[:, None] - np.arange(len(points))[None])
    distance[np.minimum(steps, len(points) - steps) < MIN_STEPS] = np.inf
    return distance.min(axis=1)


def sewn(vertices, loop):
    """Triangles closing the hole of ``loop``: its two halves between the two vertices
    farthest apart, zipped by the shorter diagonal at each step."""
    points = vertices[loop]
    first, last = np.unravel_index(
        np.argmax(np.linalg.norm(points[:, None] - points[None], axis=2)), (len(loop),) * 2
    )
    rolled = np.roll(loop, -first)
    cut = (last - first) % len(loop)
    one, two = rolled[: cut + 1], np.append(rolled[cut:], rolled[0])[::-1]
    triangles, a, b = [(one[0], one[1], two[1])], 1, 1
    while a < len(one) - 2 or b < len(two) - 2:
        ahead_one = np.linalg.norm(vertices[one[a + 1]] - vertices[two[b]])
        ahead_two = np.linalg.norm(vertices[one[a]] - vertices[two[b + 1]])
        if b == len(two) - 2 or (a < len(one) - 2 and ahead_one <= ahead_two):
            triangles.append((one[a], one[a + 1], two[b]))
            a += 1
        else:
            triangles.append((one[a], two[b + 1], two[b]))
            b += 1
    triangles.append((one[a], one[a + 1], two[b]))
    return np.array(triangles)


def first_function(mesh, L, M, sizes):
    """Where the mesh's first eigenfunction lives, and how much of it lies against
    another sheet within half a spacing of each size."""
    vertices = np.asarray(mesh.vertices, dtype=float)
    mass = np.asarray(M.diagonal())
    f = eigenpairs(L, M, vertices, 1)[1][:, 1]
    f = f if f.max() >= -f.min() else -f
    region = np.flatnonzero(f > 0.5 * f.max())
    edges = np.asarray(mesh.edges_unique)
    lengths = np.linalg.norm(vertices[edges[:, 0]] - vertices[edges[:, 1]], axis=1)
    graph = sp.coo_matrix((lengths, edges.T), shape=(len(vertices),) * 2).tocsr()
    along = dijkstra(graph, directed=False, indices=region[np.argmax(f[region])])
    tree = cKDTree(vertices)
    counts = []
    for n in sizes:
        spacing = np.sqrt(mesh.area / n)
        near = tree.query_ball_point(vertices[region], 0.5 * spacing)
        counts.append(
            sum(
                any(
                    abs(along[u] - along[v])
                    > 3 * np.linalg.norm(vertices[u] - vertices[v]) + spacing
                    for v in others
                )
                for u, others in zip(region, near, strict=True)
            )
        )
    energy = mass * f**2
    print(
        f"first eigenfunction: {len(region)} vertices above half its largest value, "
        f"{energy[region].sum() / energy.sum():.2f} of its squared norm, "
        f"{mass[region].sum() / mass.sum():.2f} of the area; with another sheet within half "
        + ", ".join(f"a spacing at {n:,} points: {c}" for n, c in zip(sizes, counts, strict=True))
    )


def sew_rows(path, sizes, n_eigenpairs=20):
    """Our cloud operator against the mesh and against the mesh with its holes sewn."""
    mesh = trimesh.load(path, process=False, force="mesh")
    vertices, faces = np.asarray(mesh.vertices, dtype=float), np.asarray(mesh.faces)
    diameter = np.linalg.norm(vertices.max(axis=0) - vertices.min(axis=0))
    patches = [
        sewn(vertices, loop)
        for loop in boundary_loops(faces, len(vertices))
        if len(loop) > 2 * MIN_STEPS
        and np.linalg.norm(np.diff(vertices[loop], axis=0), axis=1).sum() < 2 * diameter
    ]
    references = {}
    for name, triangles in (("mesh", faces), ("sewn", np.vstack([faces, *patches]))):
        L, M = cotangent_laplacian(vertices, triangles)
        references[name] = eigenpairs(L, M, vertices, n_eigenpairs)[0][1:]
        if name == "mesh":
            first_function(mesh, L, M, sizes)
    for n in sizes:
        points, _ = sample(vertices, faces, n, seed=n)
        L, M = point_cloud_laplacian(points)
        ours = eigenpairs(L, M, points, n_eigenpairs)[0][1:]
        cells = [
            f"{ours[0] / values[0]:.3f}, {np.median(np.abs(ours - values) / values):.3f}"
            for values in references.values()
        ]
        print(
            f"| {path.split('/')[-1]} ({len(patches)} sewn) | {n:,} | " + " | ".join(cells) + " |"
        )


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("meshes", nargs="*", default=[str(DATA / "sumner" / s) for s in SHAPES])
    parser.add_argument("--points", type=int, nargs="+", default=[3000, 10000])
    parser.add_argument("--sew", action="store_true", help="the operator against sewn holes")
    args = parser.parse_args()
    if args.sew:
        print("| mesh | points | against the mesh: l1, med20 | against it sewn: l1, med20 |")
        print("|---|---|---|---|")
        for path in args.meshes:
            sew_rows(path, args.points)
        return
    print(
        "| mesh | loop vertices | loop length / diameter | "
        + " | ".join(f"across / spacing at {p:,} points (q{QUANTILES})" for p in args.points)
        + " |"
    )
    print("|---|---|---|" + "---|" * len(args.points))
    for path in args.meshes:
        mesh = trimesh.load(path, process=False, force="mesh")
        vertices, faces = np.asarray(mesh.vertices), np.asarray(mesh.faces)
        diameter = np.linalg.norm(vertices.max(axis=0) - vertices.min(axis=0))
        for loop in boundary_loops(faces, len(vertices)):
            if len(loop) <= 2 * MIN_STEPS:
                continue
            points = vertices[loop]
            length = np.linalg.norm(np.diff(points, axis=0, append=points[:1]), axis=1).sum()
            gaps = across(points)
            cells = [
                ", ".join(f"{q:.2f}" for q in np.quantile(gaps / np.sqrt(mesh.area / p), QUANTILES))
                for p in args.points
            ]
            print(
                f"| {path.split('/')[-1]} | {len(loop)} | {length / diameter:.2f} | "
                + " | ".join(cells)
                + " |"
            )


if __name__ == "__main__":
    main()
