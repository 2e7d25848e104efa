"""The kernel classifier of graphs: GraphPairDistances, KernelSumSVC and
make_graph_classifier(classifier="kernels")."""

import pickle
import warnings

import numpy as np
import pytest
from conftest import data_folder
from sklearn.base import clone
from sklearn.model_selection import GridSearchCV, KFold, cross_val_score
from test_graph_learning import cycle, eigen, star

from sklearn_meshph import load_tu_dataset, make_graph_classifier
from sklearn_meshph.vectorization import GraphPairDistances, KernelSumSVC, graph_svc


def path(n):
    return n, np.array([[i, i + 1] for i in range(n - 1)])


def fields(graphs):
    return eigen().fit_transform(graphs)


@pytest.fixture(scope="module")
def graphs():
    sizes = range(5, 13)
    samples = [f(n) for f in (cycle, path, star) for n in sizes]
    return samples, np.repeat([0, 1, 2], len(sizes))


@pytest.mark.parametrize("features", ["standardized", "canberra"])
def test_pair_distances_of_a_fold_from_the_stack_of_all(graphs, features):
    X = fields(graphs[0])
    full = GraphPairDistances(features=features)
    stack = full.fit_transform(X)
    # 4 kinds x 2 times, patterns, nodes, features
    assert stack.shape == (len(X), len(X), 4 * 2 + 3)
    np.testing.assert_allclose(stack, stack.transpose(1, 0, 2), atol=1e-12)
    np.testing.assert_allclose(stack[np.arange(len(X)), np.arange(len(X))], 0.0, atol=1e-12)
    train = np.random.default_rng(0).permutation(len(X))[:10]
    test = np.setdiff1d(np.arange(len(X)), train)
    part = GraphPairDistances(features=features)
    fitted_stack = part.fit_transform([X[i] for i in train])
    assert part.n_positions_ == 11 and part.n_features_in_ == 10
    np.testing.assert_allclose(full.fold_stack(stack, train, train), fitted_stack, atol=1e-10)
    tested = part.transform([X[i] for i in test])
    np.testing.assert_allclose(full.fold_stack(stack, test, train), tested, atol=1e-10)
    # The diagrams, patterns and nodes depend on the pair alone; the Canberra distance too,
    # the standardized features on the fitted graphs' statistics.
    np.testing.assert_allclose(tested[:, :, :-1], stack[np.ix_(test, train)][:, :, :-1])
    same = np.allclose(tested[:, :, -1], stack[np.ix_(test, train)][:, :, -1])
    assert same == (features == "canberra")


def _exact_discrepancy(left, right, sigma):
    """Squared maximum mean discrepancy of two sets of points under the Gaussian kernel,
    by brute force over every pair."""
    from scipy.spatial.distance import cdist

    def mean_kernel(a, b):
        return np.exp(-cdist(a, b, "sqeuclidean") / (2 * sigma**2)).mean()

    return mean_kernel(left, left) + mean_kernel(right, right) - 2 * mean_kernel(left, right)


def test_node_discrepancy_against_brute_force(graphs):
    """The nodes' position estimates the exact squared maximum mean discrepancy of the
    graphs' signatures (brute force over every pair of nodes), better with more random
    features; it is a function of the pair alone, blind to the nodes' order, and the
    same for the same seed."""
    X = fields(graphs[0])
    sigma = 0.05
    values = [field.values.reshape(field.n_vertices, -1) for field in X]
    exact = np.array([[_exact_discrepancy(a, b, sigma) for b in values] for a in values])
    assert exact.max() > 0.1  # the graphs differ: a test that can fail
    errors = []
    for n_features in (64, 100_000):
        stack = GraphPairDistances(node_bandwidth=sigma, n_random_features=n_features)
        errors.append(np.abs(stack.fit_transform(X)[:, :, -2] - exact).max())
    assert errors[1] < 0.02 < errors[0]
    base = GraphPairDistances(node_bandwidth=sigma)
    stack = base.fit_transform(X)[:, :, -2]
    again = clone(base).fit_transform(X)[:, :, -2]
    np.testing.assert_array_equal(stack, again)
    other = clone(base).set_params(random_state=1).fit_transform(X)[:, :, -2]
    assert not np.array_equal(stack, other)
    assert max(np.abs(stack - exact).max(), np.abs(other - exact).max()) < 0.15
    # Relabelled nodes: the same graph, the same distances to the fitted ones.
    n, edges = graphs[0][3]
    order = np.random.default_rng(2).permutation(n)
    relabelled = fields([(n, order[edges])])
    np.testing.assert_allclose(base.transform(relabelled)[0, :, -2], stack[3], atol=1e-10)


