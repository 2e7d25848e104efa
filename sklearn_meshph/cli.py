"""The command line's main job: classify a folder of meshes or point clouds (or built-in
synthetic shapes) end to end.

Run ``python -m sklearn_meshph --help`` (or the ``sklearn-meshph`` console script). The
choices of ``--laplacian``, ``--filtration`` and ``--metric`` come from the registries
of the stages.

Files written to ``--output`` (created if needed; the data files also with
``--no-plots``):

- ``distances.npy``: the full ``(n, n)`` float64 distance matrix between the samples
  (``numpy.load``); row and column ``i`` are sample ``i``.
- ``diagrams.npz``: the persistence diagrams (``numpy.load``): ``sample_<i>_diagram_<k>``
  is diagram ``k`` of sample ``i``, an ``(m, 2)`` float64 array of (birth, death) rows
  (death ``inf`` for essential classes); ``filenames`` (the mesh file of each sample,
  or ``synthetic/<class>/<i>`` for built-in shapes), ``labels`` (int class of each
  sample), ``target_names`` (class names) and ``diagram_names`` (name of each ``k``).
- ``predictions.csv``: one row per sample, columns ``index, file, true label,
  predicted label, fold`` (labels are class names; ``fold`` is the 0-based
  cross-validation fold in which the sample was predicted).
- ``summary.json``: ``version`` (package), ``source``, ``settings`` (every option),
  ``n_samples``, ``class_names``, ``class_counts``, ``accuracy`` (``per_fold`` list and
  ``mean``, ``std``), ``timings`` (seconds per stage), ``warnings`` (numbers of meshes
  with a repeated eigenvalue or cleaned) and ``files`` (names of the files written).
- Pictures, unless ``--no-plots``: ``tsne.png``, ``diagrams.png``, ``eigenfunctions.png``.

Exit status: 0 on success; 2 for a usage error (bad option, missing folder, folder
without meshes, a class smaller than ``--folds``), reported on one ``error:`` line
before any mesh is loaded; 1 when a mesh cannot be processed (the line names its file).
"""

from __future__ import annotations

import argparse
import glob
import os
import re
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from sklearn.metrics import accuracy_score
from sklearn.model_selection import StratifiedKFold
from sklearn.neighbors import KNeighborsClassifier

from ._report import format_confusion, wrap, write_data, write_pictures
from .datasets import SAMPLE_EXTENSIONS, load_mesh_folder, make_shapes
from .diagrams import METRICS, DiagramDistance
from .mesh import MeshCleaningWarning
from .persistence import FILTRATIONS, LowerStarPersistence
from .spectral import (
    LAPLACIANS,
    SIGNATURES,
    LaplacianEigenTransformer,
    RepeatedEigenvalueWarning,
)

_EPILOG = """\
files written to --output (created if needed; also with --no-plots):
  distances.npy    full (n, n) distance matrix (numpy.load)
  diagrams.npz     sample_<i>_diagram_<k>: (m, 2) (birth, death) arrays, death inf for
                   essential classes; filenames, labels, target_names, diagram_names
  predictions.csv  columns: index, file, true label, predicted label, fold
  summary.json     version, source, settings, n_samples, class_names, class_counts,
                   accuracy (per_fold, mean, std), timings (s), warnings, files
  tsne.png, diagrams.png, eigenfunctions.png   unless --no-plots

exit status: 0 success; 2 usage error (bad option, missing or empty folder, a class
smaller than --folds), checked before loading; 1 a mesh that cannot be processed.
"""


def _parse_index(text: str) -> int | tuple[int, ...]:
    parts = [p for p in text.replace(" ", "").split(",") if p]
    try:
        values = tuple(int(p) for p in parts)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an int or a comma list, got {text!r}") from None
    if not values or min(values) < 0:
        raise argparse.ArgumentTypeError(f"indices must be non-negative, got {text!r}")
    return values[0] if len(values) == 1 else values


def _parse_extensions(text: str) -> tuple[str, ...]:
    parts = [p.strip().lower() for p in text.split(",") if p.strip()]
    if not parts:
        raise argparse.ArgumentTypeError(f"expected a comma list of file endings, got {text!r}")
    return tuple(p if p.startswith(".") else "." + p for p in parts)


