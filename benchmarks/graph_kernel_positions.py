"""Distributions as kernels for the graph SVM: the screens of docs/graphs.md ("What was
tried") that add positions to the stack of ``GraphPairDistances`` or use one alone.

    python benchmarks/graph_kernel_positions.py [--datasets MUTAG COX2] [--repeats 10]

PersLay's protocol (10-fold shuffled cross-validation, seeds 0 to ``--repeats - 1``).
Per dataset the default's stack is computed once (``make_graph_classifier(classifier=
"kernels")`` without its last step) and, per outer fold, sliced and standardized as
``fold_stack`` does; ``KernelSumSVC`` then chooses its sum of groups and C inside the
training folds, exactly as in the default. The rows:

- ``default``: the default's layout (diagrams; patterns; nodes' discrepancy with the
  features);
- ``+ diagrams' discrepancy``: for each of the 12 diagrams, the maximum mean
  discrepancy between two graphs' diagrams as sums of Gaussians at their points (512
  seeded random Fourier features; bandwidth half the median distance between points of
  that diagram over all the graphs: unsupervised, but from every graph, so a screen's
  shortcut), averaged into the diagrams' group beside the sliced Wasserstein kernels;
- ``edges' discrepancy for the nodes'``: the discrepancy of the edges (each edge the
  coordinate-wise minimum and maximum of its ends' signatures, a Gaussian of width 0.03
  as the nodes'; a graph without edges its nodes as loops) in the nodes' place;
- ``+ edges' discrepancy (features' group)``: the same beside the nodes' discrepancy
  and the features;
- ``+ degree's diagrams``, ``+ eccentricity's diagrams``, ``+ closeness's diagrams``,
  ``+ curvature's diagrams``: the four extended diagrams of another function on the
  nodes than the signatures (the degree; the eccentricity over the graph's largest;
  the closeness centrality within the node's component; the mean over the node's
  edges of their Forman curvature ``4 - deg(u) - deg(v)``; 0 on isolated nodes), their
  sliced Wasserstein distances (10 directions, as the signatures') averaged into the
  diagrams' group;
- ``alone: ...``: one distance, only C chosen (1, 10, 100): the nodes' discrepancy of
  the default, the diagrams' discrepancies above (averaged), the edges'.

``--rows`` runs the rows whose names start with the given strings.

Every choice is made on the training folds. PersLay's published accuracy is printed
beside (the anchor).
"""

import argparse
import dataclasses
import time

import numpy as np
import scipy.sparse as sp
from _common import DATA
from graph_classification import PERSLAY
from joblib import Parallel, delayed
from scipy.sparse.csgraph import connected_components, shortest_path
from scipy.spatial.distance import cdist
from sklearn.model_selection import KFold

from sklearn_meshph import load_tu_dataset, make_graph_classifier
from sklearn_meshph.diagrams.per_diagram import PerDiagramDistance
from sklearn_meshph.persistence import LowerStarPersistence
from sklearn_meshph.vectorization import KernelSumSVC
from sklearn_meshph.vectorization.graph_pairs import _mean_embedding

N_FEATURES = 512
ROWS = (
    "default",
    "+ diagrams' discrepancy",
    "edges' discrepancy for the nodes'",
    "+ edges' discrepancy (features' group)",
    "+ degree's diagrams",
    "+ eccentricity's diagrams",
    "+ closeness's diagrams",
    "+ curvature's diagrams",
    "alone: nodes' discrepancy",
    "alone: diagrams' discrepancy",
    "alone: edges' discrepancy",
)


def _fourier(dim, width, seed):
    rng = np.random.default_rng(seed)
    return rng.normal(scale=1.0 / width, size=(dim, N_FEATURES)), rng.uniform(
        0.0, 2.0 * np.pi, N_FEATURES
    )


def _embedding(points, projection, phases, mean):
    """The points' mean random Fourier features (``GraphPairDistances``' own), or their
    sum."""
    if len(points) == 0:
        return np.zeros(projection.shape[1])
    embedding = _mean_embedding(points, projection, phases)
    return embedding if mean else embedding * len(points)


def _squared_distances(embeddings):
    return cdist(embeddings, embeddings, "sqeuclidean")


