"""ShapeNeighbors, ShapeNeighborsClassifier and retrieval_scores: the pruned answers are
the brute-force answers of the fitted pipeline, bit for bit, ties by lowest index."""

from __future__ import annotations

import os
import pickle

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from sklearn.base import clone
from sklearn.neighbors import KNeighborsClassifier
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import FunctionTransformer, StandardScaler

from sklearn_meshph import (
    CombinedDistance,
    DiagramDistance,
    FeatureDistance,
    ShapeNeighbors,
    ShapeNeighborsClassifier,
    make_mesh_distance,
    make_shapes,
    retrieval_scores,
)
from sklearn_meshph.retrieval.parts import N_TOP, IndexedPart


def _diagrams(X):
    return [sample["diagrams"] for sample in X]


def _features(X):
    return np.array([sample["features"] for sample in X])


def _combined(
    metric="wasserstein", order=1.0, internal_p=2.0, weights=(1.0, 0.5), normalization="median"
):
    """A CombinedDistance shaped like the default: a median-normalized diagram part and a
    Canberra feature part, on samples that carry both."""
    diagram = DiagramDistance(
        metric, order=order, internal_p=internal_p, normalization=normalization
    )
    return CombinedDistance(
        [
            ("dgm", Pipeline([("pick", FunctionTransformer(_diagrams)), ("d", diagram)])),
            ("dna", Pipeline([("pick", FunctionTransformer(_features)), ("d", FeatureDistance())])),
        ],
        weights=dict(zip(("dgm", "dna"), weights, strict=True)),
    )


def _diagram(rng, n_points, n_essential):
    births = rng.uniform(0, 1, n_points).round(1)  # coarse values: many equal distances
    deaths = births + rng.uniform(0, 1, n_points).round(1)
    essential = np.column_stack(
        [rng.uniform(0, 1, n_essential).round(1), np.full(n_essential, np.inf)]
    )
    return np.vstack([np.column_stack([births, deaths]), essential]).reshape(-1, 2)


def _collection(seed, n, n_points=6, essential=(1,), duplicates=True):
    """Samples of two diagrams and 3 features; some repeated (ties), some with another
    number of essential points (infinite distances)."""
    rng = np.random.default_rng(seed)
    samples = [
        {
            "diagrams": tuple(
                _diagram(rng, int(rng.integers(0, n_points + 1)), int(rng.choice(essential)))
                for _ in range(2)
            ),
            "features": rng.uniform(0.5, 2, 3).round(1),
        }
        for _ in range(n)
    ]
    if duplicates:
        samples[n // 2] = samples[0]
        samples[-1] = samples[1]
    return samples


def _brute_force(matrix, k, exclude_self=False):
    matrix = np.array(matrix, dtype=float)
    if exclude_self:
        np.fill_diagonal(matrix, np.nan)  # sorted last, then dropped
    order = np.argsort(matrix, axis=1, kind="stable")[:, :k]
    return np.take_along_axis(matrix, order, 1), order


METRICS = [
    {"metric": "wasserstein", "order": 1.0, "internal_p": 2.0},
    {"metric": "wasserstein", "order": 2.0, "internal_p": np.inf},
    {"metric": "bottleneck", "order": 2.0, "internal_p": np.inf},
    {"metric": "wasserstein", "order": 1.0, "internal_p": 1.0, "normalization": "none"},
    {"metric": "bottleneck", "order": 2.0, "internal_p": np.inf, "normalization": "none"},
    {"metric": "sliced-wasserstein", "order": 2.0, "internal_p": np.inf},
]


@settings(max_examples=12, deadline=None)
@given(
    seed=st.integers(0, 10_000),
    params=st.sampled_from(METRICS),
    k=st.integers(1, 6),
    essential=st.sampled_from([(1,), (0, 1), (0, 0, 0, 2)]),
)
def test_pruned_neighbours_are_the_brute_force_ones(seed, params, k, essential):
    train = _collection(seed, 24, essential=essential)
    queries = _collection(seed + 1, 5, essential=essential, duplicates=False) + train[:2]
    combined = _combined(**params)
    index = ShapeNeighbors(combined, n_neighbors=k, scale_samples=None).fit(train)
    brute = clone(combined).fit(train)
    distances, indices = index.kneighbors(queries)
    expected_distances, expected_indices = _brute_force(brute.transform(queries), k)
    np.testing.assert_array_equal(indices, expected_indices)
    np.testing.assert_array_equal(distances, expected_distances)
    # The fitted samples themselves, each without its own index (leave-one-out).
    distances, indices = index.kneighbors(n_neighbors=k)
    expected_distances, expected_indices = _brute_force(brute.fit_transform(train), k, True)
    np.testing.assert_array_equal(indices, expected_indices)
    np.testing.assert_array_equal(distances, expected_distances)


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 10_000), params=st.sampled_from(METRICS[:-1]))  # sliced: no bound
def test_lower_bounds_never_exceed_the_exact_distances(seed, params):
    # Many points per diagram: the bound's tail (beyond N_TOP) is exercised too.
    train = _collection(seed, 12, n_points=3 * N_TOP, essential=(0, 1))
    index = ShapeNeighbors(_combined(**params), scale_samples=None).fit(train)
    query = index._represent(train[:4])
    lower, exact = sum(index._lower(query)), index._exact(query, np.arange(12))
    assert np.all(lower <= exact * (1 + 1e-12))
    # The bounds are not trivial: the feature part is exact, the diagram part positive.
    assert np.mean(lower[np.isfinite(exact)] / exact[np.isfinite(exact)].clip(1e-300)) > 0.3


