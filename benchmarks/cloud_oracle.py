"""Where clouds lose accuracy against their meshes (issue 27): resolution, sampling,
stiffness or mass.

    python benchmarks/cloud_oracle.py [--collection sumner] [--points 3000] [--per-class N]

Four inputs go through ``make_mesh_distance()`` (every mesh row without essential H1,
which no cloud has), scored by leave-one-out 1-NN per part of the distance (``ord1``,
``ext0``, Shape-DNA, and all of them):

- the meshes;
- the meshes **decimated** to about ``--points`` vertices (quadric edge collapse,
  ``trimesh.simplify_quadric_decimation``; a mesh with fewer kept as it is): the
  resolution of the clouds;
- the decimated meshes' **vertices as clouds**: the same points, without the faces;
- **uniform clouds** of ``--points`` points (``sample_point_cloud``, seed = the mesh's
  index, as ``learning_quality.py``).

A second table tells the operator from the complex, on the samples where cleaning kept
the same vertices in the decimated mesh and in its vertices as a cloud: the mesh's
values and spectrum on the cloud's complex (the edges of our local triangles), and the
cloud's on the mesh's faces, beside each on its own; and ``ord1`` of each time of the
signature alone, for the mesh's values and the cloud's.

Then the operator alone, on the decimated vertices (the decimated mesh cleaned): the
Shape-DNA (first 48 eigenvalues times the area, Canberra distance, leave-one-out 1-NN)
of the pencil ``(L, M)`` built five ways: the mesh's cotangent stiffness and mass;
ours (``point_cloud_laplacian``); robust-laplacian's (30 neighbours, the anchor); and
the two mixtures (the mesh's stiffness with our mass, our stiffness with the mesh's
mass), which tell whether what is lost is in the stiffness or in the mass; and two
oracles, our operator with the neighbours the mesh says are on another sheet left out
(facing away by the mesh's outward normals, or more than twice as far along the mesh's
edges as in space), which tell what telling sheets apart would give. Each Shape-DNA is
of the piece of largest mass (an oracle can cut a thin tip off). Then the default's
signature (log-HKS) from five of these pencils and our stiffness without its negative
weights, each on the decimated mesh's faces, and its ``ord1`` 1-NN: which of the
stiffness and the mass moves the eigenfunctions; beside them the mesh's surface
triangulated otherwise (its intrinsic Delaunay triangulation), our fans made into one
triangulation (every triangle once, or a manifold chosen from them) and the two oracles:
does another valid triangulation of the same points keep the mesh's figure, and do the
fans lose by disagreeing or by joining other sheets? Each row is scored on the samples
where its pencil has mass at every vertex and one piece, the mesh's beside it on those.

Last, how much of each class's surface has **another sheet within one spacing**: the
decimated mesh's vertices with a vertex within one spacing (``sqrt(area / n)``) in space
but more than five spacings away along the mesh's edges (a paw against the body, a tail
along a leg, closed lips). No neighbourhood of a cloud can see the gap there.
"""

import argparse
import dataclasses
import time
import warnings

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as sla
import trimesh
from _common import DATA, collection, edge_graph, loo_1nn
from scipy.sparse.csgraph import connected_components, dijkstra
from scipy.spatial import cKDTree
from scipy.spatial.distance import cdist

from sklearn_meshph import (
    DiagramDistance,
    ScalarField,
    clean_mesh,
    cotangent_laplacian,
    make_mesh_distance,
    point_cloud_laplacian,
    sample_point_cloud,
)
from sklearn_meshph.mesh import unit_box
from sklearn_meshph.mesh.cleaning import MeshCleaningWarning
from sklearn_meshph.pointcloud import _triangulation
from sklearn_meshph.spectral.eigensolver import generalized_eigenpairs
from sklearn_meshph.spectral.signatures import SIGNATURES

PARTS = {
    "ord1": {"ord1": 1.0, "ext0": 0.0, "ext1": 0.0, "dna": 0.0},
    "ext0": {"ord1": 0.0, "ext0": 1.0, "ext1": 0.0, "dna": 0.0},
    "Shape-DNA": {"ord1": 0.0, "ext0": 0.0, "ext1": 0.0, "dna": 1.0},
    "all (no ext1)": {"ext0": 0.5, "ext1": 0.0, "dna": 0.5},
}
N_EIGENVALUES = 48