def diagram_discrepancies(diagrams, seed=0):
    """``(n, n, n_diagrams)``: per diagram, the discrepancy of the sums of Gaussians."""
    out = []
    for j in range(len(diagrams[0])):
        points = [np.asarray(d[j], dtype=np.float64).reshape(-1, 2) for d in diagrams]
        pooled = np.vstack(points)
        rng = np.random.default_rng(seed)
        sample = pooled[rng.choice(len(pooled), min(2000, len(pooled)), replace=False)]
        width = 0.5 * np.median(cdist(sample, sample)) or 1e-12
        projection, phases = _fourier(2, width, seed + j)
        embeddings = np.array([_embedding(p, projection, phases, mean=False) for p in points])
        out.append(_squared_distances(embeddings))
    return np.stack(out, axis=2)


def edge_discrepancy(fields, width=0.03, seed=0):
    """``(n, n)``: the discrepancy of the edges' (minimum, maximum) signature vectors."""
    dim = np.asarray(fields[0].values).shape[1]
    projection, phases = _fourier(2 * dim, width, seed)
    embeddings = []
    for field in fields:
        values = np.asarray(field.values, dtype=np.float64)
        ends = values[field.edges[:, 0]], values[field.edges[:, 1]]
        if len(field.edges):
            points = np.hstack([np.minimum(*ends), np.maximum(*ends)])
        else:  # no edge: each node as a loop
            points = np.hstack([values, values])
        embeddings.append(_embedding(points, projection, phases, mean=True))
    return _squared_distances(np.array(embeddings))


FUNCTIONS = ("degree", "eccentricity", "closeness", "curvature")


def node_functions(field):
    """``(n_nodes, 4)``: the ``FUNCTIONS`` of a graph's nodes, from its edges alone."""
    n, edges = field.n_vertices, np.asarray(field.edges)
    ends = np.r_[edges[:, 0], edges[:, 1]], np.r_[edges[:, 1], edges[:, 0]]
    adjacency = sp.csr_matrix((np.ones(len(ends[0])), ends), shape=(n, n))
    degree = np.bincount(ends[0], minlength=n).astype(np.float64)
    hops = shortest_path(adjacency, unweighted=True)
    hops[~np.isfinite(hops)] = 0.0  # other components
    _, component = connected_components(adjacency, directed=False)
    size = np.bincount(component)[component]
    eccentricity = hops.max(axis=1)
    closeness = (size - 1) / np.maximum(hops.sum(axis=1), 1.0)
    curvature = np.zeros(n)
    edge_curvature = 4.0 - degree[edges[:, 0]] - degree[edges[:, 1]]
    np.add.at(curvature, edges[:, 0], edge_curvature)
    np.add.at(curvature, edges[:, 1], edge_curvature)
    curvature /= np.maximum(degree, 1.0)
    return np.column_stack(
        [degree, eccentricity / max(eccentricity.max(), 1.0), closeness, curvature]
    )


def function_distances(fields, n_jobs):
    """``(n, n, 4 * 4)``: the sliced Wasserstein distances of the extended diagrams of
    each of ``FUNCTIONS``, four diagrams per function in that order."""
    other = [
        dataclasses.replace(f, values=node_functions(f), column_names=FUNCTIONS) for f in fields
    ]
    diagrams = LowerStarPersistence(filtration="extended", n_jobs=n_jobs).fit_transform(other)
    return PerDiagramDistance(n_directions=10, n_jobs=n_jobs).fit_transform(diagrams)


def fold(distances, stack, extra, groups, y, train, test):
    """Test accuracy of ``KernelSumSVC(groups)`` on the default's positions (sliced and
    standardized per fold), with ``extra`` positions put first (``keep`` the default's
    positions kept, all when None)."""
    positions, keep = extra

    def block(rows):
        parts = []
        if positions is not None:
            parts.append(positions[np.ix_(rows, train)])
        if keep != ():
            default = distances.fold_stack(stack, rows, train)
            parts.append(default if keep is None else default[:, :, list(keep)])
        return np.concatenate(parts, axis=2)

    model = KernelSumSVC(groups=groups, random_state=0).fit(block(train), y[train])
    return np.mean(model.predict(block(test)) == y[test])


