"""The large benchmark collection of issue 29: labelled meshes made from a base collection
by transformations that keep the class, and the default's representations of them.

    python benchmarks/make_collection.py [--n 20000] [--seed 0] [--chunk 200]
                                         [--folder DIR] [--n-jobs 2] [--base watertight_dev]

Mesh ``i`` of the collection of seed ``s`` comes from base mesh ``i % n_base`` (so the
classes stay balanced) and its own random stream (``SeedSequence([s, i])``): any mesh
is regenerated alone, and a chunk of them in any order, with the same bits. The
transformations (:func:`transform_mesh`):

- remeshing: the base mesh subdivided (each triangle into four) until it has at least
  twice the vertex budget, then simplified by quadric edge collapse
  (``fast_simplification``, the ``bench`` extra) to a budget drawn in ``VERTICES``;
  a simplification that changes whether the surface is closed or its Euler
  characteristic, or misses the budget, is retried (``ATTEMPTS``; the base mesh as
  it is when none keeps the topology);
- bending about the middle of the principal axis (Barr's bend, half of the meshes, the
  ends turned by at most ``BEND`` radians);
- vertex noise (``NOISE`` times the mean edge length, each coordinate);
- a random rotation, a scale (log-uniform in ``SCALES``) and a translation.

The meshes are generated on the fly and never stored. What the benchmarks read is the
default pipeline's output before its distances (``make_mesh_distance()``: each part's
diagrams per sample, the Shape-DNA features), computed once chunk by chunk and cached
in ``--folder`` (default: ``sklearn_meshph_collection`` in the temporary folder,
outside the repository) as data-only ``.npz`` files read with ``allow_pickle=False``.
A chunk is written atomically when done, so an interrupted run resumes at the first
missing chunk. The cache's key is this generator's settings and ``GENERATOR``, not
the package's numerics: after a change of the default pipeline, pass another folder.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import tempfile
import time
from pathlib import Path

import numpy as np
import trimesh
from scipy.spatial.transform import Rotation

# The version of the transformations below: part of every chunk's key.
GENERATOR = 1
VERTICES = (1000, 2500)  # the range of vertex budgets
BEND = 0.35  # largest angle of a bent end, radians
NOISE = 0.05  # vertex noise, in mean edge lengths
SCALES = (0.5, 2.0)
# Simplifications tried: (fast_simplification's aggressiveness, budget factor).
ATTEMPTS = ((3, 1.0), (5, 1.0), (7, 1.0), (3, 1.25), (7, 1.25), (3, 2.0), (3, 3.0))
DEFAULT_FOLDER = Path(tempfile.gettempdir()) / "sklearn_meshph_collection"


def _settings(seed):
    settings = {"generator": GENERATOR, "seed": int(seed), "vertices": VERTICES}
    settings.update({"bend": BEND, "noise": NOISE, "scales": SCALES})
    return settings


def _closed_like(mesh, base):
    return mesh.is_watertight == base.is_watertight and mesh.euler_number == base.euler_number


def remesh(base, budget):
    """``(mesh, remeshed)``: ``base`` subdivided and simplified to about ``budget``
    vertices with its closedness and Euler characteristic kept: the first of
    ``ATTEMPTS`` (aggressiveness, budget factor) whose result keeps them within half a
    budget more, else the smallest that keeps them, else ``base`` as it is
    (``remeshed`` False)."""
    import fast_simplification

    vertices, faces = np.asarray(base.vertices, float), np.asarray(base.faces, np.int64)
    while len(vertices) < 2 * budget:
        vertices, faces = trimesh.remesh.subdivide(vertices, faces)
    kept = []
    for aggressiveness, factor in ATTEMPTS:
        target = factor * budget
        simple, triangles = fast_simplification.simplify(
            vertices, faces, 1.0 - target / len(vertices), agg=aggressiveness
        )
        mesh = trimesh.Trimesh(simple, triangles, process=False)
        if _closed_like(mesh, base):
            if len(simple) <= 1.5 * target:
                return mesh, True
            kept.append(mesh)
    if kept:
        return min(kept, key=lambda mesh: len(mesh.vertices)), True
    return trimesh.Trimesh(base.vertices.copy(), base.faces.copy(), process=False), False


def bend(vertices, angle):
    """Barr's bend of ``vertices`` in the plane of their two principal axes, about the
    middle of the first: the ends turn by ``angle`` radians, lengths along the axis kept."""
    center = vertices.mean(axis=0)
    _, _, axes = np.linalg.svd(vertices - center, full_matrices=False)
    local = (vertices - center) @ axes.T
    half = np.abs(local[:, 0]).max()
    if half == 0.0 or angle == 0.0:
        return vertices.copy()
    curvature = angle / half
    along, across = local[:, 0].copy(), local[:, 1].copy()
    radius = 1.0 / curvature - across
    local[:, 0] = np.sin(curvature * along) * radius
    local[:, 1] = 1.0 / curvature - np.cos(curvature * along) * radius
    return local @ axes + center


def transform_mesh(base, rng):
    """One class-preserving transformation of ``base`` (a trimesh) drawn from ``rng``:
    ``(mesh, remeshed)``, see the module's docstring."""
    budget = int(rng.integers(VERTICES[0], VERTICES[1] + 1))
    mesh, remeshed = remesh(base, budget)
    vertices = np.array(mesh.vertices, dtype=float)
    if rng.random() < 0.5:
        vertices = bend(vertices, rng.uniform(-BEND, BEND))
    edges = vertices[mesh.edges_unique]
    length = float(np.linalg.norm(edges[:, 0] - edges[:, 1], axis=1).mean())
    vertices += rng.normal(0.0, NOISE * length, vertices.shape)
    scale = np.exp(rng.uniform(np.log(SCALES[0]), np.log(SCALES[1])))
    rotation = Rotation.random(random_state=rng).as_matrix()
    vertices = scale * vertices @ rotation.T + rng.normal(0.0, 1.0, 3)
    return trimesh.Trimesh(vertices, mesh.faces, process=False), remeshed


