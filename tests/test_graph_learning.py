"""The graph classifier, its features and the graph preset."""

import pickle
import re

import numpy as np
import pytest
from conftest import data_folder
from sklearn.base import clone
from sklearn.model_selection import GridSearchCV, KFold, cross_val_score

from sklearn_meshph import (
    GraphFeatures,
    LaplacianEigenTransformer,
    ScalarField,
    load_tu_dataset,
    make_graph_classifier,
    make_mesh_distance,
)


def cycle(n):
    return n, np.array([[i, (i + 1) % n] for i in range(n)])


def star(n):
    return n, np.array([[0, i] for i in range(1, n)])


def complete(n):
    return n, np.array([[i, j] for i in range(n) for j in range(i + 1, n)])


def two_paths(n):
    """Two paths of n nodes, not joined: a graph of two components."""
    edges = [[i, i + 1] for i in range(n - 1)] + [[n + i, n + i + 1] for i in range(n - 1)]
    return 2 * n, np.array(edges)


@pytest.fixture(scope="module")
def graphs():
    """Cycles, stars and complete graphs of 5 to 10 nodes, one class each."""
    sizes = range(5, 11)
    samples = [f(n) for f in (cycle, star, complete) for n in sizes]
    return samples, np.repeat([0, 1, 2], len(sizes))


def eigen():
    return LaplacianEigenTransformer(
        laplacian="normalized",
        normalization="none",
        components="all",
        signature="hks",
        times=(0.1, 10.0),
    )


def test_classifier_separates_cycles_stars_complete_graphs(graphs):
    X, y = graphs
    model = make_graph_classifier(n_estimators=20).fit(X, y)
    assert model.score(X, y) == 1.0
    assert model.predict([cycle(13), star(13), complete(12)]).tolist() == [0, 1, 2]


def test_classifier_clone_pickle_params(graphs):
    X, y = graphs
    model = make_graph_classifier(classifier="trees", n_estimators=10, random_state=3)
    params = model.get_params()
    assert params["classifier__n_estimators"] == 10
    assert params["eigen__laplacian"] == "normalized"
    assert params["eigen__times"] == (0.1, 1.0, 10.0)  # PersLay's two and t = 1
    assert params["features__diagrams__persistence__filtration"] == "extended"
    assert params["features__graph__wl_iterations"] == 3  # the degrees' patterns
    assert clone(model).get_params()["classifier__random_state"] == 3
    model.fit(X, y)
    again = pickle.loads(pickle.dumps(model))
    np.testing.assert_array_equal(again.predict_proba(X), model.predict_proba(X))


def test_classifier_grid_search_over_a_step_parameter(graphs):
    X, y = graphs
    search = GridSearchCV(
        make_graph_classifier(classifier="trees", n_estimators=10),
        {"features__graph__n_bins": [5, 10]},
        cv=KFold(3, shuffle=True, random_state=0),
    ).fit(X, y)
    assert search.best_params_["features__graph__n_bins"] in (5, 10)
    assert search.best_estimator_.named_steps["features"].get_params()["graph__n_bins"] in (5, 10)


def test_classifier_same_for_any_n_jobs(graphs):
    X, y = graphs
    for kind, method in (("trees", "predict_proba"), ("auto", "decision_function")):
        one, two = (
            getattr(make_graph_classifier(classifier=kind, n_jobs=n).fit(X, y), method)(X)
            for n in (1, 2)
        )
        np.testing.assert_array_equal(one, two)


def test_classifier_refuses_bad_parameters():
    with pytest.raises(ValueError, match="n_estimators"):
        make_graph_classifier(n_estimators=0)
    with pytest.raises(ValueError, match="memory"):
        make_graph_classifier(memory="")


