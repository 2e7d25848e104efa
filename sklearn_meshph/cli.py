"""The command line's main job: classify a folder of meshes or point clouds, a TU dataset
folder of graphs (or built-in synthetic shapes) end to end with a pipeline of the library.

Run ``python -m sklearn_meshph --help`` (or the ``sklearn-meshph`` console script). The
pipeline is ``make_mesh_distance(--preset)`` (see :data:`sklearn_meshph.pipelines.PRESETS`)
with the eigen stage's options and ``--set step__param=value`` applied; the options,
their checks and the pipeline are in :mod:`._cli_args`, the messages in
:mod:`._cli_messages`, the files written in :mod:`._report`.

Cross-validation: the stages that learn nothing (their ``requires_fit`` tag is false:
the eigen stage, the persistence stages) give each sample the same output in every fold,
so each runs once for all samples, and the fold models take sample indices and look
those outputs up (:class:`SampleLookup`, :func:`on_indices`). Everything that learns
(median scales, normalizations...) is fitted per fold, on the training samples only, and
a k-NN classifier on the blocks it gives (:func:`cross_validate`). The full distance
matrix written to ``distances.npy`` (and embedded by t-SNE) comes from the pipeline
fitted on all samples.

Exit status: 0 on success; 2 for a usage error (bad option or parameter, missing folder,
folder without samples, a class smaller than ``--folds``, ``--neighbors`` larger than a
training fold, an ``--output`` that cannot be written), reported on one ``error:`` line
before any sample is loaded; 1 when a sample cannot be processed (the line names its
file). Output cut short by its reader (``| head``) ends the job quietly.
"""

from __future__ import annotations

import os
import re
import sys
import time
import warnings

import numpy as np
from sklearn.base import BaseEstimator, TransformerMixin, clone
from sklearn.metrics import accuracy_score
from sklearn.model_selection import StratifiedKFold
from sklearn.neighbors import KNeighborsClassifier
from sklearn.pipeline import Pipeline
from sklearn.utils import get_tags

from ._cli_args import (
    build_parser,
    build_pipeline,
    check_folds,
    check_graph_pipeline,
    check_options,
    check_output,
    choose_preset,
)
from ._cli_messages import (
    DataError,
    Names,
    UsageError,
    first_run_note,
    note,
    one_line,
    printable,
    sample_indices,
)
from ._report import (
    format_confusion,
    json_safe,
    wrap,
    write_data,
    write_pictures,
    write_summary,
)
from ._version import VERSION
from .combine import CombinedDistance
from .datasets import SHAPE_CLASSES, SkippedFilesWarning, load_mesh_folder, make_shapes
from .graph import Graph, load_tu_dataset, tu_dataset_names
from .mesh import MeshCleaningWarning
from .spectral import RepeatedEigenvalueWarning

__all__ = [
    "SampleLookup",
    "build_parser",
    "cross_validate",
    "format_confusion",
    "main",
    "on_indices",
]

# The built-in run's shapes: coarse tessellations, so that the first command stays short.
_BUILT_IN_RESOLUTION = (14, 24)


# Cross-validation --------------------------------------------------------------


class _Shared(tuple):
    """A read-only table of outputs that the clones of a lookup share (not copied)."""

    def __deepcopy__(self, memo):
        return self


class SampleLookup(TransformerMixin, BaseEstimator):
    """Stands for a stage that learns nothing: ``transform(indices)`` returns the
    stage's precomputed output of each sample index.

    Parameters
    ----------
    outputs : sequence, default=()
        The stage's output per sample, in sample order.
    """

    def __init__(self, outputs=()):
        self.outputs = outputs

    def fit(self, X, y=None):
        """Nothing to learn.

        Parameters
        ----------
        X : sequence of int
        y : ignored

        Returns
        -------
        self
        """
        return self

    def transform(self, X):
        """The outputs of the samples whose indices are ``X``.

        Parameters
        ----------
        X : sequence of int

        Returns
        -------
        list
        """
        return [self.outputs[int(i)] for i in X]


