"""make_graph_classifier under PersLay's protocol on the shared TU datasets.

PersLay (Carriere et al., AISTATS 2020): 10-fold shuffled cross-validation
(``KFold(10, shuffle=True)``), repeated 10 times (seeds 0 to 9 here), mean accuracy.
The classifier is the library's default (``classifier="auto"``: the kernel SVM when a
fold has at most 2,000 training graphs, the forest above; ``--classifier kernels`` or
``trees`` forces one). Nothing is tuned on these datasets: the kernels summed and the
SVM's C are chosen by cross-validation inside each training fold, the forest has fixed
settings (with ``--min-samples-leaf 1 5`` its leaf size is chosen inside each fit from
the training folds' out-of-bag votes), so no setting can have seen a test fold. The
steps before the classifier (signatures, persistence, features, or the distances
between each pair of graphs) learn nothing from the training graphs but the kernel
SVM's standardization of the features, so they run once per dataset and only the
classifier is fitted per fold (on the training rows of the features; for the kernel
SVM on ``GraphPairDistances.fold_stack``, the training block of the distances with the
features standardized on the training graphs): the same predictions as fitting the
whole pipeline per fold, at a fraction of the time.

Prints, per dataset, the mean accuracy and its standard deviation over the repeats
beside PersLay's published mean, the time (features and the 100 fits), the peak
memory and what the fits chose (the kernels and C, or the forest's leaf size; how many
chose each); then the total time.

    python benchmarks/graph_classification.py                  # the six, 10 x 10 folds
    python benchmarks/graph_classification.py --repeats 1 --datasets MUTAG COX2
    python benchmarks/graph_classification.py --classifier trees       # the forest only
    python benchmarks/graph_classification.py --classifier kernels     # the kernel SVM only
    python benchmarks/graph_classification.py --classifier trees --min-samples-leaf 1 5
"""

import argparse
import time

import numpy as np
from _common import DATA, peak_memory
from joblib import Parallel, delayed
from sklearn.base import clone
from sklearn.model_selection import KFold
from sklearn.pipeline import Pipeline

from sklearn_meshph import load_tu_dataset, make_graph_classifier
from sklearn_meshph.size_switch import SizeSwitchClassifier

# KernelSumSVC("graph")'s groups; "features" holds the nodes' discrepancy too.
KERNELS = ("diagrams", "patterns", "features")
PERSLAY = {
    "MUTAG": 89.8,
    "COX2": 80.9,
    "DHFR": 80.3,
    "PROTEINS": 74.8,
    "NCI1": 73.5,
    "IMDB-BINARY": 71.2,
}


def choice(fitted):
    """What a fit chose: the kernels summed and C, or the forest's leaf size."""
    if hasattr(fitted, "C_"):
        kernels = "+".join(KERNELS[g] for g in np.flatnonzero(fitted.weights_))
        return f"{kernels} C={fitted.C_:g}"
    return f"trees, leaf {getattr(fitted, 'min_samples_leaf_', fitted.min_samples_leaf)}"


def evaluate(graphs, y, repeats, n_jobs, options, scores, leaves):
    """Append to ``scores`` the mean accuracy (%) of each repeat of PersLay's protocol,
    to ``leaves`` what each fit chose."""
    model = make_graph_classifier(n_jobs=n_jobs, **options)
    fields = model[0].fit_transform(graphs)
    final = model[-1]
    if isinstance(final, SizeSwitchClassifier):  # "auto": by the training graphs
        limit, kernels, trees = final.max_small_samples, final.small, final.large
    else:
        steps = Pipeline(model.steps[1:])
        limit = len(y) if options["classifier"] == "kernels" else -1
        kernels = trees = steps
    stack = features = None
    for seed in range(repeats):
        folds = list(KFold(10, shuffle=True, random_state=seed).split(graphs))
        small = [fold for fold in folds if len(fold[0]) <= limit]
        large = [fold for fold in folds if len(fold[0]) > limit]
        results = []
        if small:
            if stack is None:
                stack = kernels[:-1].fit_transform(fields)
            # The folds in parallel (the forest's trees are already): each slices the
            # stack and standardizes the features on its training graphs.
            results += Parallel(n_jobs=n_jobs)(
                delayed(kernel_fold)(kernels[-1], kernels[-2], stack, y, train, test)
                for train, test in small
            )
        if large:
            if features is None:
                features = trees[:-1].fit_transform(fields)
            for train, test in large:
                fitted = clone(trees[-1]).fit(features[train], y[train])
                results.append((fitted.score(features[test], y[test]), choice(fitted)))
        scores.append(100 * np.mean([score for score, _ in results]))
        leaves += [chosen for _, chosen in results]


def kernel_fold(final, distances, stack, y, train, test):
    """Accuracy and choice of the kernel SVM fitted on the ``train`` graphs: the
    distances a ``GraphPairDistances`` fitted on them alone gives (``fold_stack``)."""
    fitted = clone(final).fit(distances.fold_stack(stack, train, train), y[train])
    return fitted.score(distances.fold_stack(stack, test, train), y[test]), choice(fitted)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--datasets",
        nargs="+",
        default=list(PERSLAY),
        help="folders of --data (any TU dataset; PersLay's column is blank for the others)",
    )
    parser.add_argument("--repeats", type=int, default=10, help="repeats of 10-fold CV")
    parser.add_argument("--n-jobs", type=int, default=2)
    parser.add_argument(
        "--min-samples-leaf", type=int, nargs="+", default=[1], help="leaf size or candidates"
    )
    parser.add_argument(
        "--classifier",
        choices=["auto", "kernels", "trees"],
        default="auto",
        help="make_graph_classifier's",
    )
    parser.add_argument("--data", default=str(DATA / "tu"), help="folder of the TU datasets")
    args = parser.parse_args()

    print(f"{args.repeats} x KFold(10, shuffle=True), n_jobs={args.n_jobs}")
    print(
        f"{'dataset':<12} {'graphs':>6} {'accuracy':>13} {'PersLay':>8} {'time':>8} {'peak MB':>8}"
        "  choices (fits)"
    )
    total = time.perf_counter()
    for name in args.datasets:
        graphs, y = load_tu_dataset(f"{args.data}/{name}")
        start = time.perf_counter()
        scores, leaves = [], []
        leaf = (
            args.min_samples_leaf[0] if len(args.min_samples_leaf) == 1 else args.min_samples_leaf
        )
        options = {"classifier": args.classifier, "min_samples_leaf": leaf}
        memory = peak_memory(
            evaluate, graphs, y, args.repeats, args.n_jobs, options, scores, leaves
        )
        seconds = time.perf_counter() - start
        sizes, counts = np.unique(leaves, return_counts=True)
        order = np.argsort(-counts, kind="stable")
        chosen = ", ".join(f"{sizes[i]}: {counts[i]}" for i in order)
        print(
            f"{name:<12} {len(y):>6} {np.mean(scores):>6.1f} ± {np.std(scores):<4.1f}"
            f" {PERSLAY.get(name, float('nan')):>8.1f} {seconds:>7.1f}s {memory:>8.0f}  {chosen}",
            flush=True,
        )
    print(f"total {time.perf_counter() - total:.1f}s")


if __name__ == "__main__":
    main()
