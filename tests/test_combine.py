"""CombinedDistance: the contract of a weighted sum of normalized distance matrices."""

import itertools
import pickle

import joblib
import numpy as np
import pytest
from sklearn.base import clone
from sklearn.manifold import TSNE
from sklearn.model_selection import GridSearchCV
from sklearn.neighbors import KNeighborsClassifier
from sklearn.pipeline import make_pipeline

from sklearn_meshph import (
    CombinedDistance,
    DiagramDistance,
    FeatureDistance,
    LaplacianEigenTransformer,
    LowerStarPersistence,
    ShapeDNA,
    make_shapes,
)


@pytest.fixture(scope="module")
def fields_and_labels():
    meshes, y = make_shapes(n_per_class=4, random_state=2, return_X_y=True)
    eigen = LaplacianEigenTransformer(signature="hks", n_eigenpairs=24, n_scales=3)
    return eigen.fit_transform(meshes), y


def parts():
    return [
        ("diagrams", make_pipeline(LowerStarPersistence(), DiagramDistance())),
        ("dna", make_pipeline(ShapeDNA(n_eigenpairs=21), FeatureDistance())),
    ]


def off_diagonal_median(matrix):
    return np.median(matrix[~np.eye(len(matrix), dtype=bool)])


def test_the_weighted_sum_of_median_normalized_parts(fields_and_labels):
    fields, _ = fields_and_labels
    train, test = fields[::2], fields[1::2]
    combined = CombinedDistance(parts(), weights={"dna": 0.25})
    matrix = combined.fit_transform(train)
    a = make_pipeline(LowerStarPersistence(), DiagramDistance()).fit(train)
    b = make_pipeline(ShapeDNA(n_eigenpairs=21), FeatureDistance()).fit(train)
    da, db = a.transform(train), b.transform(train)
    expected = da / off_diagonal_median(da) + 0.25 * db / off_diagonal_median(db)
    np.testing.assert_allclose(matrix, expected, rtol=1e-12)
    np.testing.assert_allclose(matrix, matrix.T)
    rectangle = combined.transform(test)
    expected = a.transform(test) / off_diagonal_median(da) + 0.25 * b.transform(
        test
    ) / off_diagonal_median(db)
    np.testing.assert_allclose(rectangle, expected, rtol=1e-12)
    raw = CombinedDistance(parts(), normalization="none").fit_transform(train)
    np.testing.assert_allclose(raw, da + db, rtol=1e-12)


def test_composes_with_grid_search_and_tsne(fields_and_labels, tmp_path):
    fields, y = fields_and_labels
    pipe = make_pipeline(
        CombinedDistance(parts()), KNeighborsClassifier(n_neighbors=1, metric="precomputed")
    )
    grid = GridSearchCV(
        pipe,
        {
            "combineddistance__weights": [{"dna": 0.0}, {"diagrams": 0.0}, None],
            "combineddistance__diagrams__diagramdistance__metric": ["bottleneck", "wasserstein"],
        },
        cv=2,
    ).fit(fields, y)
    assert grid.best_score_ > 0.5
    matrix = CombinedDistance(parts()).fit_transform(fields)
    embedding = TSNE(metric="precomputed", init="random", perplexity=5, random_state=0)
    assert embedding.fit_transform(matrix).shape == (len(fields), 2)


def test_parameters_clone_and_pickle(fields_and_labels):
    fields, _ = fields_and_labels
    combined = CombinedDistance(parts(), weights={"dna": 2.0})
    params = combined.get_params()
    assert params["dna__shapedna__n_eigenpairs"] == 21
    copy = clone(combined).set_params(dna__shapedna__n_eigenpairs=11, weights=None)
    assert copy.get_params()["dna__shapedna__n_eigenpairs"] == 11
    assert combined.get_params()["dna__shapedna__n_eigenpairs"] == 21
    fitted = combined.fit(fields[:8])
    restored = pickle.loads(pickle.dumps(fitted))
    np.testing.assert_array_equal(restored.transform(fields[8:]), fitted.transform(fields[8:]))
    assert joblib.hash(clone(combined).get_params(deep=False)) == joblib.hash(
        combined.get_params(deep=False)
    )


def test_bad_settings_are_refused(fields_and_labels):
    fields, _ = fields_and_labels
    with pytest.raises(ValueError, match="unknown parts"):
        CombinedDistance(parts(), weights={"spectrum": 1.0}).fit(fields)
    with pytest.raises(ValueError, match="distinct names"):
        CombinedDistance(parts() + parts()).fit(fields)
    with pytest.raises(ValueError, match="normalization"):
        CombinedDistance(parts(), normalization="max").fit(fields)


