"""Spectra of graphs: the graph Laplacians, the solve of a graph sample, dense and sparse
paths, heat kernel signatures at fixed times, and the eigen stage's graph fields."""

import pickle
import warnings

import numpy as np
import pytest
import scipy.linalg
import trimesh
from sklearn.base import clone

from sklearn_meshph import LaplacianEigenTransformer, ShapeDNA, laplacian_eigenfunctions
from sklearn_meshph.graph.validation import Graph
from sklearn_meshph.mesh.cleaning import MeshCleaningWarning
from sklearn_meshph.mesh.graph import mesh_edges
from sklearn_meshph.spectral import eigensolver
from sklearn_meshph.spectral.eigensolver import DENSE_MAX_NODES, generalized_eigenpairs
from sklearn_meshph.spectral.laplacians import GRAPH_LAPLACIANS, LAPLACIANS
from sklearn_meshph.spectral.multiplicity import RepeatedEigenvalueWarning
from sklearn_meshph.spectral.signatures import check_times

GRAPH_KINDS = ("graph", "normalized", "random_walk")


def make_graph(n, pairs, weights=None):
    """A validated Graph from any list of node pairs (each once)."""
    pairs = np.sort(np.asarray(pairs, dtype=np.int64).reshape(-1, 2), axis=1)
    order = np.lexsort((pairs[:, 1], pairs[:, 0]))
    weights = np.ones(len(pairs)) if weights is None else np.asarray(weights, float)
    return Graph(n, pairs[order], weights[order])


def path(n):
    return make_graph(n, [(i, i + 1) for i in range(n - 1)])


def cycle(n):
    return make_graph(n, [(i, (i + 1) % n) for i in range(n)])


def complete(n):
    return make_graph(n, [(i, j) for i in range(n) for j in range(i + 1, n)])


def star(n):
    return make_graph(n, [(0, i) for i in range(1, n)])


def random_graph(n, extra, seed, weighted=False):
    """A connected random graph: a random tree plus ``extra`` random edges."""
    rng = np.random.default_rng(seed)
    pairs = [(i, int(rng.integers(0, i))) for i in range(1, n)]
    pairs += [tuple(p) for p in rng.integers(0, n, size=(extra, 2)) if p[0] != p[1]]
    pairs = np.unique(np.sort(np.array(pairs), axis=1), axis=0)
    weights = rng.uniform(0.5, 2.0, len(pairs)) if weighted else None
    return make_graph(n, pairs, weights)


def spectrum(graph, laplacian, solver="auto", n=None):
    values, _ = laplacian_eigenfunctions(graph, n, laplacian, components="all", solver=solver)
    return values


def dense_laplacian(graph, kind):
    """The operator computed independently, densely: the test's oracle."""
    A = graph.adjacency().toarray()
    d = A.sum(axis=1)
    if kind == "graph":
        return np.diag(d) - A
    root = np.where(d > 0, 1 / np.sqrt(np.where(d > 0, d, 1)), 0.0)
    return np.diag((d > 0).astype(float)) - root[:, None] * A * root[None, :]


# Closed forms (dense path: small graphs; sparse path: a cycle above the crossover)


@pytest.mark.parametrize("solver", ["dense", "auto"])
def test_path_and_cycle_spectra(solver):
    n = 12
    k = np.arange(n)
    np.testing.assert_allclose(
        spectrum(path(n), "graph", solver), np.sort(2 - 2 * np.cos(np.pi * k / n)), atol=1e-12
    )
    np.testing.assert_allclose(
        spectrum(cycle(n), "graph", solver), np.sort(2 - 2 * np.cos(2 * np.pi * k / n)), atol=1e-12
    )
    # Normalized: a cycle is 2-regular, so its normalized spectrum is half the combinatorial.
    np.testing.assert_allclose(
        spectrum(cycle(n), "normalized", solver), np.sort(1 - np.cos(2 * np.pi * k / n)), atol=1e-12
    )


