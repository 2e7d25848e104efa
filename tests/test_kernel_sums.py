"""Kernels of samples of several diagrams: sums, means and products of the positions'
kernels with their own bandwidths and weights (against the single-diagram kernels
computed separately), positive semi-definiteness, the per-position distances and the
kernel made from them, and a grid search over the bandwidths that computes each fold's
distances once."""

import numpy as np
import pytest
import scipy.sparse as sp
from sklearn.base import clone
from sklearn.model_selection import GridSearchCV, KFold, cross_val_score
from sklearn.pipeline import make_pipeline
from sklearn.svm import SVC
from sklearn.utils import get_tags

from sklearn_meshph import (
    DiagramDistance,
    DistanceKernel,
    PerDiagramDistance,
    PersistenceScaleSpaceKernel,
    PersistenceWeightedGaussianKernel,
    SlicedWassersteinKernel,
    pairwise_diagram_distances,
)
from sklearn_meshph._base import median_scale
from sklearn_meshph.diagrams import pairwise

KERNELS = {
    "sliced-wasserstein": lambda **p: SlicedWassersteinKernel(n_directions=6, **p),
    "scale-space": lambda **p: PersistenceScaleSpaceKernel(**p),
    "weighted-gaussian": lambda **p: PersistenceWeightedGaussianKernel(weight="persistence", **p),
}


def random_samples(n, parts, seed, scales=None):
    """``n`` samples of ``parts`` diagrams (2 to 9 points; position ``k`` on the scale
    ``scales[k]``), the first sample's first diagram empty."""
    rng = np.random.default_rng(seed)
    scales = np.ones(parts) if scales is None else scales
    samples = []
    for _ in range(n):
        sample = []
        for k in range(parts):
            births = scales[k] * rng.random(int(rng.integers(2, 10)))
            sample.append(np.column_stack([births, births + scales[k] * rng.random(len(births))]))
        samples.append(tuple(sample))
    samples[0] = (np.empty((0, 2)), *samples[0][1:])
    return samples


def separately(make, samples, others, bandwidths):
    """Each position's kernel, computed by a kernel of single diagrams."""
    return [
        make(bandwidth=b).fit([s[k] for s in samples]).transform([s[k] for s in others])
        for k, b in enumerate(bandwidths)
    ]


# ------------------------------------------------------- sums, means, products, bandwidths


@pytest.mark.parametrize("name", list(KERNELS))
@pytest.mark.parametrize("bandwidth", [0.6, [0.3, 1.0, 2.5, 0.7]], ids=["one", "per-position"])
@pytest.mark.parametrize(
    "combine, weights",
    [
        ("sum", None),
        ("sum", [1.0, 0.0, 2.5, 0.5]),
        ("mean", [2.0, 1.0, 1.0, 4.0]),
        ("product", None),
    ],
)
def test_combinations_equal_the_single_diagram_kernels(name, bandwidth, combine, weights):
    samples = random_samples(9, 4, seed=1, scales=[0.5, 1.0, 3.0, 1.0])
    others = random_samples(4, 4, seed=2, scales=[0.5, 1.0, 3.0, 1.0])
    make = KERNELS[name]
    kernel = make(bandwidth=bandwidth, combine=combine, diagram_weights=weights)
    bandwidths = np.broadcast_to(bandwidth, 4)
    w = np.ones(4) if weights is None else np.array(weights)
    for left in (samples, others):
        parts = separately(make, samples, left, bandwidths)
        if combine == "product":
            expected = np.prod(parts, axis=0)
        else:
            expected = sum(wk * part for wk, part in zip(w, parts, strict=True))
            expected = expected / w.sum() if combine == "mean" else expected
        got = kernel.fit(samples).transform(left)
        np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-14 * np.abs(expected).max())
    np.testing.assert_array_equal(kernel.fit_transform(samples), kernel.transform(samples))


