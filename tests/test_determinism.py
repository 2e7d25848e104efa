"""Bitwise determinism of the whole pipeline for every joblib backend, under CPU load.

BLAS thread limits are process-global. A solve that escapes the one-BLAS-thread limit
(because another thread of a threading backend restored the caller's limit under its
feet, or because threadpoolctl ignored a limit set from a thread that does not control
OpenBLAS) runs threaded BLAS and rounds differently in the last bits. Such races need
preemption at the wrong moment, so every test here runs while another process keeps
the CPUs busy, and repeats.

The caller's BLAS runs 4 threads during these tests, whatever the machine (OpenBLAS
accepts more threads than cores): the meshes (about 340 to 720 vertices) are large
enough for threaded BLAS to round differently on some of them, so an escaped solve
shows in the output. The tests also check that the caller's limits are left as they
were: after the threading and dask backends, and after a worker raised while others
were still solving.

Only the public API and threadpoolctl are used, so that the file also runs against
older versions of the package.
"""

import os
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from contextlib import ExitStack, contextmanager

import numpy as np
import pytest
import threadpoolctl
from joblib import parallel_backend
from threadpoolctl import threadpool_info, threadpool_limits

from sklearn_meshph import (
    DiagramDistance,
    LaplacianEigenTransformer,
    LowerStarPersistence,
    make_shapes,
)

CALLER_BLAS_THREADS = 4
REPEATS = 3
N_JOBS = (4, 2, 1)  # loky: 4 workers started once, then shrunk
BACKENDS = ("loky", "threading", "dask")

# BLAS-heavy busy loop for the load process (values stay bounded).
LOAD = """
import numpy as np
a = np.random.default_rng(0).random((400, 400)) / 400
while True:
    a = np.tanh(a @ a + 0.5)
"""


@pytest.fixture(scope="module", autouse=True)
def cpu_load():
    """Another process keeping the cores busy (up to 8) for the whole module."""
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    threads = str(min(cores or 2, 8))
    env = {**os.environ, "OPENBLAS_NUM_THREADS": threads, "OMP_NUM_THREADS": threads}
    process = subprocess.Popen(
        [sys.executable, "-c", LOAD],
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        yield process
    finally:
        process.kill()
        process.wait(timeout=60)


def blas_threads():
    """The caller's BLAS thread limits, one ``(library, num_threads)`` per library."""
    return sorted(
        (info["filepath"], info["num_threads"])
        for info in threadpool_info()
        if info["user_api"] == "blas"
    )


def counts(limits):
    """Just the thread counts, for messages."""
    return [n for _, n in limits]


def _release_openblas_control():
    # threadpoolctl >= 3.8 lets only one thread (the first to set a limit) change
    # OpenBLAS's process-wide pool and silently ignores the others: release it, so that
    # the test's own settings always apply, whatever a previous test left.
    clear = getattr(threadpoolctl.OpenBLASController, "clear_controlling_thread", None)
    if clear is not None:
        clear(force=True)


def set_caller_blas(n):
    """Set the caller's BLAS limits as a default would be (no context left open)."""
    _release_openblas_control()
    threadpool_limits(limits=n, user_api="blas")
    _release_openblas_control()
    return blas_threads()


@pytest.fixture(scope="module", autouse=True)
def caller_blas():
    """The caller runs BLAS with 4 threads in this module; its limits are restored after."""
    original = blas_threads()
    limits = set_caller_blas(CALLER_BLAS_THREADS)
    assert limits and all(n == CALLER_BLAS_THREADS for _, n in limits), limits
    try:
        yield
    finally:
        _release_openblas_control()
        threadpool_limits(limits=dict(original))
        _release_openblas_control()


@pytest.fixture(scope="module")
def meshes():
    data, _ = make_shapes(n_per_class=3, resolution=(14, 20), random_state=0, return_X_y=True)
    return data


def run_pipeline(meshes, n_jobs):
    """LaplacianEigenTransformer -> LowerStarPersistence -> DiagramDistance."""
    fields = LaplacianEigenTransformer(n_jobs=n_jobs).fit_transform(meshes)
    diagrams = LowerStarPersistence(n_jobs=n_jobs).fit_transform(fields)
    distances = DiagramDistance(metric="wasserstein", n_jobs=n_jobs).fit_transform(diagrams)
    return fields, diagrams, distances


@pytest.fixture(scope="module")
def reference(meshes):
    return run_pipeline(meshes, n_jobs=1)


def differences(result, reference):
    """What differs, bitwise, between two pipeline outputs (empty if nothing)."""
    fields, diagrams, distances = result
    ref_fields, ref_diagrams, ref_distances = reference
    found = []
    bad = [
        i
        for i, (a, b) in enumerate(zip(fields, ref_fields, strict=True))
        if not (np.array_equal(a.values, b.values) and np.array_equal(a.eigenvalues, b.eigenvalues))
    ]
    if bad:
        found.append(f"eigenfunctions of meshes {bad} differ")
    bad = [
        i
        for i, (a, b) in enumerate(zip(diagrams, ref_diagrams, strict=True))
        if len(a) != len(b) or not all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))
    ]
    if bad:
        found.append(f"diagrams of meshes {bad} differ")
    if distances.shape != ref_distances.shape or not np.array_equal(distances, ref_distances):
        count = np.count_nonzero(distances != ref_distances)
        found.append(f"{count} of {ref_distances.size} distances differ")
    return found


