"""DiagramDistance: matrices, the combination rule, backends, immutability, estimator API."""

import numpy as np
import pytest
from joblib import parallel_backend

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
    assert len(remote_diagrams) == len(meshes)


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