def _stateless(step) -> bool:
    return step not in (None, "passthrough") and not get_tags(step).requires_fit


def on_indices(estimator, samples, tables=None, name="distance"):
    """An equivalent of ``estimator`` that takes sample indices instead of ``samples``.

    The first step of each of its pipelines (also inside a :class:`CombinedDistance`)
    that learns nothing is run once on all ``samples`` and replaced by its outputs; each
    such table is appended to ``tables`` as ``(name, stage, outputs)``.
    """
    tables = [] if tables is None else tables
    if isinstance(estimator, CombinedDistance):
        parts = [
            (part_name, on_indices(part, samples, tables, f"{name}__{part_name}"))
            for part_name, part in estimator.transformer_list
        ]
        return clone(estimator).set_params(transformer_list=parts)
    if isinstance(estimator, Pipeline) and _stateless(estimator.steps[0][1]):
        (first_name, first), rest = estimator.steps[0], estimator.steps[1:]
        outputs = _Shared(first.fit_transform(samples))
        tables.append((f"{name}__{first_name}", first, outputs))
        return Pipeline([(first_name, SampleLookup(outputs)), *rest])
    return Pipeline([("samples", SampleLookup(_Shared(samples))), ("model", estimator)])


def cross_validate(model, y, folds, neighbors, random_state):
    """Per-fold scores, the prediction of each sample and the fold it was tested in.

    ``model`` takes sample indices (see :func:`on_indices`); a clone of it is fitted on
    each fold's training indices, and gives the train-train block (the classifier's
    fit) and the test-train block (its prediction).
    """
    cv = StratifiedKFold(n_splits=folds, shuffle=True, random_state=random_state)
    predicted = np.empty_like(y)
    fold_of = np.empty(len(y), dtype=int)
    scores = []
    for k, (train, test) in enumerate(cv.split(np.zeros((len(y), 1)), y)):
        fitted = clone(model)
        train_block = np.asarray(fitted.fit_transform(train.tolist()), dtype=float)
        test_block = np.asarray(fitted.transform(test.tolist()), dtype=float)
        knn = KNeighborsClassifier(n_neighbors=neighbors, metric="precomputed")
        with warnings.catch_warnings():  # many classes of few samples are still classes
            warnings.filterwarnings("ignore", "The number of unique classes", UserWarning)
            knn.fit(train_block, y[train])
        predicted[test] = knn.predict(test_block)
        fold_of[test] = k
        scores.append(accuracy_score(y[test], predicted[test]))
    return np.array(scores), predicted, fold_of


# The job -----------------------------------------------------------------------


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``python -m sklearn_meshph`` and the ``sklearn-meshph`` script."""
    for name in ("stdout", "stderr"):  # started with `>&-`: Python has no stream at all
        if getattr(sys, name) is None:
            setattr(sys, name, open(os.devnull, "w"))  # noqa: SIM115 (for the whole run)
    try:
        try:
            status = _main(argv)
        finally:  # what is left in the buffer, while a closed pipe can still be caught
            sys.stdout.flush()
    except BrokenPipeError:  # the reader stopped early (``| head``)
        _silence_stdout()
        _tell("stopped: standard output was closed by its reader")
        return 141  # as a program ended by SIGPIPE, so that `set -o pipefail` sees it
    except OSError as exc:  # a file that cannot be read or written, or standard output
        _silence_stdout()
        if exc.filename:
            _tell(f"error: {exc.strerror or exc}: {exc.filename!r}")
        else:
            _tell(f"error: {exc.strerror or exc} (writing the results or standard output)")
        return 1
    except KeyboardInterrupt:  # Ctrl-C: one line, not the traceback of wherever it was
        _tell("interrupted")
        return 130
    return status


def _silence_stdout() -> None:
    """Standard output made /dev/null, so that the exit's own flush does not fail again."""
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):  # no file descriptor behind sys.stdout
        pass
    finally:
        os.close(devnull)


def _tell(line: str) -> None:
    """One line on standard error, if it can still be written."""
    try:
        print(line, file=sys.stderr, flush=True)
    except (OSError, ValueError):
        pass


