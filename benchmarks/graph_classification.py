"""make_graph_classifier under PersLay's protocol on the shared TU datasets.

PersLay (Carriere et al., AISTATS 2020): 10-fold shuffled cross-validation
(``KFold(10, shuffle=True)``), repeated 10 times (seeds 0 to 9 here), mean accuracy.
The classifier is the library's fixed recipe: nothing is tuned on these datasets (with
``--min-samples-leaf 1 5`` the forest's leaf size is chosen inside each fit from the
training folds' out-of-bag votes; with ``--classifier kernels`` the kernels summed and
the SVM's C are chosen by cross-validation inside each training fold), so no setting
can have seen a test fold. The steps before the classifier (signatures, persistence,
features, or the distances between each pair of graphs) learn nothing from the
training graphs but the kernel SVM's standardization of the features, so they run once
per dataset and only the classifier is fitted per
fold (on the training block of the distances, the pairwise slicing of
``cross_validate``; for the kernel SVM ``GraphPairDistances.fold_stack``, which also
standardizes the features on the training graphs): the same predictions as fitting the
whole pipeline per fold, at a fraction of the time.

Prints, per dataset, the mean accuracy and its standard deviation over the repeats
beside PersLay's published mean, the time (features and the 100 fits), the peak
memory and what the fits chose (the leaf size, or the kernels and C; how many chose
each); then the total time.

    python benchmarks/graph_classification.py                  # the six, 10 x 10 folds
    python benchmarks/graph_classification.py --repeats 1 --datasets MUTAG COX2
    python benchmarks/graph_classification.py --min-samples-leaf 1 5   # leaf size chosen
    python benchmarks/graph_classification.py --classifier kernels     # the kernel SVM
"""

import argparse
import time

import numpy as np
from _common import DATA, peak_memory
from joblib import Parallel, delayed
from sklearn.base import clone
from sklearn.model_selection import KFold, cross_validate

from sklearn_meshph import load_tu_dataset, make_graph_classifier

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
    """What a fit chose: its leaf size, or the kernels summed and C."""
    if hasattr(fitted, "C_"):
        kernels = "+".join(KERNELS[g] for g in np.flatnonzero(fitted.weights_))
        return f"{kernels} C={fitted.C_:g}"
    return getattr(fitted, "min_samples_leaf_", fitted.min_samples_leaf)


def evaluate(graphs, y, repeats, n_jobs, options, scores, leaves):
    """Append to ``scores`` the mean accuracy (%) of each repeat of PersLay's protocol,
    to ``leaves`` what each fit chose."""
    model = make_graph_classifier(n_jobs=n_jobs, **options)
    features = model[:-1].fit_transform(graphs)
    final = model[-1]
    for seed in range(repeats):
        cv = KFold(10, shuffle=True, random_state=seed)
        if options["classifier"] == "kernels":
            # The folds in parallel (the forest's trees are already): each slices the
            # stack and standardizes the features on its training graphs.
            folds = Parallel(n_jobs=n_jobs)(
                delayed(kernel_fold)(final, model[-2], features, y, train, test)
                for train, test in cv.split(graphs)
            )
            scores.append(100 * np.mean([score for score, _ in folds]))
            leaves += [chosen for _, chosen in folds]
            continue
        result = cross_validate(clone(final), features, y, cv=cv, return_estimator=True)
        scores.append(100 * result["test_score"].mean())
        leaves += [choice(fitted) for fitted in result["estimator"]]


def kernel_fold(final, distances, stack, y, train, test):
    """Accuracy and choice of the kernel SVM fitted on the ``train`` graphs: the
    distances a ``GraphPairDistances`` fitted on them alone gives (``fold_stack``)."""
    fitted = clone(final).fit(distances.fold_stack(stack, train, train), y[train])
    return fitted.score(distances.fold_stack(stack, test, train), y[test]), choice(fitted)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--datasets", nargs="+", default=list(PERSLAY), choices=list(PERSLAY))
    parser.add_argument("--repeats", type=int, default=10, help="repeats of 10-fold CV")
    parser.add_argument("--n-jobs", type=int, default=2)
    parser.add_argument(
        "--min-samples-leaf", type=int, nargs="+", default=[1], help="leaf size or candidates"
    )
    parser.add_argument(
        "--classifier",
        choices=["trees", "kernels"],
        default="trees",
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
            f" {PERSLAY[name]:>8.1f} {seconds:>7.1f}s {memory:>8.0f}  {chosen}",
            flush=True,
        )
    print(f"total {time.perf_counter() - total:.1f}s")


if __name__ == "__main__":
    main()