def generate(base_meshes, base_y, seed, start, stop):
    """``(meshes, y, bases, remeshed)`` of meshes ``start`` to ``stop - 1`` of the
    collection of ``seed``."""
    meshes, bases, flags = [], [], []
    for i in range(start, stop):
        b = i % len(base_meshes)
        rng = np.random.default_rng(np.random.SeedSequence([int(seed), i]))
        mesh, remeshed = transform_mesh(base_meshes[b], rng)
        meshes.append(mesh)
        bases.append(b)
        flags.append(remeshed)
    bases = np.asarray(bases, dtype=np.int64)
    return meshes, np.asarray(base_y)[bases], bases, np.asarray(flags)


def representations(meshes, n_jobs=1):
    """``(parts, seconds)``: each part's output before its distance under the default
    pipeline (diagram parts: a tuple of diagrams per mesh; ``dna``: an array), and the
    CPU seconds of this process in the eigen stage and the later ones (all the work
    with ``n_jobs=1``)."""
    from sklearn_meshph import make_mesh_distance

    pipeline = make_mesh_distance(n_jobs=n_jobs)
    start = time.process_time()
    fields = pipeline.named_steps["eigen"].fit_transform(meshes)
    eigen = time.process_time() - start
    start = time.process_time()
    parts = {
        name: part[:-1].fit_transform(fields)
        for name, part in pipeline.named_steps["distance"].transformer_list
    }
    return parts, {"eigen": eigen, "later": time.process_time() - start}


def _arrays(parts):
    """Data-only arrays of ``parts``: each diagram part as its points and offsets."""
    arrays = {}
    for name, rows in parts.items():
        if isinstance(rows, np.ndarray):
            arrays[f"features__{name}"] = rows
            continue
        diagrams = [d for sample in rows for d in sample]
        arrays[f"points__{name}"] = np.concatenate([np.reshape(d, (-1, 2)) for d in diagrams])
        sizes = [len(d) for d in diagrams]
        arrays[f"offsets__{name}"] = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
        arrays[f"positions__{name}"] = np.int64(len(rows[0]))
    return arrays


def _parts(data):
    """The parts saved by :func:`_arrays`, read back."""
    parts = {}
    for key in data.files:
        kind, _, name = key.partition("__")
        if kind == "features":
            parts[name] = data[key]
        elif kind == "points":
            points, offsets = data[key], data[f"offsets__{name}"]
            k = int(data[f"positions__{name}"])
            diagrams = [points[a:b] for a, b in zip(offsets[:-1], offsets[1:], strict=True)]
            parts[name] = [tuple(diagrams[i : i + k]) for i in range(0, len(diagrams), k)]
    return parts