def test_queries_prune_most_exact_distances_in_a_clustered_collection():
    rng = np.random.default_rng(0)
    centres = _collection(1, 4, essential=(1,), duplicates=False)
    train = []
    for i in range(80):
        centre = centres[i % 4]
        jitter = [
            d + np.where(np.isfinite(d), rng.normal(0, 0.01, d.shape), 0)
            for d in centre["diagrams"]
        ]
        jitter = [np.column_stack([d[:, 0], np.maximum(d[:, 1], d[:, 0])]) for d in jitter]
        train.append(
            {"diagrams": tuple(jitter), "features": centre["features"] * rng.uniform(0.99, 1.01, 3)}
        )
    index = ShapeNeighbors(_combined(), n_neighbors=1, scale_samples=None).fit(train)
    fraction = index.exact_fraction()
    assert fraction.shape == (80,)
    assert fraction.mean() < 0.4  # every sample would be computed without the bounds


@pytest.mark.parametrize(
    ("preset", "seed", "rtol", "rows"),
    [
        (None, 0, 0.0, {"ord1", "ext0", "ext1", "dna"}),  # the default, bit for bit
        # The "features" preset ends in a pipeline (features, then their distance): the
        # index looks through it; Euclidean distances of a block round differently.
        ("features", 1, 1e-9, {"distance"}),
    ],
)
def test_a_preset_on_meshes_matches_its_brute_force(preset, seed, rtol, rows):
    meshes, _ = make_shapes(
        n_per_class=2,
        classes=("blob", "snake", "star"),
        resolution=(10, 14),
        random_state=seed,
        return_X_y=True,
    )
    distance = None if preset is None else make_mesh_distance(preset)
    index = ShapeNeighbors(distance, n_neighbors=2, scale_samples=None).fit(meshes[:5])
    brute = make_mesh_distance(preset or "default").fit(meshes[:5])
    distances, indices = index.kneighbors(meshes[5:])
    expected_distances, expected_indices = _brute_force(brute.transform(meshes[5:]), 2)
    np.testing.assert_array_equal(indices, expected_indices)
    np.testing.assert_allclose(distances, expected_distances, rtol=rtol, atol=0)
    assert set(index.rows_) == rows


def test_scales_are_learned_on_scale_samples_drawn_from_the_fitted_samples():
    train = _collection(3, 40)
    index = ShapeNeighbors(_combined(), scale_samples=10, random_state=1).fit(train)
    assert len(index.scale_indices_) == 10 and len(np.unique(index.scale_indices_)) == 10
    subset = clone(_combined()).fit([train[i] for i in index.scale_indices_])
    assert index.distance_.scales_ == subset.scales_
    assert index.n_samples_fit_ == 40 and len(index.rows_["dgm"]) == 40
    # The metric is the subset's: its distances to the subset's samples are the same,
    # and the neighbours among all 40 are those of its whole matrix (unpruned).
    matrix = index.distance_matrix(train[:3], dtype="float64")
    np.testing.assert_array_equal(matrix[:, index.scale_indices_], subset.transform(train[:3]))
    distances, indices = index.kneighbors(train[:3], n_neighbors=7)
    expected_distances, expected_indices = _brute_force(matrix, 7)
    np.testing.assert_array_equal(indices, expected_indices)
    np.testing.assert_array_equal(distances, expected_distances)


