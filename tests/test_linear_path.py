"""The linear-cost path: make_mesh_features (the default's diagrams and spectrum as
fixed-length features), the "features" preset, and DistanceScaler."""

import pickle

import numpy as np
import pytest
import sklearn
from sklearn.base import clone
from sklearn.linear_model import LogisticRegression
from sklearn.metrics import pairwise_distances
from sklearn.neighbors import NearestNeighbors
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler

from sklearn_meshph import DistanceScaler, make_mesh_distance, make_mesh_features, make_shapes

N_FEATURES = 3 * 5 * 5 * 20 + 47  # kinds x times x landscapes x grid points, eigenvalues


@pytest.fixture(scope="module")
def fitted():
    """Meshes of six classes, their labels, and the features fitted on the first 12."""
    meshes, y = make_shapes(n_per_class=3, random_state=3, return_X_y=True)
    pipe = make_mesh_features(random_state=0)
    return meshes, y, pipe, pipe.fit_transform(meshes[:12])


def test_the_features_are_fixed_length_finite_and_deterministic(fitted):
    meshes, _, pipe, X = fitted
    assert X.shape == (12, N_FEATURES)
    assert np.isfinite(X).all()
    new = pipe.transform(meshes[12:])  # other meshes, other diagram sizes: same length
    assert new.shape == (len(meshes) - 12, N_FEATURES) and np.isfinite(new).all()
    np.testing.assert_array_equal(make_mesh_features(random_state=0).fit_transform(meshes[:12]), X)


def test_the_features_clone_and_pickle(fitted):
    meshes, _, pipe, X = fitted
    np.testing.assert_array_equal(clone(pipe).fit_transform(meshes[:12]), X)
    restored = pickle.loads(pickle.dumps(pipe))
    np.testing.assert_array_equal(restored.transform(meshes[12:]), pipe.transform(meshes[12:]))


def test_the_features_are_named_and_go_out_as_a_data_frame(fitted):
    """The eigen and persistence stages pass no column names on (their output is one
    object per sample); the union names each vectorizer's columns after its part."""
    meshes, _, pipe, X = fitted
    names = pipe.get_feature_names_out()
    assert names.shape == (N_FEATURES,) and len(set(names)) == N_FEATURES
    assert names[0] == "ord1__d0_landscape1_0" and names[-1] == "dna__eigenvalue_47"
    frame = clone(pipe).set_output(transform="pandas").fit_transform(meshes[:12])
    assert list(frame.columns) == list(names)
    np.testing.assert_array_equal(frame.to_numpy(), X)
    assert pipe[0].get_feature_names_out().shape == (0,)
    with sklearn.config_context(transform_output="pandas"):  # never wraps fields
        fields = pipe[0].transform(meshes[:2])
    assert isinstance(fields, list) and len(fields) == 2  # not a DataFrame


def test_the_parts_weigh_as_the_default_weighs_its_distances(fitted):
    """Each part has a root-mean-square distance of its weight among the fitted meshes:
    squared distances add the parts with the default's weights."""
    _, _, pipe, X = fitted
    union = pipe.named_steps["features"]
    weights = union.transformer_weights
    assert {name: w**2 for name, w in weights.items()} == pytest.approx(
        {"ord1": 1.0, "ext0": 0.5, "ext1": 1.0, "dna": 0.5}, rel=1e-12
    )
    start = 0
    for name, part in union.transformer_list:
        width = part[-1].n_features_in_
        block = X[:, start : start + width]
        start += width
        rms = np.sqrt(np.mean(pairwise_distances(block) ** 2))  # pairs drawn independently
        moved = part[-1].scales_ != 1  # an all-equal part (no handles) stays at 0
        assert rms == pytest.approx(weights[name] * np.sqrt(moved.mean()), rel=1e-9)
    assert start == X.shape[1]


