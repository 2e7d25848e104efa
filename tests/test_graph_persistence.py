"""Persistence on graphs: extended_persistence against gudhi, hand-computed cases, and
LowerStarPersistence on graph samples."""

import numpy as np
import pytest
import trimesh

from sklearn_meshph import (
    LowerStarPersistence,
    ScalarField,
    extended_persistence,
    lower_star_persistence,
)
from sklearn_meshph.graph import Graph

gudhi = pytest.importorskip("gudhi")

KEYS = ("ord0", "rel1", "ext0", "ext1")


def sorted_rows(diagram):
    """Rows in lexicographic order of their values rounded (gudhi's rescaling moves a
    few values in the last bits)."""
    diagram = np.asarray(diagram, dtype=float).reshape(-1, 2)
    return diagram[np.lexsort(np.round(diagram, 9).T[::-1])]


def off_diagonal(diagram, tol):
    diagram = sorted_rows(diagram)
    return diagram[np.abs(diagram[:, 1] - diagram[:, 0]) > tol]


def gudhi_extended(n_nodes, edges, values):
    """gudhi's four extended diagrams of the lower-star filtration of a graph."""
    tree = gudhi.SimplexTree()
    for v in range(n_nodes):
        tree.insert([v], float(values[v]))
    for u, v in edges:
        tree.insert([int(u), int(v)], float(max(values[u], values[v])))
    tree.extend_filtration()
    tree.persistence()
    parts = tree.extended_persistence()
    pairs = zip(KEYS, parts, strict=True)
    return {key: np.array([p for _, p in part]).reshape(-1, 2) for key, part in pairs}


def as_graph(n_nodes, edges):
    edges = np.asarray(edges, dtype=np.int64).reshape(-1, 2)
    edges = np.unique(np.sort(edges, axis=1), axis=0)
    return Graph(n_nodes, edges, np.ones(len(edges)))


# Random graphs of every shape the oracle test covers ------------------------------------


def _pairs(n, p, rng):
    i, j = np.triu_indices(n, 1)
    keep = rng.random(len(i)) < p
    return np.column_stack([i[keep], j[keep]])


def _tree(n, rng):
    return np.array([[rng.integers(0, v), v] for v in range(1, n)], dtype=np.int64).reshape(-1, 2)


def _cycle(n, rng):
    order = rng.permutation(n)
    return np.column_stack([order, np.roll(order, -1)])


def _relabel(edges, n, rng):
    """The same graph with its nodes renumbered at random."""
    return rng.permutation(n)[edges] if len(edges) else edges


def random_graph(family, rng):
    """``(n_nodes, edges)`` of one random graph of ``family``."""
    if family == "tree":
        n = int(rng.integers(1, 25))
        return n, _relabel(_tree(n, rng), n, rng)
    if family == "cycle":
        n = int(rng.integers(3, 20))
        return n, _cycle(n, rng)
    if family == "complete":
        n = int(rng.integers(2, 16))  # up to 91 cycles: more than one 64-bit word
        return n, _pairs(n, 1.0, rng)
    if family == "disconnected":
        # a few components (trees, cycles, dense pieces) and isolated nodes
        blocks, offset = [], 0
        for _ in range(int(rng.integers(2, 5))):
            size = int(rng.integers(1, 8))
            kind = rng.integers(0, 3)
            if kind == 0:
                block = _tree(size, rng)
            elif kind == 1 and size >= 3:
                block = _cycle(size, rng)
            else:
                block = _pairs(size, 0.6, rng)
            blocks.append(block.reshape(-1, 2) + offset)
            offset += size
        n = offset + int(rng.integers(0, 3))
        return n, _relabel(np.vstack(blocks), n, rng)
    n = int(rng.integers(1, 30))
    density = {"sparse": 0.08, "medium": 0.25, "dense": 0.6}[family]
    return n, _pairs(n, density, rng)


def random_values(n, rng, ties):
    if ties:
        return rng.integers(0, 4, n).astype(float)
    return rng.normal(size=n)