@contextmanager
def backend(name, n_jobs):
    """A joblib backend with ``n_jobs`` workers; dask: an in-process cluster of threads
    (yields its client)."""
    client = None
    with ExitStack() as stack:
        if name == "dask":
            distributed = pytest.importorskip("distributed")
            cluster = stack.enter_context(
                distributed.LocalCluster(
                    processes=False,
                    n_workers=1,
                    threads_per_worker=n_jobs,
                    dashboard_address=None,
                )
            )
            client = stack.enter_context(distributed.Client(cluster))
            # joblib's dask backend uses the cluster's threads, whatever n_jobs says.
            stack.enter_context(parallel_backend("dask", wait_for_workers_timeout=60))
        else:
            stack.enter_context(parallel_backend(name, n_jobs=n_jobs))
        yield client


def check_runs(run, reference, cpu_load, repeats=REPEATS):
    """Run ``run()`` ``repeats`` times from the caller's default BLAS limits."""
    failures = []
    for repeat in range(repeats):
        before = set_caller_blas(CALLER_BLAS_THREADS)
        if any(n != CALLER_BLAS_THREADS for _, n in before):
            failures.append(f"run {repeat}: could not set the caller's limits: {counts(before)}")
            continue
        result = run()
        after = blas_threads()
        problems = differences(result, reference)
        if after != before:
            problems.append(
                f"the caller's BLAS limits changed from {counts(before)} to {counts(after)}"
            )
        failures.extend(f"run {repeat}: {problem}" for problem in problems)
    assert cpu_load.poll() is None, "the load process died: the test ran without load"
    assert not failures, "\n".join(failures)


@pytest.mark.parametrize("n_jobs", N_JOBS)
@pytest.mark.parametrize("backend_name", BACKENDS)
def test_whole_pipeline_bitwise_identical_for_every_backend_under_load(
    backend_name, n_jobs, meshes, reference, cpu_load
):
    with backend(backend_name, n_jobs):
        check_runs(lambda: run_pipeline(meshes, n_jobs), reference, cpu_load)


def test_pipelines_run_from_the_callers_threads_inside_its_own_limits(meshes, reference, cpu_load):
    """Pipelines run concurrently from a caller's thread pool (like a grid search on the
    threading backend), one sequential and one on the threading backend, while the
    caller holds its own ``threadpool_limits`` context."""

    def one(n_jobs):
        with parallel_backend("threading", n_jobs=n_jobs):
            return run_pipeline(meshes, n_jobs)

    def run():
        with threadpool_limits(limits=CALLER_BLAS_THREADS, user_api="blas"):
            with ThreadPoolExecutor(2) as pool:
                futures = [pool.submit(one, n_jobs) for n_jobs in (1, 2)]
                results = [future.result() for future in futures]
        found = [problem for result in results for problem in differences(result, reference)]
        assert not found, "\n".join(found)
        return results[0]

    check_runs(run, reference, cpu_load)


def _wait_for(condition, timeout=15.0):
    deadline = time.monotonic() + timeout
    while not condition() and time.monotonic() < deadline:
        time.sleep(0.05)
    return condition()


def _idle(client):
    """Whether no task of the failed transform is left on the dask cluster."""
    return client is None or not any(client.processing().values())


@pytest.mark.parametrize("backend_name", ["threading", "dask"])
def test_caller_blas_limits_restored_after_a_worker_raised(
    backend_name, meshes, reference, cpu_load
):
    """The failing mesh is the largest, so it is dispatched first and raises while the
    other worker is still solving: that solve may end after transform has raised."""
    vertices = np.array(meshes[0].vertices)
    vertices = np.vstack([vertices, vertices])  # unreferenced copies: the largest input
    vertices[0] = np.nan
    failing = [(vertices, np.asarray(meshes[0].faces)), *meshes]
    failures = []
    with backend(backend_name, 2) as client:
        for repeat in range(REPEATS):
            before = set_caller_blas(CALLER_BLAS_THREADS)
            with pytest.raises(ValueError, match="sample 0"):
                LaplacianEigenTransformer(n_jobs=2).fit_transform(failing)
            # Tasks still running when the error surfaced hold the limit until they end.
            _wait_for(lambda: _idle(client))  # noqa: B023
            if not _wait_for(lambda: blas_threads() == before):  # noqa: B023
                failures.append(
                    f"run {repeat}: the caller's BLAS limits stayed {counts(blas_threads())} "
                    f"instead of {counts(before)} after the failed transform"
                )
        check_runs(lambda: run_pipeline(meshes, 2), reference, cpu_load, repeats=1)
    assert not failures, "\n".join(failures)