def test_the_features_preset_is_their_euclidean_distance(fitted):
    meshes, _, pipe, X = fitted
    preset = make_mesh_distance("features", random_state=0)
    np.testing.assert_allclose(preset.fit_transform(meshes[:12]), pairwise_distances(X))
    np.testing.assert_allclose(
        preset.transform(meshes[12:]), pairwise_distances(pipe.transform(meshes[12:]), X)
    )


def test_a_linear_model_and_a_neighbour_index_take_the_features(fitted):
    meshes, y, _, _ = fitted
    train, test = np.flatnonzero(np.arange(len(y)) % 3), np.flatnonzero(np.arange(len(y)) % 3 == 0)
    model = make_pipeline(
        make_mesh_features(random_state=0), StandardScaler(), LogisticRegression(max_iter=2000)
    )
    model.fit([meshes[i] for i in train], y[train])
    assert model.score([meshes[i] for i in test], y[test]) >= 0.8
    features = model[:1]  # the fitted features, for a (here exact) nearest-neighbour index
    index = NearestNeighbors(n_neighbors=1).fit(features.transform(meshes))
    assert (index.kneighbors(return_distance=False)[:, 0] != np.arange(len(y))).all()


def test_the_scaler_gives_each_block_a_unit_rms_distance():
    rng = np.random.default_rng(0)
    X = np.hstack([rng.normal(size=(50, 3)), 1e6 * rng.normal(size=(50, 3)), np.ones((50, 3))])
    scaler = DistanceScaler(n_blocks=3).fit(X)
    scaled = scaler.transform(X)
    for block in range(2):
        part = scaled[:, 3 * block : 3 * block + 3]
        mean_square = np.mean(pairwise_distances(part) ** 2)  # rows drawn independently
        assert mean_square == pytest.approx(1 / 3)
    assert scaler.scales_[2] == 1.0  # all equal: divided by 1
    np.testing.assert_array_equal(scaled[:, 6:], 1 / np.sqrt(3))


@pytest.mark.parametrize("scale", [1e-200, 1e-100, 1e150, 1e200, 1e300])
def test_the_scaler_holds_at_any_scale_float64_holds(scale):
    """The variance of features near 1e200 overflowed (a scale of inf: every row 0),
    that of features near 1e-200 underflowed (a scale of 1: no scaling at all)."""
    rng = np.random.default_rng(1)
    X = rng.normal(size=(30, 4))
    expected = DistanceScaler(n_blocks=2).fit_transform(X)
    got = DistanceScaler(n_blocks=2).fit_transform(X * scale)
    np.testing.assert_allclose(got, expected, rtol=1e-12)


def test_the_scaler_refuses_uneven_blocks_and_names_a_bad_sample():
    X = np.ones((4, 5))
    with pytest.raises(ValueError, match="n_blocks=2 does not divide the 5 features"):
        DistanceScaler(n_blocks=2).fit(X)
    X[2, 1] = np.nan
    with pytest.raises(ValueError, match="sample 2: its features hold NaN or infinite"):
        DistanceScaler().fit(X)
    fitted = DistanceScaler().fit(np.ones((4, 5)))
    X[2, 1] = np.inf
    with pytest.raises(ValueError, match="sample 2: its features hold NaN or infinite"):
        fitted.transform(X)
    tiny = DistanceScaler().fit([[0.0], [1e-10]])
    with pytest.raises(ValueError, match="sample 1: its features divided by the fitted"):
        tiny.transform([[1.0], [1e300]])


def test_a_constant_block_is_divided_by_1_whatever_the_rounding_of_its_mean():
    """Constant 0.1: the variance came out 4e-34 from rounding, the scale 2.8e-17, and
    the scaled rows 3.6e15."""
    X = np.hstack([np.full((5, 2), 0.1), np.arange(10.0).reshape(5, 2)])
    scaler = DistanceScaler(n_blocks=2).fit(X)
    assert scaler.scales_[0] == 1.0
    np.testing.assert_array_equal(scaler.transform(X)[:, :2], 0.1 / np.sqrt(2))