def decimate(mesh, n_points):
    """The mesh decimated to about ``n_points`` vertices (``2 n_points`` faces); a mesh
    with fewer faces is kept as it is."""
    full = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
    if len(full.faces) <= 2 * n_points:
        return full
    return full.simplify_quadric_decimation(face_count=2 * n_points)


def fields_of(samples):
    """The default's eigen stage on ``samples`` (its scalar fields)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MeshCleaningWarning)
        return make_mesh_distance(n_jobs=2).named_steps["eigen"].fit_transform(samples)


def part_scores(fields, y):
    """Leave-one-out 1-NN of each part of the default's distance on the ``fields``."""
    distance = make_mesh_distance(n_jobs=2).named_steps["distance"]
    return {
        part: loo_1nn(distance.set_params(weights=weights).fit_transform(fields), y)
        for part, weights in PARTS.items()
    }


def swapped(meshes, clouds):
    """Each sample's values and spectrum (what the operator gives) from ``meshes`` on the
    complex of ``clouds`` where the two kept the same vertices; ``clouds``' own field
    elsewhere."""
    return [
        dataclasses.replace(
            cloud, values=mesh.values, eigenvalues=mesh.eigenvalues, spectrum=mesh.spectrum
        )
        if np.array_equal(mesh.vertices, cloud.vertices)
        else cloud
        for mesh, cloud in zip(meshes, clouds, strict=True)
    ]


def ord1_per_time(fields, y):
    """Leave-one-out 1-NN of the default's ``ord1`` diagrams of each time alone."""
    parts = dict(make_mesh_distance(n_jobs=2).named_steps["distance"].transformer_list)
    diagrams = parts["ord1"].steps[0][1].fit_transform(fields)
    return [
        loo_1nn(
            DiagramDistance(metric="wasserstein", order=1, n_jobs=2).fit_transform(
                [d[t] for d in diagrams]
            ),
            y,
        )
        for t in range(len(diagrams[0]))
    ]


def shape_dna(L, M):
    """The first eigenvalues (the zero one left out) times the area, of the points with
    mass (a cloud's point in no triangle has none), on the piece of largest mass."""
    L, M = sp.csr_matrix(L), sp.csr_matrix(M)
    keep = M.diagonal() > 0
    L, M = L[keep][:, keep], M[keep][:, keep]
    _, labels = connected_components(abs(L) > 0, directed=False)
    keep = labels == np.argmax(np.bincount(labels, weights=M.diagonal()))
    L, M = L[keep][:, keep], M[keep][:, keep]
    start = np.ones(L.shape[0])
    values = sla.eigsh(L, N_EIGENVALUES + 1, M, sigma=-1e-6, which="LM", v0=start)[0]
    return np.sort(values)[1:] * M.sum()


def robust(points):
    import robust_laplacian

    L, M = robust_laplacian.point_cloud_laplacian(points, n_neighbors=30)
    return L, M


def with_neighbours_left_out(points, leave_out):
    """Our operator with ``leave_out(neighbors)`` (an ``(n, k)`` mask) removed from every
    point's surface neighbours (an oracle: the mask comes from the mesh)."""
    original = _triangulation.surface_neighbours

    def patched(points, n_neighbors, knn=None):
        neighbors, usable, normal, basis = original(points, n_neighbors, knn)
        return neighbors, usable & ~leave_out(neighbors), normal, basis

    _triangulation.surface_neighbours = patched
    try:
        return point_cloud_laplacian(points)
    finally:
        _triangulation.surface_neighbours = original


def facing_away(normals, cosine=-0.5):
    """Neighbours whose outward normal (the mesh's) is more than 120 degrees from the
    point's: the other sheet of a contact, the far side of a thin part."""
    return lambda neighbors: np.einsum("nkj,nj->nk", normals[neighbors], normals) < cosine