@pytest.mark.parametrize(
    "params",
    [
        {"node_bandwidth": 0.0},
        {"node_bandwidth": 1e-300},
        {"node_bandwidth": np.inf},
        {"node_bandwidth": np.nan},
        {"n_random_features": 0},
        {"random_state": "seed"},
        {"n_directions": 10_001},  # above the cap (10**9 once ran into the OOM killer)
        {"min_persistence": -1.0},
        {"min_persistence": np.nan},
    ],
)
def test_node_discrepancy_parameters_refused(graphs, params):
    X = fields(graphs[0][:4])
    with pytest.raises(ValueError, match="GraphPairDistances"):
        GraphPairDistances(**params).fit(X)


def test_standardized_feature_distance_against_scikit_learn_scaler():
    from sklearn.preprocessing import StandardScaler

    rng = np.random.default_rng(1)
    fitted = rng.lognormal(3.0, 2.0, (30, 6)) * rng.choice([-1, 1], (30, 6))
    fitted[:, 2] = 7.0  # constant on the fitted samples: left out
    queries = rng.lognormal(3.0, 2.0, (5, 6))
    distances = GraphPairDistances()
    distances._standardize(fitted)
    got = distances._feature_distances(queries, fitted)
    logs = np.sign(fitted) * np.log1p(np.abs(fitted))
    scaler = StandardScaler().fit(np.delete(logs, 2, axis=1))
    left = scaler.transform(np.delete(np.log1p(queries), 2, axis=1))
    right = scaler.transform(np.delete(logs, 2, axis=1))
    expected = ((left[:, None, :] - right[None, :, :]) ** 2).sum(axis=2)
    np.testing.assert_allclose(got, expected, rtol=1e-10)
    assert np.isinf(distances.features_scale_[2]) and np.isfinite(got).all()
    queries[3, 4] = np.nan
    with pytest.raises(ValueError, match="graph 3: feature 4 is nan"):
        distances._feature_distances(queries, fitted)
    with pytest.raises(ValueError, match="graph 3: feature 4 is nan"):
        GraphPairDistances()._standardize(queries)


def test_fold_stack_refuses_a_stack_of_other_samples(graphs):
    X = fields(graphs[0])
    distances = GraphPairDistances().fit(X)
    with pytest.raises(ValueError, match="stack has shape"):
        distances.fold_stack(np.zeros((3, 3, 10)), [0], [1, 2])
    stack = distances.fit_transform(X)
    with pytest.raises(ValueError, match="train: index -1 is not one of the 24"):
        distances.fold_stack(stack, [0], [1, -1])
    with pytest.raises(ValueError, match="rows: index 24 is not one of"):
        distances.fold_stack(stack, [24], [1])
    with pytest.raises(ValueError, match="rows must be a 1-d array"):
        distances.fold_stack(stack, [0.5], [1])
    with pytest.raises(ValueError, match="features"):
        GraphPairDistances(features="euclidean").fit(X)


def test_pattern_distance_of_relabelled_and_different_graphs():
    n, edges = cycle(7)
    order = np.random.default_rng(0).permutation(n)
    relabelled = (n, order[edges])
    stack = GraphPairDistances(wl_iterations=2).fit_transform(
        fields([cycle(7), relabelled, path(7), star(7)])
    )
    patterns = stack[:, :, -3]
    assert patterns[0, 1] == pytest.approx(0.0, abs=1e-12)  # the same graph
    assert patterns[0, 2] > 0 and patterns[0, 3] == pytest.approx(2.0)  # no degree shared
    assert 0 < patterns[0, 2] < 2  # a path's inner nodes look like a cycle's


def test_many_pattern_iterations_raise_no_overflow_warning():
    # The salt of levels 9 and up wraps modulo 2^64 (as meant): it raised a
    # RuntimeWarning, an error under -W error.
    graphs = fields([cycle(7), path(7), star(7)])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        deep = GraphPairDistances(wl_iterations=12).fit_transform(graphs)
    assert np.isfinite(deep).all() and deep[0, 1, -3] > 0


