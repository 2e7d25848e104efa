"""scikit-learn's own estimator checks on every estimator of the package.

Estimators whose samples are rows of a 2-d array (``FeatureDistance``, and
``CombinedDistance`` over parts that take them) run the whole of
``parametrize_with_checks``. The others take sequences of meshes, scalar fields or
diagrams: scikit-learn skips every check for them (their ``two_d_array`` tag is False),
so the checks that need no data, those of the parameter, clone and repr conventions,
run here one by one, and each check that needs a 2-d array is listed with the reason.
"""

import inspect

import pytest
from sklearn.base import BaseEstimator, clone
from sklearn.utils import get_tags
from sklearn.utils.estimator_checks import (
    check_do_not_raise_errors_in_init_or_set_params,
    check_estimator_cloneable,
    check_estimator_repr,
    check_estimator_tags_renamed,
    check_get_params_invariance,
    check_mixin_order,
    check_no_attributes_set_in_init,
    check_parameters_default_constructible,
    check_set_params,
    check_valid_tag_types,
    parametrize_with_checks,
)

import sklearn_meshph
from sklearn_meshph import CombinedDistance, DistanceScaler, FeatureDistance


def combined_of_vectors():
    return CombinedDistance(
        [("canberra", FeatureDistance()), ("cityblock", FeatureDistance(metric="cityblock"))],
        weights={"cityblock": 0.5},
    )


def expected_failed_checks(estimator):
    """The checks of ``parametrize_with_checks`` that are expected to fail, with why.

    None today: they take 2-d arrays, refuse sparse input by name, compare
    rows exactly (Canberra and cityblock distances, so no rounding differs between
    orders of the samples) and expose ``n_features_in_``.
    """
    return {}


@parametrize_with_checks(
    [FeatureDistance(), combined_of_vectors(), DistanceScaler()],
    expected_failed_checks=expected_failed_checks,
)
def test_scikit_learn_checks_of_the_estimators_of_rows(estimator, check):
    check(estimator)


def package_estimators():
    """One instance of every public estimator class of the package."""
    estimators = []
    for name in sklearn_meshph.__all__:
        cls = getattr(sklearn_meshph, name)
        if inspect.isclass(cls) and issubclass(cls, BaseEstimator):
            estimators.append(combined_of_vectors() if cls is CombinedDistance else cls())
    return estimators


ESTIMATORS = package_estimators()
SAMPLE_ESTIMATORS = [e for e in ESTIMATORS if not get_tags(e).input_tags.two_d_array]

# The conventions that need no data: parameters stored unchanged by __init__, defaults,
# get_params / set_params / clone, repr, tags and the order of the mixins.
CHECKS_WITHOUT_DATA = [
    check_estimator_cloneable,
    check_estimator_tags_renamed,
    check_valid_tag_types,
    check_estimator_repr,
    check_no_attributes_set_in_init,
    check_do_not_raise_errors_in_init_or_set_params,
    check_mixin_order,
    check_parameters_default_constructible,
    check_get_params_invariance,
    check_set_params,
]

# The API checks that need a 2-d array, for the estimators of meshes, fields and
# diagrams: each fits on random rows.
NOT_APPLICABLE = {
    "check_fit_score_takes_y": "fits on a 2-d array; the input is a sequence of samples",
    "check_estimators_overwrite_params": "fits on a 2-d array",
    "check_dont_overwrite_parameters": "fits on a 2-d array",
    "check_estimators_fit_returns_self": "fits on a 2-d array",
    "check_readonly_memmap_input": "a read-only 2-d array, not meshes or diagrams",
    "check_estimators_unfitted": "transforms a 2-d array",
    "check_n_features_in_after_fitting": "n_features_in_ counts the columns of a 2-d array",
    "check_positive_only_tag_during_fit": "fits on a 2-d array",
}