def chunk_path(folder, seed, start, stop):
    """Where the chunk ``start:stop`` of ``seed`` is cached (named after the settings)."""
    digest = hashlib.sha256(json.dumps(_settings(seed), sort_keys=True).encode()).hexdigest()
    return Path(folder) / f"collection_{digest[:12]}_{start:06d}_{stop:06d}.npz"


def build_chunk(folder, base_meshes, base_y, seed, start, stop, n_jobs=1):
    """Generate meshes ``start:stop``, compute their representations and cache them
    (atomically); returns the chunk's path."""
    path = chunk_path(folder, seed, start, stop)
    if path.exists():
        return path
    cpu = time.process_time()
    meshes, y, bases, remeshed = generate(base_meshes, base_y, seed, start, stop)
    made = time.process_time() - cpu
    parts, seconds = representations(meshes, n_jobs=n_jobs)
    arrays = _arrays(parts)
    arrays.update(y=y, bases=bases, remeshed=remeshed)
    arrays["n_vertices"] = np.array([len(m.vertices) for m in meshes], dtype=np.int64)
    arrays["seconds"] = np.array([made, seconds["eigen"], seconds["later"]])
    arrays["n_jobs"] = np.int64(n_jobs)
    arrays["settings"] = np.array(json.dumps(_settings(seed), sort_keys=True))
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    handle, temporary = tempfile.mkstemp(dir=folder, suffix=".npz.part")
    with os.fdopen(handle, "wb") as stream:
        np.savez(stream, **arrays)
    os.replace(temporary, path)
    return path


def _chunks(n, chunk):
    return [(start, min(start + chunk, n)) for start in range(0, n, chunk)]


def load_collection(folder, seed, n, chunk):
    """``(parts, info)`` of the first ``n`` samples of a built collection: the parts as
    :func:`representations` returns them, and ``info`` with ``y``, ``bases``,
    ``remeshed``, ``n_vertices`` and the chunks' CPU ``seconds`` (generation, eigen,
    later)."""
    parts, info = {}, {key: [] for key in ("y", "bases", "remeshed", "n_vertices", "seconds")}
    for start, stop in _chunks(n, chunk):
        path = chunk_path(folder, seed, start, stop)
        if not path.exists():
            raise FileNotFoundError(f"{path} is missing: run make_collection.py first")
        with np.load(path, allow_pickle=False) as data:
            for name, rows in _parts(data).items():
                parts.setdefault(name, []).append(rows)
            for key in info:
                info[key].append(data[key])
    parts = {
        name: np.concatenate(rows) if isinstance(rows[0], np.ndarray) else sum(rows, [])
        for name, rows in parts.items()
    }
    info = {
        key: np.concatenate(values) if key != "seconds" else np.array(values)
        for key, values in info.items()
    }
    return parts, info


def base_collection(name):
    """``(meshes, y)`` of the base collection (a folder of the shared data)."""
    from _common import collection

    found = collection(name, n_jobs=1)
    if found is None:
        raise SystemExit(f"base collection {name!r} not found (SKLEARN_MESHPH_DATA)")
    meshes, y, _ = found
    return meshes, y


def build(folder, base, seed, n, chunk, n_jobs, shard=(0, 1), log=print):
    """Every chunk of the first ``n`` samples, the missing ones computed: chunk ``c``
    when ``c % shard[1] == shard[0]`` (processes of different shards share the work)."""
    meshes, y = base_collection(base)
    started = time.perf_counter()
    for c, (start, stop) in enumerate(_chunks(n, chunk)):
        if c % shard[1] != shard[0]:
            continue
        cached = chunk_path(folder, seed, start, stop).exists()
        build_chunk(folder, meshes, y, seed, start, stop, n_jobs=n_jobs)
        if not cached:
            log(f"{stop}/{n} built, {time.perf_counter() - started:.0f} s", flush=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--n", type=int, default=20000)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--chunk", type=int, default=200)
    parser.add_argument("--folder", default=str(DEFAULT_FOLDER))
    parser.add_argument("--n-jobs", type=int, default=1)
    parser.add_argument("--base", default="watertight_dev")
    parser.add_argument(
        "--shard", default="0/1", help="K/M: this process builds the chunks c with c %% M == K"
    )
    args = parser.parse_args()
    shard = tuple(int(part) for part in args.shard.split("/"))
    build(args.folder, args.base, args.seed, args.n, args.chunk, args.n_jobs, shard)


if __name__ == "__main__":
    main()
