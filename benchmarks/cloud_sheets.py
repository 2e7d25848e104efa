"""Sheets that cross or lie on each other in the Sumner meshes, and what knowing them
would give the clouds (issue 27).

    python benchmarks/cloud_sheets.py buried                 # every Sumner mesh, ~7 min
    python benchmarks/cloud_sheets.py operator [--sizes 3000 10000] [--shapes all]
    python benchmarks/cloud_sheets.py accuracy [--points 3000] [--collection sumner]
    python benchmarks/cloud_sheets.py pairs [--points 3000] [--shapes ...]

``buried``: the share of each closed Sumner mesh's surface that lies inside the volume
the mesh encloses, its parts pushed into each other (a leg into the flank: the mesh
intersects itself). Points drawn on the surface (600, area-weighted, seed 0) are moved
outwards along their face's normal by 1e-3 of the mesh's scale; a point whose
generalized winding number (the solid angle the mesh subtends from it over 4 pi;
Jacobson et al., SIGGRAPH 2013) is then still above 1/2 is buried. Meshes with a boundary
(the faces, the elephants) have no inside: printed as open.

``operator`` and ``accuracy``: the **sheet oracle**, our operator with each point's
neighbours on another sheet of the mesh left out: those whose distance along the
mesh's edges (between the mesh vertices nearest to the two points) exceeds twice their
distance in space plus two median edge lengths (a paw on the flank, a leg through it).
``operator`` prints the rows of ``bench_cloud_operator.py`` (uniform clouds, the mesh's
cotangent operator as the reference) for ours, the oracle, a control (as many of the
neighbours cut as the oracle cuts, drawn at random) and oriented normals (below), with
the share of the neighbours kept by our sheet tests that each cuts (``cat-01`` and
``lion-01``, or ``--shapes all``: that benchmark's 13 shapes and the sphere); the
oracles' eigenpairs are those of their piece of largest mass; ``accuracy`` the default's
leave-one-out 1-NN on the clouds of a collection (``--collection``: the 60 Sumner
meshes by default; ``sample_point_cloud``, seed = the mesh's index, as
``learning_quality.py``), each of its parts alone, with our operator, with
the oracle's, and with what oriented normals would allow (``FacingOracle``: the
neighbours whose outward normal, the mesh's, faces more than 120 degrees away from the
point's left out, as a scanner's normals could).

``pairs``: can a cloud tell the neighbours the oracle cuts? For each pair of a point
and a neighbour its sheet tests keep, eight things a cloud sees of it (``FEATURES``:
distances, normals, heights, the quadric's residual and normal, whether the neighbour
keeps the point, their neighbours in common), and how well each alone separates the
cut pairs from the others (the area under the ROC curve: 0.5 is chance, 1 or 0 a
perfect separation).
"""

import argparse
import contextlib
import glob
import time
import warnings

import numpy as np
import scipy.sparse as sp
import trimesh
from _common import DATA, collection, edge_graph, loo_1nn
from bench_cloud_operator import SHAPES, load, rows
from cloud_weights import DEFAULT, combined
from joblib import Parallel, delayed
from scipy.sparse.csgraph import connected_components, dijkstra
from scipy.spatial import cKDTree

from sklearn_meshph import (
    MeshCleaningWarning,
    check_mesh,
    clean_mesh,
    make_mesh_distance,
    point_cloud_laplacian,
    sample_point_cloud,
)
from sklearn_meshph.pointcloud import _triangulation
from sklearn_meshph.pointcloud.graph import cloud_unit_box

SUMNER_SHAPES = ("sumner/cat/cat-01.obj", "sumner/lion/lion-01.obj")


def winding_numbers(vertices, faces, queries, block=50):
    """The generalized winding number of a closed mesh at each query point: 1 inside,
    0 outside (Van Oosterom and Strackee's solid angle of each triangle, summed)."""
    a, b, c = (vertices[faces[:, i]] for i in range(3))
    out = np.empty(len(queries))
    for start in range(0, len(queries), block):
        q = queries[start : start + block, None, :]
        x, y, z = a[None] - q, b[None] - q, c[None] - q
        lx, ly, lz = (np.linalg.norm(v, axis=2) for v in (x, y, z))
        det = np.einsum("qfi,qfi->qf", x, np.cross(y, z))
        dots = (
            lx * ly * lz
            + np.einsum("qfi,qfi->qf", x, y) * lz
            + np.einsum("qfi,qfi->qf", y, z) * lx
            + np.einsum("qfi,qfi->qf", z, x) * ly
        )
        out[start : start + block] = 2.0 * np.arctan2(det, dots).sum(axis=1) / (4.0 * np.pi)
    return out


