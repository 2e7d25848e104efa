"""The metric-based comparator of Chazal, Cohen-Steiner, Guibas, Memoli & Oudot (SGP 2009).

    python benchmarks/gh_signatures.py [--collections sumner shapes watertight_dev]
                                       [--n-samples 400] [--n-jobs 2] [--save DIR]

"Gromov-Hausdorff stable signatures for shapes using persistence" compares shapes by the
persistence diagrams of Vietoris-Rips filtrations of their intrinsic (geodesic) metric,
computed on a point sample of each shape, with the bottleneck distance. The paper we
reproduce (Zhang, Liu, Rosen & Hajij) claims that one Laplacian eigenfunction's H0
diagram has more classification power than this approach; this module is the baseline
of that comparison. It is a benchmark, not an estimator of the library.

Per mesh:

1. **Cleaning.** :func:`sklearn_meshph.clean_mesh` with its defaults (coincident vertices
   welded, degenerate and duplicate faces dropped, the connected component of largest
   area kept), as the library's pipelines do. The intrinsic metric of a disconnected
   mesh is infinite between components, so the largest component is the shape.
2. **Geodesics.** Exact shortest paths on the mesh edge graph, edge weights the Euclidean
   edge lengths, by :func:`scipy.sparse.csgraph.dijkstra`. A graph geodesic is never
   shorter than the surface geodesic it approximates and, on a well-shaped mesh, longer
   by a bounded factor: paths zigzag along the edges, so the relative error does not
   vanish under refinement (on subdivided unit icospheres of 642 to 10242 vertices the
   ratio to the great-circle distance has median 1.07 and maximum 1.22 at every level).
   The distortion is about the same for every pose of a shape meshed alike, so the
   comparison stays consistent. The graph metric is computed exactly, needs no solver
   tolerance, and leaves no heat-method or fast-marching implementation to maintain.
   The metric of the sample is this graph metric restricted to the samples.
3. **Sampling.** Farthest-point sampling in that geodesic metric
   (:func:`farthest_point_sample`): the first sample is the vertex farthest from vertex 0
   (an end of an approximate diameter, so the sample does not depend much on the vertex
   order) or, with an integer ``seed``, a random vertex; every further sample is the
   vertex farthest from the samples so far (ties: lowest index). Each step runs one
   Dijkstra from the new sample, which both updates the distance of every vertex to the
   sample and gives the new sample's distances to all earlier ones: the full
   sample-to-sample matrix comes with the sampling, ``n_samples`` Dijkstra runs in all
   (plus one from vertex 0). The covering radius ``r`` (largest distance of a vertex to
   its nearest sample) is returned: the sample is within Gromov-Hausdorff distance ``r``
   of the vertex set, so by the stability theorem of the SGP paper its Rips diagrams are
   within bottleneck distance ``2 r`` of the vertex set's.
4. **Scale.** Gromov-Hausdorff distances and Rips diagrams scale with the shape, and the
   collections mix scales (the Sumner head is over ten times larger than the cat), so
   all distances are divided by the square root of the surface area of the cleaned mesh:
   every shape has unit area, as in the library's default pipeline.
5. **Persistence.** Vietoris-Rips H0 and H1 diagrams of the sample's distance matrix, the
   whole filtration (no edge-length threshold): ripser when installed (much faster for
   H1), otherwise gudhi's ``RipsComplex``. Every Rips H0 class is born at 0 and exactly
   one never dies (the sample is connected at the largest distance). That essential class
   is the same ``(0, inf)`` for every shape, so it is dropped: the bottleneck distance
   between diagrams that both hold it is the distance without it. Zero-length pairs are
   dropped too (they lie on the diagonal).
6. **Distances.** The library's exact bottleneck distance
   (:func:`sklearn_meshph.pairwise_diagram_distances`) between the H0 diagrams, between
   the H1 diagrams, and between the pairs (H0, H1), which is the bottleneck distance of
   the typed disjoint union, i.e. the maximum of the two (computed as that maximum and
   checked against the library's tuple form on the first meshes).

Scores: leave-one-out 1-NN on the full matrix (each mesh classified by its nearest other
mesh, ties to the lowest index) and the mean 1-NN accuracy over 10 x repeated stratified
5-fold splits (``random_state=0``), as ``learning_quality.py`` scores the library.

Sample count: 400 by default. The H1 diagrams need a dense sample: on the Sumner meshes
the leave-one-out 1-NN accuracy of H0 / H1 / H0+H1 was 0.567 / 0.583 / 0.617 with 200
samples, 0.567 / 0.783 / 0.717 with 300, 0.750 / 0.883 / 0.883 with 400 and 0.650 /
0.867 / 0.833 with 500 (covering radius 0.062, 0.049, 0.043, 0.038 at unit area). The
first sample matters about as much: with ``seed=1`` (a random first vertex) 400 samples
gave 0.633 / 0.800 / 0.833, so differences of 0.05 to 0.1 between these runs are
sampling noise. 400 is the best of them (chosen on the same meshes, which favours the
baseline) and keeps the SHREC'07 development half at about 7 minutes on 2 shared cores
(421 s measured, loading excluded): per mesh about 1 s of sampling (``n_samples``
Dijkstra runs, each about 10 ms on the 42k-vertex Sumner elephant, under 1 ms on 6k
vertices) and 0.15 s of ripser, then 1.5 s of bottleneck distances per mesh on 200
meshes, almost all of it the H0 diagrams (399 points each, about 16 ms a pair). 300
samples would barely save in that stage: H0 diagrams of 299 points fall under the
library's switch to minimax augmenting paths (at most 300 x 300 point pairs), which take
about 15 ms a pair on these diagrams whose births are all 0, where its threshold search
takes 6.6 ms.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp
from _common import DATA, collection, cv_1nn, loo_1nn
from joblib import Parallel, delayed
from scipy.sparse.csgraph import dijkstra

from sklearn_meshph import (
    check_mesh,
    clean_mesh,
    pairwise_diagram_distances,
)

N_SAMPLES = 400

STAGES = ("cleaning", "sampling+geodesics", "rips", "bottleneck")

# Meshes on which the H0+H1 matrix is checked against the library's tuple bottleneck.
CHECKED = 8


def rips_backend():
    """``(name, version)`` of the Vietoris-Rips implementation used: ripser if
    installed, else gudhi."""
    try:
        import ripser

        return "ripser", ripser.__version__
    except ImportError:
        import gudhi

        return "gudhi", gudhi.__version__


def edge_graph(vertices, faces):
    """The mesh edge graph: a symmetric CSR matrix holding the Euclidean length of every
    edge of ``faces`` (each undirected edge once per direction)."""
    vertices = np.asarray(vertices, dtype=float)
    faces = np.asarray(faces, dtype=np.int64)
    edges = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    edges = np.unique(np.sort(edges, axis=1), axis=0)
    edges = edges[edges[:, 0] != edges[:, 1]]
    lengths = np.linalg.norm(vertices[edges[:, 0]] - vertices[edges[:, 1]], axis=1)
    n = len(vertices)
    rows = np.concatenate([edges[:, 0], edges[:, 1]])
    cols = np.concatenate([edges[:, 1], edges[:, 0]])
    return sp.csr_matrix((np.concatenate([lengths, lengths]), (rows, cols)), shape=(n, n))


def surface_area(vertices, faces):
    """Total area of the triangles ``faces``."""
    vertices = np.asarray(vertices, dtype=float)
    faces = np.asarray(faces, dtype=np.int64)
    a, b, c = (vertices[faces[:, k]] for k in range(3))
    return 0.5 * float(np.linalg.norm(np.cross(b - a, c - a), axis=1).sum())


def farthest_point_sample(vertices, graph, n_samples=N_SAMPLES, seed=None):
    """Farthest-point sampling of mesh vertices in the geodesic metric of the edge graph.

    Parameters
    ----------
    vertices : array-like of shape (n, 3)
        The mesh vertices.
    graph : sparse matrix of shape (n, n) or array-like of shape (m, 3)
        The edge graph weighted by edge lengths (as :func:`edge_graph` makes it), or the
        faces, from which it is built. It must be connected.
    n_samples : int, default=N_SAMPLES (400)
        Number of samples; all vertices when the mesh has fewer.
    seed : int or None, default=None
        ``None``: the first sample is the vertex farthest from vertex 0 (ties: lowest
        index), which costs one more Dijkstra run. An integer: the first sample is drawn
        uniformly at random with ``numpy.random.default_rng(seed)``.

    Returns
    -------
    samples : ndarray of shape (k,), int64
        Vertex indices in the order they were chosen (``k = min(n_samples, n)``).
    distances : ndarray of shape (k, k)
        Graph geodesic distances between the samples, symmetric with zero diagonal
        (entry ``(i, j)``, ``j < i``, from the Dijkstra run of sample ``i``).
    radius : float
        The covering radius: the largest distance from a vertex to its nearest sample.
    """
    vertices = np.asarray(vertices, dtype=float)
    n = len(vertices)
    if not sp.issparse(graph):
        graph = edge_graph(vertices, graph)
    graph = sp.csr_matrix(graph)
    if graph.shape != (n, n):
        raise ValueError(f"graph has shape {graph.shape}, expected {(n, n)}")
    if n_samples < 1:
        raise ValueError(f"n_samples must be at least 1, got {n_samples}")
    k = min(int(n_samples), n)

    def run(source):
        return dijkstra(graph, directed=True, indices=int(source))

    if seed is None:
        from_zero = run(0)
        if not np.all(np.isfinite(from_zero)):
            raise ValueError("the edge graph is not connected; keep one component first")
        first = int(np.argmax(from_zero))
    else:
        first = int(np.random.default_rng(seed).integers(n))
    samples = np.empty(k, dtype=np.int64)
    distances = np.zeros((k, k))
    nearest = np.full(n, np.inf)
    source = first
    for i in range(k):
        samples[i] = source
        row = run(source)
        if i == 0 and not np.all(np.isfinite(row)):
            raise ValueError("the edge graph is not connected; keep one component first")
        distances[i, :i] = row[samples[:i]]
        np.minimum(nearest, row, out=nearest)
        source = int(np.argmax(nearest))
    distances = distances + distances.T
    return samples, distances, float(nearest.max())


def rips_diagrams(distances):
    """Vertex-Rips H0 (essential class dropped) and H1 diagrams of a distance matrix,
    the whole filtration, zero-length pairs dropped."""
    name, _ = rips_backend()
    if name == "ripser":
        from ripser import ripser

        h0, h1 = ripser(distances, distance_matrix=True, maxdim=1)["dgms"]
    else:
        import gudhi

        complex_ = gudhi.RipsComplex(distance_matrix=distances, max_edge_length=np.inf)
        tree = complex_.create_simplex_tree(max_dimension=2)
        tree.compute_persistence()
        h0 = tree.persistence_intervals_in_dimension(0)
        h1 = tree.persistence_intervals_in_dimension(1)
    result = []
    for diagram in (h0, h1):
        diagram = np.asarray(diagram, dtype=float).reshape(-1, 2)
        keep = np.isfinite(diagram[:, 1]) & (diagram[:, 1] > diagram[:, 0])
        result.append(np.ascontiguousarray(diagram[keep]))
    return tuple(result)


def mesh_signature(mesh, n_samples=N_SAMPLES, seed=None):
    """The (H0, H1) Rips diagrams of one mesh's sampled, unit-area geodesic metric.

    ``mesh`` is anything :func:`sklearn_meshph.check_mesh` accepts. Returns a dict with
    ``diagrams`` (H0, H1), ``seconds`` per stage, ``radius`` (covering radius, unit-area
    scale), ``n_vertices`` and ``kept`` (fraction of the input vertices the cleaning
    kept)."""
    start = time.perf_counter()
    vertices, faces = check_mesh(mesh)
    cleaned = clean_mesh(vertices, faces)
    scale = np.sqrt(surface_area(cleaned.vertices, cleaned.faces))
    cleaned_at = time.perf_counter()
    graph = edge_graph(cleaned.vertices, cleaned.faces)
    _, distances, radius = farthest_point_sample(cleaned.vertices, graph, n_samples, seed)
    distances /= scale
    sampled = time.perf_counter()
    diagrams = rips_diagrams(distances)
    return {
        "diagrams": diagrams,
        "seconds": {
            "cleaning": cleaned_at - start,
            "sampling+geodesics": sampled - cleaned_at,
            "rips": time.perf_counter() - sampled,
        },
        "radius": radius / scale,
        "n_vertices": len(cleaned.vertices),
        "kept": len(cleaned.vertices) / len(vertices),
    }


def gh_distance_matrices(meshes, n_samples=N_SAMPLES, n_jobs=2, seed=None):
    """Bottleneck distance matrices of the Rips signatures of a collection of meshes.

    Parameters
    ----------
    meshes : sequence
        Meshes, (vertices, faces) pairs or paths (anything ``check_mesh`` accepts).
    n_samples : int, default=N_SAMPLES (400)
        Farthest-point samples per mesh.
    n_jobs : int, default=2
        Meshes processed in parallel (joblib) and jobs of the bottleneck matrices.
    seed : int or None, default=None
        See :func:`farthest_point_sample`.

    Returns
    -------
    dict
        ``"H0"``, ``"H1"``, ``"H0+H1"``: the ``(n, n)`` bottleneck matrices of the H0
        diagrams, of the H1 diagrams and of the pairs. The last is the library's
        bottleneck distance between (H0, H1) tuples, which is the maximum of the
        other two; it is computed as that maximum (the tuple form would redo both
        matrices), and checked against the tuple form on the first ``CHECKED`` meshes.
        ``"diagrams"``: the (H0, H1) pair of each mesh; ``"seconds"``: per stage, an
        array of the seconds of each mesh for ``"cleaning"`` (reading included when
        given paths), ``"sampling+geodesics"`` and ``"rips"`` (inside the workers) and
        the wall time of the H0 and H1 matrices for ``"bottleneck"``; ``"radius"``,
        ``"n_vertices"``, ``"kept"``: per-mesh arrays (see :func:`mesh_signature`).
    """
    results = Parallel(n_jobs=n_jobs)(
        delayed(mesh_signature)(mesh, n_samples, seed) for mesh in meshes
    )
    diagrams = [r["diagrams"] for r in results]
    start = time.perf_counter()
    h0 = pairwise_diagram_distances([d[0] for d in diagrams], metric="bottleneck", n_jobs=n_jobs)
    h1 = pairwise_diagram_distances([d[1] for d in diagrams], metric="bottleneck", n_jobs=n_jobs)
    both = np.maximum(h0, h1)
    seconds = {stage: np.array([r["seconds"][stage] for r in results]) for stage in STAGES[:3]}
    seconds["bottleneck"] = time.perf_counter() - start
    # The library's bottleneck distance between (H0, H1) tuples, on the first meshes.
    head = min(len(diagrams), CHECKED)
    typed = pairwise_diagram_distances(diagrams[:head], metric="bottleneck", n_jobs=n_jobs)
    if not np.allclose(typed, both[:head, :head], rtol=0, atol=1e-12):
        raise AssertionError("bottleneck of (H0, H1) differs from the maximum of H0 and H1")
    return {
        "H0": h0,
        "H1": h1,
        "H0+H1": both,
        "diagrams": diagrams,
        "seconds": seconds,
        "radius": np.array([r["radius"] for r in results]),
        "n_vertices": np.array([r["n_vertices"] for r in results]),
        "kept": np.array([r["kept"] for r in results]),
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--collections", nargs="+", default=["sumner", "shapes", "watertight_dev"])
    parser.add_argument("--n-samples", type=int, default=N_SAMPLES)
    parser.add_argument("--n-jobs", type=int, default=2)
    parser.add_argument("--seed", type=int, default=None, help="first sample (default: farthest)")
    parser.add_argument("--save", type=Path, default=None, help="folder for <collection>_gh.npz")
    args = parser.parse_args()
    backend = rips_backend()
    print(f"Rips: {backend[0]} {backend[1]}; {args.n_samples} farthest-point samples per mesh")
    table, timing = [], []
    for name in args.collections:
        loaded = collection(name, args.n_jobs)
        if loaded is None:
            print(f"skipping {name}: not found in {DATA}")
            continue
        meshes, y, _ = loaded
        start = time.perf_counter()
        result = gh_distance_matrices(meshes, args.n_samples, args.n_jobs, args.seed)
        wall = time.perf_counter() - start
        for kind in ("H0", "H1", "H0+H1"):
            table.append((name, kind, loo_1nn(result[kind], y), cv_1nn(result[kind], y)))
            print(f"  {name:15s} {kind:6s} LOO {table[-1][2]:.3f}  10x5-fold {table[-1][3]:.3f}")
        seconds = result["seconds"]
        sizes = [(len(h0), len(h1)) for h0, h1 in result["diagrams"]]
        timing.append(
            (
                name,
                len(meshes),
                float(np.mean(seconds["cleaning"])),
                float(np.mean(seconds["sampling+geodesics"])),
                float(np.mean(seconds["rips"])),
                seconds["bottleneck"] / len(meshes),
                wall,
                float(np.median(result["radius"])),
                float(np.max(result["radius"])),
                float(np.mean([s[1] for s in sizes])),
            )
        )
        lossy = np.flatnonzero(result["kept"] < 0.99)
        for i in lossy:
            print(f"  {name}: mesh {i} kept {result['kept'][i]:.1%} of its vertices (largest part)")
        if args.save is not None:
            args.save.mkdir(parents=True, exist_ok=True)
            np.savez(
                args.save / f"{name}_gh.npz",
                y=y,
                **{kind: result[kind] for kind in ("H0", "H1", "H0+H1")},
                radius=result["radius"],
            )
    print(
        "\n1-NN accuracy of the bottleneck distance between Rips diagrams of the geodesic metric:"
    )
    print("\n| collection | diagrams | LOO 1-NN | 10 x 5-fold 1-NN |")
    print("|---|---|---|---|")
    for name, kind, loo, cv in table:
        print(f"| {name} | {kind} | {loo:.3f} | {cv:.3f} |")
    print(
        "\nSeconds per mesh (sampling and Rips: mean time of one mesh in a worker; "
        f"bottleneck: wall time of the H0 and H1 matrices / meshes; n_jobs={args.n_jobs}):"
    )
    print(
        "\n| collection | meshes | cleaning | sampling+geodesics | Rips H0+H1 | bottleneck "
        "| wall s | covering radius median / max | mean H1 points |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for name, n, c, s, r, b, wall, rmed, rmax, h1 in timing:
        print(
            f"| {name} | {n} | {c:.3f} | {s:.2f} | {r:.3f} | {b:.4f} | {wall:.0f} "
            f"| {rmed:.3f} / {rmax:.3f} | {h1:.0f} |"
        )


if __name__ == "__main__":
    main()
