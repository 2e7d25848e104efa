"""DiagramDistance: matrices, the combination rule, backends, immutability, estimator API."""

import numpy as np
import pytest
from joblib import parallel_backend
from sklearn.exceptions import NotFittedError

from sklearn_meshph import (
    DiagramDistance,
    bottleneck_distance,
    pairwise_diagram_distances,
    wasserstein_distance,
)


def random_diagrams(n, seed=0, parts=None):
    rng = np.random.default_rng(seed)

    def one():
        k = int(rng.integers(0, 12))
        births = rng.random(k)
        return np.column_stack([births, births + rng.random(k)])

    return [one() if parts is None else tuple(one() for _ in range(parts)) for _ in range(n)]


@pytest.mark.parametrize(
    "metric, pair",
    [("bottleneck", bottleneck_distance), ("wasserstein", wasserstein_distance)],
)
def test_fit_transform_is_the_symmetric_pairwise_matrix(metric, pair):
    diagrams = random_diagrams(12)
    matrix = DiagramDistance(metric=metric).fit_transform(diagrams)
    expected = np.array([[pair(a, b) for b in diagrams] for a in diagrams])
    np.testing.assert_array_equal(matrix, matrix.T)
    np.testing.assert_array_equal(np.diag(matrix), 0)
    np.testing.assert_allclose(matrix, expected, rtol=1e-12)


def test_transform_returns_distances_to_the_fitted_diagrams():
    train, test = random_diagrams(7, seed=1), random_diagrams(3, seed=2)
    est = DiagramDistance().fit(train)
    block = est.transform(test)
    assert block.shape == (3, 7)
    expected = [[bottleneck_distance(a, b) for b in train] for a in test]
    np.testing.assert_array_equal(block, expected)


def test_several_diagrams_combine_as_a_typed_union():
    samples = random_diagrams(6, seed=3, parts=3)
    bottleneck = DiagramDistance().fit_transform(samples)
    wasserstein = DiagramDistance(metric="wasserstein", order=2.0).fit_transform(samples)
    for i in range(6):
        for j in range(6):
            parts = [bottleneck_distance(a, b) for a, b in zip(samples[i], samples[j], strict=True)]
            assert bottleneck[i, j] == max(parts)
            w = [wasserstein_distance(a, b) for a, b in zip(samples[i], samples[j], strict=True)]
            assert wasserstein[i, j] == pytest.approx(np.sqrt(np.sum(np.square(w))))


def test_identical_for_any_n_jobs_and_backend():
    diagrams = random_diagrams(25, seed=4)
    reference = DiagramDistance(metric="wasserstein").fit_transform(diagrams)
    np.testing.assert_array_equal(
        DiagramDistance(metric="wasserstein", n_jobs=2).fit_transform(diagrams), reference
    )
    with parallel_backend("threading", n_jobs=2):
        np.testing.assert_array_equal(
            DiagramDistance(metric="wasserstein").fit_transform(diagrams), reference
        )


def test_inputs_are_never_mutated():
    diagrams = random_diagrams(10, seed=5)
    for d in diagrams:
        d.setflags(write=False)  # as joblib's read-only memory maps
    copies = [d.copy() for d in diagrams]
    DiagramDistance(n_jobs=2).fit(diagrams).transform(diagrams)
    for d, c in zip(diagrams, copies, strict=True):
        np.testing.assert_array_equal(d, c)


def test_infinite_and_empty_diagrams():
    diagrams = [np.array([[0.0, np.inf]]), np.array([[0.5, np.inf]]), np.empty((0, 2))]
    matrix = DiagramDistance().fit_transform(diagrams)
    assert matrix[0, 1] == 0.5 and np.isinf(matrix[0, 2]) and np.isinf(matrix[1, 2])