def test_graph_features_of_known_graphs():
    fields = eigen().fit_transform([cycle(6), complete(4), two_paths(3)])
    features = GraphFeatures().fit(fields)
    names = list(features.get_feature_names_out())
    X = features.transform(fields)
    assert X.shape == (3, features.n_features_out_) == (3, len(names))
    row = dict(zip(names, X[0], strict=True))
    assert (row["n_nodes"], row["n_edges"], row["n_components"], row["n_cycles"]) == (6, 6, 1, 1)
    assert row["n_triangles"] == 0 and row["hops_3"] == pytest.approx(3 / 15)
    k4 = dict(zip(names, X[1], strict=True))
    assert (k4["n_triangles"], k4["transitivity"], k4["hops_1"]) == (4, 1.0, 1.0)
    # K4's normalized Laplacian: 0 once, 4/3 three times
    assert k4["zero_eigenvalues"] == 1 and k4["eigenvalue_max"] == pytest.approx(4 / 3)
    paths = dict(zip(names, X[2], strict=True))
    assert paths["n_components"] == 2 and paths["zero_eigenvalues"] == 2
    # 15 pairs, 9 across the two paths
    assert paths["unreachable_pairs"] == pytest.approx(9 / 15)
    harmonic = [paths[f"harmonic_{k}"] for k in range(30)]
    assert sum(harmonic) == pytest.approx(6 / 15)


def test_graph_features_without_pairs_and_the_signature_quantiles():
    fields = eigen().fit_transform([cycle(7), star(7)])
    X = GraphFeatures(pairs=False).fit_transform(fields)
    names = list(GraphFeatures(pairs=False).fit(fields).get_feature_names_out())
    assert not any(name.startswith("hops") for name in names)
    row = dict(zip(names, X[0], strict=True))
    values = fields[0].values[:, 1]
    assert row["signature1_q0.5"] == pytest.approx(np.median(values))
    assert row["signature1_q1"] == pytest.approx(values.max())


def test_graph_features_refuse_non_graph_fields_naming_the_sample():
    fields = eigen().fit_transform([cycle(5)])
    tetra = ScalarField(
        np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]),
        np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]),
        np.arange(4.0),
    )
    with pytest.raises(TypeError, match="sample 1: GraphFeatures reads the graph fields"):
        GraphFeatures().fit([fields[0], tetra])
    with pytest.raises(TypeError, match="sample 0: .*got ndarray"):
        GraphFeatures().fit([np.zeros((3, 2))])
    other = LaplacianEigenTransformer(
        laplacian="normalized", normalization="none", signature="hks", times=(1.0,)
    ).fit_transform([cycle(5)])
    with pytest.raises(ValueError, match="sample 0: 1 signature columns, the fitted fields have 2"):
        GraphFeatures().fit(fields).transform(other)


def test_graph_preset_gives_a_distance_matrix(graphs):
    X, _ = graphs
    pipe = make_mesh_distance("graph")
    matrix = pipe.fit_transform(X)
    assert matrix.shape == (len(X), len(X))
    restored = pickle.loads(pickle.dumps(pipe))
    np.testing.assert_array_equal(restored.transform(X[:3]), pipe.transform(X[:3]))
    np.testing.assert_array_equal(clone(pipe).fit_transform(X), matrix)
    np.testing.assert_allclose(matrix, matrix.T, atol=1e-9)
    np.testing.assert_allclose(np.diag(matrix), 0.0, atol=1e-9)
    assert (matrix[np.triu_indices(len(X), 1)] > 0).mean() > 0.9


def test_mutag_accuracy_floor():
    """A quick CV on MUTAG (structure only) reaches a sane accuracy."""
    graphs, y = load_tu_dataset(data_folder("tu/MUTAG", "TU MUTAG"))
    model = make_graph_classifier(classifier="trees", n_estimators=100)
    features = model[:-1].fit_transform(graphs)
    scores = cross_val_score(model[-1], features, y, cv=KFold(5, shuffle=True, random_state=0))
    assert scores.mean() > 0.8


def path_field(n):
    """A path of n nodes as a graph field (its spectrum and signatures zero: the pair
    histograms read the edges)."""
    return ScalarField(
        np.zeros((n, 0)),
        np.zeros((0, 3), dtype=np.int64),
        np.zeros((n, 2)),
        spectrum=np.zeros(n),
        edges=np.c_[np.arange(n - 1), np.arange(1, n)],
    )


