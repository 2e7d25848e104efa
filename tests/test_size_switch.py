"""SizeSwitchClassifier, and make_graph_classifier's default that it makes."""

import pickle

import numpy as np
import pytest
from sklearn.base import clone
from sklearn.linear_model import LogisticRegression
from sklearn.model_selection import KFold, cross_validate
from sklearn.neighbors import KNeighborsClassifier
from sklearn.svm import SVC
from sklearn.tree import DecisionTreeClassifier
from sklearn.utils.estimator_checks import parametrize_with_checks
from sklearn.utils.validation import NotFittedError

from sklearn_meshph import make_graph_classifier
from sklearn_meshph._param_validation import InvalidParameterError
from sklearn_meshph.size_switch import SizeSwitchClassifier


def switch(**params):
    return SizeSwitchClassifier(
        KNeighborsClassifier(3), DecisionTreeClassifier(random_state=0), **params
    )


@parametrize_with_checks(
    [
        switch(max_small_samples=30),
        SizeSwitchClassifier(KNeighborsClassifier(3), LogisticRegression(), max_small_samples=0),
    ]
)
def test_scikit_learn_checks(estimator, check):
    check(estimator)


def rows(n=40, seed=0):
    rng = np.random.default_rng(seed)
    X = rng.normal(size=(n, 3))
    return X, (X[:, 0] + 0.3 * rng.normal(size=n) > 0).astype(int)


def test_the_training_size_chooses_the_estimator():
    X, y = rows()
    at = switch(max_small_samples=40).fit(X, y)
    assert at.chosen_ == "small" and isinstance(at.estimator_, KNeighborsClassifier)
    above = switch(max_small_samples=39).fit(X, y)
    assert above.chosen_ == "large" and isinstance(above.estimator_, DecisionTreeClassifier)
    # Clones: the templates stay unfitted.
    with pytest.raises(NotFittedError):
        at.small.predict(X)
    np.testing.assert_array_equal(at.predict(X), KNeighborsClassifier(3).fit(X, y).predict(X))
    tree = DecisionTreeClassifier(random_state=0).fit(X, y)
    np.testing.assert_array_equal(above.predict_proba(X), tree.predict_proba(X))
    # Each fit of a cross-validation chooses on its own training samples.
    model = switch(max_small_samples=30)
    for train, _ in KFold(4).split(X):
        assert clone(model).fit(X[train], y[train]).chosen_ == "small"  # 30 samples
    assert model.fit(X, y).chosen_ == "large"


@pytest.mark.parametrize("batch_size", [1, 3, 7, 40, 1000])
def test_batches_change_no_prediction(batch_size):
    X, y = rows()
    Z = rows(23, seed=1)[0]
    whole = switch(max_small_samples=100).fit(X, y)
    batched = clone(whole).set_params(batch_size=batch_size).fit(X, y)
    np.testing.assert_array_equal(batched.predict(Z), whole.estimator_.predict(Z))
    np.testing.assert_array_equal(batched.predict_proba(Z), whole.estimator_.predict_proba(Z))
    svm = SizeSwitchClassifier(SVC(), SVC(), batch_size=batch_size).fit(X, y)
    np.testing.assert_array_equal(svm.decision_function(Z), SVC().fit(X, y).decision_function(Z))


def test_methods_follow_the_chosen_estimator():
    X, y = rows()
    model = SizeSwitchClassifier(SVC(), DecisionTreeClassifier(), max_small_samples=39)
    # Before fit a method is there when one of the candidates has it.
    assert hasattr(model, "predict_proba") and hasattr(model, "decision_function")
    assert not hasattr(switch(), "decision_function")  # neither k-NN nor the tree
    model.fit(X, y)  # 40 samples: the tree
    assert hasattr(model, "predict_proba") and not hasattr(model, "decision_function")
    model.set_params(max_small_samples=40).fit(X, y)  # the SVM, no probabilities
    assert hasattr(model, "decision_function") and not hasattr(model, "predict_proba")
    assert model.score(X, y) == SVC().fit(X, y).score(X, y)