def rows_for(model, graphs, n_jobs):
    """The screened rows: name -> (extra positions, default positions kept, groups)."""
    eigen, distances = model[0], model[1]
    fields = eigen.fit_transform(graphs)
    stack = distances.fit_transform(fields)
    diagrams = distances.persistence_.transform(fields)
    n = stack.shape[2]
    nodes = n - 2  # the layout: diagrams..., patterns, nodes, features
    per_diagram = diagram_discrepancies(diagrams)
    k = per_diagram.shape[2]
    edges = edge_discrepancy(fields)[:, :, None]
    others = tuple(i for i in range(n) if i != nodes)
    functions = function_distances(fields, n_jobs)
    per_function = functions.shape[2] // len(FUNCTIONS)
    with_function = tuple([0] * (per_function + n - 3) + [1, 2, 2])
    rows = {
        "default": ((None, None), "graph"),
        "+ diagrams' discrepancy": (
            (per_diagram, None),
            tuple([0] * (k + n - 3) + [1, 2, 2]),
        ),
        "edges' discrepancy for the nodes'": (
            (edges, others),
            tuple([2] + [0] * (n - 3) + [1, 2]),
        ),
        "+ edges' discrepancy (features' group)": (
            (edges, None),
            tuple([2] + [0] * (n - 3) + [1, 2, 2]),
        ),
        **{
            f"+ {name}'s diagrams": (
                (functions[:, :, i * per_function : (i + 1) * per_function], None),
                with_function,
            )
            for i, name in enumerate(FUNCTIONS)
        },
        "alone: nodes' discrepancy": ((None, (nodes,)), (0,)),
        "alone: diagrams' discrepancy": ((per_diagram, ()), tuple([0] * k)),
        "alone: edges' discrepancy": ((edges, ()), (0,)),
    }
    return distances, stack, rows


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--datasets", nargs="+", default=["MUTAG", "COX2", "DHFR", "PROTEINS"])
    parser.add_argument("--repeats", type=int, default=10)
    parser.add_argument("--n-jobs", type=int, default=2)
    parser.add_argument("--rows", nargs="+", help="the rows to run (start of their names)")
    parser.add_argument("--data", default=str(DATA / "tu"), help="folder of the TU datasets")
    args = parser.parse_args()
    if args.repeats < 1:
        parser.error("--repeats must be at least 1")
    unknown = [start for start in args.rows or () if not any(r.startswith(start) for r in ROWS)]
    if unknown:
        parser.error(f"--rows {unknown}: no such row; the rows are {list(ROWS)}")
    table = {}
    for name in args.datasets:
        start = time.perf_counter()
        graphs, y = load_tu_dataset(f"{args.data}/{name}")
        y = np.asarray(y)
        model = make_graph_classifier(classifier="kernels", n_jobs=args.n_jobs)
        distances, stack, rows = rows_for(model, graphs, args.n_jobs)
        assert tuple(rows) == ROWS
        splits = [
            split
            for seed in range(args.repeats)
            for split in KFold(10, shuffle=True, random_state=seed).split(y)
        ]
        for row, (extra, groups) in rows.items():
            if args.rows and not any(row.startswith(start) for start in args.rows):
                continue
            scores = Parallel(n_jobs=args.n_jobs)(
                delayed(fold)(distances, stack, extra, groups, y, train, test)
                for train, test in splits
            )
            sizes = np.array([len(test) for _, test in splits])
            per_repeat = 100 * (np.array(scores) * sizes).reshape(-1, 10).sum(1)
            per_repeat /= sizes.reshape(-1, 10).sum(1)
            table.setdefault(row, {})[name] = f"{per_repeat.mean():.1f} ± {per_repeat.std():.1f}"
        print(f"{name}: {time.perf_counter() - start:.0f} s", flush=True)
    print(f"| kernels | {' | '.join(args.datasets)} |")
    print(f"|---|{'---|' * len(args.datasets)}")
    for row, cells in table.items():
        print(f"| {row} | {' | '.join(cells[name] for name in args.datasets)} |")
    anchors = [f"{PERSLAY[name]:.1f}" if name in PERSLAY else "" for name in args.datasets]
    print(f"| PersLay (published) | {' | '.join(anchors)} |")


if __name__ == "__main__":
    main()
