"""The default pipeline on a dask.distributed cluster, through joblib's dask backend:
every stage runs on the workers and the output is bitwise the local run's on one core;
the eigen cache in a folder the workers share is written by them and read back; the
diagrams every block of pairs reads go to every worker once per call; the blocks of all
the diagram positions of a distance, and of all the default's diagram distances, go in
one parallel call, costliest first; and ``n_jobs=1`` runs everything in the calling
process.

A ``LocalCluster`` of 2 worker processes (one thread each) serves the module, and one of
a single worker process with two threads (joblib then sends it tasks) the tests that
compare both.
"""

from contextlib import nullcontext

import numpy as np
import pytest
from joblib import parallel_backend
from sklearn.pipeline import Pipeline

import sklearn_meshph.diagrams.pairwise as pairwise
from sklearn_meshph import (
    CombinedDistance,
    DiagramDistance,
    PerDiagramDistance,
    make_mesh_distance,
    make_shapes,
)

distributed = pytest.importorskip("distributed")


def _cluster(n_workers, threads_per_worker, **client_options):
    """A client of a local cluster of worker processes, closed with the cluster."""
    with (
        distributed.LocalCluster(
            n_workers=n_workers,
            threads_per_worker=threads_per_worker,
            processes=True,
            dashboard_address=None,
        ) as cluster,
        distributed.Client(cluster, **client_options) as client,
    ):
        yield client


@pytest.fixture(scope="module")
def client():
    yield from _cluster(2, 1)


@pytest.fixture(scope="module")
def one_worker():
    yield from _cluster(1, 2, set_as_default=False)


@pytest.fixture(scope="module")
def meshes():
    classes = ("blob", "snake", "tripod")
    return make_shapes(n_per_class=2, classes=classes, random_state=0, return_X_y=True)[0]


@pytest.fixture(scope="module")
def local(meshes):
    return make_mesh_distance(n_jobs=1).fit_transform(meshes)


def on_cluster(client, meshes, **params):
    """The default's matrix under joblib's dask backend, and the keys of the tasks the
    workers ran."""
    with parallel_backend("dask"), distributed.get_task_stream(client) as stream:
        matrix = make_mesh_distance(n_jobs=-1, **params).fit_transform(meshes)
    return matrix, [task["key"] for task in stream.data]


def test_default_pipeline_on_a_cluster_is_bitwise_the_local_run(client, meshes, local):
    matrix, tasks = on_cluster(client, meshes)
    np.testing.assert_array_equal(matrix, local)
    # The stages ran on the workers, not in this process.
    assert len(tasks) >= 2


def test_default_transform_on_a_cluster_is_bitwise_the_local_run(client, meshes):
    """The distances of new meshes to fitted ones: the parts' matrices in one call on
    the cluster, as the local run's."""
    expected = make_mesh_distance(n_jobs=1).fit(meshes[:4]).transform(meshes[4:])
    with parallel_backend("dask"), distributed.get_task_stream(client) as stream:
        found = make_mesh_distance(n_jobs=-1).fit(meshes[:4]).transform(meshes[4:])
    np.testing.assert_array_equal(found, expected)
    assert len(stream.data) >= 2


def test_eigen_cache_in_a_shared_folder_is_written_by_the_workers(client, meshes, local, tmp_path):
    matrix, _ = on_cluster(client, meshes, memory=tmp_path)
    np.testing.assert_array_equal(matrix, local)
    entries = sorted(p.name for p in (tmp_path / "sklearn_meshph_eigen").iterdir())
    assert len(entries) == len(meshes)
    again, _ = on_cluster(client, meshes, memory=tmp_path)
    np.testing.assert_array_equal(again, local)
    assert sorted(p.name for p in (tmp_path / "sklearn_meshph_eigen").iterdir()) == entries


def test_diagrams_go_to_the_cluster_once_per_call_not_with_each_task(client, monkeypatch):
    rng = np.random.default_rng(0)
    diagrams = [(np.sort(rng.random((30, 2)), axis=1),) for _ in range(40)]
    local = DiagramDistance(metric="wasserstein").fit_transform(diagrams)
    scattered = []
    scatter = client.scatter

    def counting_scatter(data, *args, **kwargs):
        scattered.append(data)
        return scatter(data, *args, **kwargs)

    monkeypatch.setattr(client, "scatter", counting_scatter)
    with parallel_backend("dask"), distributed.get_task_stream(client) as stream:
        matrix = DiagramDistance(metric="wasserstein", n_jobs=-1).fit_transform(diagrams)
    np.testing.assert_array_equal(matrix, local)
    # One symmetric matrix: its samples scattered once, read by every task.
    assert len(scattered) == 1
    assert len(stream.data) > 1


