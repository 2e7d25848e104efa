"""How the kernel SVM of ``make_graph_classifier(classifier="kernels")`` could choose
its kernels and C: the ways screened in docs/graphs.md ("What was tried").

    python benchmarks/graph_kernel_choices.py [--datasets MUTAG COX2] [--repeats 10]
        [--strategies first|second]

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
  training graphs;
- ``evidence, C chosen``: the groups' weights (continuous, not a subset) and a noise
  level fitted as a Gaussian process's hyperparameters, by the log marginal likelihood
  of the centred +-1 labels of the training graphs (up to 1,000 of them, drawn with
  seed 0); the weights scaled to sum 1, then C in 1, 10, 100 chosen by the same
  internal folds as ``choice`` (3 candidates instead of 21);
- ``evidence, C=1/noise``: the same weights unscaled and C the inverse of the fitted
  noise, no internal folds;
- ``GP mean``: the sign of that Gaussian process's posterior mean (kernel ridge
  regression of the labels with the fitted weights and noise).

``--strategies second`` runs another set instead (each from the same internal folds'
out-of-fold decision values, so nothing more is fitted on the test graphs):

- ``choice, stratified 5``, ``5 x 3``, ``10``: the choice from stratified internal
  folds (three seeds of 5 folds pooled; 10 folds);
- ``aligned sum, C chosen``: the sum of largest centred kernel-target alignment with
  the training labels, then its C by the internal folds (7 sums, then 3 values of C);
- ``stacked, 21`` (also with a ten times larger penalty) and ``stacked at C=1``: a
  logistic regression with non-negative weights on the candidates' out-of-fold
  decision values (a super learner: a blend, not an argmax);
- ``fixed ...``: each candidate's fixed score over the same outer folds, for diagnosis
  only (choosing one of them would be choosing on the test folds).

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
from scipy.linalg import LinAlgError, cho_factor, cho_solve
from scipy.optimize import minimize
from sklearn.model_selection import KFold, StratifiedKFold
from sklearn.svm import SVC

from sklearn_meshph import load_tu_dataset, make_graph_classifier

GROUPS = ("diagrams", "patterns", "features")
SUMS = [w for w in itertools.product((0.0, 1.0), repeat=len(GROUPS)) if any(w)]
CANDIDATES = [(w, c) for w in SUMS for c in (1.0, 10.0, 100.0)]
ALL_THREE = (1.0, 1.0, 1.0)
STACKINGS = [
    ("stacked, 21", CANDIDATES, 1.0),
    ("stacked, 21, penalty 10", CANDIDATES, 10.0),
    ("stacked at C=1", [k for k in CANDIDATES if k[1] == 1.0], 1.0),
]


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


def out_of_fold(kernels, y, train, keys, splitter=None):
    """The internal folds' decision values of each candidate on the graphs it did not
    see, ``(len(train), len(keys))``, and its accuracy over those folds."""
    splitter = splitter or KFold(5, shuffle=True, random_state=0)
    folds = list(splitter.split(train, y[train]))
    values = np.zeros((len(train), len(keys)))
    hits = np.zeros((len(train), len(keys)), dtype=bool)
    for inner_train, inner_test in folds:
        fit, held = train[inner_train], train[inner_test]
        for k, (w, c) in enumerate(keys):
            kernel = kernels @ np.array(w)
            model = svm(kernel, y, fit, c)
            block = kernel[np.ix_(held, fit)]
            values[inner_test, k] = model.decision_function(block)
            hits[inner_test, k] = model.predict(block) == y[held]
    return values, hits


def stacking_weights(values, target, penalty):
    """Non-negative weights and an intercept of a logistic regression of the +-1
    ``target`` on the candidates' out-of-fold decision ``values`` (L2 ``penalty`` on
    the weights): a convex-cone blend of the candidates, not an argmax over them."""

    def loss(params):
        w, b = params[:-1], params[-1]
        margin = target * (values @ w + b)
        value = np.sum(np.logaddexp(0.0, -margin)) + penalty * w @ w
        slope = -target * 0.5 * (1.0 - np.tanh(0.5 * margin))  # -t sigmoid(-m)
        gradient = np.r_[values.T @ slope + 2.0 * penalty * w, slope.sum()]
        return value, gradient

    start = np.r_[np.full(values.shape[1], 1.0 / values.shape[1]), 0.0]
    bounds = [(0.0, None)] * values.shape[1] + [(None, None)]
    result = minimize(loss, start, jac=True, method="L-BFGS-B", bounds=bounds)
    return result.x[:-1], result.x[-1]


def chosen(kernels, y, train, hinge):
    folds = list(KFold(5, shuffle=True, random_state=0).split(train))
    scores = [
        internal_score(kernels @ np.array(w), y, train, c, folds, hinge) for w, c in CANDIDATES
    ]
    return CANDIDATES[int(np.argmax(scores))]  # the first on ties


def negative_evidence(log_params, kernels, target):
    """Negative log marginal likelihood (without its constant) of ``target`` under a
    Gaussian process with kernel ``sum_g a_g K_g + noise I``, and its gradient, in
    ``log_params = log(a_1), ..., log(a_G), log(noise)``."""
    weights, noise = np.exp(log_params[:-1]), np.exp(log_params[-1])
    covariance = kernels @ weights + noise * np.eye(len(target))
    try:
        factor = cho_factor(covariance, lower=True)
    except LinAlgError:
        return np.inf, np.zeros_like(log_params)
    alpha = cho_solve(factor, target)
    value = 0.5 * target @ alpha + np.sum(np.log(np.diag(factor[0])))
    # d value / d theta = -0.5 tr((alpha alpha^T - C^-1) dC/dtheta)
    inner = np.outer(alpha, alpha) - cho_solve(factor, np.eye(len(target)))
    gradient = [-0.5 * np.sum(inner * kernels[:, :, g]) * w for g, w in enumerate(weights)]
    gradient.append(-0.5 * np.trace(inner) * noise)
    return value, np.array(gradient)


def evidence_fit(kernels, y, train, limit=1000):
    """The groups' weights and the noise that maximize the evidence of the training
    graphs' +-1 labels (on ``limit`` of them at most)."""
    rows = train
    if len(rows) > limit:
        rows = np.sort(np.random.RandomState(0).choice(train, limit, replace=False))
    classes = np.unique(y[train])
    target = np.where(y[rows] == classes[1], 1.0, -1.0)
    target -= target.mean()
    block = kernels[np.ix_(rows, rows)]
    bounds = [(-12.0, 6.0)] * kernels.shape[2] + [(-8.0, 4.0)]
    best = None
    for log_noise in (-2.0, 0.0):  # two starts: the evidence can have two modes
        start = np.r_[np.zeros(kernels.shape[2]), log_noise]
        result = minimize(
            negative_evidence,
            start,
            args=(block, target),
            jac=True,
            method="L-BFGS-B",
            bounds=bounds,
        )
        if best is None or result.fun < best.fun:
            best = result
    return np.exp(best.x[:-1]), np.exp(best.x[-1])