def test_the_defaults_keep_each_kernels_combination():
    """Sliced Wasserstein: the product (typed disjoint union); the others: the sum."""
    assert SlicedWassersteinKernel().combine == "product"
    assert PersistenceScaleSpaceKernel().combine == "sum"
    assert PersistenceWeightedGaussianKernel().combine == "sum"
    samples = random_samples(6, 3, seed=3)
    for make in KERNELS.values():
        default = make(bandwidth=0.8).fit_transform(samples)
        other = "sum" if make().combine == "product" else "product"
        assert not np.allclose(make(bandwidth=0.8, combine=other).fit_transform(samples), default)


def test_sliced_wasserstein_sum_is_not_the_product():
    """A far position drives the product to 0, never the sum: each term stays."""
    near = (np.array([[0.0, 1.0]]), np.array([[0.0, 1.0]]))
    far = (np.array([[0.0, 1.0]]), np.array([[0.0, 100.0]]))
    product = SlicedWassersteinKernel(n_directions=4).fit_transform([near, far])
    total = SlicedWassersteinKernel(n_directions=4, combine="mean").fit_transform([near, far])
    assert product[0, 1] < 1e-10
    assert total[0, 1] == pytest.approx(0.5, rel=1e-12)
    np.testing.assert_array_equal(np.diag(total), [1.0, 1.0])


@pytest.mark.parametrize("name", list(KERNELS))
@pytest.mark.parametrize("combine", ["sum", "mean", "product"])
def test_positive_semidefinite_with_bandwidths_and_weights(name, combine):
    rng = np.random.default_rng(4)
    for seed in range(3):
        samples = random_samples(25, 4, seed=10 + seed, scales=[0.2, 1.0, 5.0, 1.0])
        weights = None if combine == "product" else list(rng.random(4))
        bandwidths = list(rng.uniform(0.2, 3.0, 4))
        matrix = KERNELS[name](
            bandwidth=bandwidths, combine=combine, diagram_weights=weights
        ).fit_transform(samples)
        np.testing.assert_array_equal(matrix, matrix.T)
        eigenvalues = np.linalg.eigvalsh(matrix)
        assert eigenvalues.min() >= -1e-10 * eigenvalues.max()


@pytest.mark.parametrize("name", list(KERNELS))
def test_identical_for_any_n_jobs(name):
    samples, others = random_samples(30, 3, seed=5), random_samples(7, 3, seed=6)
    kernel = KERNELS[name](bandwidth=[0.4, 1.0, 2.0], combine="mean", diagram_weights=[1, 2, 3])
    reference = kernel.set_params(n_jobs=1).fit_transform(samples)
    cross = kernel.transform(others)
    kernel.set_params(n_jobs=2)
    np.testing.assert_array_equal(kernel.fit_transform(samples), reference)
    np.testing.assert_array_equal(kernel.transform(others), cross)


@pytest.mark.parametrize(
    "params, message",
    [
        ({"bandwidth": [1.0, 2.0]}, "bandwidth has 2 values for 3 diagram positions"),
        ({"bandwidth": [1.0, 1e-300, 1.0]}, "bandwidth of diagram position 1 is 1e-300"),
        ({"bandwidth": [1.0, 1.0, np.inf]}, "bandwidth of diagram position 2 is inf"),
        ({"bandwidth": [np.nan, 1.0, 1.0]}, "bandwidth of diagram position 0 is nan"),
        ({"bandwidth": [1.0, -1.0, 1.0]}, "bandwidth of diagram position 1 is -1.0"),
        ({"bandwidth": 1e-300}, "'bandwidth' parameter"),
        ({"bandwidth": np.inf}, "'bandwidth' parameter"),
        ({"bandwidth": np.nan}, "'bandwidth' parameter"),
        ({"bandwidth": "median"}, "'bandwidth' parameter"),
        ({"bandwidth": ["1", "2", "3"]}, "'bandwidth' parameter"),  # read as floats before
        ({"bandwidth": [True, 1.0, 1.0]}, "'bandwidth' parameter"),
        ({"combine": "max"}, "'combine' parameter"),
        ({"diagram_weights": [1.0, 2.0]}, "diagram_weights has 2 values for 3"),
        ({"diagram_weights": [1.0, -2.0, 1.0]}, "diagram_weights of diagram position 1"),
        ({"diagram_weights": [1.0, np.nan, 1.0]}, "diagram_weights of diagram position 1"),
        ({"diagram_weights": [0, 0, 0]}, "diagram_weights are all 0"),
        ({"diagram_weights": [1e308, 1e308, 1]}, "diagram_weights sum to more than float64"),
        ({"diagram_weights": "equal"}, "'diagram_weights' parameter"),
        ({"diagram_weights": [1, 1, 1], "combine": "product"}, "a product has no terms"),
    ],
)
@pytest.mark.parametrize("name", list(KERNELS))
def test_per_position_parameters_are_checked_at_fit(name, params, message):
    kernel = KERNELS[name](**({"combine": "sum"} | params))
    with pytest.raises(ValueError, match=message):
        kernel.fit(random_samples(3, 3, seed=7))