def test_parameters_are_checked_at_fit():
    X, y = rows()
    with pytest.raises(InvalidParameterError, match="'small' parameter of SizeSwitchClassifier"):
        SizeSwitchClassifier().fit(X, y)
    with pytest.raises(InvalidParameterError, match="'large' parameter"):
        SizeSwitchClassifier(SVC(), "trees").fit(X, y)
    for name, value in (("max_small_samples", -1), ("batch_size", 0), ("batch_size", 2.5)):
        with pytest.raises(InvalidParameterError, match=name):
            switch(**{name: value}).fit(X, y)
    with pytest.raises(NotFittedError):
        switch().predict(X)


def test_clone_params_and_pickle():
    X, y = rows()
    model = switch(max_small_samples=10, batch_size=5)
    params = model.get_params()
    assert params["small__n_neighbors"] == 3 and params["max_small_samples"] == 10
    model.set_params(small__n_neighbors=5)
    assert clone(model).small.n_neighbors == 5
    model.fit(X, y)
    again = pickle.loads(pickle.dumps(model))
    np.testing.assert_array_equal(again.predict_proba(X), model.predict_proba(X))


def cycle(n):
    return n, np.array([[i, (i + 1) % n] for i in range(n)])


def path(n):
    return n, np.array([[i, i + 1] for i in range(n - 1)])


def star(n):
    return n, np.array([[0, i] for i in range(1, n)])


def test_graph_classifier_default_is_the_kernel_svm_on_small_and_trees_on_large_sets():
    graphs = [f(n) for f in (cycle, path, star) for n in range(5, 13)]
    y = np.repeat([0, 1, 2], 8)
    auto = make_graph_classifier(n_estimators=20)
    assert list(auto.named_steps) == ["eigen", "classifier"]
    assert auto.get_params()["classifier__max_small_samples"] == 2000
    fitted = clone(auto).fit(graphs, y)
    assert fitted[-1].chosen_ == "small"
    kernels = make_graph_classifier(classifier="kernels").fit(graphs, y)
    np.testing.assert_array_equal(
        fitted.decision_function(graphs), kernels.decision_function(graphs)
    )
    # Above the limit the trees, the same as classifier="trees" (same seed).
    large = clone(auto).set_params(classifier__max_small_samples=10).fit(graphs, y)
    assert large[-1].chosen_ == "large"
    trees = make_graph_classifier(classifier="trees", n_estimators=20).fit(graphs, y)
    np.testing.assert_array_equal(large.predict_proba(graphs), trees.predict_proba(graphs))
    # Batches of the test graphs give the same decisions as one block.
    batched = clone(auto).set_params(classifier__batch_size=5).fit(graphs, y)
    np.testing.assert_array_equal(
        batched.decision_function(graphs), fitted.decision_function(graphs)
    )
    # A cross-validation whose folds fall on both sides of the limit stays nested.
    mixed = clone(auto).set_params(classifier__max_small_samples=19)
    cv = KFold(5, shuffle=True, random_state=0)  # training sets of 19, 19, 19, 19, 20
    result = cross_validate(mixed, graphs, y, cv=cv, return_estimator=True)
    chosen = [model[-1].chosen_ for model in result["estimator"]]
    assert chosen == ["small"] * 4 + ["large"]
    assert result["test_score"].mean() > 0.8


def test_tags_follow_the_candidates():
    from sklearn.ensemble import HistGradientBoostingClassifier
    from sklearn.utils import get_tags

    from sklearn_meshph import KernelSumSVC

    # A stack of distances in: cross-validations slice it pairwise, as KernelSumSVC's.
    pairwise = SizeSwitchClassifier(KernelSumSVC(), KernelSumSVC(C=(1.0,)))
    assert get_tags(pairwise).input_tags.pairwise
    assert get_tags(pairwise).input_tags.three_d_array
    # Missing values only when both take them.
    assert not get_tags(switch()).input_tags.allow_nan  # k-NN refuses them
    both = SizeSwitchClassifier(HistGradientBoostingClassifier(), DecisionTreeClassifier())
    assert get_tags(both).input_tags.allow_nan