def test_every_estimator_is_checked():
    """A new estimator is checked without editing this file: all or part of the checks."""
    names = {type(e).__name__ for e in ESTIMATORS}
    assert {"DiagramDistance", "LaplacianEigenTransformer", "ShapeDNA"} <= names
    rows = {type(e).__name__ for e in ESTIMATORS if e not in SAMPLE_ESTIMATORS}
    assert rows == {"FeatureDistance", "CombinedDistance", "DistanceScaler"}


def test_the_api_checks_that_need_data_are_all_listed():
    """Every API check scikit-learn yields is run here or listed as not applicable."""
    from sklearn.utils.estimator_checks import _yield_api_checks

    run = {check.__name__ for check in CHECKS_WITHOUT_DATA}
    for estimator in ESTIMATORS:
        for check in _yield_api_checks(estimator):
            assert check.__name__ in run | set(NOT_APPLICABLE), check.__name__


@pytest.mark.parametrize("estimator", SAMPLE_ESTIMATORS, ids=lambda e: type(e).__name__)
@pytest.mark.parametrize("check", CHECKS_WITHOUT_DATA, ids=lambda c: c.__name__)
def test_conventions_of_the_estimators_of_samples(estimator, check):
    check(type(estimator).__name__, clone(estimator))


class BrokenGetParams(FeatureDistance):
    """``__init__`` stores a modified value: clone and get_params round trips break."""

    def __init__(self, metric="canberra", n_jobs=None):
        self.metric = metric.upper()
        self.n_jobs = n_jobs


class BrokenInit(FeatureDistance):
    """``__init__`` sets an attribute that is not a parameter."""

    def __init__(self, metric="canberra", n_jobs=None):
        self.metric = metric
        self.n_jobs = n_jobs
        self.features_ = None


class BrokenSetParams(FeatureDistance):
    """``set_params`` changes what ``get_params`` returns."""

    def set_params(self, **params):
        return super().set_params(**{key: [value] for key, value in params.items()})


@pytest.mark.parametrize(
    ("estimator", "check", "message"),
    [
        (BrokenGetParams(), check_parameters_default_constructible, "modifies parameter metric"),
        (BrokenGetParams(), check_estimator_cloneable, "Cloning of .* failed"),
        (BrokenInit(), check_no_attributes_set_in_init, "Found attributes \\['features_'\\]"),
        (BrokenSetParams(), check_set_params, "get_params result does not match"),
    ],
    ids=["stored-modified", "clone", "attribute-in-init", "set-params"],
)
def test_the_checks_catch_broken_conventions(estimator, check, message):
    """The checks above can fail: each catches an estimator that breaks one convention."""
    with pytest.raises((AssertionError, RuntimeError), match=message):
        check(type(estimator).__name__, estimator)


@pytest.mark.parametrize(
    "estimator",
    [e for e in SAMPLE_ESTIMATORS if hasattr(e, "transform")],  # the steps of pipelines
    ids=lambda e: type(e).__name__,
)
def test_every_estimator_of_samples_accepts_set_output(estimator):
    """``Pipeline.set_output`` calls ``set_output`` on every step: each estimator of
    samples accepts it (tables become DataFrames, fields and diagrams stay as they
    are), and refuses an unknown container by name."""
    estimator = clone(estimator)
    assert estimator.set_output(transform="pandas") is estimator
    assert clone(estimator)._sklearn_output_config == {"transform": "pandas"}
    with pytest.raises(ValueError, match="transform must be one of"):
        estimator.set_output(transform="table")


def test_predictions_before_fit_raise_not_fitted():
    import numpy as np
    from sklearn.exceptions import NotFittedError

    from sklearn_meshph import GraphPairDistances, KernelSumSVC, ShapeNeighborsClassifier

    stack = np.zeros((2, 2, 3))
    for method in ("predict", "decision_function", "score"):
        args = (stack, [0, 1]) if method == "score" else (stack,)
        with pytest.raises(NotFittedError):
            getattr(KernelSumSVC(groups="graph"), method)(*args)
    with pytest.raises(NotFittedError):
        ShapeNeighborsClassifier().predict([np.zeros((4, 3))])
    assert GraphPairDistances().__sklearn_tags__().requires_fit