def test_bandwidths_set_after_fit_are_checked_at_transform():
    samples = random_samples(4, 2, seed=8)
    kernel = SlicedWassersteinKernel().fit(samples)
    with pytest.raises(ValueError, match="bandwidth has 3 values for 2 diagram positions"):
        kernel.set_params(bandwidth=[1.0, 1.0, 1.0]).transform(samples)


@pytest.mark.parametrize("name", list(KERNELS))
def test_clone_params_and_pickle(name, estimator_round_trip):
    samples = random_samples(6, 2, seed=9)
    kernel = KERNELS[name](bandwidth=[0.5, 2.0], combine="sum", diagram_weights=[1.0, 3.0])
    new = {"bandwidth": [1.0, 1.5], "combine": "mean", "diagram_weights": [2.0, 1.0]}
    assert estimator_round_trip(kernel, samples, new, fit_X=samples[:4]).shape == (6, 4)


# ------------------------------------------------------------- distances per position


def test_per_diagram_distances_are_the_positions_distances():
    samples, others = random_samples(8, 3, seed=11), random_samples(5, 3, seed=12)
    for metric in ("sliced-wasserstein", "bottleneck"):
        stage = PerDiagramDistance(metric=metric, n_directions=7)
        stack = stage.fit_transform(samples)
        assert stack.shape == (8, 8, 3) and stack.dtype == np.float64
        np.testing.assert_array_equal(stage.transform(samples), stack)
        cross = stage.transform(others)
        for k in range(3):
            single = DiagramDistance(metric=metric, n_directions=7).fit([s[k] for s in samples])
            np.testing.assert_array_equal(stack[:, :, k], single.transform([s[k] for s in samples]))
            np.testing.assert_array_equal(cross[:, :, k], single.transform([s[k] for s in others]))
        free = pairwise_diagram_distances(samples, metric=metric, n_directions=7, per_diagram=True)
        np.testing.assert_array_equal(free, stack)
    summed = DiagramDistance(metric="sliced-wasserstein").fit_transform(samples)
    np.testing.assert_allclose(PerDiagramDistance().fit_transform(samples).sum(axis=2), summed)
    single = PerDiagramDistance(dtype="float32").fit_transform(samples)
    assert single.dtype == np.float32
    assert PerDiagramDistance().fit(samples).set_output(transform="pandas").transform(
        others
    ).shape == (5, 8, 3)


def test_per_diagram_distances_identical_for_any_n_jobs():
    samples, others = random_samples(30, 2, seed=13), random_samples(6, 2, seed=14)
    stage = PerDiagramDistance(n_jobs=1)
    reference, cross = stage.fit_transform(samples), stage.transform(others)
    stage.set_params(n_jobs=2)
    np.testing.assert_array_equal(stage.fit_transform(samples), reference)
    np.testing.assert_array_equal(stage.transform(others), cross)


