"""How the kernel SVM of ``make_graph_classifier(classifier="kernels")`` could choose
its kernels and C: the ways screened in docs/graphs.md ("What was tried").

    python benchmarks/graph_kernel_choices.py [--datasets MUTAG COX2] [--repeats 10]

PersLay's protocol (10-fold shuffled cross-validation, seeds 0 to ``--repeats - 1``) on
the stack of ``GraphPairDistances`` (computed once per dataset: a pair's distances
depend on that pair alone). In each training fold the positions' kernels are
``exp(-d / (2 median))`` (the median over the training pairs), averaged into three
groups (diagrams, Weisfeiler-Lehman patterns, the nodes' discrepancy with the features),
as ``KernelSumSVC`` does; then
an SVM with a precomputed kernel, its kernels and C given by one of the strategies:

- ``choice``: every non-empty sum of the groups with C in 1, 10, 100 (21 candidates),
  the best by the mean accuracy of 5 internal shuffled folds (``KernelSumSVC``);
- ``choice by hinge``: the same candidates, the best by the internal folds' mean hinge
  loss (continuous, so less noisy than an accuracy on a few dozen graphs);
- ``sum, C=1`` and ``sum, C=10``: no choice, the three groups summed;
- ``average of 21`` and ``average at C=1``: no choice, the sign of the mean of the
  candidates' decision functions, each divided by its standard deviation on the
  training graphs.

Everything is chosen on the training folds; a fixed strategy's score is what that fixed
recipe would give. PersLay's published accuracy is printed beside (the anchor).
"""

import argparse
import itertools
import time

import numpy as np
from _common import DATA
from graph_classification import PERSLAY
from joblib import Parallel, delayed
from sklearn.model_selection import KFold
from sklearn.svm import SVC

from sklearn_meshph import load_tu_dataset, make_graph_classifier

GROUPS = ("diagrams", "patterns", "features")
SUMS = [w for w in itertools.product((0.0, 1.0), repeat=len(GROUPS)) if any(w)]
CANDIDATES = [(w, c) for w in SUMS for c in (1.0, 10.0, 100.0)]
ALL_THREE = (1.0, 1.0, 1.0)


def group_kernels(stack, groups, train):
    """``(n, n, 3)`` kernels of the groups, scaled by the training pairs' medians."""
    upper = np.triu_indices(len(train), 1)
    block = stack[np.ix_(train, train)]
    medians = np.array([np.median(block[:, :, k][upper]) for k in range(stack.shape[2])])
    medians[~(medians > 0)] = 1.0
    average = np.zeros((stack.shape[2], len(GROUPS)))
    average[np.arange(stack.shape[2]), groups] = 1.0
    average /= average.sum(axis=0)
    return np.exp(stack / (-2.0 * medians)) @ average


def svm(kernel, y, train, c):
    return SVC(C=c, kernel="precomputed").fit(kernel[np.ix_(train, train)], y[train])


def internal_score(kernel, y, train, c, folds, hinge):
    scores = []
    for inner_train, inner_test in folds:
        fit, held = train[inner_train], train[inner_test]
        model = svm(kernel, y, fit, c)
        if hinge:
            sign = np.where(y[held] == model.classes_[1], 1.0, -1.0)
            margin = sign * model.decision_function(kernel[np.ix_(held, fit)])
            scores.append(-np.mean(np.maximum(0.0, 1.0 - margin)))
        else:
            scores.append(np.mean(model.predict(kernel[np.ix_(held, fit)]) == y[held]))
    return np.mean(scores)


def chosen(kernels, y, train, hinge):
    folds = list(KFold(5, shuffle=True, random_state=0).split(train))
    scores = [
        internal_score(kernels @ np.array(w), y, train, c, folds, hinge) for w, c in CANDIDATES
    ]
    return CANDIDATES[int(np.argmax(scores))]  # the first on ties


def fold(stack, groups, y, train, test):
    """The test accuracy of every strategy on one outer fold (each candidate's SVM
    fitted once on the training graphs)."""
    kernels = group_kernels(stack, groups, train)
    decisions, predictions = {}, {}
    for w, c in CANDIDATES:
        kernel = kernels @ np.array(w)
        model = svm(kernel, y, train, c)
        spread = np.std(model.decision_function(kernel[np.ix_(train, train)])) or 1.0
        decisions[w, c] = model.decision_function(kernel[np.ix_(test, train)]) / spread
        predictions[w, c] = model.predict(kernel[np.ix_(test, train)])
    classes = np.unique(y[train])

    def accuracy(w, c):
        return np.mean(predictions[w, c] == y[test])

    def average(keys):
        mean = np.mean([decisions[k] for k in keys], axis=0)
        return np.mean(np.where(mean > 0, classes[1], classes[0]) == y[test])

    return {
        "choice": accuracy(*chosen(kernels, y, train, hinge=False)),
        "choice by hinge": accuracy(*chosen(kernels, y, train, hinge=True)),
        "sum, C=1": accuracy(ALL_THREE, 1.0),
        "sum, C=10": accuracy(ALL_THREE, 10.0),
        "average of 21": average(list(decisions)),
        "average at C=1": average([k for k in decisions if k[1] == 1.0]),
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--datasets", nargs="+", default=["MUTAG", "COX2", "DHFR", "PROTEINS"])
    parser.add_argument("--repeats", type=int, default=10)
    parser.add_argument("--n-jobs", type=int, default=2)
    parser.add_argument("--data", default=str(DATA / "tu"), help="folder of the TU datasets")
    args = parser.parse_args()
    header = None
    for name in args.datasets:
        start = time.perf_counter()
        graphs, y = load_tu_dataset(f"{args.data}/{name}")
        y = np.asarray(y)
        if len(np.unique(y)) != 2:
            raise SystemExit(f"{name}: the hinge loss and the averages here are for two classes")
        model = make_graph_classifier(classifier="kernels", n_jobs=args.n_jobs)
        stack = model[:-1].fit_transform(graphs)
        # KernelSumSVC("graph")'s layout: the diagrams, the patterns, then the nodes'
        # discrepancy and the features in one group.
        groups = np.r_[np.zeros(stack.shape[2] - 3, dtype=int), 1, 2, 2]
        splits = [
            split
            for seed in range(args.repeats)
            for split in KFold(10, shuffle=True, random_state=seed).split(y)
        ]
        results = Parallel(n_jobs=args.n_jobs)(
            delayed(fold)(stack, groups, y, train, test) for train, test in splits
        )
        if header is None:
            header = list(results[0])
            print(f"| dataset | {' | '.join(header)} | PersLay | seconds |")
            print(f"|---|{'---|' * (len(header) + 2)}")
        cells = []
        for strategy in header:
            per_repeat = 100 * np.array([r[strategy] for r in results]).reshape(-1, 10).mean(1)
            cells.append(f"{per_repeat.mean():.1f} ± {per_repeat.std():.1f}")
        seconds = time.perf_counter() - start
        published = PERSLAY.get(name)
        published = "" if published is None else f"{published:.1f}"
        print(f"| {name} | {' | '.join(cells)} | {published} | {seconds:.0f} |", flush=True)


if __name__ == "__main__":
    main()