def around(points, faces, ratio=2.0):
    """Neighbours more than ``ratio`` times farther along the mesh's edges than in space."""
    graph = edge_graph(points, faces)[0]

    def mask(neighbors):
        rows = np.repeat(np.arange(len(points)), neighbors.shape[1])
        space = np.linalg.norm(points[rows] - points[neighbors.ravel()], axis=1)
        along = dijkstra(graph, directed=False, limit=1.01 * ratio * space.max())
        return (along[rows, neighbors.ravel()] > ratio * space).reshape(neighbors.shape)

    return mask


def pencils(mesh):
    """The cleaned decimated mesh's vertices (in the unit box) and faces, and the pencils
    ``(L, M)`` built on those vertices: the mesh's, ours, robust-laplacian's and the
    two mixtures (decimation can leave degenerate faces, hence the cleaning)."""
    unit = unit_box(np.asarray(mesh.vertices, dtype=np.float64))[0]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MeshCleaningWarning)
        clean = clean_mesh(unit, np.asarray(mesh.faces))
    points, faces = clean.vertices, clean.faces
    L_mesh, M_mesh = cotangent_laplacian(points, faces)
    L_ours, M_ours = point_cloud_laplacian(points)
    return (
        points,
        faces,
        {
            "the mesh's L and M": (L_mesh, M_mesh),
            "ours": (L_ours, M_ours),
            "robust-laplacian": robust(points),
            "the mesh's L, our M": (L_mesh, M_ours),
            "our L, the mesh's M": (L_ours, M_mesh),
        },
    )


def operators(points, faces, built):
    """Shape-DNA of each pencil of :func:`pencils`, and of the two oracles."""
    normals = trimesh.Trimesh(points, faces, process=False).vertex_normals
    spectra = {label: shape_dna(L, M) for label, (L, M) in built.items()}
    spectra["ours, neighbours facing away (mesh normals) left out"] = shape_dna(
        *with_neighbours_left_out(points, facing_away(normals))
    )
    spectra["ours, neighbours 2x farther along the mesh left out"] = shape_dna(
        *with_neighbours_left_out(points, around(points, faces))
    )
    return spectra


def without_negative_weights(L):
    """The stiffness with its negative edge weights (obtuse corners) set to zero."""
    weights = -sp.csr_matrix(L, copy=True)
    weights.setdiag(0.0)
    weights.data = np.maximum(weights.data, 0.0)
    weights.eliminate_zeros()
    return (sp.diags(np.asarray(weights.sum(axis=1)).ravel()) - weights).tocsr()


def fan_triangulations(points):
    """Our fans' triangles made into one triangulation, two ways, each triangle measured
    flat in space (not on a point's quadric) and counted once: every triangle some fan
    holds (a soup, overlapping where fans disagree), and a manifold chosen greedily from
    them (those held by more fans first, then the rounder; a triangle is taken while
    none of its edges has two triangles yet). Do the fans lose by disagreeing?"""
    fans = np.sort(_triangulation.tangent_fans(points)[0], axis=1)
    triangles, held = np.unique(fans, axis=0, return_counts=True)
    corners = points[triangles]
    sides = corners[:, [1, 2, 0]] - corners
    roundness = np.linalg.norm(np.cross(sides[:, 0], sides[:, 1]), axis=1) / (sides**2).sum(
        axis=(1, 2)
    )
    taken, edges_used = [], {}
    for t in np.lexsort((-roundness, -held)):
        a, b, c = triangles[t]
        edges = ((a, b), (b, c), (a, c))
        if all(edges_used.get(e, 0) < 2 for e in edges):
            for e in edges:
                edges_used[e] = edges_used.get(e, 0) + 1
            taken.append(t)
    return triangles, triangles[np.sort(taken)]