def _main(argv) -> int:
    args = build_parser().parse_args(argv)
    try:
        return _run(args)
    except UsageError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except DataError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1


def compute_fields(samples, eigen, names: Names, skip: bool = False):
    """The eigen stage on all the samples at once (it learns nothing); the fields, the
    number of samples of each kind of warning, and with ``skip`` the samples it refused
    as ``(index, message)`` pairs (their fields None) instead of stopping."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", RepeatedEigenvalueWarning)
        warnings.simplefilter("always", MeshCleaningWarning)
        _stage(names, eigen.fit, samples)
        fields, refused = _stage(names, eigen._transform, samples, skip)
    gone = {i for i, _ in refused}  # the samples left out are not counted

    def kept_indices(category):
        return [i for i in sample_indices(caught, category) if i not in gone]

    counts = {
        "repeated_eigenvalue": note(
            kept_indices(RepeatedEigenvalueWarning),
            "have a repeated eigenvalue at the requested index",
            names,
        ),
        "cleaned": note(kept_indices(MeshCleaningWarning), "were cleaned", names),
    }
    for w in caught:  # others: shown once each, as Python would
        if not issubclass(w.category, (RepeatedEigenvalueWarning, MeshCleaningWarning)):
            print(f"warning: {names.message(w.message)}", file=sys.stderr)
    return fields, counts, refused


def _leave_out(refused, y, class_names, names: Names, args):
    """The samples but the ``refused`` ones (listed by file, as unreadable files are):
    ``(kept indices, y, class_names, skipped)``, ``y`` and ``class_names`` without the
    classes left with no sample (as a class of unreadable files is dropped), the folds
    checked again, ``skipped`` the ``(file, reason)`` pairs of the refused."""
    print(f"left out {len(refused)} sample(s) that cannot be used:")
    skipped = []
    for i, message in refused:
        file = names.files[i] if names.files is not None else f"sample {i}"
        # By file, not by number: the samples are numbered anew without them.
        reason = f"{file}: {re.sub(rf'^sample {i}: ', '', one_line(message))}"
        skipped.append((file, reason))
        print(wrap(f"  {printable(reason)}"))
    gone = {i for i, _ in refused}
    kept = [i for i in range(len(y)) if i not in gone]
    if not kept:
        raise DataError("no sample can be used (all were left out above)")
    present, y = np.unique(y[kept], return_inverse=True)
    class_names = [class_names[c] for c in present]
    check_folds(y, class_names, args.folds, args.neighbors, args.random_state)
    return kept, y, class_names, skipped


def _stage(names: Names, function, *args):
    try:
        return function(*args)
    except (ValueError, TypeError) as exc:
        raise DataError(names.message(exc)) from None


def _built_in(args):
    """The synthetic shapes: labels first (checked before anything is generated)."""
    class_names = list(SHAPE_CLASSES)
    y = np.repeat(np.arange(len(class_names)), args.n_per_class)
    check_folds(y, class_names, args.folds, args.neighbors, args.random_state)
    check_output(args.output)
    data = make_shapes(
        n_per_class=args.n_per_class,
        resolution=_BUILT_IN_RESOLUTION,
        random_state=args.random_state,
    )
    filenames = [f"synthetic/{data.target_names[t]}/{i}" for i, t in enumerate(data.target)]
    source = f"built-in synthetic shapes (make_shapes, {args.n_per_class} per class)"
    return list(data.data), np.asarray(data.target), class_names, filenames, Names(), source, []


def _from_folder(args):
    """The folder's files, listed and checked, then loaded."""
    try:
        listing = load_mesh_folder(args.path, extensions=args.extensions, load=False)
    except (ValueError, TypeError) as exc:
        raise UsageError(one_line(exc)) from None
    class_names = [str(n) for n in listing.target_names]
    check_folds(listing.target, class_names, args.folds, args.neighbors, args.random_state)
    check_output(args.output)
    names = Names(listing.filenames, args.path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SkippedFilesWarning)  # listed below instead
        data = _stage(names, _load, args)
    root = os.path.join(str(args.path), "")
    skipped = [
        (Names([f], args.path).files[0], reason.replace(root, "")) for f, reason in data.skipped
    ]
    if skipped:
        print(f"skipped {len(skipped)} file(s) that cannot be read:")
        for _, reason in skipped:
            print(wrap(f"  {printable(reason)}"))
        class_names = [str(n) for n in data.target_names]
        check_folds(data.target, class_names, args.folds, args.neighbors, args.random_state)
        names = Names(data.filenames, args.path)
    samples, y = list(data.data), np.asarray(data.target)
    return samples, y, class_names, names.files, names, str(args.path), skipped