def test_a_part_that_separates_nothing_adds_nothing(fields_and_labels):
    """Essential H1 of genus-0 shapes: every distance is 0; the part must not fail."""
    fields, _ = fields_and_labels
    h1 = make_pipeline(
        LowerStarPersistence(filtration="extended", parts=("essential H1",)), DiagramDistance()
    )
    dna = make_pipeline(ShapeDNA(n_eigenpairs=21), FeatureDistance())
    combined = CombinedDistance([("h1", h1), ("dna", dna)]).fit(fields[:8])
    assert combined.scales_["h1"] == 1.0
    alone = CombinedDistance([("dna", dna)]).fit(fields[:8])
    np.testing.assert_allclose(combined.transform(fields[8:]), alone.transform(fields[8:]))


def vector_parts():
    return [("canberra", FeatureDistance()), ("cityblock", FeatureDistance(metric="cityblock"))]


@pytest.mark.parametrize(
    ("weights", "message"),
    [
        ({"canberra": -1.0}, "weights"),
        ({"canberra": np.inf}, "weights"),
        ({"canberra": np.nan}, "weights"),
        ([1.0, -0.5], "weights"),
        ("canberra", "weights"),
        ({"spectrum": 1.0}, r"unknown parts \['spectrum'\]"),
        ([1.0, 2.0, 3.0], "3 numbers for 2 parts"),
    ],
)
def test_weights_are_finite_non_negative_and_name_parts(weights, message):
    X = np.random.default_rng(0).random((6, 3))
    with pytest.raises(ValueError, match=message):
        CombinedDistance(vector_parts(), weights=weights).fit(X)


def test_weights_by_name_or_one_per_part():
    X = np.random.default_rng(1).random((6, 3))
    by_name = CombinedDistance(vector_parts(), weights={"cityblock": 2.0}).fit_transform(X)
    by_order = CombinedDistance(vector_parts(), weights=[1.0, 2.0]).fit_transform(X)
    np.testing.assert_array_equal(by_name, by_order)
    zero = CombinedDistance(vector_parts(), weights=[0.0, 1.0]).fit_transform(X)
    alone = CombinedDistance(vector_parts()[1:]).fit_transform(X)
    np.testing.assert_allclose(zero, alone, rtol=1e-12)


class _FarApart(FeatureDistance):
    """Euclidean distances, infinite between samples on either side of 0.5 in the first
    feature (as diagrams with different numbers of essential points)."""

    def _far(self, D, X, Y):
        side = lambda Z: np.asarray(Z)[:, 0] > 0.5  # noqa: E731
        return np.where(side(X)[:, None] != side(Y)[None, :], np.inf, D)

    def fit_transform(self, X, y=None):
        self._fitted = np.asarray(X)
        return self._far(super().fit_transform(X), X, X)

    def transform(self, X):
        return self._far(super().transform(X), X, self._fitted)


def test_a_part_of_weight_zero_is_left_out_even_where_infinite():
    X = np.random.default_rng(3).random((8, 3))
    parts = [
        ("far", _FarApart(metric="euclidean")),
        ("cityblock", FeatureDistance(metric="cityblock")),
    ]
    assert np.isinf(parts[0][1].fit_transform(X)).any()
    zero = CombinedDistance(parts, weights={"far": 0.0})
    alone = CombinedDistance(parts[1:])
    np.testing.assert_array_equal(zero.fit_transform(X), alone.fit_transform(X))
    np.testing.assert_array_equal(zero.transform(X[:3]), alone.transform(X[:3]))
    # All 0: every distance 0 and a classifier's choice among ties, refused (as
    # ShapeNeighbors does) before any part is fitted.
    for off in ([0.0, 0.0], {"far": 0, "cityblock": 0.0}):
        with pytest.raises(ValueError, match="weights are all 0"):
            CombinedDistance(parts, weights=off).fit_transform(X)


def test_transform_reads_the_fitted_parts_and_weights():
    X = np.random.default_rng(2).random((8, 3))
    combined = CombinedDistance(vector_parts(), weights={"cityblock": 2.0}).fit(X[:6])
    reference = combined.transform(X[6:])
    combined.set_params(weights={"cityblock": 0.0}, cityblock__metric="euclidean")
    combined.transformer_list[0][1].set_params(metric="cosine")
    np.testing.assert_array_equal(combined.transform(X[6:]), reference)
    assert combined.weights_ == {"canberra": 1.0, "cityblock": 2.0}
    assert combined.parts_[1][1].metric == "cityblock"
    assert not np.array_equal(combined.fit(X[:6]).transform(X[6:]), reference)