def test_mismatched_samples_are_rejected():
    with pytest.raises(ValueError, match="different numbers of diagrams"):
        DiagramDistance().fit_transform([(np.zeros((0, 2)),), (np.zeros((0, 2)),) * 2])
    est = DiagramDistance().fit(random_diagrams(3, parts=2))
    with pytest.raises(ValueError, match="X has 1 diagrams per sample, the fitted data 2"):
        est.transform(random_diagrams(2))
    with pytest.raises(ValueError, match="sample 1: .*row 0 contains NaN"):
        DiagramDistance().fit([np.zeros((1, 2)), np.array([[np.nan, 1.0]])])


def test_clone_params_and_pickle(estimator_round_trip):
    est = DiagramDistance(metric="wasserstein", order=1.0, n_jobs=2)
    diagrams = random_diagrams(5)
    matrix = estimator_round_trip(
        est, diagrams, {"metric": "bottleneck", "order": 3.0}, fit_X=diagrams[:3]
    )
    expected = [[wasserstein_distance(a, b, order=1.0) for b in diagrams[:3]] for a in diagrams]
    np.testing.assert_allclose(matrix, expected, rtol=1e-12)
    with pytest.raises(ValueError, match="metric"):
        DiagramDistance(metric="cosine").fit(diagrams)


def test_identical_on_a_dask_cluster():
    distributed = pytest.importorskip("dask.distributed")
    from sklearn_meshph import LaplacianEigenTransformer, LowerStarPersistence, make_shapes

    meshes, _ = make_shapes(n_per_class=1, random_state=0, return_X_y=True)
    diagrams = random_diagrams(20, seed=6, parts=2)
    local_fields = LaplacianEigenTransformer(eigen_index=1).fit_transform(meshes)
    local = DiagramDistance(metric="wasserstein").fit_transform(diagrams)
    with (
        distributed.LocalCluster(
            n_workers=2, threads_per_worker=1, dashboard_address=None
        ) as cluster,
        distributed.Client(cluster),
        parallel_backend("dask"),
    ):
        remote = DiagramDistance(metric="wasserstein", n_jobs=-1).fit_transform(diagrams)
        fields = LaplacianEigenTransformer(eigen_index=1, n_jobs=-1).fit_transform(meshes)
        remote_diagrams = LowerStarPersistence(n_jobs=-1).fit_transform(fields)
    np.testing.assert_array_equal(remote, local)
    for a, b in zip(fields, local_fields, strict=True):
        np.testing.assert_array_equal(a.values, b.values)
    local_diagrams = LowerStarPersistence().fit_transform(local_fields)
    assert len(remote_diagrams) == len(local_diagrams) == len(meshes)
    for a, b in zip(remote_diagrams, local_diagrams, strict=True):
        for part_a, part_b in zip(a, b, strict=True):
            np.testing.assert_array_equal(part_a, part_b)


@pytest.mark.parametrize("backend", ["multiprocessing", "loky", "threading"])
def test_identical_for_every_joblib_backend(backend):
    """multiprocessing cannot hand results back one block at a time: all at once then."""
    diagrams = random_diagrams(30, seed=8, parts=2)
    serial = DiagramDistance(metric="wasserstein").fit_transform(diagrams)
    with parallel_backend(backend, n_jobs=2):
        parallel = DiagramDistance(metric="wasserstein", n_jobs=2).fit_transform(diagrams)
    np.testing.assert_array_equal(parallel, serial)