def buried_share(path, n_points=600):
    """Share of the surface of the mesh at ``path`` inside its own volume, or None when
    the mesh has a boundary."""
    mesh = trimesh.load(path, process=False)
    edges = np.sort(mesh.edges, axis=1)
    if (np.unique(edges, axis=0, return_counts=True)[1] == 1).any():
        return None
    points, face = trimesh.sample.sample_surface(mesh, n_points, seed=0)
    moved = points + 1e-3 * mesh.scale * mesh.face_normals[face]
    inside = winding_numbers(np.asarray(mesh.vertices), np.asarray(mesh.faces), moved)
    return float(np.mean(np.abs(inside) > 0.5))


class SheetOracle:
    """Which neighbours of a cloud sampled on a mesh lie on another sheet of it."""

    def __init__(self, vertices, faces):
        self.graph, length = edge_graph(vertices, faces)
        self.slack = 2.0 * float(np.median(length))
        self.tree = cKDTree(vertices)

    def other_sheet(self, points, neighbors):
        """``(n, k)`` mask: neighbour ``j`` of point ``i`` is more than twice as far
        along the mesh's edges as in space, plus the slack."""
        rows_ = np.repeat(np.arange(len(points)), neighbors.shape[1])
        space = np.linalg.norm(points[rows_] - points[neighbors.ravel()], axis=1)
        near = self.tree.query(points)[1]
        start, end = near[rows_], near[neighbors.ravel()]
        along = np.full(len(rows_), np.inf)
        sources = np.unique(start)
        limit = 2.0 * space.max() + self.slack
        for first in range(0, len(sources), 400):
            chunk = sources[first : first + 400]
            distances = dijkstra(self.graph, directed=False, indices=chunk, limit=limit)
            position = np.searchsorted(chunk, start)
            found = position < len(chunk)
            found[found] = chunk[position[found]] == start[found]
            along[found] = distances[position[found], end[found]]
        return (along > 2.0 * space + self.slack).reshape(neighbors.shape)


class FacingOracle:
    """The neighbours a cloud with oriented normals could leave out: those whose
    outward normal (the mesh's, at the vertex nearest each point) is more than 120
    degrees from the point's (another sheet facing it, the far side of a thin wall)."""

    def __init__(self, vertices, faces):
        self.normals = trimesh.Trimesh(vertices, faces, process=False).vertex_normals
        self.tree = cKDTree(vertices)

    def other_sheet(self, points, neighbors):
        normals = self.normals[self.tree.query(points)[1]]
        return np.einsum("nkj,nj->nk", normals[neighbors], normals) < -0.5


@contextlib.contextmanager
def leaving_out(choose, cut):
    """Our sheet tests with the neighbours ``choose(seen, neighbors)`` marks (an
    ``(n, k)`` mask) left out of those they keep; appends the share cut to ``cut``."""
    original = _triangulation.surface_neighbours

    def patched(seen, n_neighbors, knn=None):
        neighbors, usable, normal, basis = original(seen, n_neighbors, knn)
        dropped = choose(seen, neighbors) & usable
        cut.append(dropped.sum() / max(usable.sum(), 1))
        return neighbors, usable & ~dropped, normal, basis

    _triangulation.surface_neighbours = patched
    try:
        yield
    finally:
        _triangulation.surface_neighbours = original


def oracle_neighbours(oracle, points, cut):
    """``oracle``'s other-sheet neighbours left out, for clouds made from ``points`` (in
    the mesh's units; the operator sees them in the unit box, maybe cleaned: matched
    back by nearest point)."""
    unit = cKDTree(cloud_unit_box(points)[0])
    return leaving_out(
        lambda seen, neighbors: oracle.other_sheet(points[unit.query(seen)[1]], neighbors), cut
    )


def random_neighbours(share, cut, seed=0):
    """The control: a random ``share`` of the neighbours left out (the oracle's share,
    so that what the oracle gains is seen to come from which neighbours it cuts, not
    from how many)."""
    return leaving_out(
        lambda seen, neighbors: np.random.default_rng(seed).random(neighbors.shape) < share, cut
    )