def test_graph_features_refuse_only_what_would_not_fit():
    field = path_field(12001)  # the eigen stage's limit of every eigenpair too
    assert field.is_graph
    message = "sample 0: 12001 nodes, more than the 12000 .*pairs=False"
    with pytest.raises(ValueError, match=message):
        GraphFeatures().fit([field])
    assert GraphFeatures(pairs=False).fit_transform([field]).shape[0] == 1
    with pytest.raises(ValueError, match="sample 0: 4001 nodes, .*n_resistance_bins=0"):
        GraphFeatures(pairs=False, n_resistance_bins=10).fit([path_field(4001)])


def test_pair_histograms_of_large_graphs_from_a_fixed_sample_of_nodes(monkeypatch):
    """Above the limit the histograms count the pairs of a fixed sample of nodes, with
    the whole graph's distances: close to the exact histograms, the same every time."""
    from sklearn_meshph.vectorization import graph_features

    field = path_field(600)
    names = list(GraphFeatures().fit([field]).get_feature_names_out())
    exact = GraphFeatures().fit_transform([field])[0]
    monkeypatch.setattr(graph_features, "_MAX_PAIR_NODES", 300)
    sampled = GraphFeatures().fit_transform([field])[0]
    np.testing.assert_array_equal(GraphFeatures().fit_transform([field])[0], sampled)

    def bins(prefix):
        return [i for i, name in enumerate(names) if re.fullmatch(prefix + r"_\d+", name)]

    hops, harmonic = bins("hops"), bins("harmonic")
    assert len(hops) > 10 and len(harmonic) > 10
    assert not np.array_equal(sampled[hops], exact[hops])  # a sample was taken
    # 300 of the 600 nodes: each bin's share within 0.02 of the exact one.
    np.testing.assert_allclose(sampled[hops + harmonic], exact[hops + harmonic], atol=0.02)
    # The distances are the whole path's, not those of the sample joined as a path of
    # 300 nodes (at most 299 hops).
    assert sampled[names.index("hops_max")] > 550
    mean = names.index("hops_mean")
    assert sampled[mean] == pytest.approx(exact[mean], rel=0.02)


def spider(leg):
    """A path 0-1-2-3-4 with node 5 hung on node ``leg``: degrees 1, 1, 1, 2, 2, 3 for
    ``leg`` 1 or 2, but a different neighbourhood of the node of degree 3."""
    return 6, np.array([[0, 1], [1, 2], [2, 3], [3, 4], [leg, 5]])


def pattern_counts(fields, **params):
    features = GraphFeatures(pairs=False, **params).fit(fields)
    names = list(features.get_feature_names_out())
    X = features.transform(fields)
    iterations = features.wl_iterations + 1
    columns = [
        [names.index(f"wl{i}_{k}") for k in range(features.wl_buckets)] for i in range(iterations)
    ]
    return [[row[c] for c in columns] for row in X]


def test_graph_features_weisfeiler_lehman_patterns_of_known_graphs():
    fields = eigen().fit_transform([star(5), cycle(6), spider(1), spider(2)])
    # buckets enough for these few patterns not to share one
    star5, cycle6, spider1, spider2 = pattern_counts(fields, wl_iterations=2, wl_buckets=1000)
    # iteration 0: the degree histogram (a centre of degree 4, four leaves)
    np.testing.assert_array_equal(star5[0], np.r_[0, 4, 0, 0, 1, np.zeros(995)])
    # one pattern per kind of node at every iteration: centre and leaves, all of a cycle
    for counts in star5[1:]:
        assert sorted(counts[counts > 0]) == [1, 4]
    for counts in cycle6[1:]:
        assert sorted(counts[counts > 0]) == [6]
    # the same degrees, told apart by the neighbourhood of the node of degree 3
    np.testing.assert_array_equal(spider1[0], spider2[0])
    assert not np.array_equal(spider1[1], spider2[1])
    # spider(2) at iteration 1: leaves 0 and 4 (next to a degree 2), leaf 5 (next to the
    # degree 3), nodes 1 and 3 (degree 2 between a leaf and the degree 3), node 2
    assert sorted(spider2[1][spider2[1] > 0]) == [1, 1, 2, 2]
    # degrees from wl_buckets - 1 up share the last bin
    np.testing.assert_array_equal(
        pattern_counts(fields[:1], wl_iterations=1, wl_buckets=3)[0][0], [0, 4, 1]
    )