def signature_fields(points, faces, built):
    """The default's signature (log-HKS at 5 times from 48 eigenpairs, unit area) from
    each pencil of :func:`pencils`, from our stiffness without its negative weights, from
    the mesh's own surface triangulated otherwise (its intrinsic Delaunay triangulation,
    robust-laplacian's ``mesh_laplacian``), from our fans made into one triangulation
    (:func:`fan_triangulations`), and from the two oracles of :func:`operators`, each on
    the mesh's faces (the complex held fixed). A pencil that leaves a vertex without
    mass or splits gives None (its fields would not be comparable)."""
    import robust_laplacian

    L_ours, M_ours = built["ours"]
    soup, manifold = fan_triangulations(points)
    normals = trimesh.Trimesh(points, faces, process=False).vertex_normals
    all_pencils = {
        **built,
        "ours, negative weights set to 0": (without_negative_weights(L_ours), M_ours),
        "the mesh's intrinsic Delaunay triangulation": robust_laplacian.mesh_laplacian(
            points, faces
        ),
        "our fans' triangles, each once, flat": cotangent_laplacian(points, soup),
        "a manifold chosen from our fans, flat": cotangent_laplacian(points, manifold),
        "ours, neighbours facing away (mesh normals) left out": with_neighbours_left_out(
            points, facing_away(normals)
        ),
        "ours, neighbours 2x farther along the mesh left out": with_neighbours_left_out(
            points, around(points, faces)
        ),
    }
    fields = {}
    for label, (L, M) in all_pencils.items():
        L, M = sp.csr_matrix(L), sp.dia_matrix(M)
        if (M.diagonal() <= 0).any() or connected_components(abs(L) > 0, directed=False)[0] > 1:
            fields[label] = None
            continue
        values, vectors = generalized_eigenpairs(L, M / M.diagonal().sum(), N_EIGENVALUES)
        signature, _ = SIGNATURES["log-hks"].value(values, vectors, 5)
        fields[label] = ScalarField(points, faces, signature, eigenvalues=values)
    return fields