def uneven_samples(n=120, seed=0):
    """Samples of three diagrams: the first of 1 point, the second of 2 to 40 points
    (its pairs cost most, unevenly), the third empty but for an essential point."""
    rng = np.random.default_rng(seed)

    def diagram(k):
        births = rng.random(k)
        return np.column_stack([births, births + rng.random(k)])

    essential = [np.array([[rng.random(), np.inf]]) for _ in range(n)]
    return [(diagram(1), diagram(int(rng.integers(2, 41))), essential[i]) for i in range(n)]


def combined_and_stacks(n_jobs, backend=None, **backend_params):
    """A median-normalized Wasserstein distance (its fit_transform and a transform) and
    a stack of bottleneck distances, under ``backend`` (None: none)."""
    X, Y = uneven_samples(), uneven_samples(7, seed=1)
    distance = DiagramDistance(metric="wasserstein", order=1.0, normalization="median")
    stack = PerDiagramDistance(metric="bottleneck")
    context = parallel_backend(backend, **backend_params) if backend else nullcontext()
    with context:
        distance.set_params(n_jobs=n_jobs)
        stack.set_params(n_jobs=n_jobs)
        return (
            distance.fit_transform(X),
            distance.transform(Y),
            stack.fit_transform(X),
            stack.transform(Y),
        )


@pytest.fixture(scope="module")
def local_blocks():
    return combined_and_stacks(n_jobs=1)


@pytest.mark.parametrize("cluster", ["one_worker", "client"])
def test_distance_blocks_on_1_and_2_workers_are_bitwise_the_local_run(
    cluster, request, local_blocks
):
    client = request.getfixturevalue(cluster)
    with distributed.get_task_stream(client) as stream:
        results = combined_and_stacks(-1, "dask", client=client)
    for result, expected in zip(results, local_blocks, strict=True):
        np.testing.assert_array_equal(result, expected)
    assert len(stream.data) > 4  # the blocks ran on the cluster


@pytest.mark.parametrize("backend", ["loky", "threading"])
def test_distance_blocks_are_bitwise_the_local_run_under_local_backends(backend, local_blocks):
    for result, expected in zip(combined_and_stacks(2, backend), local_blocks, strict=True):
        np.testing.assert_array_equal(result, expected)


def test_n_jobs_1_under_the_dask_backend_runs_nothing_on_the_cluster(client, meshes, local):
    with parallel_backend("dask"), distributed.get_task_stream(client) as stream:
        matrix = make_mesh_distance(n_jobs=1).fit_transform(meshes)
        blocks = combined_and_stacks(n_jobs=1)
    np.testing.assert_array_equal(matrix, local)
    assert stream.data == []
    assert blocks[0].shape == (120, 120)


def test_the_samples_go_to_every_worker_at_once(client, monkeypatch):
    kinds = []
    scatter = client.scatter

    def recording_scatter(data, *args, **kwargs):
        kinds.append(kwargs.get("broadcast", False))
        return scatter(data, *args, **kwargs)

    monkeypatch.setattr(client, "scatter", recording_scatter)
    with parallel_backend("dask"):
        DiagramDistance(metric="wasserstein", n_jobs=-1).fit_transform(uneven_samples())
    assert kinds == [True]


def test_blocks_that_carry_futures_all_go_to_the_scheduler_at_once(client, monkeypatch):
    """Under dask every block is handed to the scheduler at once (joblib's default of
    two in flight per worker left workers idle between blocks); locally, the default."""
    seen = []
    original = pairwise.parallel

    def recording_parallel(n_jobs, batch_size="auto", pre_dispatch="2 * n_jobs"):
        seen.append(pre_dispatch)
        return original(n_jobs, batch_size=batch_size, pre_dispatch=pre_dispatch)

    monkeypatch.setattr(pairwise, "parallel", recording_parallel)
    X = uneven_samples()
    with parallel_backend("dask"):
        on_cluster = DiagramDistance(metric="wasserstein", n_jobs=-1).fit_transform(X)
    with parallel_backend("threading"):
        here = DiagramDistance(metric="wasserstein", n_jobs=2).fit_transform(X)
    assert seen == ["all", "2 * n_jobs"]
    np.testing.assert_array_equal(on_cluster, here)