def test_graph_features_patterns_ignore_the_order_of_the_nodes():
    order = np.array([3, 5, 0, 4, 1, 2])
    n, edges = spider(2)
    relabelled = (n, np.sort(order[edges], axis=1))
    a, b = pattern_counts(eigen().fit_transform([spider(2), relabelled]), wl_iterations=3)
    for before, after in zip(a, b, strict=True):
        np.testing.assert_array_equal(before, after)


def test_graph_features_without_patterns():
    fields = eigen().fit_transform([cycle(5)])
    features = GraphFeatures().fit(fields)  # the default: no patterns
    assert not any(name.startswith("wl") for name in features.get_feature_names_out())
    assert features.transform(fields).shape == (1, features.n_features_out_)
    with pytest.raises(ValueError, match="wl_buckets"):
        GraphFeatures(wl_buckets=1).fit(fields)


@pytest.mark.parametrize(
    ("params", "name"),
    [
        ({"wl_buckets": 2**31, "wl_iterations": 1}, "wl_buckets"),
        ({"wl_iterations": 10**9}, "wl_iterations"),
        ({"n_bins": 2**40}, "n_bins"),
        ({"max_hops": 10**12}, "max_hops"),
        ({"n_pair_bins": 2**33}, "n_pair_bins"),
    ],
)
def test_graph_features_refuse_bin_counts_that_would_exhaust_memory(params, name):
    fields = eigen().fit_transform([cycle(5)])
    with pytest.raises(ValueError, match=f"'{name}' parameter of GraphFeatures"):
        GraphFeatures(**params).fit(fields)


def resistance_row(fields, **params):
    features = GraphFeatures(pairs=False, **params).fit(fields)
    names = list(features.get_feature_names_out())
    columns = [names.index(f"resistance_{k}") for k in range(features.n_resistance_bins)]
    return features.transform(fields)[:, columns]


def test_graph_features_resistances_of_known_graphs():
    fields = eigen().fit_transform([cycle(6), two_paths(3), complete(5)])
    # bins [0, 0.7), [0.7, 1.4), [1.4, 2.1]: no resistance below near an edge
    rows = resistance_row(fields, n_resistance_bins=3, max_resistance=2.1)
    # a hexagon: 5/6 between neighbours (6 pairs), 4/3 two apart (6), 3/2 across (3)
    np.testing.assert_allclose(rows[0], [0.0, 12 / 15, 3 / 15])
    # two paths of 3 nodes: 1, 1 and 2 in each; the 9 pairs across are in no bin
    np.testing.assert_allclose(rows[1], [0.0, 4 / 15, 2 / 15])
    # K5: 2/5 between any two nodes
    np.testing.assert_allclose(rows[2], [1.0, 0.0, 0.0])
    # larger resistances share the last bin
    clipped = resistance_row(fields, n_resistance_bins=2, max_resistance=1.0)
    np.testing.assert_allclose(clipped[1], [0.0, 6 / 15])
    assert (
        GraphFeatures().fit(fields).n_features_out_
        == GraphFeatures(n_resistance_bins=0).fit(fields).n_features_out_
    )