FAMILIES = ("tree", "cycle", "complete", "disconnected", "sparse", "medium", "dense")
PER_FAMILY = 250  # 7 x 250 = 1750 graphs, half of them with ties


@pytest.mark.parametrize("family", FAMILIES)
def test_gudhi_agrees_on_random_graphs(family):
    rng = np.random.default_rng(FAMILIES.index(family))
    for trial in range(PER_FAMILY):
        n, edges = random_graph(family, rng)
        values = random_values(n, rng, ties=trial % 2 == 1)
        graph = as_graph(n, edges)
        ours = extended_persistence(graph, values)
        expected = gudhi_extended(n, graph.edges, values)
        for key in KEYS:
            # gudhi rescales values internally: its diagonal points may move off by ~1e-16
            want = off_diagonal(expected[key], 1e-9)
            got = sorted_rows(ours[key])
            assert got.shape == want.shape, (family, trial, key, got, want)
            np.testing.assert_allclose(got, want, atol=1e-9, err_msg=f"{family} {trial} {key}")


# Hand-computed cases ---------------------------------------------------------------------


def test_cycle_graph_has_one_cycle_from_max_to_min():
    square = (4, np.array([[0, 1], [1, 2], [2, 3], [0, 3]]))
    diagrams = extended_persistence(square, [0.0, 3.0, 1.0, 2.0])
    assert set(diagrams) == set(KEYS)
    np.testing.assert_array_equal(diagrams["ext1"], [[3.0, 0.0]])
    np.testing.assert_array_equal(diagrams["ext0"], [[0.0, 3.0]])
    # the minimum 1 is born at 1 and joins the minimum 0 at 2 (its neighbour of value 2)
    np.testing.assert_array_equal(diagrams["ord0"], [[1.0, 2.0]])
    # the maximum 2 is born at 2 (downwards) and joins the maximum 3 at 1
    np.testing.assert_array_equal(diagrams["rel1"], [[2.0, 1.0]])
    for diagram in diagrams.values():
        assert diagram.dtype == np.float64 and diagram.shape[1] == 2


def test_tree_has_no_cycles_and_a_path_is_monotone():
    path = (4, np.array([[0, 1], [1, 2], [2, 3]]))
    diagrams = extended_persistence(path, [0.0, 1.0, 2.0, 3.0])
    assert [len(diagrams[key]) for key in KEYS] == [0, 0, 1, 0]
    np.testing.assert_array_equal(diagrams["ext0"], [[0.0, 3.0]])


def test_components_isolated_nodes_and_two_cycles():
    # a triangle (0, 1, 2), a square (3, 4, 5, 6) and isolated nodes 7 and 8
    edges = [[0, 1], [1, 2], [0, 2], [3, 4], [4, 5], [5, 6], [3, 6]]
    values = [1.0, 2.0, 5.0, 0.0, 4.0, 1.0, 3.0, 7.0, -1.0]
    diagrams = extended_persistence((9, np.array(edges)), values)
    # isolated nodes are components whose (min, max) has length zero: dropped
    np.testing.assert_array_equal(sorted_rows(diagrams["ext0"]), [[0.0, 4.0], [1.0, 5.0]])
    np.testing.assert_array_equal(sorted_rows(diagrams["ext1"]), [[4.0, 0.0], [5.0, 1.0]])
    np.testing.assert_array_equal(diagrams["ord0"], [[1.0, 3.0]])
    np.testing.assert_array_equal(diagrams["rel1"], [[3.0, 1.0]])


def test_constant_cycle_has_no_points():
    triangle = (3, np.array([[0, 1], [1, 2], [0, 2]]))
    assert all(len(d) == 0 for d in extended_persistence(triangle, [2.0, 2.0, 2.0]).values())


def test_many_cycles_need_several_words():
    # the complete graph on 14 nodes has 78 independent cycles (two 64-bit words)
    n = 14
    i, j = np.triu_indices(n, 1)
    values = np.arange(n, dtype=float)
    diagrams = extended_persistence((n, np.column_stack([i, j])), values)
    expected = gudhi_extended(n, np.column_stack([i, j]), values)
    assert len(diagrams["ext1"]) == 78
    np.testing.assert_allclose(sorted_rows(diagrams["ext1"]), sorted_rows(expected["ext1"]))


