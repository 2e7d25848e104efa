"""LeafSizeForest, the graph classifier's trees: the leaf size chosen out of bag."""

import pickle
import warnings

import numpy as np
import pytest
from sklearn.base import clone
from sklearn.ensemble import ExtraTreesClassifier

from sklearn_meshph import make_graph_classifier
from sklearn_meshph.leaf_forest import LeafSizeForest


def noisy(n=300, flip=0.3, seed=0):
    """One informative feature among four, a third of the labels flipped."""
    rng = np.random.default_rng(seed)
    X = rng.normal(size=(n, 4))
    y = (X[:, 0] > 0).astype(int)
    flipped = rng.random(n) < flip
    return X, np.where(flipped, 1 - y, y)


def duplicates(seed=0):
    """Forty distinct rows with random classes, each repeated five times: only leaves
    of one sample tell them apart."""
    rng = np.random.default_rng(seed)
    rows = rng.normal(size=(40, 4))
    classes = rng.integers(0, 2, 40)
    return np.repeat(rows, 5, axis=0), np.repeat(classes, 5)


def out_of_bag(X, y, leaf, n_estimators=100):
    forest = ExtraTreesClassifier(
        n_estimators, min_samples_leaf=leaf, bootstrap=True, oob_score=True, random_state=0
    )
    return forest.fit(X, y)


@pytest.mark.parametrize(("data", "leaf"), [(noisy, 5), (duplicates, 1)])
def test_the_leaf_size_the_out_of_bag_votes_prefer(data, leaf):
    X, y = data()
    forest = LeafSizeForest(n_estimators=100, min_samples_leaf=(1, 5), random_state=0).fit(X, y)
    scores = [out_of_bag(X, y, size).oob_score_ for size in (1, 5)]
    np.testing.assert_allclose(forest.oob_scores_, scores)
    assert forest.min_samples_leaf_ == leaf
    # The forest kept is grown again at that leaf size on every sample, no bootstrap.
    whole = ExtraTreesClassifier(100, min_samples_leaf=leaf, random_state=0).fit(X, y)
    np.testing.assert_array_equal(forest.predict_proba(X), whole.predict_proba(X))
    np.testing.assert_array_equal(forest.feature_importances_, whole.feature_importances_)
    kept = LeafSizeForest(n_estimators=100, bootstrap=True, random_state=0).fit(X, y)
    np.testing.assert_array_equal(kept.predict_proba(X), out_of_bag(X, y, leaf).predict_proba(X))


def test_graph_classifier_chooses_its_leaf_size_per_fit_when_given_candidates():
    """make_graph_classifier(min_samples_leaf=(1, 5)) picks leaves of 1 or 5 graphs inside
    each fit; an int, the default 1, is the plain forest."""
    cycles = [(n, np.array([[i, (i + 1) % n] for i in range(n)])) for n in range(5, 25)]
    plain = make_graph_classifier(classifier="trees", n_estimators=5)
    assert isinstance(plain.named_steps["classifier"], ExtraTreesClassifier)
    assert plain.get_params()["classifier__min_samples_leaf"] == 1
    model = make_graph_classifier(classifier="trees", n_estimators=30, min_samples_leaf=(1, 5))
    model.fit(cycles, np.arange(20) % 2)
    trees = model.named_steps["classifier"]
    assert model.get_params()["classifier__min_samples_leaf"] == (1, 5)
    assert trees.min_samples_leaf_ == (1, 5)[int(np.argmax(trees.oob_scores_))]
    assert all(tree.min_samples_leaf == trees.min_samples_leaf_ for tree in trees.forest_)
    assert not trees.forest_.bootstrap  # the kept forest sees every training graph


def test_graph_classifier_refuses_a_bad_leaf_size():
    with pytest.raises(ValueError, match="min_samples_leaf"):
        make_graph_classifier(min_samples_leaf=0)


def test_few_trees_warn_nothing_and_score_the_voted_samples():
    X, y = noisy(n=40)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        forest = LeafSizeForest(n_estimators=2, random_state=0).fit(X, y)
    assert np.all((forest.oob_scores_ >= 0) & (forest.oob_scores_ <= 1))


def test_clone_pickle_and_the_same_result_for_any_n_jobs():
    X, y = noisy()
    forest = LeafSizeForest(n_estimators=20, random_state=np.random.RandomState(3))
    assert clone(forest).get_params()["min_samples_leaf"] == (1, 5)
    one = LeafSizeForest(n_estimators=20, n_jobs=1, random_state=0).fit(X, y)
    two = LeafSizeForest(n_estimators=20, n_jobs=2, random_state=0).fit(X, y)
    np.testing.assert_allclose(one.predict_proba(X), two.predict_proba(X), rtol=1e-12)
    np.testing.assert_array_equal(one.oob_scores_, two.oob_scores_)
    again = pickle.loads(pickle.dumps(one))
    np.testing.assert_array_equal(again.predict(X), one.predict(X))
    forest.fit(X, y)  # a RandomState seed: the same bootstrap draws for each candidate
    assert forest.predict(X).shape == y.shape


@pytest.mark.parametrize(
    ("params", "name"),
    [
        ({"min_samples_leaf": ()}, "min_samples_leaf"),
        ({"min_samples_leaf": (0, 5)}, "min_samples_leaf"),
        ({"min_samples_leaf": (2, 2)}, "min_samples_leaf"),
        ({"min_samples_leaf": 5}, "min_samples_leaf"),
        ({"min_samples_leaf": (1, True)}, "min_samples_leaf"),
        ({"n_estimators": 0}, "n_estimators"),
        ({"max_features": "all"}, "max_features"),
        ({"bootstrap": "yes"}, "bootstrap"),
    ],
)
def test_refuses_bad_parameters_by_name(params, name):
    X, y = noisy(n=20)
    with pytest.raises(ValueError, match=f"'{name}' parameter of LeafSizeForest"):
        LeafSizeForest(**params).fit(X, y)


def test_refuses_features_other_than_the_fitted_ones():
    X, y = noisy(n=40)
    forest = LeafSizeForest(n_estimators=5, random_state=0).fit(X, y)
    with pytest.raises(ValueError, match="features"):
        forest.predict(X[:, :3])


@pytest.mark.parametrize("state", [None, np.random.RandomState(3), 7])
def test_every_candidate_draws_alike_and_an_unfitted_forest_says_so(state, monkeypatch):
    """With ``random_state=None`` each candidate forest drew its own bootstrap samples,
    against the documentation; ``predict`` before ``fit`` was an AttributeError."""
    from sklearn.exceptions import NotFittedError

    X, y = noisy()
    with pytest.raises(NotFittedError):
        LeafSizeForest().predict(X)
    seeds = []
    grow = LeafSizeForest._forest

    def recording(self, leaf, seed, *, bootstrap):
        seeds.append(seed)
        return grow(self, leaf, seed, bootstrap=bootstrap)

    monkeypatch.setattr(LeafSizeForest, "_forest", recording)
    LeafSizeForest(n_estimators=5, min_samples_leaf=(1, 5), random_state=state).fit(X, y)
    assert len(seeds) == 3 and len(set(seeds)) == 1 and isinstance(seeds[0], int)  # + the kept