def largest_piece(L, M):
    """``(L, M)`` with the points off the piece of largest mass given no mass and no
    stiffness (the eigenpairs leave them out): the oracle can cut a piece off where it
    maps points to the wrong sheet."""
    L, mass = sp.csr_matrix(L), M.diagonal().copy()
    labels = connected_components(abs(L) > 0, directed=False)[1]
    off = labels != np.argmax(np.bincount(labels, weights=mass))
    mass[off] = 0.0
    keep = sp.diags((~off).astype(float))
    return keep @ L @ keep, sp.diags(mass)


def pair_features(points, neighbors, usable, normal, basis):
    """Per neighbour pair ``(i, j)``, what a cloud can see of it: ``FEATURES``."""
    n, k = neighbors.shape
    rows_, cols = np.repeat(np.arange(n), k), neighbors.ravel()
    offset = points[cols] - points[rows_]
    distance = np.linalg.norm(offset, axis=1)
    tenth = np.repeat(np.linalg.norm(points[neighbors[:, 9]] - points, axis=1), k)
    kept = sp.csr_matrix((usable.ravel().astype(float), (rows_, cols)), shape=(n, n))
    shared = np.asarray((kept @ kept.T)[rows_, cols]).ravel() / np.repeat(
        np.maximum(usable.sum(1), 1), k
    )
    residual, turned = np.zeros(n * k), np.zeros(n * k)
    for i in range(n):
        own = slice(i * k, (i + 1) * k)
        if usable[i].sum() < 6:  # too few for the quadric's five coefficients
            continue
        x, y = offset[own] @ basis[i, :, 0], offset[own] @ basis[i, :, 1]
        design = np.column_stack([x, y, x * x, x * y, y * y])
        c = np.linalg.lstsq(design[usable[i]], offset[own][usable[i]] @ normal[i], rcond=None)[0]
        residual[own] = np.abs(offset[own] @ normal[i] - design @ c) / tenth[own]
        slope_x, slope_y = c[0] + 2 * c[2] * x + c[3] * y, c[1] + c[3] * x + 2 * c[4] * y
        predicted = (
            normal[i] - slope_x[:, None] * basis[i, :, 0] - slope_y[:, None] * basis[i, :, 1]
        )
        predicted /= np.linalg.norm(predicted, axis=1)[:, None]
        turned[own] = 1.0 - np.abs(np.einsum("ki,ki->k", predicted, normal[neighbors[i]]))
    return np.column_stack(
        [
            distance / tenth,
            np.abs(np.einsum("ki,ki->k", normal[rows_], normal[cols])),
            np.abs(np.einsum("ki,ki->k", offset, normal[rows_])) / distance,
            np.abs(np.einsum("ki,ki->k", offset, normal[cols])) / distance,
            np.asarray(kept[cols, rows_]).ravel(),
            shared,
            residual,
            turned,
        ]
    )


FEATURES = (
    "distance / 10th neighbour's",
    "normals' |cosine|",
    "height over i's plane / distance",
    "height over j's plane / distance",
    "j keeps i",
    "neighbours kept by both / by i",
    "residual of i's quadric / 10th neighbour's distance",
    "1 - |cosine| of j's normal and i's quadric's there",
)


def run_pairs(args):
    from sklearn.metrics import roc_auc_score

    print(
        f"| shape, {args.points} points | pairs kept | on another sheet | "
        + " | ".join(FEATURES)
        + " |"
    )
    print("|---|---|---|" + "---|" * len(FEATURES))
    for shape in args.shapes or SUMNER_SHAPES + ("sumner/horse/horse-01.obj",):
        vertices, faces = load(shape)
        points = np.asarray(sample_point_cloud((vertices, faces), args.points, random_state=0))
        unit = cloud_unit_box(points)[0]
        neighbors, usable, normal, basis = _triangulation.surface_neighbours(unit)
        other = SheetOracle(vertices, faces).other_sheet(points, neighbors)[usable]
        features = pair_features(unit, neighbors, usable, normal, basis)[usable.ravel()]
        if other.all() or not other.any():  # one class: no separation to score
            scores = " | ".join("n/a" for _ in FEATURES)
        else:
            scores = " | ".join(f"{roc_auc_score(other, f):.2f}" for f in features.T)
        print(f"| {shape.split('/')[-1]} | {usable.sum()} | {other.mean():.3f} | {scores} |")


def run_buried(_args):
    paths = sorted(glob.glob(str(DATA / "sumner" / "*" / "*.obj")))
    shares = Parallel(n_jobs=2)(delayed(buried_share)(p) for p in paths)
    print("| mesh | share of the surface buried in the mesh's own volume |")
    print("|---|---|")
    for path, share in zip(paths, shares, strict=True):
        print(f"| {path.split('/')[-1]} | {'open' if share is None else f'{share:.3f}'} |")