def test_numbering_of_nodes_does_not_matter():
    rng = np.random.default_rng(5)
    n, edges = random_graph("medium", rng)
    values = random_values(n, rng, ties=False)
    first = extended_persistence((n, edges), values)
    perm = rng.permutation(n)
    renamed = np.empty(n, dtype=np.int64)
    renamed[perm] = np.arange(n)
    second = extended_persistence((n, renamed[edges].reshape(-1, 2)), values[perm])
    for key in KEYS:
        np.testing.assert_array_equal(sorted_rows(first[key]), sorted_rows(second[key]))


def test_bad_input_is_named():
    square = (4, np.array([[0, 1], [1, 2], [2, 3], [0, 3]]))
    with pytest.raises(ValueError, match=r"shape \(4,\)"):
        extended_persistence(square, [0.0, 1.0, 2.0])
    with pytest.raises(ValueError, match="graph: values contain NaN or inf"):
        extended_persistence(square, [0.0, np.nan, 2.0, 1.0])
    with pytest.raises(ValueError, match="graph: values contain NaN or inf"):
        extended_persistence(square, [0.0, np.inf, -np.inf, 1.0])
    with pytest.raises(ValueError, match="graph: values must be a numeric array"):
        extended_persistence(square, ["a", "b", "c", "d"])
    # text that reads as numbers, None, and None among numbers were taken as numbers or
    # NaN ("got (1,)" for None); an object array of numbers is numbers
    for bad in (["1", "2", "3", "4"], None, [0.0, None, 1.0, 2.0]):
        with pytest.raises(ValueError, match="graph: values must be a numeric array of 4"):
            extended_persistence(square, bad)
    as_objects = extended_persistence(square, np.array([0, 3, 1, 2], dtype=object))
    np.testing.assert_array_equal(as_objects["ext1"], [[3.0, 0.0]])
    with pytest.raises(TypeError, match="graph: values must be real numbers, got complex"):
        extended_persistence(square, np.arange(4) + 5j)
    huge = extended_persistence(square, [1e308, 1e308, 0.0, 1e308])
    np.testing.assert_array_equal(huge["ext1"], [[1e308, 0.0]])
    with pytest.raises(ValueError, match=r"values must have shape \(4,\), got \(4, 2\)"):
        extended_persistence(square, np.zeros((4, 2)))
    vertices = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], dtype=float)
    with pytest.raises(TypeError, match="extended_persistence takes a graph"):
        extended_persistence((vertices, np.array([[0, 1, 2]])), np.zeros(3))


# LowerStarPersistence and lower_star_persistence on graphs -------------------------------


def graph_field(n_nodes, edges, values):
    """A ScalarField on a graph's nodes (no coordinates), as the eigen stage makes it."""
    edges = np.asarray(edges, dtype=np.int64).reshape(-1, 2)
    return ScalarField(np.empty((n_nodes, 0)), np.empty((0, 3), dtype=int), values, edges=edges)


def library_orientation(diagrams):
    """extended_persistence's dict as LowerStarPersistence(filtration='extended') orders
    and orients it: lower value first."""
    return [
        diagrams["ord0"],
        diagrams["rel1"][:, ::-1],
        diagrams["ext0"],
        diagrams["ext1"][:, ::-1],
    ]


def test_extended_filtration_of_a_graph_field_is_extended_persistence():
    rng = np.random.default_rng(11)
    n, edges = 12, _pairs(12, 0.4, rng)
    graph = as_graph(n, edges)
    values = np.column_stack([rng.normal(size=n), rng.integers(0, 3, n).astype(float)])
    out = LowerStarPersistence(filtration="extended").fit_transform(
        [graph_field(n, graph.edges, values), (graph, values)]
    )
    for sample in out:
        assert len(sample) == 8  # four diagrams per function, function-major
        for k in range(2):
            expected = library_orientation(extended_persistence(graph, values[:, k]))
            for got, want in zip(sample[4 * k : 4 * k + 4], expected, strict=True):
                np.testing.assert_array_equal(sorted_rows(got), sorted_rows(want))
    ext1 = out[0][3]
    assert len(ext1) and (ext1[:, 0] < ext1[:, 1]).all()