def _add_option(parser, flag, registry, default):
    """An option whose choices and help come from a stage's registry."""
    parser.add_argument(flag, choices=registry.names, default=default, help=registry.help())


def _version() -> str:
    from . import __version__

    return __version__


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m sklearn_meshph",
        description=(
            "Classify triangle meshes or point clouds by persistent homology of a Laplacian "
            "eigenfunction (Zhang, Liu, Rosen & Hajij): eigenfunction per sample -> "
            "lower-star persistence diagrams -> bottleneck/Wasserstein distances -> k-NN, "
            "scored by stratified cross-validation. Prints accuracy, a confusion matrix and "
            "the time per stage, writes the distances, diagrams, predictions and a summary, "
            "and a t-SNE embedding, example diagrams and eigenfunctions as PNGs."
        ),
        epilog=_EPILOG,
        formatter_class=_HelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {_version()}")
    parser.add_argument(
        "path",
        nargs="?",
        help="folder of meshes or point clouds (.xyz, .pts, PLY without faces) with one "
        "sub-folder per class (like sklearn's load_files); without it, a built-in "
        "synthetic shape set (make_shapes) is generated",
    )
    parser.add_argument(
        "--extensions",
        type=_parse_extensions,
        default=SAMPLE_EXTENSIONS,
        help="comma list of file endings that count as samples (meshes or point clouds) "
        "in PATH (case-insensitive)",
    )
    parser.add_argument(
        "--eigen-index",
        type=_parse_index,
        default=LaplacianEigenTransformer().eigen_index,
        help="eigenfunction index (1 = Fiedler vector, the paper's choice) or a comma list",
    )
    _add_option(parser, "--laplacian", LAPLACIANS, LaplacianEigenTransformer().laplacian)
    _add_option(parser, "--signature", SIGNATURES, LaplacianEigenTransformer().signature)
    parser.add_argument(
        "--n-scales",
        type=int,
        default=LaplacianEigenTransformer().n_scales,
        help="times or energies of a signature (--signature hks or wks)",
    )
    parser.add_argument(
        "--normalization",
        choices=("area", "none"),
        default="area",
        help="'area': unit-area mesh, scale and resolution free; 'none': the paper's literal",
    )
    _add_option(parser, "--filtration", FILTRATIONS, LowerStarPersistence().filtration)
    _add_option(parser, "--metric", METRICS, DiagramDistance().metric)
    parser.add_argument("--order", type=float, default=2.0, help="Wasserstein order q (>= 1)")
    parser.add_argument("--folds", type=int, default=5, help="stratified CV folds (>= 2)")
    parser.add_argument("--neighbors", type=int, default=1, help="k of the k-NN classifier")
    parser.add_argument(
        "--n-jobs", type=int, default=-1, help="parallel jobs (joblib); -1 = all cores"
    )
    parser.add_argument(
        "--n-per-class", type=int, default=12, help="synthetic meshes per class (no PATH)"
    )
    parser.add_argument(
        "--random-state",
        type=int,
        default=0,
        help="seed of the eigensolver, the synthetic shapes, the CV folds and t-SNE",
    )
    parser.add_argument(
        "--output",
        type=Path,
        default=Path("meshph-output"),
        help="folder for the result files and pictures (created)",
    )
    parser.add_argument(
        "--no-plots", action="store_true", help="skip the pictures (data files are written)"
    )
    parser.add_argument(
        "--verbose",
        type=int,
        default=1,
        help="progress bars on stderr per stage (needs tqdm, the 'progress' extra); 0 = none",
    )
    return parser


class _HelpFormatter(argparse.ArgumentDefaultsHelpFormatter, argparse.RawDescriptionHelpFormatter):
    """Defaults in the help, and the epilog's table kept as written."""


class _UsageError(Exception):
    """A problem with the options or the folder: one line, exit status 2."""


# Data --------------------------------------------------------------------------------