def test_per_diagram_parameters_and_out_are_checked():
    samples = random_samples(3, 2, seed=15)
    with pytest.raises(ValueError, match="'metric' parameter"):
        PerDiagramDistance(metric="cosine").fit(samples)
    with pytest.raises(ValueError, match="'memory' parameter"):
        PerDiagramDistance(memory=3).fit(samples)
    with pytest.raises(ValueError, match="X has 3 diagrams per sample, the fitted data 2"):
        PerDiagramDistance().fit(samples).transform(random_samples(2, 3, seed=16))
    with pytest.raises(ValueError, match=r"out has shape \(3, 3\), expected \(3, 3, 2\)"):
        pairwise_diagram_distances(samples, per_diagram=True, out=np.empty((3, 3)))
    out = np.empty((3, 3, 2))
    assert pairwise_diagram_distances(samples, per_diagram=True, out=out) is out


def test_per_diagram_distances_round_trip(estimator_round_trip, tmp_path):
    samples = random_samples(5, 2, seed=17)
    stage = PerDiagramDistance(memory=str(tmp_path))
    new = {"metric": "bottleneck", "n_directions": 3, "memory": None}
    assert estimator_round_trip(stage, samples, new, fit_X=samples[:3]).shape == (5, 3, 2)


# ------------------------------------------------------------ the kernel of distances


def test_distance_kernel_is_the_sliced_wasserstein_kernel():
    samples, others = random_samples(9, 3, seed=18), random_samples(4, 3, seed=19)
    stage = PerDiagramDistance(n_directions=6).fit(samples)
    train, test = stage.fit_transform(samples), stage.transform(others)
    for params in (
        {"bandwidth": 0.7},
        {"bandwidth": [0.3, 1.0, 2.0]},
        {"bandwidth": [0.3, 1.0, 2.0], "combine": "sum", "diagram_weights": [1, 0.5, 2]},
        {"bandwidth": 1.3, "combine": "mean", "diagram_weights": [3, 0.5, 2]},
    ):
        kernel = SlicedWassersteinKernel(n_directions=6, **params).fit(samples)
        ours = DistanceKernel(**params)
        np.testing.assert_allclose(ours.fit_transform(train), kernel.transform(samples), rtol=1e-14)
        np.testing.assert_allclose(ours.transform(test), kernel.transform(others), rtol=1e-14)
    # One position: the kernel of DiagramDistance's matrix, bit for bit.
    combined = DiagramDistance(metric="sliced-wasserstein", n_directions=6).fit(samples)
    kernel = SlicedWassersteinKernel(n_directions=6, bandwidth=0.9).fit(samples)
    ours = DistanceKernel(bandwidth=0.9).fit(combined.transform(samples))
    np.testing.assert_array_equal(
        ours.transform(combined.transform(others)), kernel.transform(others)
    )


def test_distance_kernel_median_normalization():
    samples = random_samples(10, 2, seed=20, scales=[0.1, 10.0])
    stack = PerDiagramDistance().fit_transform(samples)
    kernel = DistanceKernel(normalization="median", combine="sum", bandwidth=[0.5, 2.0])
    matrix = kernel.fit_transform(stack)
    scales = [median_scale(stack[:, :, k]) for k in range(2)]
    np.testing.assert_array_equal(kernel.scales_, scales)
    expected = sum(
        np.exp(-stack[:, :, k] / scales[k] / (2 * b * b)) for k, b in enumerate([0.5, 2.0])
    )
    np.testing.assert_allclose(matrix, expected, rtol=1e-14)
    # The scales are learned at fit: transform keeps them.
    np.testing.assert_array_equal(kernel.transform(stack[:3] * 1.0), matrix[:3])
    assert DistanceKernel().fit(stack).scales_.tolist() == [1.0, 1.0]