def test_many_blocks_float32_and_memmap_output(tmp_path):
    """Rows are split into a few blocks of pairs per worker: 1, 2 and 15 workers give
    4 to 60 blocks of 60 samples, and the same matrices in every layout."""
    diagrams = random_diagrams(60, seed=7)
    samples = [(d,) for d in diagrams]
    reference = np.array([[bottleneck_distance(a, b) for b in diagrams] for a in diagrams])
    for n_jobs in (1, 2, 15):
        with parallel_backend("threading", n_jobs=n_jobs):
            np.testing.assert_array_equal(DiagramDistance().fit_transform(diagrams), reference)
            single = DiagramDistance(dtype="float32").fit_transform(diagrams)
            assert single.dtype == np.float32
            np.testing.assert_allclose(single, reference, rtol=1e-6)
            path = tmp_path / f"{n_jobs}.npy"
            out = np.lib.format.open_memmap(path, mode="w+", shape=(60, 60))
            assert pairwise_diagram_distances(samples, out=out) is out
            out.flush()
            np.testing.assert_array_equal(np.load(path), reference)
            rectangle = DiagramDistance().fit(diagrams[:7]).transform(diagrams)
            np.testing.assert_array_equal(rectangle, reference[:, :7])
            wide = pairwise_diagram_distances(diagrams[:3], samples)
            np.testing.assert_array_equal(wide, reference[:3])
    # Worker processes, as the default backend gives.
    np.testing.assert_array_equal(DiagramDistance(n_jobs=2).fit_transform(diagrams), reference)
    with pytest.raises(ValueError, match=r"out has shape \(60, 59\), expected \(60, 60\)"):
        pairwise_diagram_distances(samples, out=np.zeros((60, 59)))


@pytest.mark.parametrize(
    "metric, order", [("bottleneck", 2.0), ("wasserstein", 1.0), ("wasserstein", 2.0)]
)
def test_median_normalization_divides_each_position_by_its_median(metric, order):
    fitted, other = random_diagrams(9, seed=1, parts=3), random_diagrams(4, seed=2, parts=3)
    est = DiagramDistance(metric=metric, order=order, normalization="median")
    matrix = est.fit_transform(fitted)
    # Independently: each position's own matrix, its median over the fitted pairs.
    per = [
        pairwise_diagram_distances([s[k] for s in fitted], metric=metric, order=order)
        for k in range(3)
    ]
    scales = [np.median(m[np.triu_indices(9, 1)][m[np.triu_indices(9, 1)] > 0]) for m in per]
    np.testing.assert_allclose(est.scales_, scales, rtol=1e-12)
    scaled = [m / s for m, s in zip(per, scales, strict=True)]
    if metric == "bottleneck":
        expected = np.maximum.reduce(scaled)
    else:
        expected = sum(m**order for m in scaled) ** (1 / order)
    np.testing.assert_allclose(matrix, expected, rtol=1e-12)
    np.testing.assert_allclose(est.transform(fitted), matrix, rtol=1e-12, atol=1e-15)
    cross = [
        pairwise_diagram_distances(
            [s[k] for s in other], [s[k] for s in fitted], metric=metric, order=order
        )
        / scales[k]
        for k in range(3)
    ]
    expected = (
        np.maximum.reduce(cross)
        if metric == "bottleneck"
        else sum(m**order for m in cross) ** (1 / order)
    )
    np.testing.assert_allclose(est.fit(fitted).transform(other), expected, rtol=1e-12)


@pytest.mark.parametrize("metric", ["bottleneck", "wasserstein"])
def test_median_normalization_ignores_the_scale_of_each_position(metric):
    # Positions measured in different units (a signature at two times): multiplying the
    # values of one position's diagrams by 1000 changes nothing after normalization, and
    # everything without it.
    samples = random_diagrams(8, seed=4, parts=2)
    stretched = [(a, 1000.0 * b) for a, b in samples]
    est = DiagramDistance(metric=metric, order=1.0, normalization="median")
    np.testing.assert_allclose(est.fit_transform(stretched), est.fit_transform(samples), rtol=1e-10)
    plain = DiagramDistance(metric=metric, order=1.0)
    assert not np.allclose(plain.fit_transform(stretched), plain.fit_transform(samples))


def test_median_normalization_of_a_position_that_separates_nothing():
    # Identical (or empty) diagrams at a position: scale 1, no NaN, the other counts alone.
    samples = [(d, np.empty((0, 2))) for d in random_diagrams(5, seed=5)]
    est = DiagramDistance(metric="wasserstein", order=1.0, normalization="median")
    matrix = est.fit_transform(samples)
    assert est.scales_[1] == 1.0 and np.isfinite(matrix).all()
    expected = DiagramDistance(metric="wasserstein", order=1.0).fit_transform(
        [s[0] for s in samples]
    )
    np.testing.assert_allclose(matrix, expected / est.scales_[0], rtol=1e-12)