class _Names:
    """Maps ``sample K`` in messages to the sample's file, for data from a folder."""

    def __init__(self, filenames=None, root=None):
        self.files = None
        if filenames is not None:
            root = Path(root)
            self.files = []
            for f in filenames:
                try:
                    self.files.append(Path(f).relative_to(root).as_posix())
                except ValueError:
                    self.files.append(str(f))

    def name(self, index: int) -> str:
        if self.files is None or not 0 <= index < len(self.files):
            return f"sample {index}"
        return f"sample {index} ({self.files[index]})"

    def message(self, text: str) -> str:
        """``text`` on one line, with each ``sample K`` naming its file."""
        text = " ".join(str(text).split())
        if self.files is None:
            return text
        return re.sub(r"\bsample (\d+)\b", lambda m: self.name(int(m.group(1))), text)


def _sample_indices(caught, category) -> list[int]:
    """Distinct samples named by the caught warnings of ``category``."""
    found = set()
    for w in caught:
        if category is not None and issubclass(w.category, category):
            match = re.search(r"\bsample (\d+)\b", str(w.message))
            found.add(int(match.group(1)) if match else -1)
    return sorted(found)


def _note(indices, what: str, names: _Names) -> int:
    """Print one note line per kind of warning; the number of distinct meshes."""
    known = [i for i in indices if i >= 0]
    if not indices:
        return 0
    print(f"  note: {len(indices)} mesh(es) {what}" + (":" if known else ""))
    for i in known[:5]:
        print(f"    {names.name(i)}")
    if len(known) > 5:
        print(f"    ... and {len(known) - 5} more")
    return len(indices)


def compute_fields(meshes, eigen: LaplacianEigenTransformer, names: _Names | None = None):
    """Eigenfunctions of all the meshes in one call (messages count in the whole
    collection); returns the fields and the numbers of meshes warned about."""
    names = names or _Names()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", RepeatedEigenvalueWarning)
        warnings.simplefilter("always", MeshCleaningWarning)
        fields = eigen.transform(meshes)
    counts = {
        "repeated_eigenvalue": _note(
            _sample_indices(caught, RepeatedEigenvalueWarning),
            "have a repeated eigenvalue at the requested index",
            names,
        ),
        "cleaned": _note(_sample_indices(caught, MeshCleaningWarning), "were cleaned", names),
    }
    for w in caught:  # others: shown once each, as Python would
        if not issubclass(w.category, (RepeatedEigenvalueWarning, MeshCleaningWarning)):
            print(f"warning: {names.message(w.message)}", file=sys.stderr)
    return fields, counts


def compute_distances(diagrams, distance: DiagramDistance) -> np.ndarray:
    """The symmetric distance matrix, each unordered pair computed once."""
    return np.asarray(distance.fit_transform(diagrams), dtype=float)


def cross_validate(matrix, y, folds, neighbors, random_state):
    """Scores per fold, the prediction of each sample and the fold it was tested in."""
    cv = StratifiedKFold(n_splits=folds, shuffle=True, random_state=random_state)
    predicted = np.empty_like(y)
    fold_of = np.empty(len(y), dtype=int)
    scores = []
    for k, (train, test) in enumerate(cv.split(matrix, y)):
        knn = KNeighborsClassifier(n_neighbors=neighbors, metric="precomputed")
        with warnings.catch_warnings():  # many classes of few meshes are still classes
            warnings.filterwarnings("ignore", "The number of unique classes", UserWarning)
            knn.fit(matrix[np.ix_(train, train)], y[train])
        predicted[test] = knn.predict(matrix[np.ix_(test, train)])
        fold_of[test] = k
        scores.append(accuracy_score(y[test], predicted[test]))
    return np.array(scores), predicted, fold_of


# Reports -----------------------------------------------------------------------------