def test_all_positions_go_in_one_parallel_call_costliest_block_first(monkeypatch):
    """DiagramDistance(normalization="median") and a stack compute a matrix per
    diagram position: all their blocks are dispatched in one call, a block of the
    costly position (many points) first, and the costly position in more blocks than
    the cheap ones."""
    dispatched = []  # per parallel call, the (position, start) of its blocks in order

    def recording_parallel(n_jobs, batch_size="auto", pre_dispatch="2 * n_jobs"):
        def run(calls):
            dispatched.append([])
            for function, args, kwargs in calls:
                left = args[1].value
                n_points = len(left[0])  # the position's points: tells it apart
                dispatched[-1].append((n_points, args[3]))
                yield function(*args, **kwargs)

        return run

    monkeypatch.setattr(pairwise, "parallel", recording_parallel)
    X = uneven_samples()
    sizes = [sum(len(s[k]) for s in X) for k in range(3)]
    with parallel_backend("threading"):
        for estimator in (
            DiagramDistance(metric="wasserstein", normalization="median"),
            PerDiagramDistance(metric="bottleneck"),
        ):
            dispatched.clear()
            expected = estimator.set_params(n_jobs=1).fit_transform(X)
            assert dispatched == []  # n_jobs=1: no parallel call
            np.testing.assert_array_equal(estimator.set_params(n_jobs=2).fit_transform(X), expected)
            assert len(dispatched) == 1
            order = [n_points for n_points, _ in dispatched[0]]
            assert order[0] == sizes[1]
            assert order.count(sizes[1]) > 2 * max(order.count(sizes[0]), 1)


def test_the_defaults_diagram_distances_go_in_one_parallel_call(monkeypatch):
    """make_mesh_distance()'s three diagram parts (one per kind, five positions each)
    hand their blocks to one parallel call, in fit_transform as in transform (they made
    one call per kind, each ending in a wait for its last block), a block of every kind
    among them, costliest first; the output is the local run's."""
    meshes = make_shapes(n_per_class=2, classes=("blob", "tripod"), random_state=0).data
    local = make_mesh_distance(n_jobs=1)
    expected = local.fit_transform(meshes[:3]), local.transform(meshes[3:])
    calls, broadcasts = [], []  # per parallel call, the estimated cost of each block
    original, broadcast = pairwise._guided_blocks, pairwise.broadcast

    def recording_blocks(requests, workers):
        tasks = original(requests, workers)
        calls.append(([r for r in requests], [cost for *_, cost in tasks]))
        return tasks

    def recording_broadcast(values):
        broadcasts.append(len(values))
        return broadcast(values)

    monkeypatch.setattr(pairwise, "_guided_blocks", recording_blocks)
    monkeypatch.setattr(pairwise, "broadcast", recording_broadcast)
    with parallel_backend("threading"):
        pipeline = make_mesh_distance(n_jobs=2)
        fitted = pipeline.fit_transform(meshes[:3])
        assert len(calls) == 1
        transformed = pipeline.transform(meshes[3:])
    assert len(calls) == 2
    assert broadcasts == [15, 15 + 15]  # symmetric: one side per matrix; else two
    for requests, costs in calls:
        assert len(requests) == 3 * 5  # kinds x times
        assert costs == sorted(costs, reverse=True)
    np.testing.assert_array_equal(fitted, expected[0])
    np.testing.assert_array_equal(transformed, expected[1])


def test_parts_that_cannot_leave_their_matrices_compute_them_as_before(tmp_path, monkeypatch):
    """A Pipeline with memory computes its distance in its own fit_transform; the parts
    of one n_jobs go in one call, those of another in theirs; same output either way."""
    calls, original = [], pairwise.pair_matrices

    def counting(requests, **kwargs):
        calls.append((len(requests), kwargs["n_jobs"]))
        return original(requests, **kwargs)

    def part(n_jobs, **pipeline):
        distance = DiagramDistance(metric="wasserstein", normalization="median", n_jobs=n_jobs)
        return Pipeline([("distance", distance)], **pipeline)

    def combined(n_jobs, other):
        names = ("a", "b", "cached", "alone")
        parts = [part(n_jobs), part(n_jobs), part(n_jobs, memory=str(tmp_path)), part(other)]
        return CombinedDistance(list(zip(names, parts, strict=True)))

    X, Y = uneven_samples(40), uneven_samples(5, seed=1)
    reference = combined(1, 1).fit(X)
    expected = reference.fit_transform(X), reference.transform(Y)
    monkeypatch.setattr(pairwise, "pair_matrices", counting)
    with parallel_backend("threading"):
        fitted = combined(2, 1).fit(X)
        calls.clear()
        matrix = fitted.fit_transform(X)
        assert calls == [(3, 2), (6, 2), (3, 1)]  # cached, then a + b, then alone
        np.testing.assert_array_equal(matrix, expected[0])
        np.testing.assert_array_equal(fitted.transform(Y), expected[1])