def run_operator(args):
    print("| shape | points | operator | cut | mass | l1 | med20 | med50 | align20 |")
    print("|---|---|---|---|---|---|---|---|---|")
    shapes = SHAPES if args.shapes == ["all"] else args.shapes or SUMNER_SHAPES
    for shape in shapes:
        vertices, faces = load(shape)
        oracle, cut = SheetOracle(vertices, faces), []

        def with_oracle(points, oracle=oracle, cut=cut):
            with oracle_neighbours(oracle, points, cut):
                return largest_piece(*point_cloud_laplacian(points))

        def random_cut(points, cut=cut):
            with random_neighbours(cut[-1], cut):
                return largest_piece(*point_cloud_laplacian(points))

        facing, facing_cut = FacingOracle(vertices, faces), []

        def with_normals(points, facing=facing, facing_cut=facing_cut):
            with oracle_neighbours(facing, points, facing_cut):
                return largest_piece(*point_cloud_laplacian(points))

        builders = {
            "ours": point_cloud_laplacian,
            "sheet oracle": with_oracle,
            "random cut": random_cut,
            "oriented normals": with_normals,
        }
        for n, _, results in rows(shape, args.sizes, builders, 50):
            # Each builder runs twice (timed, then traced): the oracle's share is third
            # from the end.
            shares = {
                "sheet oracle": cut[-3],
                "random cut": cut[-1],
                "oriented normals": facing_cut[-1],
            }
            for name, row in results.items():
                share = f"{shares[name]:.3f}" if name in shares else ""
                cells = " | ".join(f"{row[q]:.3f}" for q in ("mass", "l1", "med20", "med50"))
                print(
                    f"| {shape.split('/')[-1]} | {n} | {name} | {share} | {cells} | "
                    f"{row['align20']:.3f} |",
                    flush=True,
                )


def run_accuracy(args):
    meshes, y, _ = collection(args.collection, 2)
    pipeline = make_mesh_distance(n_jobs=1)
    eigen = pipeline.named_steps["eigen"]
    fields = {"ours": [], "sheet oracle": [], "oriented normals": []}
    cut, facing_cut = [], []
    start = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MeshCleaningWarning)
        for k, mesh in enumerate(meshes):
            points = np.asarray(sample_point_cloud(mesh, args.points, random_state=k))
            fields["ours"].append(eigen.fit_transform([points])[0])
            clean = clean_mesh(*check_mesh(mesh))
            oracle = SheetOracle(np.asarray(clean.vertices, float), np.asarray(clean.faces))
            with oracle_neighbours(oracle, points, cut):
                fields["sheet oracle"].append(eigen.fit_transform([points])[0])
            facing = FacingOracle(np.asarray(clean.vertices, float), np.asarray(clean.faces))
            with oracle_neighbours(facing, points, facing_cut):
                fields["oriented normals"].append(eigen.fit_transform([points])[0])
    print(
        f"{args.collection}, {args.points} points ({time.perf_counter() - start:.0f} s); "
        f"the oracle cut {np.mean(cut):.3f} of the neighbours kept, {np.max(cut):.3f} at most; "
        f"the oriented normals {np.mean(facing_cut):.3f}, {np.max(facing_cut):.3f} at most"
    )
    print("| operator | ord1 | ext0 | Shape-DNA | default |")
    print("|---|---|---|---|---|")
    for name, samples in fields.items():
        parts = {
            part: np.asarray(estimator.fit_transform(samples))
            for part, estimator in pipeline.named_steps["distance"].transformer_list
            if part in DEFAULT
        }
        cells = " | ".join(f"{loo_1nn(parts[p], y):.3f}" for p in ("ord1", "ext0", "dna"))
        print(f"| {name} | {cells} | {loo_1nn(combined(parts, DEFAULT), y):.3f} |", flush=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("what", choices=("buried", "operator", "accuracy", "pairs"))
    parser.add_argument("--sizes", type=int, nargs="+", default=[3000, 10000])
    parser.add_argument(
        "--shapes", nargs="+", help="paths under the data folder, or all: bench_cloud_operator's"
    )
    parser.add_argument("--points", type=int, default=3000)
    parser.add_argument("--collection", default="sumner", help="for accuracy: a data folder")
    args = parser.parse_args()
    run = {"buried": run_buried, "operator": run_operator, "accuracy": run_accuracy}
    run.get(args.what, run_pairs)(args)


if __name__ == "__main__":
    main()
