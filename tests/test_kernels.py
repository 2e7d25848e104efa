"""Kernels between diagrams and the sliced Wasserstein distance: gudhi's values, tuples,
properties (symmetry, positive semi-definiteness, metric axioms, the bound against W1),
the infinite-point policy, parallel determinism and the estimator API (feature names,
pandas output)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from joblib import parallel_backend
from sklearn.base import clone
from sklearn.exceptions import NotFittedError
from sklearn.pipeline import make_pipeline
from sklearn.svm import SVC

from sklearn_meshph import DiagramDistance, pairwise_diagram_distances, wasserstein_distance
from sklearn_meshph.diagrams.distances import sliced_wasserstein_distance
from sklearn_meshph.vectorization.kernels import (
    PersistenceScaleSpaceKernel,
    PersistenceWeightedGaussianKernel,
    SlicedWassersteinKernel,
)

gudhi_rep = pytest.importorskip("gudhi.representations")


def random_diagram(rng, size=None, scale=1.0):
    k = int(rng.integers(2, 15)) if size is None else size
    births = scale * rng.random(k)
    return np.column_stack([births, births + scale * rng.random(k)])


def random_diagrams(n, seed=0, parts=None, sizes=(0, 1)):
    """``n`` samples; the first ones have the given sizes (empty, one point), the others
    2 to 14 points."""
    rng = np.random.default_rng(seed)
    chosen = list(sizes) + [None] * n

    def one(i):
        return random_diagram(rng, chosen[i])

    if parts is None:
        return [one(i) for i in range(n)]
    return [tuple(one(i) for _ in range(parts)) for i in range(n)]


def gudhi_pairs(kernel, left, right):
    """gudhi's kernel of each pair; 0 when a diagram is empty (gudhi's PSS and PWG
    refuse empty diagrams; their sums are empty)."""
    return np.array([[kernel(a, b) if len(a) and len(b) else 0.0 for b in right] for a in left])


# ---------------------------------------------------------------------------- gudhi


@pytest.mark.parametrize("n_directions", [1, 2, 10, 31])
@pytest.mark.parametrize("bandwidth", [0.3, 1.0, 2.5])
def test_sliced_wasserstein_kernel_equals_gudhi(bandwidth, n_directions):
    diagrams = random_diagrams(9, seed=n_directions)
    ours = SlicedWassersteinKernel(bandwidth=bandwidth, n_directions=n_directions)
    theirs = gudhi_rep.SlicedWassersteinKernel(
        num_directions=n_directions + 1, bandwidth=2 * bandwidth**2
    )
    expected = theirs.fit(diagrams).transform(diagrams)
    np.testing.assert_allclose(ours.fit_transform(diagrams), expected, rtol=1e-10)
    other = random_diagrams(4, seed=100 + n_directions, sizes=(1,))
    np.testing.assert_allclose(
        ours.fit(diagrams).transform(other), theirs.transform(other), rtol=1e-10
    )


@pytest.mark.parametrize("n_directions", [1, 3, 10, 50])
def test_sliced_wasserstein_distance_equals_gudhi(n_directions):
    diagrams = random_diagrams(10, seed=n_directions)
    expected = (
        gudhi_rep.SlicedWassersteinDistance(num_directions=n_directions + 1)
        .fit(diagrams)
        .transform(diagrams)
    )
    matrix = DiagramDistance(metric="sliced-wasserstein", n_directions=n_directions)
    matrix = matrix.fit_transform(diagrams)
    np.testing.assert_allclose(matrix, expected, rtol=1e-10, atol=1e-15)
    np.testing.assert_array_equal(
        pairwise_diagram_distances(
            diagrams, metric="sliced-wasserstein", n_directions=n_directions
        ),
        matrix,
    )
    for i, j in [(0, 1), (1, 2), (3, 4), (0, 0)]:
        assert sliced_wasserstein_distance(
            diagrams[i], diagrams[j], n_directions=n_directions
        ) == pytest.approx(expected[i, j], rel=1e-10, abs=1e-15)


@pytest.mark.parametrize("bandwidth", [0.2, 1.0, 3.0])
def test_persistence_scale_space_kernel_equals_gudhi(bandwidth):
    diagrams = random_diagrams(9, seed=1)
    matrix = PersistenceScaleSpaceKernel(bandwidth=bandwidth).fit_transform(diagrams)
    expected = gudhi_pairs(
        gudhi_rep.PersistenceScaleSpaceKernel(bandwidth=bandwidth), diagrams, diagrams
    )
    # gudhi subtracts nearly equal exponentials: its own error is relative to the terms.
    np.testing.assert_allclose(matrix, expected, rtol=1e-10, atol=1e-13 * np.abs(expected).max())
    assert (matrix[0] == 0).all() and (matrix[:, 0] == 0).all()
    # The kernel over the non-empty diagrams as gudhi's classes compute it.
    full = gudhi_rep.PersistenceScaleSpaceKernel(bandwidth=bandwidth)
    np.testing.assert_allclose(
        matrix[1:, 1:], full.fit(diagrams[1:]).transform(diagrams[1:]), rtol=1e-10, atol=1e-14
    )


WEIGHTS = [
    ("constant", 1.0, lambda x: 1),
    ("persistence", 1.0, lambda x: x[1] - x[0]),
    ("persistence", 2.5, lambda x: (x[1] - x[0]) ** 2.5),
    (
        lambda d: np.arctan(2.0 * (d[:, 1] - d[:, 0]) ** 1.5),
        1.0,
        lambda x: np.arctan(2.0 * (x[1] - x[0]) ** 1.5),
    ),
]


@pytest.mark.parametrize("weight, power, gudhi_weight", WEIGHTS)
@pytest.mark.parametrize("bandwidth", [0.3, 1.0, 2.0])
def test_persistence_weighted_gaussian_kernel_equals_gudhi(weight, power, gudhi_weight, bandwidth):
    diagrams = random_diagrams(9, seed=2)
    ours = PersistenceWeightedGaussianKernel(bandwidth=bandwidth, weight=weight, power=power)
    theirs = gudhi_rep.PersistenceWeightedGaussianKernel(bandwidth=bandwidth, weight=gudhi_weight)
    expected = gudhi_pairs(theirs, diagrams, diagrams)
    np.testing.assert_allclose(ours.fit_transform(diagrams), expected, rtol=1e-10)
    other = random_diagrams(3, seed=3, sizes=())
    np.testing.assert_allclose(
        ours.fit(diagrams).transform(other), gudhi_pairs(theirs, other, diagrams), rtol=1e-10
    )


def test_scale_space_points_on_the_diagonal_contribute_nothing():
    """gudhi weighs the mirror image of a point on the diagonal +1: a pair of such
    points adds to its kernel; here (as in the paper) they add nothing."""
    rng = np.random.default_rng(4)
    clean = [random_diagram(rng, 6) for _ in range(4)]
    noisy = [np.vstack([d, [[0.3, 0.3], [0.5, 0.5]]]) for d in clean]
    kernel = PersistenceScaleSpaceKernel(bandwidth=0.7)
    np.testing.assert_allclose(kernel.fit_transform(noisy), kernel.fit_transform(clean), rtol=1e-14)
    expected = gudhi_pairs(gudhi_rep.PersistenceScaleSpaceKernel(bandwidth=0.7), clean, clean)
    np.testing.assert_allclose(kernel.fit_transform(noisy), expected, rtol=1e-10)


# ---------------------------------------------------------------------------- tuples


def test_tuples_combine_as_a_typed_disjoint_union():
    samples = random_diagrams(7, seed=5, parts=3, sizes=(1,))
    per_position = [[s[k] for s in samples] for k in range(3)]

    sw = SlicedWassersteinKernel(bandwidth=0.8, n_directions=6).fit_transform(samples)
    gudhi_sw = gudhi_rep.SlicedWassersteinKernel(num_directions=7, bandwidth=2 * 0.8**2)
    product = np.prod([gudhi_sw.fit(d).transform(d) for d in per_position], axis=0)
    np.testing.assert_allclose(sw, product, rtol=1e-10)

    pss = PersistenceScaleSpaceKernel(bandwidth=0.5).fit_transform(samples)
    gudhi_pss = gudhi_rep.PersistenceScaleSpaceKernel(bandwidth=0.5)
    total = sum(gudhi_pairs(gudhi_pss, d, d) for d in per_position)
    np.testing.assert_allclose(pss, total, rtol=1e-10)

    pwg = PersistenceWeightedGaussianKernel(weight="persistence").fit_transform(samples)
    gudhi_pwg = gudhi_rep.PersistenceWeightedGaussianKernel(weight=lambda x: x[1] - x[0])
    total = sum(gudhi_pairs(gudhi_pwg, d, d) for d in per_position)
    np.testing.assert_allclose(pwg, total, rtol=1e-10)

    distances = DiagramDistance(metric="sliced-wasserstein", n_directions=6).fit_transform(samples)
    gudhi_distance = gudhi_rep.SlicedWassersteinDistance(num_directions=7)
    total = sum(gudhi_distance.fit(d).transform(d) for d in per_position)
    np.testing.assert_allclose(distances, total, rtol=1e-10)


# ---------------------------------------------------------------------------- properties

coordinate = st.floats(0.0, 10.0, allow_nan=False, allow_infinity=False)
persistence = st.floats(0.0, 5.0, allow_nan=False, allow_infinity=False)
diagram = st.lists(st.tuples(coordinate, persistence), max_size=6).map(
    lambda rows: np.array([(b, b + p) for b, p in rows], dtype=float).reshape(-1, 2)
)
KERNELS = [
    lambda s: SlicedWassersteinKernel(bandwidth=s, n_directions=5),
    lambda s: PersistenceScaleSpaceKernel(bandwidth=s),
    lambda s: PersistenceWeightedGaussianKernel(bandwidth=s),
    lambda s: PersistenceWeightedGaussianKernel(bandwidth=s, weight="persistence", power=2),
]


@settings(max_examples=40, deadline=None)
@given(
    diagrams=st.lists(diagram, min_size=1, max_size=7),
    bandwidth=st.floats(0.1, 5.0),
    which=st.integers(0, len(KERNELS) - 1),
)
def test_kernels_are_symmetric_and_positive_semidefinite(diagrams, bandwidth, which):
    matrix = KERNELS[which](bandwidth).fit_transform(diagrams)
    np.testing.assert_array_equal(matrix, matrix.T)
    eigenvalues = np.linalg.eigvalsh(matrix)
    assert eigenvalues.min() >= -1e-9 * np.abs(eigenvalues).max()


@settings(max_examples=60, deadline=None)
@given(a=diagram, b=diagram, c=diagram, n_directions=st.integers(1, 12))
def test_sliced_wasserstein_is_a_pseudometric_below_twice_w1(a, b, c, n_directions):
    def sw(x, y):
        return sliced_wasserstein_distance(x, y, n_directions=n_directions)

    ab, bc, ac = sw(a, b), sw(b, c), sw(a, c)
    assert ab == sw(b, a)
    assert sw(a, a) == 0.0
    assert ac <= ab + bc + 1e-9 * (1.0 + ab + bc)
    # On every line, at most twice the exact W1 with the Euclidean ground metric, hence
    # 2 sqrt(2) times that with the L-infinity one (Carrière, Cuturi & Oudot 2017).
    w1_euclidean = wasserstein_distance(a, b, order=1.0, internal_p=2.0)
    w1_infinity = wasserstein_distance(a, b, order=1.0, internal_p=np.inf)
    assert ab <= 2.0 * w1_euclidean * (1.0 + 1e-9) + 1e-12
    assert ab <= 2.0 * np.sqrt(2.0) * w1_infinity * (1.0 + 1e-9) + 1e-12


def test_sliced_wasserstein_bound_on_random_diagrams():
    rng = np.random.default_rng(6)
    ratios = []
    for _ in range(200):
        a, b = random_diagram(rng, scale=3.0), random_diagram(rng, scale=3.0)
        w1 = wasserstein_distance(a, b, order=1.0, internal_p=2.0)
        sw = sliced_wasserstein_distance(a, b, n_directions=int(rng.integers(1, 30)))
        assert sw <= 2.0 * w1 * (1.0 + 1e-12) + 1e-15
        if w1 > 0:
            ratios.append(sw / w1)
    assert 0.0 < max(ratios) <= 2.0


# ---------------------------------------------------------------------------- estimators

ALL_KERNELS = [
    SlicedWassersteinKernel(bandwidth=0.7, n_directions=7),
    PersistenceScaleSpaceKernel(bandwidth=0.4),
    PersistenceWeightedGaussianKernel(bandwidth=0.6, weight="persistence"),
]
IDS = ["sliced-wasserstein", "scale-space", "weighted-gaussian"]


@pytest.mark.parametrize("kernel", ALL_KERNELS, ids=IDS)
@pytest.mark.parametrize("parts", [None, 2])
def test_transform_of_the_fitted_samples_is_fit_transform(kernel, parts):
    kernel = clone(kernel)
    samples = random_diagrams(11, seed=7, parts=parts)
    matrix = kernel.fit_transform(samples)
    assert matrix.shape == (11, 11) and matrix.dtype == np.float64
    np.testing.assert_array_equal(kernel.transform(samples), matrix)
    np.testing.assert_array_equal(matrix, matrix.T)
    block = kernel.transform(samples[3:7])
    np.testing.assert_array_equal(block, matrix[3:7])
    single = kernel.set_params(dtype="float32").fit_transform(samples)
    assert single.dtype == np.float32
    np.testing.assert_allclose(single, matrix, rtol=1e-6)


@pytest.mark.parametrize("kernel", ALL_KERNELS, ids=IDS)
def test_identical_for_any_n_jobs(kernel):
    kernel = clone(kernel)
    samples = random_diagrams(40, seed=8, parts=2)
    other = random_diagrams(9, seed=9, parts=2)
    reference = kernel.set_params(n_jobs=1).fit_transform(samples)
    cross = kernel.transform(other)
    parallel = kernel.set_params(n_jobs=2)
    np.testing.assert_array_equal(parallel.fit_transform(samples), reference)
    np.testing.assert_array_equal(parallel.transform(other), cross)
    with parallel_backend("threading", n_jobs=2):
        threads = kernel.set_params(n_jobs=None).fit_transform(samples)
    np.testing.assert_array_equal(threads, reference)


@pytest.mark.parametrize("kernel", ALL_KERNELS, ids=IDS)
def test_essential_points(kernel):
    kernel = clone(kernel)
    finite = random_diagrams(5, seed=10, sizes=(3, 2))
    with_essential = [d.copy() for d in finite]
    with_essential[1] = np.vstack([finite[1], [[0.25, np.inf]]])
    with_essential[3] = np.vstack([[[0.5, np.inf]], finite[3]])

    dropped = kernel.set_params(infinite="drop").fit_transform(with_essential)
    np.testing.assert_array_equal(dropped, kernel.fit_transform(finite))

    with pytest.raises(ValueError, match="sample 1, diagram 0: row 2 is an essential point"):
        kernel.set_params(infinite="error").fit(with_essential)
    kernel.set_params(infinite="error").fit(finite)
    with pytest.raises(ValueError, match="sample 1, diagram 0: row 0 is an essential point"):
        kernel.transform(with_essential[2:])

    # Clipped at the largest finite death of the fitted diagrams, at transform time too.
    clip = max(d[:, 1].max() for d in finite if len(d))
    clipped = [np.where(np.isinf(d), clip, d) for d in with_essential]
    kernel.set_params(infinite="clip")
    np.testing.assert_array_equal(
        kernel.fit_transform(with_essential), kernel.fit_transform(clipped)
    )
    kernel.fit(finite)
    assert kernel.clip_values_[0] == clip
    np.testing.assert_array_equal(kernel.transform(with_essential), kernel.transform(clipped))


def test_sliced_wasserstein_distance_with_essential_points():
    a = np.array([[0.0, 1.0], [0.5, np.inf], [0.1, np.inf]])
    b = np.array([[0.0, 1.2], [0.3, np.inf], [0.4, np.inf]])
    finite = sliced_wasserstein_distance(a[:1], b[:1], n_directions=4)
    # Essential births matched by sorted birth: |0.1 - 0.3| + |0.5 - 0.4|.
    assert sliced_wasserstein_distance(a, b, n_directions=4) == pytest.approx(finite + 0.3)
    assert np.isinf(sliced_wasserstein_distance(a, b[:2], n_directions=4))
    matrix = DiagramDistance(metric="sliced-wasserstein", n_directions=4).fit_transform(
        [a, b, b[:2]]
    )
    assert matrix[0, 1] == pytest.approx(finite + 0.3)
    assert np.isinf(matrix[0, 2]) and np.isinf(matrix[1, 2]) and matrix[2, 2] == 0


def test_sliced_wasserstein_median_normalization_sums_the_positions():
    samples = random_diagrams(8, seed=11, parts=2)
    est = DiagramDistance(metric="sliced-wasserstein", normalization="median")
    matrix = est.fit_transform(samples)
    per = [
        pairwise_diagram_distances([s[k] for s in samples], metric="sliced-wasserstein")
        for k in range(2)
    ]
    np.testing.assert_allclose(
        matrix, per[0] / est.scales_[0] + per[1] / est.scales_[1], rtol=1e-12
    )


@pytest.mark.parametrize(
    "kernel, new_params",
    [
        (SlicedWassersteinKernel(n_jobs=2), {"bandwidth": 2.0, "n_directions": 5}),
        (PersistenceScaleSpaceKernel(), {"bandwidth": 0.5, "essential": "clip"}),
        (PersistenceWeightedGaussianKernel(), {"weight": "persistence", "power": 2.0}),
    ],
    ids=IDS,
)
def test_clone_params_and_pickle(kernel, new_params, estimator_round_trip):
    samples = random_diagrams(6, seed=12)
    matrix = estimator_round_trip(kernel, samples, new_params, fit_X=samples[:4])
    assert matrix.shape == (6, 4)


@pytest.mark.parametrize(
    "kernel, message",
    [
        (SlicedWassersteinKernel(bandwidth=0.0), "bandwidth"),
        (SlicedWassersteinKernel(n_directions=0), "n_directions"),
        (PersistenceScaleSpaceKernel(infinite="keep"), "infinite"),
        (PersistenceWeightedGaussianKernel(weight="arctan"), "weight"),
        (PersistenceWeightedGaussianKernel(power=-1.0), "power"),
        (PersistenceWeightedGaussianKernel(dtype="float16"), "dtype"),
        (PersistenceWeightedGaussianKernel(weight=lambda d: d[:, 0]), None),
        (PersistenceWeightedGaussianKernel(weight=lambda d: d), "weight must map"),
        (
            PersistenceWeightedGaussianKernel(weight=lambda d: np.where(d[:, 0] > 0, 1, np.inf)),
            "is not finite",
        ),
    ],
)
def test_parameters_are_checked(kernel, message):
    diagrams = [np.array([[0.0, 1.0], [0.5, 0.7]]), np.array([[0.0, 2.0]])]
    if message is None:
        assert kernel.fit_transform(diagrams).shape == (2, 2)
        return
    with pytest.raises(ValueError, match=message):
        kernel.fit_transform(diagrams)


def test_distance_parameters_are_checked():
    diagrams = [np.array([[0.0, 1.0]]), np.array([[0.0, 2.0]])]
    with pytest.raises(ValueError, match="n_directions"):
        pairwise_diagram_distances(diagrams, metric="sliced-wasserstein", n_directions=0)
    with pytest.raises(ValueError, match="n_directions"):
        DiagramDistance(metric="sliced-wasserstein", n_directions=1.5).fit(diagrams)
    with pytest.raises(ValueError, match="n_directions"):
        sliced_wasserstein_distance(diagrams[0], diagrams[1], n_directions=0)
    # a line is a sort of every diagram: at most 10,000 of them (just above the cap, so
    # that a regression fails here rather than exhausting memory)
    with pytest.raises(ValueError, match="n_directions"):
        sliced_wasserstein_distance(diagrams[0], diagrams[1], n_directions=10_001)
    with pytest.raises(ValueError, match="n_directions"):
        DiagramDistance(metric="sliced-wasserstein", n_directions=10_001).fit(diagrams)
    with pytest.raises(ValueError, match="n_directions"):
        SlicedWassersteinKernel(n_directions=10_001).fit_transform(diagrams)


def toy_two_classes(n, seed):
    """Class 0: points near the diagonal; class 1: the same noise and one long bar."""
    rng = np.random.default_rng(seed)
    diagrams, labels = [], []
    for i in range(n):
        noise = random_diagram(rng, 5, scale=0.3)
        noise[:, 1] = noise[:, 0] + 0.2 * (noise[:, 1] - noise[:, 0])
        if i % 2:
            birth = rng.random()
            noise = np.vstack([noise, [[birth, birth + 2.0 + rng.random()]]])
        diagrams.append(noise)
        labels.append(i % 2)
    return diagrams, np.array(labels)


@pytest.mark.parametrize("kernel", ALL_KERNELS, ids=IDS)
def test_support_vector_machine_on_a_precomputed_kernel(kernel):
    train, y_train = toy_two_classes(20, seed=13)
    test, y_test = toy_two_classes(10, seed=14)
    model = make_pipeline(clone(kernel), SVC(kernel="precomputed")).fit(train, y_train)
    assert (model.predict(train) == y_train).all()
    assert (model.predict(test) == y_test).all()


@pytest.mark.parametrize("kernel", ALL_KERNELS, ids=IDS)
def test_feature_names_and_pandas_output(kernel):
    # One column per fitted sample, named after it; set_output(transform="pandas") used
    # to fail for want of get_feature_names_out.
    pd = pytest.importorskip("pandas")
    fitted, new = random_diagrams(5, seed=3), random_diagrams(3, seed=4)
    kernel = clone(kernel)
    prefix = type(kernel).__name__.lower()
    with pytest.raises(NotFittedError, match="not fitted"):
        kernel.get_feature_names_out()
    names = list(kernel.fit(fitted).get_feature_names_out())
    assert names == [f"{prefix}{i}" for i in range(5)]
    frame = kernel.set_output(transform="pandas").transform(new)
    assert isinstance(frame, pd.DataFrame) and list(frame.columns) == names
    np.testing.assert_array_equal(
        frame.to_numpy(), kernel.set_output(transform="default").transform(new)
    )
    square = kernel.set_output(transform="pandas").fit_transform(fitted)
    assert square.shape == (5, 5) and list(square.columns) == names
