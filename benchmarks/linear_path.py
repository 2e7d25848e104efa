"""The linear-cost path (``make_mesh_features()``) under nested cross-validation, for
``learning_quality.py``.

The features' unsupervised stages learn nothing from labels (the diagrams and spectra
learn nothing at all), so the diagrams are computed once; the learned parts (the
landscapes' grids, the scales of ``DistanceScaler``) are fitted on each outer training
split only. Every choice among the configurations (``candidates()``: the vectorizers;
``weightings()``: the weights) is made inside the outer training split by its
leave-one-out 1-NN, and the linear models' regularization by an inner 3-fold grid
search, so the outer test split never takes part in a choice.
"""

from __future__ import annotations

import time
import warnings

import numpy as np
from _common import folds, loo_1nn
from sklearn.base import clone
from sklearn.linear_model import LogisticRegression, RidgeClassifier
from sklearn.metrics import pairwise_distances
from sklearn.model_selection import GridSearchCV, StratifiedKFold
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler

from sklearn_meshph import (
    BettiCurve,
    DiagramStatistics,
    PersistenceLandscape,
    Silhouette,
    make_mesh_features,
)

#: The vectorizers tried in place of the preset's (5 landscapes of 20 points).
VECTORIZERS = {
    "landscapes 5 x 20 (the preset)": PersistenceLandscape(n_landscapes=5, resolution=20),
    "landscapes 5 x 10": PersistenceLandscape(n_landscapes=5, resolution=10),
    "landscapes 10 x 20": PersistenceLandscape(n_landscapes=10, resolution=20),
    "landscapes 2 x 20": PersistenceLandscape(n_landscapes=2, resolution=20),
    "silhouette 20": Silhouette(resolution=20),
    "Betti curve 20": BettiCurve(resolution=20),
    "statistics": DiagramStatistics(),
}
#: Weights of the parts: the square roots of the default's (the preset) or the default's
#: own, and the spectrum's weight as the default's or doubled.
WEIGHTINGS = {"sqrt": 0.5, "linear": 1.0}
DNA_FACTORS = (1.0, 2.0)

LINEAR_MODELS = {
    "StandardScaler + LogisticRegression": (
        make_pipeline(StandardScaler(), LogisticRegression(max_iter=2000)),
        {"logisticregression__C": [0.01, 0.1, 1.0]},
    ),
    "StandardScaler + RidgeClassifier": (
        make_pipeline(StandardScaler(), RidgeClassifier()),
        {"ridgeclassifier__alpha": [1.0, 10.0, 100.0, 1000.0]},
    ),
}


def preset_parts():
    """The fitted-per-split stages of ``make_mesh_features()`` after the diagrams and
    the spectrum: name -> (stages, weight)."""
    union = make_mesh_features().named_steps["features"]
    return {
        name: (part[1:], union.transformer_weights[name]) for name, part in union.transformer_list
    }


def candidates():
    """Vectorizer name -> {part: stages}: the preset's stages with each vectorizer in
    place of its landscapes (the spectrum's stages unchanged)."""
    preset = preset_parts()
    found = {}
    for vectorizer_name, vectorizer in VECTORIZERS.items():
        parts = {name: clone(stages) for name, (stages, _) in preset.items()}
        for name, stages in parts.items():
            if name != "dna":
                stages.set_params(landscape=clone(vectorizer))
        found[vectorizer_name] = parts
    return found


def weightings():
    """Weighting name -> {part: weight}: the preset's (the square roots of the default's
    weights) or the default's own, with the spectrum's weight as the default's or doubled."""
    default = {name: weight**2 for name, (_, weight) in preset_parts().items()}
    found = {}
    for weighting, power in WEIGHTINGS.items():
        for factor in DNA_FACTORS:
            weights = {name: w**power for name, w in default.items()}
            weights["dna"] *= factor**power
            found[f"{weighting} weights, spectrum x{factor:g}"] = weights
    return found


PRESET = ("landscapes 5 x 20 (the preset)", "sqrt weights, spectrum x1")