def test_graph_cycles_give_ext1_but_a_cloud_graph_does_not():
    square = np.array([[0, 1], [1, 2], [2, 3], [0, 3]])
    values = np.array([0.0, 3.0, 1.0, 2.0])
    on_graph = LowerStarPersistence(filtration="extended").fit_transform(
        [graph_field(4, square, values)]
    )[0]
    np.testing.assert_array_equal(on_graph[3], [[0.0, 3.0]])
    np.testing.assert_array_equal(on_graph[1], [[1.0, 2.0]])  # (saddle, max)
    points = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=float)
    cloud = ScalarField(points, np.empty((0, 3), dtype=int), values, edges=square)
    on_cloud = LowerStarPersistence(filtration="extended").fit_transform([cloud])[0]
    assert len(on_cloud[3]) == 0
    for got, want in zip(on_cloud[:3], on_graph[:3], strict=True):
        np.testing.assert_array_equal(sorted_rows(got), sorted_rows(want))


def test_negated_function_swaps_and_reflects_on_graphs():
    rng = np.random.default_rng(3)
    n, edges = 12, _pairs(12, 0.4, rng)
    values = rng.normal(size=n)
    estimator = LowerStarPersistence(filtration="extended")
    up, down = estimator.fit_transform(
        [graph_field(n, edges, values), graph_field(n, edges, -values)]
    )

    def reflect(d):
        return np.column_stack([-d[:, 1], -d[:, 0]])

    for got, source in zip(down, (up[1], up[0], up[2], up[3]), strict=True):
        np.testing.assert_allclose(sorted_rows(got), sorted_rows(reflect(source)))


def test_sublevel_filtrations_and_parts_on_graphs():
    rng = np.random.default_rng(8)
    n, edges = random_graph("sparse", rng)
    graph = as_graph(n, edges)
    values = rng.normal(size=n)
    field = graph_field(n, graph.edges, values)
    h0 = LowerStarPersistence(filtration="sublevel").fit_transform([field])[0]
    np.testing.assert_array_equal(h0, lower_star_persistence(graph, values))
    diagrams = extended_persistence(graph, values)
    finite = h0[np.isfinite(h0[:, 1])]
    np.testing.assert_array_equal(sorted_rows(finite), sorted_rows(diagrams["ord0"]))
    sup = LowerStarPersistence(filtration="superlevel").fit_transform([field])[0]
    np.testing.assert_allclose(
        sorted_rows(-sup[np.isfinite(sup[:, 1])][:, ::-1]), sorted_rows(diagrams["rel1"][:, ::-1])
    )
    only = LowerStarPersistence(filtration="extended", parts=("ext1",)).fit_transform([field])[0]
    np.testing.assert_array_equal(sorted_rows(only), sorted_rows(diagrams["ext1"][:, ::-1]))
    square = graph_field(4, [[0, 1], [1, 2], [2, 3], [0, 3]], [0.0, 3.0, 1.0, 2.0])
    long = LowerStarPersistence(filtration="extended", min_persistence=1.0).fit_transform([square])
    # |d - b| > 1 keeps the cycle and the component, not the pairs of length 1
    assert [len(diagram) for diagram in long[0]] == [0, 0, 1, 1]


def test_repeated_edges_and_loops_of_a_field_are_one_simplex():
    square = [[0, 1], [1, 2], [2, 3], [0, 3]]
    messy = [[1, 0], [0, 1], [1, 2], [2, 2], [3, 2], [0, 3], [2, 3]]
    values = np.array([0.0, 3.0, 1.0, 2.0])
    estimator = LowerStarPersistence(filtration="extended")
    clean, noisy = estimator.fit_transform(
        [graph_field(4, square, values), graph_field(4, messy, values)]
    )
    for a, b in zip(clean, noisy, strict=True):
        np.testing.assert_array_equal(sorted_rows(a), sorted_rows(b))
    assert len(noisy[3]) == 1