def _from_tu_folder(args):
    """The graphs of a TU dataset folder, their labels as classes, each named
    ``graph K`` after its id in the files."""
    names = tu_dataset_names(args.path)
    if len(names) > 1:
        raise UsageError(
            f"{str(args.path)!r} holds several TU datasets ({', '.join(names)}); "
            "give the folder of one"
        )
    try:
        graphs, labels = load_tu_dataset(args.path)
    except (ValueError, TypeError) as exc:
        raise DataError(one_line(exc)) from None
    values, y = np.unique(labels, return_inverse=True)
    class_names = [str(v) for v in values]
    check_folds(y, class_names, args.folds, args.neighbors, args.random_state, graphs=True)
    check_output(args.output)
    filenames = [f"graph {k}" for k in range(1, len(graphs) + 1)]
    source = f"TU dataset {names[0]} ({args.path})"
    return graphs, y, class_names, filenames, Names(filenames, args.path), source, []


def _load(args):
    return load_mesh_folder(
        args.path,
        extensions=args.extensions,
        n_jobs=args.n_jobs,
        verbose=args.verbose,
        on_error="skip" if args.skip_unreadable else "raise",
    )


def _describe(samples, class_names, source, pipeline, args) -> None:
    n_clouds = sum(isinstance(m, np.ndarray) for m in samples)
    kind = (
        "graphs"
        if all(isinstance(m, Graph) for m in samples)
        else "meshes"
        if n_clouds == 0
        else "point clouds"
        if n_clouds == len(samples)
        else f"samples ({len(samples) - n_clouds} meshes, {n_clouds} point clouds)"
    )
    print(f"data: {printable(source)}: {len(samples)} {kind}, {len(class_names)} classes")
    print(wrap("classes: " + ", ".join(printable(n) for n in class_names)))
    print(f"pipeline: preset {args.preset!r} (every parameter in summary.json)")
    for name, step in pipeline.steps:
        print(wrap(f"  {name}: {_outline(step)}"))
    print(f"  then {args.neighbors}-NN, {args.folds}-fold stratified CV (fitted per fold)")


def _outline(estimator) -> str:
    """The estimator in a line: the stages of pipelines joined by arrows, the parts of
    combinations by name, the others by their ``repr``."""
    if hasattr(estimator, "steps"):
        return " -> ".join(_outline(step) for _, step in estimator.steps)
    if hasattr(estimator, "transformer_list"):
        parts = ", ".join(f"{n}: {_outline(p)}" for n, p in estimator.transformer_list)
        return f"{type(estimator).__name__}({parts})"
    return one_line(repr(estimator))


def _diagrams(tables, n_samples, n_functions):
    """The persistence diagrams computed once for all samples, per sample, and their
    names; None when the pipeline computes none."""
    found = [(name, stage, out) for name, stage, out in tables if hasattr(stage, "diagram_names")]
    if not found:
        return None
    # A stage of one diagram per sample gives an array: tuple() of it would split its
    # rows into diagrams of one point each.
    per_sample = [
        sum((out[i] if isinstance(out[i], tuple) else (out[i],) for _, _, out in found), ())
        for i in range(n_samples)
    ]
    labels = []
    for name, stage, _ in found:
        part = name.split("__")[-2] if name.count("__") > 1 else ""
        labels += [f"{part}: {d}" if part else d for d in stage.diagram_names(n_functions)]
    return per_sample, labels