def evidence_strategies(kernels, y, train, test):
    weights, noise = evidence_fit(kernels, y, train)
    kernel = kernels @ weights
    classes = np.unique(y[train])
    target = np.where(y[train] == classes[1], 1.0, -1.0)
    alpha = np.linalg.solve(
        kernel[np.ix_(train, train)] + noise * np.eye(len(train)), target - target.mean()
    )
    mean = kernel[np.ix_(test, train)] @ alpha + target.mean()
    scaled = kernel / weights.sum()
    folds = list(KFold(5, shuffle=True, random_state=0).split(train))
    scores = [internal_score(scaled, y, train, c, folds, hinge=False) for c in (1.0, 10.0, 100.0)]
    c = (1.0, 10.0, 100.0)[int(np.argmax(scores))]

    def accuracy(model_kernel, c):
        model = svm(model_kernel, y, train, c)
        return np.mean(model.predict(model_kernel[np.ix_(test, train)]) == y[test])

    return {
        "evidence, C chosen": accuracy(scaled, c),
        "evidence, C=1/noise": accuracy(kernel, 1.0 / noise),
        "GP mean": np.mean(np.where(mean > 0, classes[1], classes[0]) == y[test]),
    }


def second_set(kernels, y, train, test, accuracy, decisions, spreads):
    """The second set of strategies (``--strategies second``), each candidate's SVM on
    all the training graphs already fitted (``accuracy``, ``decisions``): the choice
    from stratified internal folds; the sum of largest centred alignment with the
    labels, then C by the internal folds; stacked (``stacking_weights``); and every
    candidate's fixed score, for diagnosis only."""
    classes = np.unique(y[train])
    target = np.where(y[train] == classes[1], 1.0, -1.0)
    values, hits = out_of_fold(kernels, y, train, CANDIDATES)
    result = {"choice": accuracy(*CANDIDATES[int(np.argmax(hits.mean(axis=0)))])}
    for name, seeds, n_folds in (("5", [0], 5), ("5 x 3", [0, 1, 2], 5), ("10", [0], 10)):
        rates = sum(
            out_of_fold(
                kernels,
                y,
                train,
                CANDIDATES,
                StratifiedKFold(n_folds, shuffle=True, random_state=s),
            )[1].mean(axis=0)
            for s in seeds
        )
        result[f"choice, stratified {name}"] = accuracy(*CANDIDATES[int(np.argmax(rates))])
    centre = np.eye(len(train)) - 1.0 / len(train)
    alignments = []
    for w in SUMS:
        centred = centre @ (kernels[np.ix_(train, train)] @ np.array(w)) @ centre
        alignments.append(target @ centred @ target / np.linalg.norm(centred))
    w = SUMS[int(np.argmax(alignments))]
    rates = [hits[:, CANDIDATES.index((w, c))].mean() for c in (1.0, 10.0, 100.0)]
    result["aligned sum, C chosen"] = accuracy(w, (1.0, 10.0, 100.0)[int(np.argmax(rates))])
    for name, keys, penalty in STACKINGS:
        columns = [CANDIDATES.index(k) for k in keys]
        weights, intercept = stacking_weights(values[:, columns], target, penalty)
        test_values = np.column_stack([decisions[k] * spreads[k] for k in keys])
        labels = np.where(test_values @ weights + intercept > 0, classes[1], classes[0])
        result[name] = np.mean(labels == y[test])
    return {**result, **{f"fixed {w} C={c:g}": accuracy(w, c) for w, c in CANDIDATES}}