def test_cycle_spectrum_by_the_sparse_path():
    n = DENSE_MAX_NODES + 101
    values = spectrum(cycle(n), "graph", "auto", n=9)
    expected = np.sort(2 - 2 * np.cos(2 * np.pi * np.arange(n) / n))[:9]
    np.testing.assert_allclose(values, expected, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("n", [2, 5, 9])
def test_complete_and_star_spectra(n):
    ones = np.ones(n - 1)
    np.testing.assert_allclose(spectrum(complete(n), "graph"), [0, *(n * ones)], atol=1e-12)
    np.testing.assert_allclose(
        spectrum(complete(n), "normalized"), [0, *(n / (n - 1) * ones)], atol=1e-12
    )
    middle = np.ones(n - 2)
    np.testing.assert_allclose(spectrum(star(n), "graph"), [0, *middle, n], atol=1e-12)
    np.testing.assert_allclose(spectrum(star(n), "normalized"), [0, *middle, 2], atol=1e-12)


def test_weights_scale_the_combinatorial_laplacian_not_the_normalized_one():
    edge = make_graph(2, [(0, 1)], [3.5])
    np.testing.assert_allclose(spectrum(edge, "graph"), [0, 7], atol=1e-12)
    np.testing.assert_allclose(spectrum(edge, "normalized"), [0, 2], atol=1e-12)
    np.testing.assert_allclose(spectrum(edge, "random_walk"), [0, 2], atol=1e-12)


def test_tiny_weights_scale_the_random_walk_vectors_without_a_warning():
    """Found by an adversarial review: with weights near 1e-300 the D-orthonormal
    eigenvectors are near 1e150, and the sign rule cubed them (overflow, NaN skewness,
    RuntimeWarnings); with weights spanning float64's range the error was scipy's
    "array must not contain infs or NaNs"."""
    options = dict(laplacian="random_walk", normalization="none", components="all", n_jobs=1)
    path = [[0, 1], [1, 2], [2, 3]]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        tiny = LaplacianEigenTransformer(eigen_index=(1, 2, 3), **options).fit_transform(
            [Graph(4, path, [1e-300, 2e-300, 3e-300])]
        )[0]
    unit = LaplacianEigenTransformer(eigen_index=(1, 2, 3), **options).fit_transform(
        [Graph(4, path, [1.0, 2.0, 3.0])]
    )[0]
    np.testing.assert_allclose(tiny.values, unit.values * 1e150, rtol=1e-9)
    with pytest.raises(ValueError, match="sample 0: .* the weights span too wide a range"):
        LaplacianEigenTransformer(**options).fit_transform([Graph(3, path[:2], [2.3e-308, 1e300])])


@pytest.mark.parametrize("kind", ["graph", "normalized"])
def test_operators_match_the_dense_definitions(kind):
    graph = make_graph(7, [(0, 1), (1, 2), (0, 2), (3, 4)], [1.0, 2.0, 0.5, 4.0])
    L, M = GRAPH_LAPLACIANS[kind].value(graph)
    np.testing.assert_allclose(L.toarray(), dense_laplacian(graph, kind), atol=1e-15)
    np.testing.assert_array_equal(M.diagonal(), np.ones(7))


def test_isolated_nodes_definition():
    graph = make_graph(3, [(0, 1)])
    L, _ = GRAPH_LAPLACIANS["normalized"].value(graph)
    assert L[2, 2] == 0.0 and L[0, 0] == 1.0  # Chung's convention, as scipy and networkx
    L, M = GRAPH_LAPLACIANS["random_walk"].value(graph)
    np.testing.assert_array_equal(M.diagonal(), [1.0, 1.0, 1.0])  # degree 1, 1; isolated: 1
    assert L[2, 2] == 0.0


def test_random_walk_has_the_normalized_spectrum_and_d_orthonormal_vectors():
    graph = random_graph(40, 30, seed=1, weighted=True)
    walk, walk_vectors = laplacian_eigenfunctions(graph, None, "random_walk")
    normalized, vectors = laplacian_eigenfunctions(graph, None, "normalized")
    np.testing.assert_allclose(walk, normalized, atol=1e-12)
    degrees = np.asarray(graph.adjacency().sum(axis=1)).ravel()
    gram = walk_vectors.T @ (degrees[:, None] * walk_vectors)
    np.testing.assert_allclose(gram, np.eye(40), atol=1e-10)
    # phi_walk = D^-1/2 phi_normalized (same sign rule on both sides, up to a sign).
    mapped = vectors / np.sqrt(degrees)[:, None]
    cosines = np.abs(np.einsum("ij,ij->j", mapped * degrees[:, None], walk_vectors))
    np.testing.assert_allclose(cosines, 1.0, atol=1e-8)


def test_mesh_and_cloud_registries_have_the_graph_laplacians():
    assert set(GRAPH_LAPLACIANS.names) <= set(LAPLACIANS.names)
    assert {"graph", "normalized", "random_walk"} <= set(GRAPH_LAPLACIANS.names)
    assert "cotangent" not in GRAPH_LAPLACIANS
    sphere = trimesh.creation.icosphere(1)
    faces = np.asarray(sphere.faces)
    adjacency = mesh_edges(faces, len(sphere.vertices)).tocoo()
    upper = adjacency.row < adjacency.col
    as_graph = make_graph(
        len(sphere.vertices), np.column_stack([adjacency.row, adjacency.col])[upper]
    )
    for kind in GRAPH_KINDS:
        L, M = LAPLACIANS[kind].value(sphere.vertices, faces)
        L_graph, M_graph = GRAPH_LAPLACIANS[kind].value(as_graph)
        np.testing.assert_allclose(L.toarray(), L_graph.toarray(), atol=1e-15)
        np.testing.assert_allclose(M.diagonal(), M_graph.diagonal())


# Dense and sparse paths


def test_dense_and_sparse_paths_agree_on_a_mid_size_graph():
    graph = random_graph(400, 60, seed=2, weighted=True)
    for kind in GRAPH_KINDS:
        L, M = GRAPH_LAPLACIANS[kind].value(graph)
        dense = generalized_eigenpairs(L, M, 12, solver="dense")
        sparse = generalized_eigenpairs(L, M, 12, solver="cholesky", dense_max=0)
        np.testing.assert_allclose(dense[0], sparse[0], rtol=1e-8, atol=1e-12)
        # Simple eigenvalues here: the same vectors, signs fixed by one rule.
        np.testing.assert_allclose(dense[1], sparse[1], atol=1e-7)


def test_auto_switches_to_the_sparse_path_above_the_crossover(monkeypatch):
    calls = []
    original = eigensolver.dense_eigenpairs

    def spy(*args):
        calls.append(args[0].shape[0])
        return original(*args)

    monkeypatch.setattr(eigensolver, "dense_eigenpairs", spy)
    for n in (DENSE_MAX_NODES, DENSE_MAX_NODES + 1):
        LaplacianEigenTransformer(laplacian="graph", eigen_index=1).fit_transform([cycle(n)])
    assert calls == [DENSE_MAX_NODES]
    # solver="dense" takes the dense path at any size, every eigenpair when None.
    (field,) = LaplacianEigenTransformer(
        laplacian="normalized", solver="dense", signature="hks", times=[1.0]
    ).fit_transform([cycle(DENSE_MAX_NODES + 1)])
    assert calls[-1] == DENSE_MAX_NODES + 1 and len(field.spectrum) == DENSE_MAX_NODES + 1


def test_dense_solver_on_a_mesh_agrees_with_the_factorization():
    sphere = trimesh.creation.icosphere(3)  # 642 vertices: above the mesh crossover
    dense = laplacian_eigenfunctions(sphere, 10, solver="dense")
    sparse = laplacian_eigenfunctions(sphere, 10)
    np.testing.assert_allclose(dense[0], sparse[0], rtol=1e-9, atol=1e-10)


def test_dense_limit_is_a_clear_error(monkeypatch):
    monkeypatch.setattr(eigensolver, "DENSE_LIMIT", 50)
    with pytest.raises(ValueError, match=r"sample 0: .*dense eigensolver needs two 60 x 60"):
        LaplacianEigenTransformer(
            laplacian="normalized", signature="hks", times=[1.0]
        ).fit_transform([cycle(60)])


# Heat kernel signatures at fixed times


@pytest.mark.parametrize("kind", GRAPH_KINDS)
@pytest.mark.parametrize("normalization", ["none", "area"])
def test_fixed_time_hks_is_the_heat_kernel_diagonal(kind, normalization):
    graph = make_graph(
        9, [(0, 1), (1, 2), (2, 0), (2, 3), (3, 4), (5, 6), (6, 7)], np.linspace(0.5, 2, 7)
    )  # a triangle with a tail, a path, an isolated node
    times = (0.1, 1.0, 10.0)
    (field,) = LaplacianEigenTransformer(
        laplacian=kind,
        normalization=normalization,
        components="all",
        signature="hks",
        times=times,
    ).fit_transform([graph])
    assert field.column_names == tuple(f"heat kernel signature t={t:g}" for t in times)
    degrees = graph.adjacency().toarray().sum(axis=1)
    n = graph.n_nodes
    # The operator as the solve sees it, M^-1/2 L M^-1/2, and the mass:
    if kind == "graph":
        operator, mass = dense_laplacian(graph, "graph"), np.ones(n)
    else:
        operator = dense_laplacian(graph, "normalized")
        mass = np.where(degrees > 0, degrees, 1.0) if kind == "random_walk" else np.ones(n)
    if normalization == "area":  # M / sum(M): the eigenvalues grow by sum(M)
        operator, mass = operator * mass.sum(), mass / mass.sum()
    for j, t in enumerate(times):
        # HKS(x, t) = sum_k exp(-lambda_k t) phi_k(x)^2 = [M^-1/2 expm(-t A) M^-1/2]_xx.
        expected = np.diag(scipy.linalg.expm(-t * operator)) / mass
        np.testing.assert_allclose(field.values[:, j], expected, rtol=1e-9, atol=1e-12)


def test_perslay_setting_isolated_node_keeps_its_heat():
    graph = make_graph(4, [(0, 1), (1, 2)])
    (field,) = LaplacianEigenTransformer(
        laplacian="normalized",
        normalization="none",
        components="all",
        signature="hks",
        times=(0.1, 10),
    ).fit_transform([graph])
    assert field.column_names == ("heat kernel signature t=0.1", "heat kernel signature t=10")
    np.testing.assert_allclose(field.values[3], [1.0, 1.0], atol=1e-12)


def test_log_hks_takes_fixed_times_and_wks_ignores_them():
    graph = random_graph(20, 10, seed=3)
    fixed = dict(laplacian="normalized", components="all", times=[0.5, 5.0])
    (log_hks,) = LaplacianEigenTransformer(signature="log-hks", **fixed).fit_transform([graph])
    assert log_hks.column_names == (
        "log heat kernel signature t=0.5",
        "log heat kernel signature t=5",
    )
    (wks,) = LaplacianEigenTransformer(signature="wks", n_scales=3, **fixed).fit_transform([graph])
    assert wks.values.shape == (20, 3)


@pytest.mark.parametrize(
    "times, match",
    [
        ([1e-300], "between 1e-150 and 1e\\+150, got 1e-300"),
        ([1.0, np.inf], "got inf"),
        ([-1.0], "got -1.0"),
        ([np.nan], "got nan"),
        ([], "non-empty 1-D"),
        ([[1.0, 2.0]], "non-empty 1-D"),
        (["1"], "array of positive numbers"),
    ],
)
def test_bad_times_are_refused(times, match):
    with pytest.raises(ValueError, match=match):
        LaplacianEigenTransformer(signature="hks", times=times).fit([cycle(5)])
    with pytest.raises(ValueError, match=match):
        check_times(times)


def test_times_of_the_wrong_type_are_refused():
    with pytest.raises(ValueError, match="'times' parameter"):
        LaplacianEigenTransformer(signature="hks", times=10.0).fit([cycle(5)])


# The eigen stage on graph samples


def test_graph_fields():
    graph = make_graph(6, [(0, 1), (2, 3), (3, 4), (4, 5), (2, 5)])  # an edge and a square
    with pytest.warns(MeshCleaningWarning, match="sample 0: components='largest' dropped 1 other"):
        (field,) = LaplacianEigenTransformer(laplacian="graph", eigen_index=(1, 2)).fit_transform(
            [graph]
        )
    assert field.is_graph and field.vertices.shape == (4, 0) and field.faces.shape == (0, 3)
    np.testing.assert_array_equal(field.edges, [[0, 1], [0, 3], [1, 2], [2, 3]])
    np.testing.assert_array_equal(field.vertex_indices, [2, 3, 4, 5])
    np.testing.assert_array_equal(field.input_to_kept, [-1, -1, 0, 1, 2, 3])
    assert field.cleaning.n_other_components == 1 and field.cleaning.n_component_vertices == 2
    assert field.cleaning.area_share == pytest.approx(0.2)  # 1 of 5 unit edge weights
    assert field.column_names == ("eigenfunction 1", "eigenfunction 2")
    np.testing.assert_allclose(field.spectrum, [0, 2 * 4, 2 * 4], atol=1e-9)  # M = I / 4


def test_components_all_keeps_every_component_and_isolated_nodes():
    graph = make_graph(6, [(0, 1), (1, 2), (0, 2), (3, 4)])  # triangle, edge, isolated node
    for kind in GRAPH_KINDS:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            (field,) = LaplacianEigenTransformer(
                laplacian=kind, components="all", signature="hks", times=[1.0]
            ).fit_transform([graph])
        assert field.vertices.shape == (6, 0) and field.vertex_indices is None
        np.testing.assert_array_equal(field.edges, graph.edges)
        assert np.count_nonzero(field.spectrum < 1e-9) == 3  # one zero per component
        assert len(field.spectrum) == 6  # every eigenpair of a graph by default


def test_largest_component_ties_keep_the_lowest_node_and_error_names_the_count():
    graph = make_graph(5, [(0, 1), (2, 3)])
    with pytest.warns(MeshCleaningWarning, match="2 other components.*3 of its 5 nodes"):
        (field,) = LaplacianEigenTransformer(laplacian="graph", eigen_index=1).fit_transform(
            [graph]
        )
    np.testing.assert_array_equal(field.vertex_indices, [0, 1])
    with pytest.raises(ValueError, match=r"sample 0: the graph has 3 connected components \(1 of"):
        LaplacianEigenTransformer(laplacian="graph", components="error").fit_transform([graph])


def test_cotangent_on_a_graph_and_all_on_a_mesh_are_clear_errors():
    sphere = trimesh.creation.icosphere(1)
    with pytest.raises(
        ValueError,
        match="sample 1: the 'cotangent' Laplacian is a surface's.*'graph', 'normalized', "
        "'random_walk'",
    ):
        LaplacianEigenTransformer().fit_transform([sphere, cycle(5)])
    with pytest.raises(ValueError, match="sample 0: components='all' .* a mesh takes"):
        LaplacianEigenTransformer(components="all").fit_transform([sphere])
    with pytest.raises(ValueError, match="components='all' .* a point cloud takes"):
        laplacian_eigenfunctions(np.asarray(sphere.vertices), 3, components="all")
    with pytest.raises(ValueError, match="components='all' .* a mesh takes"):
        laplacian_eigenfunctions(sphere, 3, components="all")


def test_edgeless_graph():
    graph = make_graph(4, np.empty((0, 2)))
    (field,) = LaplacianEigenTransformer(
        laplacian="normalized", components="all", signature="hks", times=[1.0]
    ).fit_transform([graph])
    np.testing.assert_allclose(field.spectrum, 0.0, atol=1e-15)
    with pytest.raises(ValueError, match="sample 0: a spectral signature needs at least one"):
        LaplacianEigenTransformer(
            laplacian="normalized", components="all", signature="hks"
        ).fit_transform([graph])


def test_n_eigenpairs_on_graphs_and_shape_dna():
    graphs = [random_graph(15, 5, seed=4), (12, np.array([[i, i + 1] for i in range(11)]))]
    eigen = LaplacianEigenTransformer(laplacian="normalized", signature="hks", times=[1.0])
    fields = eigen.fit_transform(graphs)
    assert [len(f.spectrum) for f in fields] == [15, 12]  # None: every eigenpair
    fields = eigen.set_params(n_eigenpairs=5).fit_transform(graphs)
    assert [len(f.spectrum) for f in fields] == [5, 5]
    features = ShapeDNA(n_eigenpairs=5).fit_transform(fields)
    np.testing.assert_allclose(features[1], spectrum(path(12), "normalized")[1:5] * 12)


def test_laplacian_eigenfunctions_on_a_graph():
    graph = make_graph(5, [(1, 2), (2, 3), (3, 4)])
    with pytest.warns(MeshCleaningWarning, match="graph: components='largest' dropped 1"):
        values, vectors = laplacian_eigenfunctions(graph, None, "graph")
    assert vectors.shape == (4, 4)
    np.testing.assert_allclose(
        values, np.sort(2 - 2 * np.cos(np.pi * np.arange(4) / 4)), atol=1e-12
    )
    with pytest.raises(ValueError, match=r"between 1 and 4 \(the kept nodes\), got 5"):
        laplacian_eigenfunctions(graph, 5, "graph")


def test_graph_results_do_not_depend_on_n_jobs():
    graphs = [random_graph(n, n // 2, seed=n, weighted=True) for n in (30, 450, 60, 300)]
    eigen = LaplacianEigenTransformer(laplacian="normalized", eigen_index=(1, 2), n_eigenpairs=8)
    one = eigen.set_params(n_jobs=1).fit_transform(graphs)
    two = eigen.set_params(n_jobs=2).fit_transform(graphs)
    for a, b in zip(one, two, strict=True):
        np.testing.assert_array_equal(a.values, b.values)
        np.testing.assert_array_equal(a.spectrum, b.spectrum)


def test_graph_solves_are_cached(tmp_path, monkeypatch):
    graphs = [random_graph(20, 8, seed=5, weighted=True), cycle(9)]
    eigen = LaplacianEigenTransformer(
        laplacian="random_walk", components="all", signature="hks", times=[1.0], memory=tmp_path
    )
    first = eigen.fit_transform(graphs)

    def no_solve(*args):
        raise AssertionError("solved again")

    monkeypatch.setattr("sklearn_meshph.spectral.transformer.graph_eigenpairs", no_solve)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a usable entry: no CacheWarning
        again = eigen.fit_transform(graphs)
    for a, b in zip(first, again, strict=True):
        np.testing.assert_array_equal(a.values, b.values)
        np.testing.assert_array_equal(a.edges, b.edges)
    # Other weights are another graph: not a hit.
    reweighted = Graph(9, cycle(9).edges, np.full(9, 2.0))
    with pytest.raises(AssertionError, match="solved again"):
        eigen.fit_transform([reweighted])


def test_times_parameter_clones_and_pickles():
    eigen = LaplacianEigenTransformer(signature="hks", times=(0.1, 10))
    assert clone(eigen).get_params()["times"] == (0.1, 10)
    assert pickle.loads(pickle.dumps(eigen)).times == (0.1, 10)


def test_eigenfunctions_of_a_zero_eigenvalue_say_it_is_one_per_component():
    graph = make_graph(7, [(0, 1), (1, 2), (3, 4), (4, 5)])  # two paths, an isolated node
    with pytest.warns(
        RepeatedEigenvalueWarning,
        match="sample 0: eigenvalue 1 is 0, as are eigenvalues 0-2: the sample has 3 connected",
    ):
        (field,) = LaplacianEigenTransformer(
            laplacian="graph", components="all", eigen_index=1
        ).fit_transform([graph])
    np.testing.assert_allclose(field.eigenvalues, 0.0, atol=1e-12)


def test_weights_beyond_float64s_range_are_refused():
    huge = make_graph(3, [(0, 1), (0, 2)], [1e308, 1e308])
    for kind in GRAPH_KINDS:
        with pytest.raises(ValueError, match="sample 0: the graph's edge weights sum beyond"):
            LaplacianEigenTransformer(laplacian=kind, eigen_index=1).fit_transform([huge])
    # Tiny weights are a scale like any other: the normalized spectrum does not see it.
    tiny = make_graph(3, [(0, 1), (0, 2)], [1e-300, 1e-300])
    np.testing.assert_allclose(spectrum(tiny, "normalized"), [0, 1, 2], atol=1e-12)
    np.testing.assert_allclose(
        spectrum(tiny, "graph"), [0, 1e-300, 3e-300], rtol=1e-12, atol=1e-310
    )


def test_fixed_times_on_a_mesh_are_the_same_sum_over_its_eigenpairs():
    sphere = trimesh.creation.icosphere(2)
    eigen = LaplacianEigenTransformer(signature="hks", n_eigenpairs=20, times=[0.01, 0.1])
    (field,) = eigen.fit_transform([sphere])
    (basis,) = LaplacianEigenTransformer(
        eigen_index=tuple(range(20)), n_eigenpairs=20
    ).fit_transform([sphere])
    expected = (basis.values**2) @ np.exp(-np.outer(basis.eigenvalues, [0.01, 0.1]))
    np.testing.assert_allclose(field.values, expected, rtol=1e-10)
    assert field.column_names[1] == "heat kernel signature t=0.1"


def test_graphs_too_small_for_the_request_are_named():
    with pytest.raises(ValueError, match="sample 0: eigen_index 3 needs at least 4 nodes, the"):
        LaplacianEigenTransformer(laplacian="graph", eigen_index=3).fit_transform([path(3)])
    single = make_graph(1, np.empty((0, 2)))
    with pytest.raises(ValueError, match="sample 0: the cleaned graph has too few nodes"):
        LaplacianEigenTransformer(laplacian="graph", signature="hks").fit_transform([single])
    (field,) = LaplacianEigenTransformer(
        laplacian="graph", signature="hks", times=[1.0]
    ).fit_transform([single])  # fixed times need no positive eigenvalue
    np.testing.assert_allclose(field.values, [[1.0]])
