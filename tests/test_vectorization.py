"""Vectorizations of diagrams: equal to gudhi.representations, stable, and well-behaved
scikit-learn transformers (feature names, pandas output, float32, parallel blocks)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from sklearn.base import clone
from sklearn.linear_model import LogisticRegression
from sklearn.model_selection import StratifiedKFold, cross_val_score
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler

from sklearn_meshph import (
    BettiCurve,
    DiagramStatistics,
    EntropyCurve,
    LaplacianEigenTransformer,
    LowerStarPersistence,
    PersistenceEntropy,
    PersistenceImage,
    PersistenceLandscape,
    PersistenceScaleSpaceKernel,
    PersistenceWeightedGaussianKernel,
    Silhouette,
    SlicedWassersteinKernel,
    make_shapes,
)

gudhi_rep = pytest.importorskip("gudhi.representations")

VECTORIZERS = [
    PersistenceImage(resolution=(6, 5)),
    PersistenceLandscape(resolution=12),
    Silhouette(resolution=12),
    BettiCurve(resolution=12),
    EntropyCurve(resolution=12),
    PersistenceEntropy(),
    DiagramStatistics(),
]


def random_diagrams(n, seed=0, max_points=15, empty=True):
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        k = int(rng.integers(0 if empty else 1, max_points))
        births = rng.normal(size=k)
        out.append(np.column_stack([births, births + rng.exponential(size=k)]))
    return out


def close(ours, theirs):
    theirs = np.asarray(theirs, dtype=float)
    scale = max(1.0, float(np.abs(theirs).max()))
    np.testing.assert_allclose(ours, theirs, rtol=1e-10, atol=1e-12 * scale)


@pytest.mark.parametrize("bandwidth", [0.3, 1.0])
@pytest.mark.parametrize("weight", ["constant", "persistence"])
def test_persistence_image_equals_gudhi(bandwidth, weight):
    diagrams = random_diagrams(30, seed=1)
    gudhi_weight = (lambda p: 1.0) if weight == "constant" else (lambda p: p[1])
    ours = PersistenceImage(bandwidth=bandwidth, resolution=(7, 4), weight=weight)
    theirs = gudhi_rep.PersistenceImage(bandwidth=bandwidth, weight=gudhi_weight, resolution=[7, 4])
    close(ours.fit_transform(diagrams), theirs.fit_transform(diagrams))
    np.testing.assert_allclose(ours.im_ranges_[0], theirs.im_range_fixed_, rtol=1e-15)
    # A given range, and transform on other diagrams.
    fixed = (-1.0, 2.0, 0.0, 1.5)
    ours = PersistenceImage(bandwidth=bandwidth, resolution=(5, 5), im_range=fixed, weight=weight)
    theirs = gudhi_rep.PersistenceImage(
        bandwidth=bandwidth, weight=gudhi_weight, resolution=[5, 5], im_range=list(fixed)
    )
    other = random_diagrams(10, seed=2)
    close(ours.fit(diagrams).transform(other), theirs.fit(diagrams).transform(other))


@pytest.mark.parametrize("bandwidth", [0.2, 1.0])
def test_pixel_images_equal_persims_imager(bandwidth):
    persim = pytest.importorskip("persim")
    diagrams = random_diagrams(20, seed=11)
    imager = persim.PersistenceImager(
        birth_range=(-2.0, 2.0),
        pers_range=(0.0, 3.0),
        pixel_size=0.25,
        kernel_params={"sigma": bandwidth**2},
    )
    theirs = np.array(imager.transform(diagrams, skew=True))  # (n, birth, persistence)
    ours = PersistenceImage(
        bandwidth=bandwidth,
        resolution=(16, 12),
        im_range=(-2.0, 2.0, 0.0, 3.0),
        sampling="pixel",
        weight="persistence",
    ).fit_transform(diagrams)
    assert theirs.max() > 0.05
    close(ours.reshape(-1, 12, 16), theirs.transpose(0, 2, 1))


@pytest.mark.parametrize("keep_endpoints", [False, True])
@pytest.mark.parametrize("n_landscapes", [1, 3, 20])
def test_landscapes_equal_gudhi(n_landscapes, keep_endpoints):
    diagrams = random_diagrams(25, seed=3)
    ours = PersistenceLandscape(n_landscapes, resolution=17, keep_endpoints=keep_endpoints)
    theirs = gudhi_rep.Landscape(n_landscapes, resolution=17, keep_endpoints=keep_endpoints)
    close(ours.fit_transform(diagrams), theirs.fit_transform(diagrams))
    np.testing.assert_allclose(ours.grids_[0], theirs.grid_, rtol=1e-15)
    ours = PersistenceLandscape(n_landscapes, resolution=9, sample_range=(-1.0, np.nan))
    theirs = gudhi_rep.Landscape(n_landscapes, resolution=9, sample_range=[-1.0, np.nan])
    close(ours.fit_transform(diagrams), theirs.fit_transform(diagrams))


@pytest.mark.parametrize("power", [0.0, 1.0, 2.5])
def test_silhouettes_equal_gudhi(power):
    diagrams = random_diagrams(25, seed=4, empty=False)  # gudhi: NaN on empty diagrams
    ours = Silhouette(power=power, resolution=21)
    theirs = gudhi_rep.Silhouette(weight=lambda p: (p[1] - p[0]) ** power, resolution=21)
    close(ours.fit_transform(diagrams), theirs.fit_transform(diagrams))
    assert not Silhouette().fit(diagrams).transform([np.empty((0, 2))]).any()


@pytest.mark.parametrize("keep_endpoints", [False, True])
def test_betti_curves_equal_gudhi(keep_endpoints):
    diagrams = random_diagrams(25, seed=5)
    ours = BettiCurve(resolution=33, keep_endpoints=keep_endpoints)
    theirs = gudhi_rep.BettiCurve(resolution=33, keep_endpoints=keep_endpoints)
    np.testing.assert_array_equal(ours.fit_transform(diagrams), theirs.fit_transform(diagrams))
    # Grid points that are births and deaths themselves (half-open intervals).
    grid_points = [np.array([[0.0, 1.0], [1.0, 2.0], [0.0, 2.0]])]
    ours = BettiCurve(resolution=5, sample_range=(0.0, 2.0))
    theirs = gudhi_rep.BettiCurve(resolution=5, sample_range=[0.0, 2.0])
    np.testing.assert_array_equal(
        ours.fit_transform(grid_points), theirs.fit_transform(grid_points)
    )


def test_entropy_equals_gudhi_and_its_curve_follows_the_definition():
    diagrams = random_diagrams(25, seed=6, empty=False)
    close(
        PersistenceEntropy().fit_transform(diagrams),
        gudhi_rep.Entropy(mode="scalar").fit_transform(diagrams),
    )
    curve = EntropyCurve(resolution=15, normalized=False).fit(diagrams)
    values = curve.transform(diagrams)
    for diagram, row in zip(diagrams, values, strict=True):
        shares = (diagram[:, 1] - diagram[:, 0]) / (diagram[:, 1] - diagram[:, 0]).sum()
        alive = (diagram[:, :1] <= curve.grids_[0]) & (curve.grids_[0] < diagram[:, 1:])
        np.testing.assert_allclose(row, (-shares * np.log(shares)) @ alive, atol=1e-12)
    normalized = EntropyCurve(resolution=15).fit_transform(diagrams)
    positive = values.sum(axis=1) > 0  # a single point has entropy 0 everywhere
    assert positive.sum() >= 20
    np.testing.assert_allclose(normalized[positive].sum(axis=1), 1.0)
    assert not normalized[~positive].any()
    # normalized entropy lies in [0, 1]; n equal points give exactly 1
    assert PersistenceEntropy(normalized=True).fit_transform(
        [np.array([[0.0, 1.0]] * 4)]
    ) == pytest.approx(1.0)


def test_statistics_by_hand():
    diagram = np.array([[0.0, 1.0], [1.0, 4.0], [2.0, 2.5]])
    stats = DiagramStatistics(quantiles=(0.0, 0.5, 1.0)).fit([diagram])
    row = stats.transform([diagram, np.empty((0, 2))])
    np.testing.assert_allclose(row[0], [3, 4.5, 3, 1.5, 0.5, 1, 3, 1, 2.5])
    assert not row[1].any()
    assert len(stats.get_feature_names_out()) == row.shape[1]


@pytest.mark.parametrize("vectorizer", VECTORIZERS, ids=lambda v: type(v).__name__)
def test_tuples_are_the_positions_side_by_side_each_with_its_own_grid(vectorizer):
    first, second = random_diagrams(12, seed=7), random_diagrams(12, seed=8)
    second = [100.0 * d for d in second]  # another scale: its own learned range
    pairs = list(zip(first, second, strict=True))
    together = vectorizer.fit(pairs).transform(pairs)
    alone = np.hstack(
        [vectorizer.fit(first).transform(first), vectorizer.fit(second).transform(second)]
    )
    np.testing.assert_allclose(together, alone, rtol=1e-12)


@pytest.mark.parametrize("vectorizer", VECTORIZERS, ids=lambda v: type(v).__name__)
def test_sklearn_contract(vectorizer, estimator_round_trip):
    pairs = list(zip(random_diagrams(40, seed=9), random_diagrams(40, seed=10), strict=True))
    features = vectorizer.fit(pairs).transform(pairs)
    names = vectorizer.get_feature_names_out()
    assert features.shape == (40, len(names)) and len(set(names)) == len(names)
    assert np.isfinite(features).all()
    # pandas output names its columns
    pandas = pytest.importorskip("pandas")
    frame = vectorizer.set_output(transform="pandas").transform(pairs)
    assert isinstance(frame, pandas.DataFrame) and list(frame.columns) == list(names)
    vectorizer.set_output(transform="default")
    # float32 on request, identical blocks for any n_jobs
    single = vectorizer.set_params(dtype="float32", n_jobs=1).fit(pairs).transform(pairs)
    assert single.dtype == np.float32
    np.testing.assert_array_equal(single, features.astype(np.float32))
    vectorizer.set_params(dtype="float64", n_jobs=2)
    np.testing.assert_array_equal(vectorizer.fit(pairs).transform(pairs), features)
    vectorizer.set_params(n_jobs=None)
    estimator_round_trip(vectorizer, pairs, {"infinite": "clip"})


def test_essential_policies():
    diagrams = [np.array([[0.0, 1.0], [0.5, np.inf]]), np.array([[0.0, 3.0]])]
    stats = DiagramStatistics(quantiles=())
    dropped = stats.fit_transform(diagrams)
    assert dropped[0, 0] == 1  # one finite point counted
    clipped = stats.set_params(infinite="clip").fit_transform(diagrams)
    assert clipped[0, 0] == 2 and clipped[0, 2] == pytest.approx(2.5)  # clipped at 3.0
    with pytest.raises(ValueError, match=r"sample 0, diagram 0: row 1 is an essential"):
        stats.set_params(infinite="error").fit(diagrams)


def test_malformed_diagrams_name_the_sample():
    with pytest.raises(ValueError, match="sample 1"):
        PersistenceImage().fit([np.zeros((1, 2)), np.array([[1.0, 0.0]])])
    with pytest.raises(ValueError, match="diagrams per sample"):
        PersistenceLandscape().fit([np.zeros((1, 2))]).transform([(np.zeros((1, 2)),) * 2])
    with pytest.raises(ValueError, match="resolution"):
        PersistenceImage(resolution=(0, 3)).fit([np.zeros((1, 2))])


def diagram_strategy():
    point = st.tuples(st.floats(-5, 5, allow_nan=False), st.floats(0, 5, allow_nan=False)).map(
        lambda bp: (bp[0], bp[0] + bp[1])
    )
    return st.lists(point, min_size=1, max_size=8).map(lambda p: np.array(p, dtype=float))


@settings(max_examples=60, deadline=None)
@given(diagram_strategy(), st.floats(0, 0.05), st.integers(0, 2**32 - 1))
def test_landscapes_silhouettes_and_images_are_stable(diagram, eps, seed):
    # Moving every point by at most eps (L-infinity; persistence kept >= 0) moves the
    # diagram by at most eps in bottleneck distance; landscapes and silhouettes then
    # move by at most sqrt(2) eps (sup norm), a constant-weight image by at most
    # n sqrt(5) eps max|grad g| (g the Gaussian).
    rng = np.random.default_rng(seed)
    moved = diagram + rng.uniform(-eps, eps, size=diagram.shape)
    moved[:, 1] = np.maximum(moved[:, 1], moved[:, 0])
    both = [diagram, moved]
    fixed = (-6.0, 11.0)
    for vectorizer in (
        PersistenceLandscape(3, resolution=50, sample_range=fixed),
        Silhouette(power=0.0, resolution=50, sample_range=fixed),
    ):
        a, b = vectorizer.fit(both).transform(both)
        assert np.abs(a - b).max() <= np.sqrt(2) * eps + 1e-12
    sigma = 0.5
    image = PersistenceImage(bandwidth=sigma, resolution=(10, 10), im_range=(-6, 6, 0, 6))
    a, b = image.fit(both).transform(both)
    gradient = np.exp(-0.5) / (2 * np.pi * sigma**3)
    assert np.abs(a - b).max() <= len(diagram) * np.sqrt(5) * eps * gradient + 1e-12


def test_a_linear_model_on_images_of_mesh_diagrams():
    meshes, y = make_shapes(n_per_class=5, random_state=1, return_X_y=True)
    model = make_pipeline(
        LaplacianEigenTransformer(signature="log-hks", n_eigenpairs=30, n_scales=3),
        LowerStarPersistence(filtration="extended", parts=("superlevel H0 (saddle, max)",)),
        PersistenceImage(bandwidth=0.2, resolution=(8, 8), weight="persistence"),
        StandardScaler(),
        LogisticRegression(max_iter=2000),
    )
    scores = cross_val_score(model, meshes, y, cv=StratifiedKFold(5))
    assert scores.mean() >= 0.8  # chance is 1/6


def rips_h0_like(n, seed=0):
    """Diagrams whose births are all 0, as Rips H0 diagrams are."""
    rng = np.random.default_rng(seed)
    return [np.column_stack([np.zeros(5), rng.uniform(0.1, 2.0, 5)]) for _ in range(n)]


@pytest.mark.parametrize("sampling", ["point", "pixel"])
def test_images_of_equal_births_are_not_zero(sampling):
    # A learned birth axis of zero width used to give pixels of zero width: all zeros.
    diagrams = rips_h0_like(4)
    image = PersistenceImage(bandwidth=0.3, resolution=(5, 5), sampling=sampling)
    features = image.fit_transform(diagrams)
    assert (features.sum(axis=1) > 0).all()
    lo, hi = image.im_ranges_[0, :2]
    assert lo == -0.3 and hi == 0.3  # widened by the bandwidth on each side


EDGE_ESTIMATORS = [
    PersistenceImage(resolution=(4, 4)),
    PersistenceImage(resolution=(4, 4), sampling="pixel"),
    PersistenceLandscape(resolution=8),
    Silhouette(resolution=8),
    BettiCurve(resolution=8),
    EntropyCurve(resolution=8),
    PersistenceEntropy(),
    DiagramStatistics(),
    SlicedWassersteinKernel(),
    PersistenceScaleSpaceKernel(),
    PersistenceWeightedGaussianKernel(weight="persistence"),
]
EDGE_IDS = [
    "image",
    "pixel-image",
    "landscape",
    "silhouette",
    "betti",
    "entropy-curve",
    "entropy",
    "statistics",
    "sliced",
    "scale-space",
    "weighted",
]
EDGE_DIAGRAMS = [np.array([[0.0, 1.0], [0.5, 2.0]]), np.array([[0.2, 0.3]]), np.empty((0, 2))]


def _settings(estimator):
    """The edge settings of the parameters ``estimator`` has, each with the words its
    error must hold."""
    params = estimator.get_params()
    cases = []
    if "bandwidth" in params:
        cases += [({"bandwidth": b}, "bandwidth") for b in (1e-170, np.inf, 1e300, 0.0, -1.0)]
    if "sample_range" in params:
        for bad in [(2.0, 1.0), (0.0, np.inf), (-np.inf, 1.0), (1.0, 1.0), (None, -5.0)]:
            cases.append(({"sample_range": bad}, "sample_range"))
    if "im_range" in params:
        for bad in [(1, 0, 0, 1), (0, 1, 1, 0), (0, np.inf, 0, 1), (0, 1, -np.inf, 1)]:
            cases.append(({"im_range": bad}, "im_range"))
    return cases


@pytest.mark.parametrize("estimator", EDGE_ESTIMATORS, ids=EDGE_IDS)
def test_parameters_at_the_edges_are_refused_clearly(estimator):
    for params, words in _settings(estimator):
        with pytest.raises(ValueError, match=words):
            clone(estimator).set_params(**params).fit(EDGE_DIAGRAMS)


@pytest.mark.parametrize("estimator", EDGE_ESTIMATORS, ids=EDGE_IDS)
@pytest.mark.parametrize("scale", [1e-300, 1e150, 1e300, 1e307, 1e308])
def test_extreme_points_give_finite_values_or_a_clear_error(estimator, scale):
    with np.errstate(over="ignore"):  # a death beyond float64 is an essential point
        diagrams = [d * scale for d in EDGE_DIAGRAMS] + [np.array([[-scale, scale]])]
    try:
        values = clone(estimator).fit_transform(diagrams)
    except ValueError as error:
        assert "rescale the diagrams" in str(error) and "sample " in str(error)
        return
    assert np.isfinite(values).all()


def test_bandwidth_at_the_edges_of_its_range_gives_finite_values():
    for bandwidth in (1.5e-154, 1e-150, 1e150):
        for estimator in EDGE_ESTIMATORS:
            if "bandwidth" in estimator.get_params():
                values = (
                    clone(estimator).set_params(bandwidth=bandwidth).fit_transform(EDGE_DIAGRAMS)
                )
                assert np.isfinite(values).all()


CLIP_SAMPLES = [
    (np.array([[0.0, 1.0], [0.2, np.inf]]), np.array([[0.5, np.inf]])),
    (np.array([[0.3, 2.0]]), np.array([[0.1, np.inf], [0.4, np.inf]])),
]


@pytest.mark.parametrize("shift", [-7.5, 3.0, 1000.0])
def test_clipping_does_not_depend_on_the_origin(shift):
    # Position 1 holds only essential points: they used to be clipped at 0 wherever the
    # diagrams were, so their persistence changed with a translation.
    moved = [tuple(d + shift for d in sample) for sample in CLIP_SAMPLES]
    stats = DiagramStatistics(quantiles=(0.5,), infinite="clip")
    names = list(stats.fit(CLIP_SAMPLES).get_feature_names_out())
    here, there = stats.transform(CLIP_SAMPLES), stats.fit(moved).transform(moved)
    moving = [k for k, name in enumerate(names) if "birth" in name or "death" in name]
    fixed = [k for k in range(len(names)) if k not in moving]
    np.testing.assert_allclose(there[:, fixed], here[:, fixed], atol=1e-9)
    np.testing.assert_allclose(there[:, moving], here[:, moving] + shift, atol=1e-9)


@pytest.mark.parametrize(
    "estimator",
    [PersistenceEntropy(), SlicedWassersteinKernel(), PersistenceScaleSpaceKernel()],
    ids=["entropy", "sliced", "scale-space"],
)
def test_clipped_shape_functions_ignore_a_translation(estimator):
    moved = [tuple(d - 7.5 for d in sample) for sample in CLIP_SAMPLES]
    estimator = clone(estimator).set_params(infinite="clip")
    np.testing.assert_allclose(
        estimator.fit_transform(moved), estimator.fit_transform(CLIP_SAMPLES), rtol=1e-9
    )


def test_essential_is_the_old_name_of_infinite():
    diagrams = [np.array([[0.0, 1.0], [0.5, np.inf]]), np.array([[0.0, 3.0]])]
    with pytest.warns(FutureWarning, match="renamed infinite"):
        old = DiagramStatistics(essential="clip").fit_transform(diagrams)
    np.testing.assert_array_equal(old, DiagramStatistics(infinite="clip").fit_transform(diagrams))


def test_one_weight_convention_for_images_and_kernels():
    # A callable weight receives (birth, death) rows, in images as in kernels.
    diagrams = [np.array([[1.0, 2.0], [1.5, 4.0]]), np.array([[2.0, 2.5]])]
    persistence = lambda d: d[:, 1] - d[:, 0]  # noqa: E731
    for estimator in (
        PersistenceImage(resolution=(4, 4)),
        PersistenceWeightedGaussianKernel(),
    ):
        called = clone(estimator).set_params(weight=persistence).fit_transform(diagrams)
        named = clone(estimator).set_params(weight="persistence").fit_transform(diagrams)
        np.testing.assert_allclose(called, named, rtol=1e-12)


@pytest.mark.parametrize(
    ("estimator", "message"),
    [
        (
            "BettiCurve(resolution=2**20 + 1)",
            r"'resolution' parameter of BettiCurve must be an int in the range \[1, 1048576\]",
        ),
        ("Silhouette(resolution=10**12)", r"'resolution' parameter of Silhouette"),
        ("EntropyCurve(resolution=10**12)", r"'resolution' parameter of EntropyCurve"),
        ("PersistenceLandscape(n_landscapes=10**9)", r"'n_landscapes' parameter"),
        (
            "PersistenceLandscape(n_landscapes=4096, resolution=8192)",
            r"n_landscapes \* resolution = 4096 \* 8192 values per diagram, more than MAX_LANDSC",
        ),
        (
            "PersistenceImage(resolution=(100000, 100000))",
            r"resolution must be 2 ints from 1 to 4096 \(MAX_PIXELS\)",
        ),
        ("PersistenceImage(resolution=(True, 2))", r"'resolution' parameter of PersistenceImage"),
    ],
)
def test_sizes_beyond_memory_are_refused_by_name(estimator, message):
    """Each of these reached numpy as a raw MemoryError (or a bool passed as an int)."""
    import sklearn_meshph

    model = eval(estimator, vars(sklearn_meshph))
    with pytest.raises(ValueError, match=message):
        model.fit([np.array([[0.0, 1.0]])])


def test_signature_scales_are_bounded():
    from sklearn_meshph import LaplacianEigenTransformer
    from sklearn_meshph.spectral.signatures import MAX_SCALES, check_times

    with pytest.raises(ValueError, match=r"'n_scales' parameter"):
        LaplacianEigenTransformer(signature="hks", n_scales=MAX_SCALES + 1).fit([])
    with pytest.raises(ValueError, match=r"times holds 1025 times, more than MAX_SCALES"):
        check_times(np.ones(MAX_SCALES + 1))
    assert len(check_times(np.ones(MAX_SCALES))) == MAX_SCALES


def test_sequences_of_numbers_may_be_arrays():
    """A 1-D array where a sequence of numbers is documented was refused by the
    parameter checks (tuple or list only)."""
    from sklearn_meshph import DiagramStatistics, make_graph_classifier, make_shapes

    diagrams = [np.array([[0.0, 1.0]]), np.array([[0.2, 0.5]])]
    as_arrays = [
        (PersistenceImage(resolution=np.array([3, 2]), im_range=np.array([0, 1, 0, 1])), {}),
        (BettiCurve(sample_range=np.array([0.0, 1.0])), {}),
        (DiagramStatistics(quantiles=np.array([0.5])), {}),
    ]
    for model, _ in as_arrays:
        as_tuple = clone(model).set_params(
            **{k: tuple(v) for k, v in model.get_params().items() if isinstance(v, np.ndarray)}
        )
        np.testing.assert_array_equal(
            model.fit_transform(diagrams), as_tuple.fit_transform(diagrams)
        )
    assert len(make_graph_classifier(times=np.array([0.1, 10.0])).get_params()["eigen__times"]) == 2
    assert len(make_shapes(1, resolution=np.array([8, 16]), return_X_y=True)[0]) == 6


@pytest.mark.parametrize(
    "make",
    [
        "KernelSumSVC(C=np.array(1.0))",
        "KernelSumSVC(C=np.ones((2, 1)))",
        "PersistenceImage(resolution=np.array(5))",
        "PersistenceImage(im_range=np.ones((4, 1)))",
        "PersistenceImage(im_range=np.array(['0', '1', '0', '1']))",
        "BettiCurve(sample_range=np.array(1.0))",
        "BettiCurve(sample_range=(True, 1.0))",
        "DiagramStatistics(quantiles=('0.5',))",
        "PersistenceLandscape(n_landscapes=np.int32(4096), resolution=np.int32(2**20))",
    ],
)
def test_badly_shaped_sequences_are_refused_by_name(make):
    """Found by an adversarial review: accepting 1-D arrays let 0-d, 2-D and string
    arrays through to raw TypeErrors, and an int32 product wrapped past the size bound."""
    import sklearn_meshph
    from sklearn_meshph import KernelSumSVC  # noqa: F401 (named in the strings)

    model = eval(make, {**vars(sklearn_meshph), "np": np})
    data = np.zeros((4, 4, 1)) if make.startswith("Kernel") else [np.array([[0.0, 1.0]])]
    target = [0, 0, 1, 1] if make.startswith("Kernel") else None
    with pytest.raises(ValueError, match=r"parameter of|more than MAX_LANDSCAPE"):
        model.fit(data, target)


def test_make_shapes_resolution_is_checked():
    from sklearn_meshph import make_shapes

    for bad in ((1, 1), (5, 6, 7), (0, 0), (3000, 3000), (40, 18), np.array([[5, 6]])):
        with pytest.raises(ValueError, match="resolution"):
            make_shapes(1, resolution=bad)


@pytest.mark.parametrize(
    "vectorizer",
    [
        DiagramStatistics(dtype="float32"),
        PersistenceImage(dtype="float32", bandwidth=1e-30, im_range=(0, 1, 0, 1)),
    ],
    ids=["statistics", "image"],
)
def test_float32_output_that_overflows_is_refused_by_sample(vectorizer):
    """The float64 values were checked, then cast: entries past 3.4e38 became inf."""
    X = [np.array([[0.0, 1.0]]), np.array([[0.0, 1e300]])]
    if isinstance(vectorizer, PersistenceImage):
        X = [np.array([[0.0, 1.0]]), np.array([[0.0, 0.0]])]
    with pytest.raises(ValueError, match=r"sample \d: its .* overflow float32"):
        vectorizer.fit_transform(X)
    assert np.isfinite(clone(vectorizer).set_params(dtype="float64").fit_transform(X)).all()


@pytest.mark.parametrize("resolution", [3, 4, 20])
def test_an_image_axis_of_zero_width_at_1e20_still_sees_the_points(resolution):
    """Persistence 1e20 for every point: widened by the bandwidth (1e20 +- 1 == 1e20)
    the axis kept zero width, and every pixel was 0. Pixels are widened by float64
    steps; grid points stay on the points (widened, an even grid stepped over them)."""
    X = [np.array([[5.0, 5 + 1e20]]), np.array([[7.0, 7 + 1e20]])]
    pixel = PersistenceImage(sampling="pixel", resolution=(3, resolution)).fit(X)
    lo, hi = pixel.im_ranges_[0, 2:]
    assert lo < 1e20 < hi
    point = PersistenceImage(resolution=(3, resolution)).fit(X)  # sampling="point"
    for image in (pixel, point):
        values = image.transform(X).reshape(2, resolution, 3)  # persistence rows
        assert (values.sum(axis=(1, 2)) > 0).all()
        assert not np.array_equal(values[0], values[1])  # births 5 and 7 told apart


def test_feature_names_follow_the_fitted_grid_after_set_params():
    """The names were counted from ``resolution`` as set now, the columns from the grid
    fitted: a pandas output then failed on the length mismatch."""
    from sklearn_meshph import PersistenceLandscape

    D = [np.array([[0.0, 1.0], [0.2, 0.5]]), np.array([[0.0, 2.0]])]
    for model in (BettiCurve(resolution=100), PersistenceLandscape(resolution=10)):
        model.fit(D).set_params(resolution=3)
        assert model.transform(D).shape[1] == len(model.get_feature_names_out())
        assert model.set_output(transform="pandas").transform(D).shape[0] == 2


def test_weights_that_are_not_numbers_and_ragged_distances_name_the_problem():
    from sklearn_meshph import DistanceKernel

    image = PersistenceImage(weight=lambda rows: ["a"] * len(rows))
    with pytest.raises(ValueError, match="sample 0, diagram 0: weight must map .* numbers"):
        image.fit_transform([np.array([[0.0, 1.0]])])
    with pytest.raises(ValueError, match="X must be a rectangular array of distances"):
        DistanceKernel().fit_transform([[0, 1], [1]])