def test_distance_kernel_checks_its_input():
    stack = PerDiagramDistance().fit_transform(random_samples(4, 2, seed=21))
    kernel = DistanceKernel()
    with pytest.raises(ValueError, match=r"square distances .* got shape \(3, 4, 2\)"):
        kernel.fit(stack[:3])
    with pytest.raises(ValueError, match=r"got shape \(4,\)"):
        kernel.fit(stack[0, :, 0])
    with pytest.raises(TypeError, match="got a sparse matrix"):
        kernel.fit(sp.csr_array(stack[:, :, 0]))
    with pytest.raises(TypeError, match="real distances, got an array of dtype complex128"):
        kernel.fit(stack + 1j)
    bad = stack.copy()
    bad[2, 1, 1] = -0.5
    with pytest.raises(ValueError, match=r"sample 2: .* fitted sample 1 \(diagram position 1\)"):
        kernel.fit(bad)
    bad[2, 1, 1] = np.nan
    with pytest.raises(ValueError, match="sample 2: .* is nan"):
        kernel.fit(bad)
    assert kernel.fit(stack).n_features_in_ == 4
    with pytest.raises(ValueError, match="expected 4 columns .* and 2 diagram positions"):
        kernel.transform(stack[:, :3])
    with pytest.raises(ValueError, match="expected 4 columns .* and 2 diagram positions"):
        kernel.transform(stack[:, :, 0])
    with pytest.raises(ValueError, match="bandwidth has 3 values for 2"):
        DistanceKernel(bandwidth=[1, 1, 1]).fit(stack)
    infinite = stack.copy()
    infinite[0, 1, 0] = infinite[1, 0, 0] = np.inf
    assert kernel.fit_transform(infinite)[0, 1] == 0.0
    # A float32 stack (PerDiagramDistance(dtype="float32")) is read as it is.
    single = PerDiagramDistance(dtype="float32").fit_transform(random_samples(4, 2, seed=21))
    matrix = kernel.fit_transform(single)
    assert matrix.dtype == np.float64
    np.testing.assert_allclose(matrix, kernel.fit_transform(stack), rtol=1e-6)


def test_distance_kernel_api(estimator_round_trip):
    pd = pytest.importorskip("pandas")
    stack = PerDiagramDistance().fit_transform(random_samples(5, 2, seed=22))
    kernel = DistanceKernel(bandwidth=[1.0, 2.0], combine="sum")
    assert get_tags(kernel).input_tags.pairwise
    new = {"bandwidth": 0.5, "normalization": "median", "diagram_weights": [1.0, 2.0]}
    estimator_round_trip(kernel, stack[:, :3], new, fit_X=stack[:3, :3])
    names = list(clone(kernel).fit(stack).get_feature_names_out())
    assert names == [f"distancekernel{i}" for i in range(5)]
    frame = clone(kernel).set_output(transform="pandas").fit_transform(stack)
    assert isinstance(frame, pd.DataFrame) and list(frame.columns) == names


# --------------------------------------------------- searching without recomputing


def toy_classes(n, seed):
    """Two classes differing on the second diagram position only."""
    rng = np.random.default_rng(seed)
    samples, labels = [], []
    for i in range(n):
        births = rng.random(4)
        first = np.column_stack([births, births + rng.random(4)])
        second = np.column_stack([births, births + 0.2 + (i % 2) * (1.0 + rng.random(4))])
        samples.append((first, second))
        labels.append(i % 2)
    return samples, np.array(labels)


def count_distance_matrices(monkeypatch):
    calls = []
    original = pairwise.distance_matrices

    def counting(sides, *args, **kwargs):
        calls.extend(len(left) for left, _ in sides)  # one per diagram position
        return original(sides, *args, **kwargs)

    monkeypatch.setattr(pairwise, "distance_matrices", counting)
    return calls


GRID = {"distancekernel__bandwidth": [0.3, 1.0, [0.5, 2.0]], "svc__C": [1.0, 10.0]}


def test_grid_search_computes_each_folds_distances_once(monkeypatch, tmp_path):
    samples, y = toy_classes(18, seed=23)
    calls = count_distance_matrices(monkeypatch)
    model = make_pipeline(
        PerDiagramDistance(memory=str(tmp_path)),
        DistanceKernel(combine="sum"),
        SVC(kernel="precomputed"),
    )
    search = GridSearchCV(model, GRID, cv=KFold(3)).fit(samples, y)
    assert len(search.cv_results_["params"]) == 6
    # Per fold, the training stack and the test stack; then the refit's: 2 positions each.
    assert len(calls) == 2 * (3 * 2 + 1)
    assert len(list((tmp_path / "sklearn_meshph_distances").glob("*.npy"))) == 3 * 2 + 1
    assert search.best_score_ == 1.0
    # Without the cache, every candidate of every fold computes both again.
    calls.clear()
    GridSearchCV(model.set_params(perdiagramdistance__memory=None), GRID, cv=KFold(3)).fit(
        samples, y
    )
    assert len(calls) == 2 * (6 * 3 * 2 + 1)