def test_graph_without_edges_and_bad_graph_values_are_named():
    lonely = LowerStarPersistence(filtration="extended").fit_transform(
        [ScalarField(np.empty((3, 0)), np.empty((0, 3), dtype=int), [0.0, 1.0, 2.0])]
    )[0]
    assert all(len(d) == 0 for d in lonely)
    with pytest.raises(ValueError, match=r"sample 1: .*shape \(4,\)"):
        LowerStarPersistence().fit_transform(
            [(as_graph(4, [[0, 1]]), np.zeros(4)), (as_graph(4, [[0, 1]]), np.zeros(3))]
        )
    with pytest.raises(ValueError, match=r"shape \(4,\)"):
        lower_star_persistence(as_graph(4, [[0, 1]]), np.zeros(5))
    # Found by an adversarial review: an int beyond float64 was a bare OverflowError.
    square = (4, [[0, 1], [1, 2], [2, 3], [0, 3]])
    with pytest.raises(ValueError, match="graph: values must be finite, got one beyond float64"):
        extended_persistence(square, [0, 1, 2, 10**400])
    with pytest.raises(ValueError, match="graph: values must be a numeric array"):
        extended_persistence(square, [[0.0], [1.0, 2.0], 3.0, 4.0])  # ragged


def test_graphs_meshes_and_workers_mix_in_one_call():
    rng = np.random.default_rng(21)
    samples = []
    for _ in range(12):
        n, edges = random_graph("medium", rng)
        samples.append((as_graph(n, edges), rng.normal(size=(n, 2))))
    sphere = trimesh.creation.icosphere(1)
    mesh_sample = (sphere, sphere.vertices[:, 2])
    samples.insert(5, mesh_sample)
    estimator = LowerStarPersistence(filtration="extended", parts=("ord1", "ext1"))
    serial = estimator.fit_transform(samples)
    parallel = estimator.set_params(n_jobs=2).fit_transform(samples)
    alone = estimator.set_params(n_jobs=None).fit_transform([mesh_sample])[0]
    for got, want in zip(serial[5], alone, strict=True):
        np.testing.assert_array_equal(got, want)
    for sample, (graph, values) in zip(
        serial[:5] + serial[6:], samples[:5] + samples[6:], strict=True
    ):
        expected = [library_orientation(extended_persistence(graph, v)) for v in values.T]
        want = [expected[0][1], expected[0][3], expected[1][1], expected[1][3]]
        for got, wanted in zip(sample, want, strict=True):
            np.testing.assert_array_equal(sorted_rows(got), sorted_rows(wanted))
    for a, b in zip(serial, parallel, strict=True):
        for x, y in zip(a, b, strict=True):
            np.testing.assert_array_equal(x, y)


def test_extended_persistence_refuses_graphs_whose_cycle_table_would_not_fit(monkeypatch):
    """ext1's table grows with the square of the independent cycles (the complete graph
    on 1,000 nodes would need 29 GiB): such a graph is refused before any allocation,
    naming the sample; the count is exact, so repeated edges and loops do not count."""
    from sklearn_meshph.persistence import graph_extended

    monkeypatch.setattr(graph_extended, "MAX_CYCLE_TABLE_BYTES", 10_000)
    i, j = np.triu_indices(30, 1)  # K30: 406 independent cycles, 24 KB
    dense = (30, np.column_stack([i, j]))
    values = np.arange(30.0)
    with pytest.raises(ValueError, match="graph: 406 independent cycles; .* would need"):
        extended_persistence(dense, values)
    path = np.column_stack([np.arange(29), np.arange(1, 30)])
    repeated = (30, np.vstack([path] * 40 + [np.column_stack([np.arange(30)] * 2)]))
    assert len(extended_persistence(repeated, values)["ext1"]) == 0  # a path: no cycle
    fields = [graph_field(30, path, values), graph_field(*dense, values)]
    with pytest.raises(ValueError, match="sample 1: 406 independent cycles"):
        LowerStarPersistence(filtration="extended").fit_transform(fields)