def blocks(parts, inputs, train):
    """Each part's features of every sample, its stages fitted on ``train`` only."""
    return {
        name: clone(stages).fit([inputs[name][i] for i in train]).transform(inputs[name])
        for name, stages in parts.items()
    }


def weighted(parts, weights):
    return np.hstack([weights[name] * block for name, block in parts.items()])


def default_inputs(fields, y):
    """The inputs of the preset's learned stages: each kind's diagrams, the spectra."""
    union = make_mesh_features().named_steps["features"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return {name: part[0].fit_transform(fields) for name, part in union.transformer_list}


def nearest(F, y, train, test):
    D = pairwise_distances(F[test], F[train])
    return float(np.mean(y[train][np.argmin(D, axis=1)] == y[test]))


def nested_features(fields, y, repeats=10, linear_repeats=3):
    """The linear-cost path's accuracy on a collection, the preset's and nested.

    Returns {row: (mean, std, seconds)}: 1-NN (Euclidean) of the preset with every
    split fitted on its training meshes, the same with the configuration chosen inside
    each training split among ``candidates()``, and the linear models on the preset's
    features with their regularization chosen inside (``linear_repeats`` x 5 outer
    folds), and which configurations won."""
    inputs = default_inputs(fields, y)
    vectorizers, weights = candidates(), weightings()
    rows, won = {}, {}
    start = time.perf_counter()
    preset, nested = [], []
    for train, test in folds(y, repeats):
        inner, found = {}, {}
        for vectorizer, parts in vectorizers.items():
            computed = blocks(parts, inputs, train)
            for weighting, chosen in weights.items():
                F = found[vectorizer, weighting] = weighted(computed, chosen)
                inner[vectorizer, weighting] = loo_1nn(pairwise_distances(F[train]), y[train])
        best = max(inner, key=inner.get)  # the first of the best, in the order above
        won[best] = won.get(best, 0) + 1
        preset.append(nearest(found[PRESET], y, train, test))
        nested.append(nearest(found[best], y, train, test))
    seconds = time.perf_counter() - start
    rows["1-NN, the preset (no choice)"] = (np.mean(preset), np.std(preset), seconds)
    rows["1-NN, configuration chosen inside (nested)"] = (np.mean(nested), np.std(nested), seconds)
    n_splits = min(5, int(np.bincount(y).min()))
    for model_name, (model, grid) in LINEAR_MODELS.items():
        start = time.perf_counter()
        scores = []
        for train, test in folds(y, linear_repeats):
            F = weighted(blocks(vectorizers[PRESET[0]], inputs, train), weights[PRESET[1]])
            inner = StratifiedKFold(n_splits=min(3, n_splits), shuffle=True, random_state=1)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                search = GridSearchCV(clone(model), grid, cv=inner).fit(F[train], y[train])
            scores.append(search.score(F[test], y[test]))
        rows[f"{model_name}, nested"] = (
            np.mean(scores),
            np.std(scores),
            time.perf_counter() - start,
        )
    return rows, won


def print_nested_features(results, names):
    """The table of :func:`nested_features` for the collections ``names``."""
    print(
        "\nThe linear-cost path (make_mesh_features(); make_mesh_distance('features') for "
        "1-NN),\nevery split fitted on its training meshes; nested: every choice made "
        "inside the training split:\n"
    )
    print("| model | " + " | ".join(f"{n} mean +/- std | {n} s" for n in names) + " |")
    print("|---|" + "---|---|" * len(names))
    rows = {}
    for n in names:
        for row, value in results["features", n][0].items():
            rows.setdefault(row, {})[n] = value
    print_rows(rows, names)
    for n in names:
        print(f"- {n}: configurations chosen inside the splits: {results['features', n][1]}")


def print_rows(rows, names):
    """Table rows of ``{row: {collection: (mean, std, seconds)}}``."""
    for row, per in rows.items():
        cells = []
        for n in names:
            mean, std, seconds = per.get(n, (float("nan"),) * 3)
            cells += [f"{mean:.3f} +/- {std:.3f}", f"{seconds:.0f}"]
        print(f"| {row} | " + " | ".join(cells) + " |")