@pytest.mark.parametrize("seed", range(5))
def test_graph_features_resistances_agree_with_networkx(seed):
    """The histogram of networkx's resistance distances per component (the oracle),
    on random graphs of one to three components, some with isolated nodes."""
    nx = pytest.importorskip("networkx")
    rng = np.random.default_rng(seed)
    n = int(rng.integers(8, 30))
    graph = nx.gnm_random_graph(n, int(rng.integers(n // 2, 2 * n)), seed=seed)
    edges = np.array(graph.edges(), dtype=np.int64).reshape(-1, 2)
    fields = eigen().fit_transform([(n, edges)])
    expected = []
    for nodes in nx.connected_components(graph):
        component = graph.subgraph(nodes)
        for i in nodes:
            expected += [nx.resistance_distance(component, i, j) for j in nodes if j > i]
    # both rounded to 9 decimals: resistances on a bin's edge (integers on trees) land
    # in the bin above
    expected = np.minimum(np.round(expected, 9), 6.0)
    histogram = np.histogram(expected, np.linspace(0.0, 6.0, 25))[0] / (n * (n - 1) / 2)
    row = resistance_row(fields, n_resistance_bins=24, max_resistance=6.0)[0]
    np.testing.assert_allclose(row, histogram, atol=1e-12)


def test_graph_features_resistances_ignore_the_order_of_the_nodes():
    order = np.array([3, 5, 0, 4, 1, 2])
    n, edges = spider(2)
    fields = eigen().fit_transform([spider(2), (n, np.sort(order[edges], axis=1))])
    rows = resistance_row(fields, n_resistance_bins=50)
    np.testing.assert_allclose(rows[0], rows[1])


@pytest.mark.parametrize(
    "params",
    [
        {"n_resistance_bins": 2**33},
        {"n_resistance_bins": -1},
        {"max_resistance": np.inf},
        {"max_resistance": np.nan},
        {"max_resistance": 1e-300},
        {"max_resistance": 0.0},
    ],
)
def test_graph_features_refuse_bad_resistance_bins(params):
    fields = eigen().fit_transform([cycle(5)])
    name = next(iter(params))
    with pytest.raises(ValueError, match=f"'{name}' parameter of GraphFeatures"):
        GraphFeatures(**{"n_resistance_bins": 5, **params}).fit(fields)


def petersen():
    outer = [[i, (i + 1) % 5] for i in range(5)]
    spokes = [[i, i + 5] for i in range(5)]
    inner = [[5 + i, 5 + (i + 2) % 5] for i in range(5)]
    return 10, np.array(outer + spokes + inner)


def cube():
    return 8, np.array([[i, i ^ bit] for i in range(8) for bit in (1, 2, 4) if i < i ^ bit])


def symmetric_graphs():
    """Graphs whose nodes' signatures are equal up to rounding (vertex-transitive or
    nearly), where the order of the nodes decides the rounding; and a ring with two
    opposite arms (a molecule's shape)."""
    ring_with_arms = (8, np.array([[i, (i + 1) % 6] for i in range(6)] + [[0, 6], [3, 7]]))
    return [cycle(6), cycle(9), star(7), complete(5), petersen(), cube(), ring_with_arms]


@pytest.mark.parametrize("seed", range(3))
def test_graph_classifier_ignores_the_order_of_the_nodes(seed):
    """The same graph with its nodes renumbered gets the same features and the same
    stack of distances (the signatures of symmetric nodes differ by rounding, which
    once decided which diagram points of length ~1e-16 existed, and on which side of
    a spectrum bin's edge an eigenvalue such as 1.5 fell)."""
    rng = np.random.default_rng(seed)
    samples = symmetric_graphs()
    renumbered = []
    for n, edges in samples:
        order = rng.permutation(n)
        renumbered.append((n, order[edges]))
    y = np.arange(len(samples)) % 2
    trees = make_graph_classifier(classifier="trees", n_estimators=5, n_jobs=1)
    features = trees[:-1].fit(samples, y)
    np.testing.assert_allclose(
        features.transform(renumbered), features.transform(samples), rtol=1e-9, atol=1e-9
    )
    kernels = make_graph_classifier(classifier="kernels", n_jobs=1)
    fields, distances = kernels[0], kernels[1]
    distances.fit(fields.fit_transform(samples))
    np.testing.assert_allclose(
        distances.transform(fields.transform(renumbered)),
        distances.transform(fields.transform(samples)),
        rtol=1e-9,
        atol=1e-9,
    )


def test_eigen_stage_refuses_a_graph_too_large_for_every_eigenpair_before_building_it():
    """Every eigenpair is a dense solve: a graph beyond its limit is refused from its
    node count (an edgeless graph of 10**8 nodes once allocated gigabytes first, then
    failed in a MemoryError naming no sample)."""
    import tracemalloc

    tracemalloc.start()
    try:
        with pytest.raises(ValueError, match="sample 1: 100000000 nodes; every eigenpair"):
            eigen().fit_transform([cycle(5), (10**8, np.zeros((0, 2), dtype=int))])
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 50e6