def test_distance_matrix_writes_the_brute_force_matrix_by_blocks(tmp_path):
    train = _collection(5, 23, essential=(0, 1))
    index = ShapeNeighbors(_combined(), scale_samples=None, block_size=4).fit(train)
    brute = clone(_combined())
    expected = brute.fit_transform(train)
    written = index.distance_matrix(path=tmp_path / "d.npy")
    assert written.dtype == np.float32
    np.testing.assert_array_equal(np.load(tmp_path / "d.npy"), expected.astype(np.float32))
    rows = index.distance_matrix(train[:6], dtype="float64")
    np.testing.assert_array_equal(rows, brute.transform(train[:6]))
    with pytest.raises(ValueError, match="dtype must be 'float32' or 'float64'"):
        index.distance_matrix(dtype="float16")
    # Found probing stop 52's surfaces: a FIFO at the path failed as "File or stream is
    # not seekable", naming nothing; /proc/version as an I/O error.
    os.mkfifo(tmp_path / "fifo.npy")
    for path in (tmp_path / "fifo.npy", tmp_path, "/dev/null"):
        with pytest.raises(ValueError, match="exists and is not a regular file"):
            index.distance_matrix(path=path)


def test_classifier_predicts_as_kneighbors_classifier_on_the_brute_force_matrix():
    train = _collection(7, 30)
    y = np.array(["a", "b", "c"])[np.arange(30) % 3]
    test = _collection(8, 10, duplicates=False)
    for k in (1, 3):
        model = ShapeNeighborsClassifier(_combined(), n_neighbors=k, scale_samples=None).fit(
            train, y
        )
        brute = clone(_combined()).fit(train)
        reference = KNeighborsClassifier(k, metric="precomputed").fit(brute.transform(train), y)
        expected = reference.predict(brute.transform(test))
        np.testing.assert_array_equal(model.predict(test), expected)
        assert model.score(test, expected) == 1.0
        np.testing.assert_allclose(model.predict_proba(test).sum(axis=1), 1.0)


def test_a_fitted_index_pickles_and_clones():
    train = _collection(9, 15)
    index = ShapeNeighbors(_combined(), n_neighbors=3).fit(train)
    again = pickle.loads(pickle.dumps(index))
    np.testing.assert_array_equal(again.kneighbors(train[:4])[1], index.kneighbors(train[:4])[1])
    fresh = clone(index)
    assert not hasattr(fresh, "rows_") and fresh.get_params()["n_neighbors"] == 3


def test_one_diagram_distance_is_a_metric_of_one_part():
    diagrams = [np.array([[0.0, t]]) for t in (1.0, 2.0, 2.0, 4.0)]
    index = ShapeNeighbors(DiagramDistance("wasserstein", order=1.0), n_neighbors=2).fit(diagrams)
    distances, indices = index.kneighbors([np.array([[0.0, 2.5]])])
    np.testing.assert_array_equal(indices, [[1, 2]])  # a tie: lowest index first
    np.testing.assert_array_equal(distances, [[0.5, 0.5]])


def test_bad_settings_and_inputs_are_refused_by_name():
    train = _collection(2, 6)
    with pytest.raises(TypeError, match="Pipeline ending in one .* got StandardScaler"):
        ShapeNeighbors(StandardScaler()).fit(train)
    other = CombinedDistance(
        [("x", Pipeline([("pick", FunctionTransformer(_features)), ("s", StandardScaler())]))]
    )
    with pytest.raises(TypeError, match="part 'x' ends in a StandardScaler"):
        ShapeNeighbors(other).fit(train)
    with pytest.raises(ValueError, match="n_neighbors"):
        ShapeNeighbors(_combined(), n_neighbors=0).fit(train)
    index = ShapeNeighbors(_combined()).fit(train)
    with pytest.raises(ValueError, match=r"n_neighbors must be an int in \[1, 5\]"):
        index.kneighbors(n_neighbors=6)
    with pytest.raises(ValueError, match="y must hold one label per sample of X"):
        ShapeNeighborsClassifier(_combined()).fit(train, [0, 1])
    broken = [{"diagrams": (np.array([[1.0, 0.0]]), np.empty((0, 2))), "features": [1, 1, 1]}]
    with pytest.raises(ValueError, match="samples 0 to 0 of X: .*death"):
        ShapeNeighbors(_combined(), block_size=1).fit(train).kneighbors(broken)


