"""Helpers shared by the benchmark scripts."""

import os
import time
from pathlib import Path

import numpy as np
from sklearn.model_selection import RepeatedStratifiedKFold


def median_time(repeats, func, *args, **kwargs):
    """Median wall time of ``repeats`` calls of ``func(*args, **kwargs)``."""
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        func(*args, **kwargs)
        times.append(time.perf_counter() - start)
    return float(np.median(times))


def _status_mb(field):
    with open("/proc/self/status") as status:
        for line in status:
            if line.startswith(field):
                return int(line.split()[1]) / 1024
    return float("nan")


def peak_memory(func, *args):
    """Peak resident-set growth (MB, at least 0) while ``func`` runs (Linux: resets
    VmHWM first)."""
    try:
        with open("/proc/self/clear_refs", "w") as refs:
            refs.write("5")
    except OSError:
        return float("nan")
    before = _status_mb("VmRSS")
    func(*args)
    return max(0.0, _status_mb("VmHWM") - before)  # memory freed earlier is reused: no growth


# Collections and 1-NN scores shared by learning_quality.py, gh_signatures.py,
# plot_gh_tsne.py and bench_cache.py ------------------------------------------------

DATA = Path(
    os.environ.get("SKLEARN_MESHPH_DATA", Path(__file__).parents[1] / ".." / "shared" / "data")
)


def collection(name, n_jobs):
    """``(meshes, y, target_names)`` of a collection (``"shapes"``: make_shapes with 10
    per class; otherwise a folder of DATA), or None when its folder is missing."""
    from sklearn_meshph import load_mesh_folder, make_shapes

    if name == "shapes":
        data = make_shapes(n_per_class=10, random_state=0)
    elif (DATA / name).is_dir():
        data = load_mesh_folder(DATA / name, n_jobs=n_jobs)
    else:
        return None
    return list(data.data), np.asarray(data.target), list(data.target_names)


def edge_graph(vertices, faces):
    """The mesh's edges as a symmetric sparse matrix of their lengths (for distances
    along the edges, ``scipy.sparse.csgraph.dijkstra``), and the lengths."""
    import scipy.sparse as sp

    edges = np.vstack([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    length = np.linalg.norm(vertices[edges[:, 0]] - vertices[edges[:, 1]], axis=1)
    graph = sp.coo_matrix((length, (edges[:, 0], edges[:, 1])), shape=(len(vertices),) * 2)
    return graph.tocsr().maximum(graph.tocsr().T), length


def loo_1nn(matrix, y):
    """Leave-one-out 1-NN accuracy of a full distance matrix (ties: lowest index)."""
    matrix = np.array(matrix, dtype=float)
    np.fill_diagonal(matrix, np.inf)
    return float(np.mean(y[np.argmin(matrix, axis=1)] == y))


def folds(y, repeats=10):
    """``repeats`` x repeated stratified 5-fold splits (fewer folds for tiny classes)."""
    n_splits = min(5, int(np.bincount(y).min()))
    splits = RepeatedStratifiedKFold(n_splits=n_splits, n_repeats=repeats, random_state=0)
    return splits.split(np.zeros(len(y)), y)


def cv_1nn(matrix, y, repeats=10):
    """Mean 1-NN accuracy over the splits of :func:`folds` on a full matrix."""
    matrix = np.asarray(matrix, dtype=float)
    scores = [
        np.mean(y[train][np.argmin(matrix[np.ix_(test, train)], axis=1)] == y[test])
        for train, test in folds(y, repeats)
    ]
    return float(np.mean(scores))