def _check_options(args) -> None:
    if args.folds < 2:
        raise _UsageError(f"--folds must be at least 2, got {args.folds}")
    if args.n_scales < 1:
        raise _UsageError(f"--n-scales must be at least 1, got {args.n_scales}")
    if args.neighbors < 1:
        raise _UsageError(f"--neighbors must be at least 1, got {args.neighbors}")
    if args.path is None and args.n_per_class < 1:
        raise _UsageError(f"--n-per-class must be at least 1, got {args.n_per_class}")
    if args.n_jobs == 0:
        raise _UsageError("--n-jobs must not be 0 (use -1 for all cores)")
    if args.verbose < 0:
        raise _UsageError(f"--verbose must be at least 0, got {args.verbose}")
    if args.output.exists() and not args.output.is_dir():
        raise _UsageError(f"--output {str(args.output)!r} exists and is not a folder")


def _estimators(args):
    eigen = LaplacianEigenTransformer(
        eigen_index=args.eigen_index,
        laplacian=args.laplacian,
        normalization=args.normalization,
        n_jobs=args.n_jobs,
        random_state=args.random_state,
        verbose=args.verbose,
        signature=args.signature,
        n_scales=args.n_scales,
    )
    persistence = LowerStarPersistence(
        filtration=args.filtration, n_jobs=args.n_jobs, verbose=args.verbose
    )
    distance = DiagramDistance(
        metric=args.metric, order=args.order, n_jobs=args.n_jobs, verbose=args.verbose
    )
    for estimator in (eigen, persistence, distance):
        try:
            estimator._check_params()
        except ValueError as exc:  # InvalidParameterError is a ValueError
            raise _UsageError(" ".join(str(exc).split())) from None
    return eigen, persistence, distance


def _list_folder(args):
    """The files of the folder, listed without loading, and the class check."""
    try:
        listing = load_mesh_folder(args.path, extensions=args.extensions, load=False)
    except (ValueError, TypeError) as exc:
        raise _UsageError(" ".join(str(exc).split())) from None
    return listing


def _load(args, names: _Names):
    """The meshes of the folder (in parallel with a progress bar where supported)."""
    return load_mesh_folder(
        args.path, extensions=args.extensions, n_jobs=args.n_jobs, verbose=args.verbose
    )


def _check_classes(counts, names, folds) -> None:
    small = [(str(n), int(c)) for n, c in zip(names, counts, strict=True) if c < folds]
    if small:
        listed = ", ".join(f"{n!r} ({c})" for n, c in small[:5]) + (
            ", ..." if len(small) > 5 else ""
        )
        raise _UsageError(
            f"{len(small)} class(es) have fewer meshes than --folds {folds}: {listed}; "
            "lower --folds or add meshes"
        )