def test_infinite_order_with_median_normalization_takes_the_maximum():
    """The l_inf norm of the scaled per-position distances, not all ones (the old
    ``(sum d^q)^(1/q)`` at ``q = inf``)."""
    samples = random_diagrams(7, seed=6, parts=3)
    est = DiagramDistance(metric="wasserstein", order=np.inf, normalization="median")
    matrix = est.fit_transform(samples)
    per = [pairwise_diagram_distances([s[k] for s in samples]) for k in range(3)]
    expected = np.maximum.reduce([m / s for m, s in zip(per, est.scales_, strict=True)])
    np.testing.assert_allclose(matrix, expected, rtol=1e-12)
    assert len(np.unique(matrix[np.triu_indices(7, 1)])) > 1
    bottleneck = DiagramDistance(metric="bottleneck", normalization="median")
    np.testing.assert_allclose(matrix, bottleneck.fit_transform(samples), rtol=1e-12)
    np.testing.assert_allclose(est.transform(samples[:2]), matrix[:2], rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize(
    "change",
    [{"metric": "wasserstein"}, {"order": 1.0}, {"normalization": "none"}, {"internal_p": 2.0}],
)
def test_transform_refuses_distance_parameters_changed_after_fit(change):
    samples = random_diagrams(6, seed=7, parts=2)
    est = DiagramDistance(metric="bottleneck", normalization="median").fit(samples)
    reference = est.transform(samples[:2])
    est.set_params(n_jobs=2, verbose=0, dtype="float32")  # how, not what: allowed
    np.testing.assert_allclose(est.transform(samples[:2]), reference, rtol=1e-6)
    est.set_params(**change)
    name = next(iter(change))
    with pytest.raises(NotFittedError, match=f"{name}=.*fitted with.*call fit again"):
        est.transform(samples[:2])
    # Fitting again learns the scales under the new parameters.
    assert est.fit(samples).transform(samples[:2]).shape == (2, 6)


def test_feature_names_and_pandas_output():
    samples = random_diagrams(5, seed=8)
    est = DiagramDistance().fit(samples)
    assert list(est.get_feature_names_out()) == [f"diagramdistance{i}" for i in range(5)]
    frame = DiagramDistance().set_output(transform="pandas").fit_transform(samples)
    assert list(frame.columns) == list(est.get_feature_names_out())
    np.testing.assert_array_equal(frame.to_numpy(), est.transform(samples))
    with pytest.raises(NotFittedError, match="not fitted"):
        DiagramDistance().get_feature_names_out()


def test_float32_distances_that_overflow_are_refused_naming_the_pair():
    """The distances were written into a float32 matrix: past 3.4e38, inf."""
    import pytest

    from sklearn_meshph._base import median_scale

    X = [np.array([[0.0, 1.0]]), np.array([[0.0, 2.0]]), np.array([[0.0, 1e300]])]
    with pytest.raises(ValueError, match="samples 0 and 2: their distance overflows float32"):
        DiagramDistance(dtype="float32").fit_transform(X)
    with pytest.raises(ValueError, match="sample 2 and fitted sample 0: their distance over"):
        DiagramDistance(dtype="float32").fit(X[:2]).transform(X)
    assert np.isfinite(DiagramDistance(dtype="float64").fit_transform(X)).all()
    # The median of two distances near the largest float: their sum overflowed to inf.
    assert median_scale(np.array([[0.0, 1.7e308], [1e308, 0.0]])) == pytest.approx(1.35e308)
    rows = np.random.default_rng(0).random((6, 6))
    assert median_scale(rows) == np.median(rows[~np.eye(6, dtype=bool)])
