"""benchmarks/make_collection.py in small: the collection is reproducible from its seed
mesh by mesh, its transformations keep the class and the topology, its cache reads back
what was computed, and pruned queries on it equal brute force under the default."""

from __future__ import annotations

import numpy as np
import pytest

from sklearn_meshph import ShapeNeighbors, ShapeNeighborsClassifier, make_shapes

pytest.importorskip("fast_simplification")

N_PER_BASE = 3


@pytest.fixture(scope="module")
def benchmarks(pytestconfig):
    """The modules of benchmarks/ (make_collection, bench_queries), imported from there."""
    import sys

    folder = str(pytestconfig.rootpath / "benchmarks")
    sys.path.insert(0, folder)
    try:
        import bench_queries
        import make_collection

        yield make_collection, bench_queries
    finally:
        sys.path.remove(folder)


@pytest.fixture(scope="module")
def base():
    return make_shapes(n_per_class=1, random_state=0, return_X_y=True)


@pytest.fixture(scope="module")
def built(benchmarks, base, tmp_path_factory):
    """A collection of N_PER_BASE meshes per base shape, built into a cache and read back."""
    make_collection, _ = benchmarks
    meshes, y = base
    folder = tmp_path_factory.mktemp("collection")
    n = N_PER_BASE * len(y)
    make_collection.build_chunk(folder, meshes, y, 0, 0, n)
    return make_collection.load_collection(folder, 0, n, n), folder


def test_reproducible_from_the_seed_mesh_by_mesh(benchmarks, base):
    make_collection, _ = benchmarks
    meshes, y = base
    first = make_collection.generate(meshes, y, 5, 0, 8)[0]
    again = make_collection.generate(meshes, y, 5, 0, 8)[0]
    alone = make_collection.generate(meshes, y, 5, 6, 8)[0]  # a chunk alone
    other = make_collection.generate(meshes, y, 6, 0, 8)[0]
    for a, b in zip(first, again, strict=True):
        assert np.array_equal(a.vertices, b.vertices) and np.array_equal(a.faces, b.faces)
    for a, b in zip(first[6:], alone, strict=True):
        assert np.array_equal(a.vertices, b.vertices) and np.array_equal(a.faces, b.faces)
    assert not any(
        a.vertices.shape == b.vertices.shape and np.allclose(a.vertices, b.vertices)
        for a, b in zip(first, other, strict=True)
    )


def test_transformations_keep_label_and_topology(benchmarks, base):
    make_collection, _ = benchmarks
    meshes, y = base
    made, labels, bases, remeshed = make_collection.generate(meshes, y, 0, 0, 2 * len(y))
    assert np.array_equal(bases, np.arange(2 * len(y)) % len(y))
    assert np.array_equal(labels, y[bases])
    assert remeshed.all()
    low, high = make_collection.VERTICES
    for mesh, b in zip(made, bases, strict=True):
        assert mesh.is_watertight and mesh.euler_number == meshes[b].euler_number
        assert low <= len(mesh.vertices) <= 1.5 * high
        assert len(mesh.vertices) != len(meshes[b].vertices)  # remeshed, not moved only


def test_remesh_keeps_topology_or_returns_the_base(benchmarks, base, monkeypatch):
    make_collection, _ = benchmarks
    import trimesh

    torus = trimesh.creation.torus(1.0, 0.3, major_sections=60, minor_sections=30)
    mesh, remeshed = make_collection.remesh(torus, 1000)
    assert remeshed and mesh.is_watertight and mesh.euler_number == 0
    assert len(mesh.vertices) <= 1.5 * 1000

    # A simplification that always breaks the surface is refused: the base comes back.
    import fast_simplification

    def broken(vertices, faces, reduction, agg):
        return vertices, faces[1:]

    monkeypatch.setattr(fast_simplification, "simplify", broken)
    mesh, remeshed = make_collection.remesh(torus, 1000)
    assert not remeshed
    assert np.array_equal(mesh.vertices, torus.vertices)


def test_bend_keeps_lengths_along_the_axis(benchmarks):
    make_collection, _ = benchmarks
    along = np.linspace(-1.0, 1.0, 201)
    line = np.column_stack([along, np.zeros_like(along), np.zeros_like(along)])
    line += 1e-9 * np.random.default_rng(0).normal(size=line.shape)  # fixes the axes
    bent = make_collection.bend(line, 0.3)
    length = np.sum(np.linalg.norm(np.diff(bent, axis=0), axis=1))
    assert length == pytest.approx(2.0, rel=1e-6)
    ends = bent[[0, -1]] - bent[[1, -2]]
    turn = np.degrees(np.arccos(abs(ends[0] @ ends[1]) / np.prod(np.linalg.norm(ends, axis=1))))
    assert turn == pytest.approx(np.degrees(0.6), abs=1.0)  # each end turned by 0.3 rad


def test_cache_reads_back_what_was_computed(benchmarks, base, built):
    make_collection, _ = benchmarks
    (parts, info), folder = built
    meshes, y = base
    n = N_PER_BASE * len(y)
    made = make_collection.generate(meshes, y, 0, 0, n)[0]
    direct, _ = make_collection.representations(made)
    assert parts.keys() == direct.keys()
    for name, rows in direct.items():
        if isinstance(rows, np.ndarray):
            assert np.array_equal(parts[name], rows)
        else:
            for a, b in zip(parts[name], rows, strict=True):
                assert len(a) == len(b)
                assert all(np.array_equal(p, q) for p, q in zip(a, b, strict=True))
    assert np.array_equal(info["y"], np.tile(y, N_PER_BASE))
    with pytest.raises(FileNotFoundError, match="make_collection.py first"):
        make_collection.load_collection(folder, 1, n, n)


def test_pruned_queries_equal_brute_force_on_the_collection(benchmarks, built):
    _, bench_queries = benchmarks
    (parts, info), _ = built
    samples, y = bench_queries.samples_of(parts), info["y"]
    fitted, queries = samples[:-6], samples[-6:]
    index = ShapeNeighbors(bench_queries.default_metric(), n_neighbors=4).fit(fitted)
    distances, indices = index.kneighbors(queries)
    brute = index.distance_matrix(queries, dtype="float64")
    order = np.argsort(brute, axis=1, kind="stable")[:, :4]
    assert np.array_equal(indices, order)
    assert np.array_equal(distances, np.take_along_axis(brute, order, axis=1))
    loo = index.kneighbors(return_distance=False)
    square = index.distance_matrix(dtype="float64")
    np.fill_diagonal(square, np.inf)
    assert np.array_equal(loo, np.argsort(square, axis=1, kind="stable")[:, :4])
    # The transformed meshes are recognized: 1-NN on the others finds their class.
    model = ShapeNeighborsClassifier(bench_queries.default_metric()).fit(fitted, y[:-6])
    assert model.score(queries, y[-6:]) >= 5 / 6