def _kernels_cached() -> bool:
    """Whether numba's cache already holds compiled kernels of this package (in the
    package's ``__pycache__`` folders, or in ``NUMBA_CACHE_DIR`` when it is set)."""
    root = os.environ.get("NUMBA_CACHE_DIR") or os.path.dirname(os.path.abspath(__file__))
    return any(glob.iglob(os.path.join(root, "**", "*.nbi"), recursive=True))


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``python -m sklearn_meshph`` and the ``sklearn-meshph`` script."""
    args = build_parser().parse_args(argv)
    try:
        return _run(args)
    except _UsageError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except _DataError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1


class _DataError(Exception):
    """A mesh that cannot be processed: one line naming its file, exit status 1."""


def _stage(names: _Names, function, *args):
    try:
        return function(*args)
    except (ValueError, TypeError) as exc:
        raise _DataError(names.message(exc)) from None


def _run(args) -> int:
    _check_options(args)
    eigen, persistence, distance = _estimators(args)
    timings = {}
    start = time.perf_counter()
    if args.path is None:
        if args.n_per_class < args.folds:
            raise _UsageError(
                f"--n-per-class {args.n_per_class} is smaller than --folds {args.folds}"
            )
        data = make_shapes(n_per_class=args.n_per_class, random_state=args.random_state)
        source = f"built-in synthetic shapes (make_shapes, {args.n_per_class} per class)"
        names = _Names()
        filenames = [f"synthetic/{data.target_names[t]}/{i}" for i, t in enumerate(data.target)]
        class_names = [str(n) for n in data.target_names]
    else:
        listing = _list_folder(args)
        class_names = [str(n) for n in listing.target_names]
        _check_classes(
            np.bincount(listing.target, minlength=len(class_names)), class_names, args.folds
        )
        names = _Names(listing.filenames, args.path)
        data = _stage(names, _load, args, names)
        source = str(args.path)
        filenames = list(names.files)
    meshes, y = list(data.data), np.asarray(data.target)
    timings["load"] = time.perf_counter() - start
    counts = np.bincount(y, minlength=len(class_names))
    n_clouds = sum(isinstance(m, np.ndarray) for m in meshes)
    kind = (
        "meshes"
        if n_clouds == 0
        else "point clouds"
        if n_clouds == len(meshes)
        else f"samples ({len(meshes) - n_clouds} meshes, {n_clouds} point clouds)"
    )
    print(f"data: {source}: {len(meshes)} {kind}, {len(class_names)} classes")
    print(wrap("classes: " + ", ".join(class_names)))
    print("pipeline:")
    for step in (eigen, persistence, distance):
        print(f"  {' '.join(repr(step).split())} ->")
    print(f"  {args.neighbors}-NN, {args.folds}-fold stratified CV")
    if not _kernels_cached():
        print(
            "note: first run: compiling the numba kernels once (about half a minute on 2 "
            "cores); later runs load them from the cache"
        )

    t = time.perf_counter()
    fields, warned = _stage(names, compute_fields, meshes, eigen, names)
    timings["eigenfunctions"] = time.perf_counter() - t
    t = time.perf_counter()
    diagrams = _stage(names, persistence.fit_transform, fields)
    timings["persistence"] = time.perf_counter() - t
    t = time.perf_counter()
    matrix = _stage(names, compute_distances, diagrams, distance)
    timings["distances"] = time.perf_counter() - t
    t = time.perf_counter()
    try:
        scores, predicted, fold_of = cross_validate(
            matrix, y, args.folds, args.neighbors, args.random_state
        )
    except ValueError as exc:  # e.g. more neighbours than training samples in a fold
        raise _UsageError(" ".join(str(exc).split())) from None
    timings["cross-validation"] = time.perf_counter() - t

    print(
        f"\n{args.folds}-fold stratified CV accuracy: {scores.mean():.3f} "
        f"(+/- {scores.std():.3f}; folds {', '.join(f'{s:.2f}' for s in scores)})"
    )
    print("\nconfusion matrix (rows: true class, columns: predicted)")
    print(format_confusion(y, predicted, class_names))

    diagram_names = persistence.diagram_names(fields[0].n_functions)
    if not args.no_plots:
        t = time.perf_counter()
        try:
            written = write_pictures(
                args.output,
                matrix,
                y,
                class_names,
                fields,
                diagrams,
                diagram_names,
                args.random_state,
                eigen.eigen_index,
            )
        except ImportError as exc:
            print(f"\npictures skipped: {exc}")
        else:
            print(f"\npictures in {args.output}: " + ", ".join(p.name for p in written))
        timings["pictures"] = time.perf_counter() - t

    t = time.perf_counter()
    settings = {
        key: (str(value) if isinstance(value, Path) else value)
        for key, value in sorted(vars(args).items())
    }
    summary = {
        "version": _version(),
        "source": source,
        "settings": settings,
        "n_samples": len(y),
        "class_names": class_names,
        "class_counts": counts.tolist(),
        "accuracy": {
            "per_fold": scores.tolist(),
            "mean": float(scores.mean()),
            "std": float(scores.std()),
        },
        "warnings": warned,
    }
    summary["timings"] = dict(timings, total=time.perf_counter() - start)
    results = {
        "matrix": matrix,
        "diagrams": diagrams,
        "diagram_names": diagram_names,
        "y": y,
        "predicted": predicted,
        "fold_of": fold_of,
        "names": class_names,
        "filenames": filenames,
        "summary": summary,
    }
    written = write_data(args.output, **results)
    timings["results"] = time.perf_counter() - t
    timings["total"] = time.perf_counter() - start
    print(f"results in {args.output}: " + ", ".join(p.name for p in written))

    print("\ntime per stage (s)")
    for name, seconds in timings.items():
        print(f"  {name:<18}{seconds:8.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