def fold(stack, groups, y, train, test, strategies="first"):
    """The test accuracy of every strategy on one outer fold (each candidate's SVM
    fitted once on the training graphs)."""
    kernels = group_kernels(stack, groups, train)
    decisions, predictions, spreads = {}, {}, {}
    for w, c in CANDIDATES:
        kernel = kernels @ np.array(w)
        model = svm(kernel, y, train, c)
        spread = np.std(model.decision_function(kernel[np.ix_(train, train)])) or 1.0
        spreads[w, c] = spread
        decisions[w, c] = model.decision_function(kernel[np.ix_(test, train)]) / spread
        predictions[w, c] = model.predict(kernel[np.ix_(test, train)])
    classes = np.unique(y[train])

    def accuracy(w, c):
        return np.mean(predictions[w, c] == y[test])

    def average(keys):
        mean = np.mean([decisions[k] for k in keys], axis=0)
        return np.mean(np.where(mean > 0, classes[1], classes[0]) == y[test])

    if strategies == "second":
        return second_set(kernels, y, train, test, accuracy, decisions, spreads)
    return {
        "choice": accuracy(*chosen(kernels, y, train, hinge=False)),
        "choice by hinge": accuracy(*chosen(kernels, y, train, hinge=True)),
        "sum, C=1": accuracy(ALL_THREE, 1.0),
        "sum, C=10": accuracy(ALL_THREE, 10.0),
        "average of 21": average(list(decisions)),
        "average at C=1": average([k for k in decisions if k[1] == 1.0]),
        **evidence_strategies(kernels, y, train, test),
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--datasets", nargs="+", default=["MUTAG", "COX2", "DHFR", "PROTEINS"])
    parser.add_argument("--repeats", type=int, default=10)
    parser.add_argument("--n-jobs", type=int, default=2)
    parser.add_argument("--data", default=str(DATA / "tu"), help="folder of the TU datasets")
    parser.add_argument(
        "--strategies",
        choices=("first", "second"),
        default="first",
        help="which set of strategies (the module's docstring)",
    )
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
            delayed(fold)(stack, groups, y, train, test, args.strategies) for train, test in splits
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