def separable_stack(n=40, seed=0):
    """Position 0 is noise, position 1 separates the two classes."""
    rng = np.random.default_rng(seed)
    y = np.repeat([0, 1], n // 2)
    noise = rng.random((n, 1))
    signal = y[:, None] + 0.1 * rng.random((n, 1))
    stack = np.dstack([np.abs(noise - noise.T), np.abs(signal - signal.T)])  # (n, n, 2) distances
    return stack, y


def test_kernel_sum_chooses_the_informative_kernel():
    stack, y = separable_stack()
    model = KernelSumSVC(C=(1.0, 10.0)).fit(stack, y)
    assert set(model.cv_scores_) == {(w, c) for w in [(0, 1), (1, 0), (1, 1)] for c in (1.0, 10.0)}
    assert model.weights_.tolist() == [0.0, 1.0]  # the noise adds nothing but errors
    assert model.score(stack, y) == 1.0
    assert model.n_features_in_ == len(y) and model.scales_.shape == (2,)
    grouped = KernelSumSVC(groups=[0, 0]).fit(stack, y)
    assert list(grouped.cv_scores_) == [((1,), 1.0), ((1,), 10.0), ((1,), 100.0)]


def test_kernel_sum_clone_pickle_params():
    stack, y = separable_stack()
    model = KernelSumSVC(groups=(0, 1), cv=3, random_state=4)
    assert clone(model).get_params()["random_state"] == 4
    assert model.set_params(cv=4).cv == 4
    model.fit(stack, y)
    again = pickle.loads(pickle.dumps(model))
    np.testing.assert_array_equal(again.decision_function(stack), model.decision_function(stack))


def test_kernel_sum_blocks_of_rows_give_the_same_model(monkeypatch):
    # The kernels are taken a block of rows at a time (memory); any block gives the
    # same bits, the last block a partial one included.
    stack, y = separable_stack(n=42)
    whole = KernelSumSVC(groups=(0, 1)).fit(stack, y)
    monkeypatch.setattr(graph_svc, "_KERNEL_BLOCK", 5 * stack.shape[1] * stack.shape[2])
    blocked = KernelSumSVC(groups=(0, 1)).fit(stack, y)
    assert blocked.cv_scores_ == whole.cv_scores_
    np.testing.assert_array_equal(blocked.decision_function(stack), whole.decision_function(stack))
    np.testing.assert_array_equal(blocked._kernels(stack), whole._kernels(stack))


def test_kernel_sum_chooses_on_a_subset_of_large_training_sets():
    stack, y = separable_stack(n=60)
    model = KernelSumSVC(max_selection_samples=20, cv=2).fit(stack, y)
    assert model.score(stack, y) == 1.0  # the SVM kept is fitted on all 60


@pytest.mark.parametrize(
    "change, message",
    [
        (lambda s: s.__setitem__((3, 1, 0), np.nan), "sample 3: distance nan"),
        (lambda s: s.__setitem__((5, 2, 1), -1.0), "sample 5: distance -1.0"),
    ],
)
def test_kernel_sum_refuses_bad_distances_naming_the_sample(change, message):
    stack, y = separable_stack()
    bad = stack.copy()
    change(bad)
    with pytest.raises(ValueError, match=message):
        KernelSumSVC().fit(bad, y)
    model = KernelSumSVC().fit(stack, y)
    with pytest.raises(ValueError, match=message):
        model.predict(bad)
    with pytest.raises(ValueError, match="expected 40"):
        model.predict(stack[:, :30])


def test_kernel_sum_refuses_bad_parameters():
    stack, y = separable_stack()
    with pytest.raises(ValueError, match="groups must give an int to each of the 2"):
        KernelSumSVC(groups=[0]).fit(stack, y)
    for bad in ((1.0, 0.0), (np.nan,), (np.inf,), (True,), np.array([]), np.ones((1, 1))):
        with pytest.raises(ValueError, match="KernelSumSVC|C must be a non-empty sequence"):
            KernelSumSVC(C=bad).fit(stack, y)
    # A 1-D array is a sequence, as the docs say (it was refused; then "truth value of an
    # array is ambiguous").
    model = KernelSumSVC(C=np.array([1.0, 10.0])).fit(stack, y)
    assert {c for _, c in model.cv_scores_} == {1.0, 10.0}
    with pytest.raises(ValueError, match="1 training sample: .* needs at least 2"):
        KernelSumSVC().fit(stack[:1, :1], y[:1])


def test_kernel_sum_refuses_more_groups_than_it_can_cross_validate():
    """Every non-empty sum of groups is a candidate: a 15-position stack with a group
    per position (the default groups=None) would be 32,767 sums, a fit of hours."""
    stack, y = separable_stack()
    wide = np.repeat(stack[:, :, :1], 15, axis=2)
    with pytest.raises(ValueError, match="15 groups of positions: their 32767 sums"):
        KernelSumSVC().fit(wide, y)
    model = KernelSumSVC(groups=[0] * 7 + [1] * 8).fit(wide, y)  # grouped: 3 sums
    assert model.n_groups_ == 2


def test_kernel_sum_on_fewer_samples_than_folds_leaves_one_out():
    stack, y = separable_stack()
    rows = [0, 1, 20, 21]  # two of each class
    few, labels = stack[np.ix_(rows, rows)], y[rows]
    assert len(np.unique(labels)) == 2
    model = KernelSumSVC().fit(few, labels)  # cv=5 > 4 samples: four folds of one
    same = KernelSumSVC(cv=4).fit(few, labels)
    assert model.cv_scores_ == same.cv_scores_
    np.testing.assert_array_equal(model.decision_function(few), same.decision_function(few))
    # A bandwidth whose square under- or overflows made NaN kernels or an OverflowError.
    for bandwidth in (1e-300, 1e300, np.inf):
        with pytest.raises(ValueError, match="'bandwidth' parameter of KernelSumSVC"):
            KernelSumSVC(bandwidth=bandwidth).fit(stack, y)
    assert KernelSumSVC(bandwidth=1e-100).fit(stack, y).score(stack, y) == 1.0
    # ... and so did a small bandwidth with small distances: 2 bandwidth^2 times their
    # median underflowed to 0, and 0 / -0.0 on the diagonal is NaN.
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # far pairs overflow to a kernel of 0, silently
        tiny = KernelSumSVC(bandwidth=1e-100).fit(stack * 1e-200, y)
        far = stack.copy()
        far[0, -1] = far[-1, 0] = 1e3 * stack.max()  # many medians away
        KernelSumSVC(bandwidth=1.5e-154).fit(far, y)
    kernels = tiny._kernels(stack * 1e-200)
    assert np.isfinite(kernels).all() and (np.diagonal(kernels, axis1=0, axis2=1) == 1).all()
    assert tiny.score(stack * 1e-200, y) == 1.0


def test_kernel_classifier_of_graphs(graphs):
    X, y = graphs
    model = make_graph_classifier(classifier="kernels", times=(0.1, 10.0))
    assert list(model.named_steps) == ["eigen", "distances", "classifier"]
    assert model.get_params()["classifier__groups"] == "graph"
    cv = KFold(4, shuffle=True, random_state=0)
    scores = cross_val_score(model, X, y, cv=cv)
    assert scores.mean() > 0.9
    # The stack of all the graphs, each fold's taken by fold_stack (a slice, the
    # features standardized on the fold's training graphs), gives the same predictions
    # as the pipeline per fold (what benchmarks/graph_classification.py does).
    stack = model[:-1].fit_transform(X)
    distances = model.named_steps["distances"]
    X_, y_ = np.arange(len(y)), np.asarray(y)
    sliced = [
        clone(model[-1])
        .fit(distances.fold_stack(stack, train, train), y_[train])
        .score(distances.fold_stack(stack, test, train), y_[test])
        for train, test in cv.split(X_)
    ]
    np.testing.assert_array_equal(sliced, scores)
    fitted = pickle.loads(pickle.dumps(clone(model).fit(X, y)))
    assert fitted.predict([cycle(14), path(14), star(14)]).tolist() == [0, 1, 2]


def test_kernel_classifier_refuses_an_unknown_classifier():
    with pytest.raises(ValueError, match="classifier"):
        make_graph_classifier(classifier="svm")


def test_mutag_kernel_accuracy_floor():
    graphs, y = load_tu_dataset(data_folder("tu/MUTAG", "TU MUTAG"))
    model = make_graph_classifier(classifier="kernels")
    stack = model[:-1].fit_transform(graphs)
    distances, y = model.named_steps["distances"], np.asarray(y)
    scores = [
        clone(model[-1])
        .fit(distances.fold_stack(stack, train, train), y[train])
        .score(distances.fold_stack(stack, test, train), y[test])
        for train, test in KFold(5, shuffle=True, random_state=0).split(stack)
    ]
    assert np.mean(scores) > 0.8


def test_graph_groups_follow_the_number_of_signatures(graphs):
    """groups="graph" is GraphPairDistances' layout at any number of times: the
    diagrams in one group, the patterns and the features one each; a grid search over
    the signatures' times works on the default (a fixed tuple of groups broke it)."""
    X, y = graphs
    stack = make_graph_classifier(classifier="kernels", times=(0.1, 10.0))[:-1].fit_transform(X)
    named = KernelSumSVC("graph").fit(stack, y)
    explicit = KernelSumSVC((0,) * 8 + (1, 2, 2)).fit(stack, y)
    assert named.cv_scores_ == explicit.cv_scores_
    np.testing.assert_array_equal(named.decision_function(stack), explicit.decision_function(stack))
    with pytest.raises(ValueError, match='groups="graph" needs at least 4 positions'):
        KernelSumSVC("graph").fit(stack[:, :, :3], y)
    with pytest.raises(ValueError, match="'groups' parameter of KernelSumSVC"):
        KernelSumSVC("graphs").fit(stack, y)
    search = GridSearchCV(
        make_graph_classifier(),
        {"eigen__times": [(0.1, 10.0), (0.1, 1.0, 10.0)]},
        cv=KFold(3, shuffle=True, random_state=0),
        error_score="raise",
    ).fit(X, y)
    assert search.best_params_["eigen__times"] in [(0.1, 10.0), (0.1, 1.0, 10.0)]