@pytest.mark.parametrize("order", list(itertools.permutations(range(4))))
def test_nested_set_params_does_not_depend_on_keyword_order(order):
    """A new transformer_list, a part replaced by name, nested and own parameters: the
    same result in every order of the keywords."""
    new_parts = [
        ("ord1", make_pipeline(FeatureDistance(metric="cityblock"))),
        ("dna", FeatureDistance()),
    ]
    items = [
        ("weights", {"ord1": 2.0}),
        ("ord1__featuredistance__metric", "chebyshev"),
        ("transformer_list", new_parts),
        ("dna", FeatureDistance(metric="braycurtis")),
    ]
    combined = CombinedDistance(vector_parts())
    combined.set_params(**dict(items[k] for k in order))
    params = combined.get_params()
    assert [name for name, _ in combined.transformer_list] == ["ord1", "dna"]
    assert params["ord1__featuredistance__metric"] == "chebyshev"
    assert params["dna__metric"] == "braycurtis"
    assert params["weights"] == {"ord1": 2.0}
    with pytest.raises(ValueError, match="Invalid parameter 'nothing'"):
        combined.set_params(ord1__nothing=1)


def test_feature_names_and_pandas_output_of_vector_distances():
    X = np.random.default_rng(3).random((5, 3))
    for estimator, prefix in [
        (FeatureDistance(), "featuredistance"),
        (CombinedDistance(vector_parts()), "combineddistance"),
    ]:
        frame = estimator.set_output(transform="pandas").fit_transform(X)
        assert list(frame.columns) == [f"{prefix}{i}" for i in range(5)]
        assert list(estimator.get_feature_names_out()) == list(frame.columns)
        assert list(estimator.transform(X[:2]).columns) == list(frame.columns)


def test_weights_that_overflow_are_refused():
    from sklearn_meshph import CombinedDistance, DiagramDistance

    diagrams = [np.array([[0.0, 1.0]]), np.array([[0.0, 2.0], [1.0, 1.5]]), np.array([[0.2, 3.0]])]
    parts = [("a", DiagramDistance()), ("b", DiagramDistance(metric="sliced-wasserstein"))]
    with pytest.raises(ValueError, match="weighted sum of the parts' distances overflows"):
        CombinedDistance(parts, weights=(1e308, 1e308)).fit_transform(diagrams)


def test_parts_of_the_wrong_shape_or_with_nan_and_undefined_feature_distances_are_refused():
    """A (3, 1) part was broadcast over the others silently, a (3, 2) one raised numpy's
    broadcasting error; NaN went through; FeatureDistance gave NaN for a constant row
    under the correlation distance, or for features near 1e308."""
    from scipy.spatial.distance import cdist
    from sklearn.preprocessing import FunctionTransformer

    X = np.array([[0.0], [1.0], [3.0]])
    good = FunctionTransformer(lambda A: cdist(A, X, "cityblock"))
    for bad, message in [
        (lambda A: A, r"part 'b' gave distances of shape \(3, 1\); expected \(3, 3\)"),
        (lambda A: cdist(A, X) * np.nan, "sample 0: part 'b' gave it a NaN distance"),
    ]:
        combined = CombinedDistance([("a", good), ("b", FunctionTransformer(bad))])
        with pytest.raises(ValueError, match=message):
            combined.fit_transform(X)
    fitted = CombinedDistance([("a", good), ("b", FunctionTransformer(lambda A: cdist(A, X)))])
    fitted.fit(X)
    short = FunctionTransformer(lambda A: cdist(A, X[:2]))
    fitted.parts_[1] = ("b", short)
    with pytest.raises(ValueError, match=r"shape \(2, 2\); expected \(2, 3\)"):
        fitted.transform(X[:2])
    with pytest.raises(ValueError, match="sample 0: its correlation distance .* is NaN"):
        FeatureDistance("correlation").fit_transform([[1.0, 1.0], [1.0, 2.0]])
    with pytest.raises(ValueError, match="sample 0: its canberra distance to fitted sample 1"):
        FeatureDistance().fit_transform([[1e308], [-1e308]])


