"""The default pipeline on a dask.distributed cluster, through joblib's dask backend:
every stage runs on the workers and the output is bitwise the local run's on one core;
the eigen cache in a folder the workers share is written by them and read back; the
diagrams every block of pairs reads go to the cluster once per call.

One ``LocalCluster`` of 2 worker processes (one thread each) serves the module.
"""

import numpy as np
import pytest
from joblib import parallel_backend

from sklearn_meshph import DiagramDistance, make_mesh_distance, make_shapes

distributed = pytest.importorskip("distributed")


@pytest.fixture(scope="module")
def client():
    with (
        distributed.LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        yield client


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