def test_retrieval_scores_of_hand_computed_rankings():
    # Sample 0 ranks 1 (its class), then 3, then 2; 1 ranks 0, 3, 2; 2 ranks 3, 0, 1;
    # 3 ranks 2, 1 (tie with 0 at 1.0: lowest index first is 0), then 1.
    D = np.array(
        [
            [0.0, 1.0, 3.0, 2.0],
            [1.0, 0.0, 4.0, 2.0],
            [3.0, 4.0, 0.0, 0.5],
            [1.0, 1.0, 0.5, 0.0],
        ]
    )
    scores = retrieval_scores(D, [0, 0, 1, 1])
    assert scores["nearest_neighbor"] == 1.0 and scores["first_tier"] == 1.0
    assert scores["dcg"] == 1.0 and scores["mean_average_precision"] == 1.0
    # Classes {0, 2} and {1, 3}: 0 finds 2 third, 1 finds 3 second, 2 finds 0 second,
    # 3 finds 1 third (0 comes before 1 in the tie).
    scores = retrieval_scores(D, [0, 1, 0, 1])
    assert scores["nearest_neighbor"] == 0.0
    assert scores["first_tier"] == 0.0 and scores["second_tier"] == 0.5
    dcg = np.mean([1 / np.log2(3), 1 / np.log2(2), 1 / np.log2(2), 1 / np.log2(3)])
    assert scores["dcg"] == pytest.approx(dcg)
    assert scores["mean_average_precision"] == pytest.approx(np.mean([1 / 3, 1 / 2, 1 / 2, 1 / 3]))


def test_retrieval_scores_with_larger_classes():
    # One query class of 3: sample 0 retrieves 3 (other), 1 (same), 4 (other), 2 (same).
    D = np.full((5, 5), 9.0)
    np.fill_diagonal(D, 0.0)
    D[0, [3, 1, 4, 2]] = [1.0, 2.0, 3.0, 4.0]
    y = [0, 0, 0, 1, 1]
    ranks_of_0 = retrieval_scores(D, y)
    # Query 0: R = 2; first tier 1/2, second tier (4 results) 2/2; AP (1/2 + 2/4) / 2;
    # DCG (1/log2(2) + 1/log2(4)) / (1 + 1/log2(2)).
    # The others rank by index (all at 9): 1 -> 0, 2, 3, 4; 2 -> 0, 1, 3, 4;
    # 3 -> 0, 1, 2, 4; 4 -> 0, 1, 2, 3.
    first = [1 / 2, 1.0, 1.0, 0.0, 0.0]
    second = [1.0, 1.0, 1.0, 0.0, 0.0]
    ap = [(1 / 2 + 2 / 4) / 2, 1.0, 1.0, 1 / 4, 1 / 4]
    dcg = [(1 + 1 / 2) / 2, 1.0, 1.0, 1 / np.log2(4), 1 / np.log2(4)]
    assert ranks_of_0["nearest_neighbor"] == pytest.approx(np.mean([0, 1, 1, 0, 0]))
    assert ranks_of_0["first_tier"] == pytest.approx(np.mean(first))
    assert ranks_of_0["second_tier"] == pytest.approx(np.mean(second))
    assert ranks_of_0["mean_average_precision"] == pytest.approx(np.mean(ap))
    assert ranks_of_0["dcg"] == pytest.approx(np.mean(dcg))


def test_retrieval_scores_refuse_what_they_cannot_score():
    with pytest.raises(ValueError, match="square distance matrix"):
        retrieval_scores(np.zeros((2, 3)), [0, 1])
    with pytest.raises(ValueError, match="one class per row of D"):
        retrieval_scores(np.zeros((2, 2)), [0])
    with pytest.raises(ValueError, match="class 1 has a single sample"):
        retrieval_scores(np.zeros((3, 3)), [0, 0, 1])
    D = np.zeros((2, 2))
    D[1, 0] = np.nan
    with pytest.raises(ValueError, match="sample 1: D holds NaN"):
        retrieval_scores(D, [0, 0])
    # Raw numpy errors before: an empty matrix, classes that do not sort, sparse or
    # ragged matrices.
    import scipy.sparse as sp

    with pytest.raises(ValueError, match="D has 0 samples: at least two"):
        retrieval_scores(np.zeros((0, 0)), [])
    with pytest.raises(ValueError, match="y must hold classes of one sortable kind"):
        retrieval_scores(np.zeros((4, 4)), [0, None, 0, None])
    with pytest.raises(ValueError, match="y must hold classes of one sortable kind"):
        retrieval_scores(np.zeros((4, 4)), np.array([1, "1", 2, 2], dtype=object))
    with pytest.raises(ValueError, match="y must hold classes of one sortable kind"):
        retrieval_scores(np.zeros((4, 4)), [1, "1", 1, "1"])  # a list: one class of strings
    with pytest.raises(TypeError, match="got a sparse one: pass D.toarray"):
        retrieval_scores(sp.csr_matrix(np.ones((2, 2))), [0, 0])
    with pytest.raises(ValueError, match="D must be a square matrix of numbers"):
        retrieval_scores([[0, 1], [1]], [0, 0])