def test_graph_classifier_default_fits_a_handful_of_graphs():
    """The old default (trees) fitted on three graphs; the kernel SVM's internal
    cross-validation then leaves one out instead of refusing."""
    graphs, y = [cycle(5), cycle(7), path(6)], [0, 0, 1]
    model = make_graph_classifier().fit(graphs, y)
    assert set(model.predict([cycle(6), path(8)])) <= {0, 1}
    assert len(model[-1].estimator_[-1].cv_scores_) == 21  # 3 folds of one graph each
    graphs, y = [cycle(5), cycle(7), cycle(9), path(6), path(8), path(10)], [0] * 3 + [1] * 3
    model = make_graph_classifier().fit(graphs, y)
    assert model.predict([cycle(6), path(7)]).tolist() == [0, 1]
    with pytest.raises(ValueError, match="at least 2"):
        make_graph_classifier().fit([cycle(5)], [0])


def test_probabilities_of_the_default_through_calibration():
    """The default's SVM has no predict_proba; CalibratedClassifierCV around it gives
    them (it asks for a method before fitting, which the switch answers)."""
    from sklearn.calibration import CalibratedClassifierCV

    graphs = [f(n) for f in (cycle, path) for n in range(5, 17)]
    y = np.repeat([0, 1], 12)
    model = CalibratedClassifierCV(make_graph_classifier(), cv=3).fit(graphs, y)
    proba = model.predict_proba([cycle(18), path(18)])
    assert proba.shape == (2, 2) and proba[0, 0] > 0.5 and proba[1, 1] > 0.5


def test_batches_of_sparse_and_frame_inputs_and_bad_samples():
    import pandas as pd
    import scipy.sparse as sp

    X, y = rows()
    linear = SizeSwitchClassifier(LogisticRegression(), DecisionTreeClassifier(), batch_size=7)
    linear.fit(X, y)
    np.testing.assert_array_equal(linear.predict(sp.coo_matrix(X)), linear.estimator_.predict(X))
    model = switch(max_small_samples=100, batch_size=7).fit(X, y)
    expected = model.estimator_.predict(X)
    frame = pd.DataFrame(X, columns=["a", "b", "c"], index=np.arange(40)[::-1])
    frame_model = switch(max_small_samples=100, batch_size=7).fit(frame, y)
    np.testing.assert_array_equal(frame_model.predict(frame), expected)
    with pytest.raises(TypeError, match="a sequence or an array-like of samples, got generator"):
        model.fit((row for row in X), y)
    with pytest.raises(TypeError, match="got float"):
        model.predict(3.0)
    with pytest.raises(TypeError, match="got a 0-d array"):
        model.fit(np.array(1.0), y)


def test_a_failed_refit_leaves_the_last_fit_whole():
    X, y = rows()
    model = switch(max_small_samples=100).fit(X, y)
    with pytest.raises(ValueError):
        model.set_params(max_small_samples=0).fit(X, y[:5])  # the tree refuses
    assert model.chosen_ == "small" and isinstance(model.estimator_, KNeighborsClassifier)
    # A regressor fits, then has no classes: it was kept (its values predicted as
    # labels) and a raw AttributeError raised.
    from sklearn.linear_model import LinearRegression

    model.set_params(max_small_samples=0, large=LinearRegression())
    with pytest.raises(TypeError, match="'large' estimator \\(LinearRegression\\) is not a"):
        model.fit(X, y)
    assert model.chosen_ == "small" and set(model.predict(X)) <= set(y)


def test_graph_classifier_default_same_under_any_backend():
    """The kernel SVM's decisions do not depend on joblib's backend or job count (more
    tasks than cores)."""
    from joblib import parallel_backend

    graphs = [f(n) for f in (cycle, path, star) for n in range(5, 13)]
    y = np.repeat([0, 1, 2], 8)
    reference = make_graph_classifier(n_jobs=1).fit(graphs, y).decision_function(graphs)
    for backend in ("loky", "threading"):
        with parallel_backend(backend):
            model = make_graph_classifier(n_jobs=4).fit(graphs, y)
            np.testing.assert_array_equal(model.decision_function(graphs), reference)