def test_grid_search_on_a_precomputed_stack_gives_the_same_scores(monkeypatch):
    samples, y = toy_classes(18, seed=24)
    stack = pairwise_diagram_distances(samples, metric="sliced-wasserstein", per_diagram=True)
    calls = count_distance_matrices(monkeypatch)
    kernel = DistanceKernel(combine="mean", normalization="median")
    on_stack = GridSearchCV(make_pipeline(kernel, SVC(kernel="precomputed")), GRID, cv=KFold(3))
    on_stack.fit(stack, y)
    assert calls == []
    on_samples = GridSearchCV(
        make_pipeline(PerDiagramDistance(), kernel, SVC(kernel="precomputed")), GRID, cv=KFold(3)
    ).fit(samples, y)
    for key in ("split0_test_score", "split1_test_score", "split2_test_score"):
        np.testing.assert_array_equal(on_stack.cv_results_[key], on_samples.cv_results_[key])


def test_nested_cross_validation_on_a_precomputed_stack(monkeypatch):
    """The outer split slices the stack too (the search is pairwise as its pipeline):
    the same scores as from the diagrams, and no distance computed after the stack."""
    samples, y = toy_classes(24, seed=25)
    stack = pairwise_diagram_distances(samples, metric="sliced-wasserstein", per_diagram=True)
    calls = count_distance_matrices(monkeypatch)
    kernel = DistanceKernel(normalization="median", combine="sum")
    grid = {"distancekernel__bandwidth": [0.3, 3.0]}
    inner = GridSearchCV(make_pipeline(kernel, SVC(kernel="precomputed")), grid, cv=KFold(3))
    outer = KFold(4, shuffle=True, random_state=0)
    on_stack = cross_val_score(inner, stack, y, cv=outer)
    assert calls == []
    search = GridSearchCV(
        make_pipeline(PerDiagramDistance(), kernel, SVC(kernel="precomputed")), grid, cv=KFold(3)
    )
    np.testing.assert_array_equal(cross_val_score(search, samples, y, cv=outer), on_stack)


def test_distance_kernel_weights_that_overflow_are_refused():
    """Weights of 1e308 summed to inf: a mean gave NaN on the diagonal, a sum inf."""
    square = np.array([[0.0, 1.0], [1.0, 0.0]])
    stack = np.stack([square, 2 * square], -1)
    for combine in ("mean", "sum"):
        kernel = DistanceKernel(diagram_weights=[1e308, 1e308], combine=combine)
        with pytest.raises(ValueError, match="diagram_weights sum to more than float64"):
            kernel.fit_transform(stack)
    kernel = DistanceKernel(diagram_weights=[1e307, 1e307], combine="mean")
    plain = DistanceKernel(combine="mean").fit_transform(stack)
    np.testing.assert_allclose(kernel.fit_transform(stack), plain)


def test_per_position_parameters_take_any_sequence_of_numbers():
    """A pandas Series or a range was refused once the strings and bools were."""
    import pandas as pd

    square = np.array([[0.0, 1.0], [1.0, 0.0]])
    stack = np.stack([square, 2 * square], -1)
    expected = DistanceKernel(diagram_weights=[1.0, 2.0], combine="sum").fit_transform(stack)
    for weights in (pd.Series([1.0, 2.0]), range(1, 3), np.array([1, 2])):
        kernel = DistanceKernel(diagram_weights=weights, combine="sum")
        np.testing.assert_array_equal(kernel.fit_transform(stack), expected)
    for bad in ({1.0, 2.0}, {"a": 1.0, "b": 2.0}, pd.Series(["1", "2"])):
        with pytest.raises(ValueError, match="'diagram_weights' parameter"):
            DistanceKernel(diagram_weights=bad, combine="sum").fit_transform(stack)