def _timed(timings, key, function, *args):
    start = time.perf_counter()
    result = function(*args)
    timings[key] = time.perf_counter() - start
    return result


def _run(args) -> int:
    check_options(args)
    graphs = args.path is not None and bool(tu_dataset_names(args.path))
    choose_preset(args, graphs)
    pipeline = build_pipeline(args)
    if graphs:
        check_graph_pipeline(pipeline)
    timings = {}
    start = time.perf_counter()
    source_of = _from_tu_folder if graphs else _built_in if args.path is None else _from_folder
    samples, y, class_names, filenames, names, source, skipped = source_of(args)
    timings["load"] = time.perf_counter() - start
    _describe(samples, class_names, source, pipeline, args)
    first_run_note()

    eigen, distance = pipeline.named_steps["eigen"], pipeline.named_steps["distance"]
    fields, warned, refused = _timed(
        timings, "eigen stage", compute_fields, samples, eigen, names, args.skip_unreadable
    )
    if refused:
        kept, y, class_names, left_out = _leave_out(refused, y, class_names, names, args)
        fields, filenames = [fields[i] for i in kept], [filenames[i] for i in kept]
        names, skipped = names.subset(kept), skipped + left_out
    tables = []
    model = _timed(timings, "persistence", _stage, names, on_indices, distance, fields, tables)
    scores, predicted, fold_of = _timed(
        timings,
        "cross-validation",
        _stage,
        names,
        cross_validate,
        model,
        y,
        args.folds,
        args.neighbors,
        args.random_state,
    )
    everything = list(range(len(y)))
    matrix = _timed(timings, "full matrix", _stage, names, clone(model).fit_transform, everything)
    matrix = np.asarray(matrix, dtype=float)

    print(
        f"\n{args.folds}-fold stratified CV accuracy: {scores.mean():.3f} "
        f"(+/- {scores.std():.3f}; folds {', '.join(f'{s:.2f}' for s in scores)})"
    )
    print("\nconfusion matrix (rows: true class, columns: predicted)")
    print(format_confusion(y, predicted, [printable(n) for n in class_names]))

    diagrams = _diagrams(tables, len(y), fields[0].n_functions)
    summary = {
        "version": VERSION,
        "source": source,
        "preset": args.preset,
        "pipeline": json_safe(pipeline.get_params(deep=True)),
        "settings": json_safe(dict(sorted(vars(args).items()))),
        "n_samples": len(y),
        "class_names": class_names,
        "class_counts": np.bincount(y, minlength=len(class_names)).tolist(),
        "skipped": [{"file": f, "reason": reason} for f, reason in skipped],
        "accuracy": {
            "per_fold": scores.tolist(),
            "mean": float(scores.mean()),
            "std": float(scores.std()),
        },
        "warnings": warned,
        "timings": dict(timings, total=time.perf_counter() - start),
    }
    predictions = (y, predicted, fold_of)
    labels = (class_names, filenames)
    # The data first: a disk that fills at the pictures keeps the results.
    written = write_data(args.output, matrix, diagrams, predictions, *labels, summary)
    print(f"\nresults in {printable(args.output)}: " + ", ".join(p.name for p in written))
    if not args.no_plots:
        t = time.perf_counter()
        try:
            pictures = write_pictures(
                args.output, matrix, y, class_names, fields, args.random_state, diagrams
            )
        except ImportError as exc:
            print(f"pictures skipped: {one_line(exc)}")
        else:
            print(f"pictures in {printable(args.output)}: " + ", ".join(p.name for p in pictures))
        timings["pictures"] = time.perf_counter() - t
    timings["total"] = time.perf_counter() - start
    if not args.no_plots:  # the summary's timings, the pictures' included
        summary["timings"] = dict(timings)
        write_summary(args.output, dict(summary, files=[p.name for p in written]))
    print("\ntime per stage (s)")
    for name, seconds in timings.items():
        print(f"  {name:<18}{seconds:8.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