def _part(name):
    def pick(X):
        return [sample[name] for sample in X]

    return Pipeline([("pick", FunctionTransformer(pick)), ("d", DiagramDistance())])


def test_cheap_parts_are_computed_first_and_prune_the_costly_one(monkeypatch):
    # "small": one point whose persistence is always 20 (its bound is 0) but whose place
    # differs; "big": many points, nearly the same for every sample. Once a neighbour
    # is known, the small part's exact distances rule most candidates out before their
    # big part is computed.
    rng = np.random.default_rng(0)
    big = _diagram(rng, 3 * N_TOP, 0)

    def sample(shift):
        moved = big + rng.normal(0, 1e-3, big.shape)
        moved[:, 1] = np.maximum(moved[:, 1], moved[:, 0])
        return {"small": (np.array([[shift, shift + 20.0]]),), "big": (moved,)}

    train = [sample(shift) for shift in rng.uniform(0, 10, 60)]
    queries = [sample(shift) for shift in (0.0, 5.0, 10.0)]
    metric = CombinedDistance([("small", _part("small")), ("big", _part("big"))])
    index = ShapeNeighbors(metric, n_neighbors=2, scale_samples=None).fit(train)
    names = {id(part): name for name, _, _, part in index._parts_}
    computed = {"small": 0, "big": 0}
    exact = IndexedPart.exact

    def counted(self, query, cols):
        computed[names[id(self)]] += len(cols)
        return exact(self, query, cols)

    monkeypatch.setattr(IndexedPart, "exact", counted)
    distances, indices = index.kneighbors(queries)
    monkeypatch.undo()
    expected_distances, expected_indices = _brute_force(
        clone(metric).fit(train).transform(queries), 2
    )
    np.testing.assert_array_equal(indices, expected_indices)
    np.testing.assert_array_equal(distances, expected_distances)
    assert computed["big"] < computed["small"] / 2
    # exact_fraction counts the candidates whose every part was computed.
    assert np.sum(index.exact_fraction(queries)) * len(train) == computed["big"]


def test_a_failed_refit_leaves_the_last_fit_whole():
    """The labels, or the scales and parts, were replaced before the failing step: the
    classifier then indexed the old rows with new labels (IndexError), the index read
    new parts beside old rows (AttributeError)."""
    X = [np.array([[0.0, t]]) for t in (1, 1.2, 4, 4.5)]
    query = [np.array([[0.0, 4.2]])]
    model = ShapeNeighborsClassifier(DiagramDistance()).fit(X, list("aabb"))
    bad = [np.array([[0.0, 1.0]]), np.array([[0.0, np.nan]])]
    with pytest.raises(ValueError):
        model.fit(bad, ["x", "y"])
    assert model.predict(query).tolist() == ["b"] and model.classes_.tolist() == ["a", "b"]
    index = ShapeNeighbors(DiagramDistance(), n_neighbors=2, scale_samples=2).fit(X)
    expected = index.kneighbors(query)
    more = [np.array([[0.0, t]]) for t in (1, 2, 3, 4, 5)] + [np.array([[0.0, np.nan]])]
    with pytest.raises(ValueError):
        index.fit(more)  # the scales are learned on 2 samples, the NaN is met later
    assert index.n_samples_fit_ == 4
    for got, want in zip(index.kneighbors(query), expected, strict=True):
        np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize("metric", ["euclidean", "sqeuclidean", "cosine", "canberra"])
def test_feature_distances_of_a_query_are_the_pipelines_to_the_bit(metric):
    """The index computed a query's Euclidean distances one row at a time, the pipeline
    all rows at once: scikit-learn's products of matrices gave a sample 1.7e-7 from
    itself in one and 0 in the other."""
    from sklearn.pipeline import make_pipeline

    from sklearn_meshph import DiagramStatistics

    rng = np.random.default_rng(0)
    X = [np.sort(rng.random((5, 2)), axis=1) for _ in range(12)]
    index = ShapeNeighbors(make_pipeline(DiagramStatistics(), FeatureDistance(metric)), 3)
    index.fit(X)
    for start in range(0, 12, 5):  # queries of 5, 5 and 2 rows
        distances, neighbours = index.kneighbors(X[start : start + 5])
        full = index.distance_.transform(X[start : start + 5])
        np.testing.assert_array_equal(np.take_along_axis(full, neighbours, 1), distances)
        one = index.distance_.transform(X[start : start + 1])
        np.testing.assert_array_equal(one[0], full[0])