def test_a_part_of_weight_0_is_neither_fitted_nor_computed():
    """A weight-0 part that would refuse its input (a NaN distance) made the whole
    combination fail; an index refused a weight-0 part it cannot index."""
    from sklearn.preprocessing import FunctionTransformer

    from sklearn_meshph import ShapeNeighbors

    F = np.array([[1.0, 1.0, 1.0], [1.0, 2.0, 3.0], [3.0, 1.0, 2.0], [2.0, 2.0, 1.0]])
    parts = [("a", FeatureDistance()), ("b", FeatureDistance(metric="correlation"))]
    combined = CombinedDistance(parts, weights={"b": 0})
    np.testing.assert_array_equal(
        combined.fit_transform(F), CombinedDistance(parts[:1]).fit_transform(F)
    )
    assert combined.scales_["b"] == 1.0 and not hasattr(combined.parts_[1][1], "features_")
    np.testing.assert_array_equal(combined.transform(F[:2]), combined.fit_transform(F)[:2])
    with pytest.raises(ValueError, match="correlation distance .* is NaN"):
        CombinedDistance(parts).fit_transform(F)
    other = CombinedDistance(
        [("a", FeatureDistance()), ("c", FunctionTransformer(lambda X: X))], weights=[1, 0]
    )
    index = ShapeNeighbors(other, n_neighbors=2).fit(list(F))
    assert index.kneighbors(list(F[:1]))[1].shape == (1, 2)
    with pytest.raises(ValueError, match="weights are all 0 "):
        CombinedDistance(parts, weights=[0, 0]).fit_transform(F)
    with pytest.raises(ValueError, match="weights are all 0"):
        ShapeNeighbors(CombinedDistance(parts, weights=[0, 0]), n_neighbors=2).fit(list(F))
    # The fitted features are counted by the first part of positive weight.
    import pandas as pd

    frame = pd.DataFrame(F, columns=["x", "y", "z"])
    fitted = CombinedDistance(parts[::-1], weights=[0, 1]).fit(frame)
    assert fitted.n_features_in_ == 3 and list(fitted.feature_names_in_) == ["x", "y", "z"]


@pytest.mark.parametrize("scale", [1e-200, 1e200, 1e300])
@pytest.mark.parametrize("metric", ["euclidean", "sqeuclidean", "cosine"])
def test_feature_distances_hold_at_any_scale_float64_holds(metric, scale):
    """Cosine distances of rows near 1e200 or 1e-200 were 1 from themselves (their norms
    overflowed or vanished); Euclidean ones were refused as overflowing."""
    from scipy.spatial.distance import cdist

    F = np.random.default_rng(0).random((6, 3))
    if metric == "sqeuclidean" and scale > 1:
        scale = 1e150  # its values are the squares: they must fit float64 themselves
    expected = cdist(F, F, metric) * (scale**2 if metric == "sqeuclidean" else 1)
    expected *= scale if metric == "euclidean" else 1
    got = FeatureDistance(metric).fit_transform(F * scale)
    np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-15 * expected.max())


def test_feature_distances_of_rows_near_the_largest_float():
    """Rows at 1e308: the power of two above them, 2**1024, was inf, the rows divided
    by it 0 and the distances NaN; cosine distances all 1. Equal rows of squares past
    float64 gave NaN (0 times inf), not 0."""
    rows = [[1e308, 0.0], [0.0, 0.0], [5e307, 1.0]]
    euclidean = FeatureDistance("euclidean").fit_transform(rows)
    np.testing.assert_allclose(euclidean[0], [0.0, 1e308, 5e307])
    cosine = FeatureDistance("cosine").fit_transform([[1e308, 0.0], [0.0, 1.0], [5e307, 1.0]])
    np.testing.assert_allclose(cosine, [[0, 1, 0], [1, 0, 1], [0, 1, 0]], atol=1e-12)
    with pytest.raises(ValueError, match="sqeuclidean distance to fitted sample 2 is beyond"):
        FeatureDistance("sqeuclidean").fit_transform([[1e160], [1e160], [0.0]])
    with pytest.raises(ValueError, match="euclidean distance to fitted sample 1 is beyond"):
        FeatureDistance("euclidean").fit_transform([[1.7e308, 0.0], [-1.7e308, 0.0]])


def test_a_feature_metric_that_cannot_be_computed_is_refused_at_fit():
    # An unknown name, or one that needs arguments, failed only at transform.
    X = np.random.default_rng(0).random((5, 3))
    for metric, message in (("nope", "metric 'nope' cannot be computed"), ("seuclidean", "'V'")):
        with pytest.raises(ValueError, match=message):
            FeatureDistance(metric=metric).fit(X)
    assert FeatureDistance(metric="chebyshev").fit(X).transform(X).shape == (5, 5)