def contact_share(mesh, within=1.0, apart=5.0):
    """Share of the vertices with another sheet within ``within`` spacings in space
    and more than ``apart`` spacings away along the edges."""
    points = np.asarray(mesh.vertices, dtype=np.float64)
    faces = np.asarray(mesh.faces)
    spacing = np.sqrt(mesh.area / len(points))
    graph = edge_graph(points, faces)[0]
    pairs = cKDTree(points).query_pairs(within * spacing, output_type="ndarray")
    if len(pairs) == 0:
        return 0.0
    along = dijkstra(graph, directed=False, limit=1.2 * apart * spacing)
    far = along[pairs[:, 0], pairs[:, 1]] > apart * spacing
    return len(np.unique(pairs[far])) / len(points)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--collection", default="sumner")
    parser.add_argument("--points", type=int, default=3000)
    parser.add_argument("--per-class", type=int, default=None, help="first N of each class")
    args = parser.parse_args()
    loaded = collection(args.collection, 2)
    if loaded is None:
        raise SystemExit(f"{args.collection} not found in {DATA}")
    meshes, y, names = loaded
    if args.per_class is not None:
        keep = np.concatenate([np.flatnonzero(y == c)[: args.per_class] for c in np.unique(y)])
        meshes, y = [meshes[i] for i in keep], y[keep]
    start = time.perf_counter()
    decimated = [decimate(m, args.points) for m in meshes]
    inputs = {
        "meshes": meshes,
        f"meshes decimated to ~{args.points} vertices": decimated,
        "their vertices as clouds": [np.asarray(d.vertices) for d in decimated],
        f"uniform clouds of {args.points} points": [
            sample_point_cloud(m, args.points, random_state=k) for k, m in enumerate(meshes)
        ],
    }
    print(
        f"{args.collection}: {len(meshes)} meshes; make_mesh_distance(), leave-one-out 1-NN "
        "per part of the distance"
    )
    print(f"| input | {' | '.join(PARTS)} |\n|---|{'---|' * len(PARTS)}")
    fields = {}
    for label, samples in inputs.items():
        fields[label] = fields_of(samples)
        scores = part_scores(fields[label], y)
        print(f"| {label} | {' | '.join(f'{scores[p]:.3f}' for p in PARTS)} |", flush=True)
    decimated_fields, vertex_fields = list(fields.values())[1:3]
    # The operator or the complex: the mesh's values on the cloud's complex and the
    # cloud's values on the mesh's faces, on the samples where cleaning kept the same
    # vertices in both (every row of this table on those samples only).
    same = np.flatnonzero(
        [
            np.array_equal(a.vertices, b.vertices)
            for a, b in zip(decimated_fields, vertex_fields, strict=True)
        ]
    )
    meshes_kept = [decimated_fields[i] for i in same]
    clouds_kept = [vertex_fields[i] for i in same]
    print(
        f"\nThe operator or the complex, on the {len(same)} samples whose decimated mesh and "
        "vertices as a cloud kept the same vertices"
    )
    print(f"| values and spectrum, complex | {' | '.join(PARTS)} |\n|---|{'---|' * len(PARTS)}")
    for label, mixed in (
        ("the mesh's, its faces", meshes_kept),
        ("the cloud's, its local triangles' edges", clouds_kept),
        ("the mesh's, the cloud's edges", swapped(meshes_kept, clouds_kept)),
        ("the cloud's, the mesh's faces", swapped(clouds_kept, meshes_kept)),
    ):
        scores = part_scores(mixed, y[same])
        print(f"| {label} | {' | '.join(f'{scores[p]:.3f}' for p in PARTS)} |", flush=True)

    print("\n`ord1` alone per time of the signature (1-Wasserstein), on the same samples")
    for label, kept in (("the mesh's values", meshes_kept), ("the cloud's values", clouds_kept)):
        per_time = ord1_per_time(kept, y[same])
        print(f"| {label} | {' | '.join(f'{score:.3f}' for score in per_time)} |", flush=True)

    built = [pencils(d) for d in decimated]
    spectra = [operators(*b) for b in built]
    print(
        f"\nThe operator alone on the decimated vertices: Shape-DNA ({N_EIGENVALUES} "
        "eigenvalues x area, Canberra), leave-one-out 1-NN, and the median over the shapes "
        "of the median relative error of eigenvalues 1-20 against the mesh's"
    )
    print("| pencil | Shape-DNA 1-NN | median error 1-20 |\n|---|---|---|")
    reference = np.array([s["the mesh's L and M"] for s in spectra])
    for label in spectra[0]:
        features = np.array([s[label] for s in spectra])
        distances = cdist(features, features, "canberra")
        error = np.median(np.median(np.abs(features / reference - 1)[:, :20], axis=1))
        print(f"| {label} | {loo_1nn(distances, y):.3f} | {error:.3f} |", flush=True)
    first = np.array([[s["the mesh's L and M"][0], s["ours"][0]] for s in spectra])
    print("\nFirst eigenvalue x area, the mesh's and ours, where ours is farthest above:")
    for i in np.argsort(first[:, 0] / first[:, 1])[:5]:
        print(f"- sample {i} ({names[y[i]]}): {first[i, 0]:.1f} and {first[i, 1]:.1f}")

    signatures = [signature_fields(*b) for b in built]
    reference = "the mesh's L and M"
    print(
        "\n`ord1` of the signature of each pencil, on the mesh's faces (the complex held "
        "fixed), on the samples where that pencil and the mesh's have mass at every vertex "
        "and one piece, beside the mesh's pencil on the same samples"
    )
    print("| pencil | samples | `ord1` 1-NN | the mesh's on them |\n|---|---|---|---|")
    ord1 = dict(make_mesh_distance(n_jobs=2).named_steps["distance"].transformer_list)["ord1"]
    for label in signatures[0]:
        usable = np.flatnonzero(
            [f[label] is not None and f[reference] is not None for f in signatures]
        )
        score, mesh_score = (
            loo_1nn(ord1.fit_transform([signatures[i][key] for i in usable]), y[usable])
            for key in (label, reference)
        )
        print(f"| {label} | {len(usable)} | {score:.3f} | {mesh_score:.3f} |", flush=True)

    shares = np.array([contact_share(d) for d in decimated])
    print("\nVertices of the decimated meshes with another sheet within one spacing")
    print("| class | mean | largest |\n|---|---|---|")
    for c in np.unique(y):
        print(f"| {names[c]} | {shares[y == c].mean():.3f} | {shares[y == c].max():.3f} |")
    print(f"\n{time.perf_counter() - start:.0f} s")


if __name__ == "__main__":
    main()
