"""The main job's options: the parser, the checks made before any sample is loaded, and
the pipeline they build (a preset of :data:`sklearn_meshph.pipelines.PRESETS`, with the
eigen stage's options and ``--set`` applied to it)."""

from __future__ import annotations

import argparse
import ast
import json
import os
import re
import tempfile
from pathlib import Path

import numpy as np
from sklearn.model_selection import StratifiedKFold

from ._cli_messages import UsageError, one_line
from ._param_validation import check_params
from ._report import RESULT_FILES
from ._version import VERSION
from .datasets import SAMPLE_EXTENSIONS
from .pipelines import PRESETS, make_mesh_distance
from .shapes import MAX_SHAPES, SHAPE_CLASSES
from .spectral import LAPLACIANS, SIGNATURES
from .spectral.laplacians import GRAPH_LAPLACIANS

__all__ = [
    "GRAPH_PRESET",
    "build_parser",
    "build_pipeline",
    "check_folds",
    "check_graph_pipeline",
    "check_options",
    "check_output",
    "choose_preset",
]

#: The preset of a TU dataset folder (graphs) when ``--preset`` is not given.
GRAPH_PRESET = "graph"

_EPILOG = """\
the pipeline: --preset picks one of PRESETS (make_mesh_distance; 'graph' by default
for a TU dataset folder, whose graphs are named 'graph K' after their id in the files);
--eigen-index, --laplacian, --normalization, --signature, --n-scales and --n-eigenpairs
override its eigen stage when given; --set step__param=value sets any parameter
(set_params), e.g.
--set distance__weights='{"ord1": 1, "ext0": 0, "ext1": 1, "dna": 0.5}'. The stages
that learn nothing (eigen, persistence) run once for all samples (the eigen stage cached
in --memory when given); everything else is fitted on each fold's training samples only.

files written to --output (created if needed; also with --no-plots):
  distances.npy    full (n, n) distance matrix (numpy.load), the pipeline fitted on
                   all samples (not the cross-validated models)
  diagrams.npz     sample_<i>_diagram_<k>: (m, 2) (birth, death) arrays, death inf for
                   essential classes; filenames, labels, target_names, diagram_names
                   (only for presets that compute persistence diagrams)
  predictions.csv  columns: index, file, true label, predicted label, fold
  summary.json     version, source, preset, pipeline (every parameter), settings,
                   n_samples, class_names, class_counts, skipped, accuracy (per_fold,
                   mean, std), timings (s), warnings, files
  tsne.png, eigenfunctions.png (and diagrams.png)   unless --no-plots; the t-SNE
                   picture embeds distances.npy

exit status: 0 success; 2 usage error (bad option or parameter, missing or empty
folder, a class smaller than --folds, --neighbors larger than a training fold, an
--output that cannot be written), checked before loading; 1 a sample that cannot be
processed (the line names its file).
"""

# The options that override the eigen stage's parameters, when given.
EIGEN_OPTIONS = ("eigen_index", "laplacian", "normalization", "signature", "n_scales")
EIGEN_OPTIONS += ("n_eigenpairs",)


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


def _literal(text: str):
    """A value written on the command line: JSON (``Infinity``, ``true``, ``null``), a
    Python literal (``(1, 2)``, ``None``), ``inf``, or else the text itself."""
    if text.strip().lower() in ("inf", "+inf", "-inf"):
        return float(text)
    for parse in (json.loads, ast.literal_eval):
        try:
            value = parse(text)
        except (ValueError, SyntaxError, TypeError, MemoryError, RecursionError):
            continue
        return tuple(value) if isinstance(value, list) else value
    return text


def _parse_assignment(text: str) -> tuple[str, object]:
    name, sep, value = text.partition("=")
    if not sep or not name.strip() or "__" not in name:
        raise argparse.ArgumentTypeError(
            f"expected step__param=value (e.g. eigen__n_scales=3), got {text!r}"
        )
    return name.strip(), _literal(value.strip())


class _HelpFormatter(argparse.ArgumentDefaultsHelpFormatter, argparse.RawDescriptionHelpFormatter):
    """Defaults in the help (unless the help says it, or there is none), and the
    epilog's table kept as written."""

    def _get_help_string(self, action):
        nothing = action.default is None or action.default is False or action.default == []
        if nothing or "default:" in (action.help or ""):
            return action.help
        return super()._get_help_string(action)


def _eigen_option(parser, flag, help_text, **kwargs) -> None:
    parser.add_argument(flag, default=None, help=help_text + " (default: the preset's)", **kwargs)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m sklearn_meshph",
        description=(
            "Classify triangle meshes, point clouds or graphs (a TU dataset folder) by "
            "persistent homology of Laplacian eigenfunctions and spectral signatures: a "
            "pipeline of the library (--preset) gives the distances between samples, a "
            "k-NN classifier is scored by stratified cross-validation, each fold's model "
            "fitted on its training samples only. Prints accuracy, a confusion matrix and "
            "the time per stage, writes the distances, predictions and a summary, and a "
            "t-SNE embedding and the functions of some samples as PNGs."
        ),
        epilog=_EPILOG,
        formatter_class=_HelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {VERSION}")
    parser.add_argument(
        "path",
        nargs="?",
        help="folder of meshes or point clouds (.xyz, .pts, PLY without faces) with one "
        "sub-folder per class (like sklearn's load_files), or a TU dataset folder of "
        "graphs (DS_A.txt, DS_graph_indicator.txt, DS_graph_labels.txt, plain or .gz); "
        "without it, a small built-in synthetic shape set (make_shapes) is generated",
    )
    parser.add_argument(
        "--preset",
        default=None,
        help=f"the pipeline (default: 'default', or {GRAPH_PRESET!r} for a TU dataset "
        "folder), one of PRESETS: " + PRESETS.help(),
    )
    parser.add_argument(
        "--memory",
        default=None,
        help="folder caching the eigensolves (reused by later runs on the same samples); "
        "default: no cache",
    )
    parser.add_argument(
        "--set",
        dest="assignments",
        metavar="STEP__PARAM=VALUE",
        action="append",
        type=_parse_assignment,
        default=[],
        help="set a parameter of the pipeline (repeatable); VALUE is read as JSON or a "
        "Python literal, else as text",
    )
    _eigen_option(parser, "--eigen-index", "eigenfunction index or comma list", type=_parse_index)
    _eigen_option(parser, "--laplacian", LAPLACIANS.help(), choices=LAPLACIANS.names)
    _eigen_option(parser, "--signature", SIGNATURES.help(), choices=SIGNATURES.names)
    _eigen_option(parser, "--n-scales", "times or energies of a signature", type=int)
    _eigen_option(parser, "--n-eigenpairs", "eigenpairs behind a signature", type=int)
    _eigen_option(
        parser,
        "--normalization",
        "'area': unit-area mesh, scale and resolution free; 'none': the paper's literal",
        choices=("area", "none"),
    )
    parser.add_argument(
        "--extensions",
        type=_parse_extensions,
        default=SAMPLE_EXTENSIONS,
        help="comma list of file endings that count as samples (meshes or point clouds) "
        "in PATH (case-insensitive)",
    )
    parser.add_argument(
        "--skip-unreadable",
        action="store_true",
        help="leave out (and list) the files that cannot be read, and the samples the "
        "eigen stage refuses (NaN coordinates, nothing left after cleaning, a cloud on a "
        "line...), instead of stopping",
    )
    parser.add_argument("--folds", type=int, default=5, help="stratified CV folds (>= 2)")
    parser.add_argument("--neighbors", type=int, default=1, help="k of the k-NN classifier")
    parser.add_argument(
        "--n-jobs", type=int, default=-1, help="parallel jobs (joblib); -1 = all cores"
    )
    parser.add_argument(
        "--n-per-class", type=int, default=6, help="synthetic meshes per class (no PATH)"
    )
    parser.add_argument(
        "--random-state",
        type=int,
        default=0,
        help="seed of the eigensolver, the synthetic shapes, the CV folds and t-SNE",
    )
    parser.add_argument(
        "--output",
        type=_output_path,
        default=Path("meshph-output"),
        help="folder for the result files and pictures (created; an earlier run's result "
        "files there are replaced or removed, nothing else is touched)",
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


def check_options(args) -> None:
    """The options' own ranges (the pipeline's parameters are checked when built)."""
    if args.folds < 2:
        raise UsageError(f"--folds must be at least 2, got {args.folds}")
    if args.neighbors < 1:
        raise UsageError(f"--neighbors must be at least 1, got {args.neighbors}")
    if args.path is None and args.n_per_class < args.folds:
        raise UsageError(f"--n-per-class {args.n_per_class} is smaller than --folds {args.folds}")
    if args.path is None and args.n_per_class * len(SHAPE_CLASSES) > MAX_SHAPES:
        raise UsageError(
            f"--n-per-class {args.n_per_class} for {len(SHAPE_CLASSES)} classes is more than "
            f"the {MAX_SHAPES} built-in shapes a run may make (MAX_SHAPES)"
        )
    if args.n_jobs == 0:
        raise UsageError("--n-jobs must not be 0 (use -1 for all cores)")
    if args.verbose < 0:
        raise UsageError(f"--verbose must be at least 0, got {args.verbose}")
    if args.memory is not None:
        _check_memory(args.memory)


def _check_memory(memory: str) -> None:
    """``--memory`` must name a folder, or where one can be made: not a file, a FIFO or a
    device (the cache then went unused with a warning per sample), nor a path under one."""
    if not memory.strip():
        raise UsageError(f"--memory must name a folder, got {memory!r}")
    path = Path(memory)
    if path.is_symlink() and not path.exists():
        raise UsageError(f"--memory {memory!r} is a symbolic link to nothing")
    existing = path
    while not existing.exists() and existing != existing.parent:
        existing = existing.parent
    if existing.exists() and not existing.is_dir():
        where = "" if existing == path else f" is under {str(existing)!r}, which"
        raise UsageError(f"--memory must name a folder: {memory!r}{where} is not a folder")


def choose_preset(args, graphs: bool) -> None:
    """``--preset`` when given, else ``"default"``, or :data:`GRAPH_PRESET` for
    ``graphs`` (a TU dataset folder)."""
    if args.preset is None:
        args.preset = GRAPH_PRESET if graphs else "default"


def check_graph_pipeline(pipeline) -> None:
    """Refuse a pipeline whose eigen stage takes a Laplacian that graphs have not (a
    surface's, such as ``"cotangent"``), before anything is loaded."""
    for estimator in _estimators(pipeline):
        laplacian = estimator.get_params(deep=False).get("laplacian")
        if isinstance(laplacian, str) and laplacian not in GRAPH_LAPLACIANS:
            raise UsageError(
                f"the eigen stage's Laplacian {laplacian!r} is a surface's (meshes, point "
                "clouds); the graphs of a TU folder take --laplacian "
                + ", ".join(GRAPH_LAPLACIANS.names)
                + f" (the {GRAPH_PRESET!r} preset's pipeline is made for them)"
            )


def _output_path(text: str) -> Path:
    """``--output``'s folder: an empty name is refused (``Path("")`` is the current
    folder, where every result file would have gone)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("must name a folder, got an empty name")
    return Path(text)


def check_output(output: Path) -> None:
    """Refuse an ``--output`` that cannot be written, without creating anything: a file,
    a path under a file, or a folder where no file can be made."""
    if output.is_symlink() and not output.exists():
        raise UsageError(f"--output {str(output)!r} is a symbolic link to nothing")
    if output.exists() and not output.is_dir():
        raise UsageError(f"--output {str(output)!r} exists and is not a folder")
    for name in RESULT_FILES:  # checked now: a FIFO there would hang the job at its end
        inside = output / name
        if inside.is_file() and not inside.is_symlink() and not os.access(inside, os.W_OK):
            raise UsageError(
                f"--output {str(output)!r} holds {name!r}, which is read-only: the job "
                "writes over or removes its result files there; make it writable or "
                "choose another --output"
            )
        if inside.is_symlink() or (inside.exists() and not inside.is_file()):
            raise UsageError(
                f"--output {str(output)!r} holds {name!r}, which is not a regular file (a "
                "link, a folder, a FIFO or a device): the results would be written there "
                "(through a link, over the file it names); remove it or choose another "
                "--output"
            )
    existing = output
    while not existing.exists() and existing != existing.parent:
        if existing.is_symlink():  # a link to nothing, a chain or a loop of links
            raise UsageError(
                f"--output {str(output)!r} is under {str(existing)!r}, a symbolic link to "
                "nothing (or a loop of links)"
            )
        existing = existing.parent
    if not existing.is_dir():
        raise UsageError(f"--output {str(output)!r} is under {str(existing)!r}, which is a file")
    try:
        tempfile.TemporaryFile(dir=existing).close()
    except OSError as exc:
        reason = exc.strerror or type(exc).__name__
        raise UsageError(
            f"--output {str(output)!r} cannot be written ({str(existing)!r}: {reason})"
        ) from None


def check_folds(
    y, class_names, folds: int, neighbors: int, random_state, graphs: bool = False
) -> None:
    """Every class at least ``folds`` samples, and ``neighbors`` at most the smallest
    training fold of the stratified split; at least two classes (``graphs``: the labels
    of a TU dataset, not sub-folders, make the classes)."""
    counts = np.bincount(y, minlength=len(class_names))
    if np.count_nonzero(counts) < 2:
        where = (
            "a TU dataset whose graph labels take at least two values"
            if graphs
            else "a folder with one sub-folder per class (at least two)"
        )
        raise UsageError(
            f"the data holds one class ({class_names[int(np.argmax(counts))]!r}): there is "
            f"nothing to classify; give {where}"
        )
    small = [(str(n), int(c)) for n, c in zip(class_names, counts, strict=True) if c < folds]
    if small:
        listed = ", ".join(f"{n!r} ({c})" for n, c in small[:5]) + (
            ", ..." if len(small) > 5 else ""
        )
        raise UsageError(
            f"{len(small)} class(es) have fewer samples than --folds {folds}: {listed}; "
            "lower --folds or add samples"
        )
    cv = StratifiedKFold(n_splits=folds, shuffle=True, random_state=random_state)
    smallest = min(len(train) for train, _ in cv.split(np.zeros((len(y), 1)), y))
    if neighbors > smallest:
        raise UsageError(
            f"--neighbors {neighbors} is larger than the smallest training fold "
            f"({smallest} samples); lower --neighbors or --folds"
        )


def _estimators(estimator):
    """``estimator`` and every estimator among its parameters, nested ones too."""
    yield estimator
    for value in estimator.get_params(deep=True).values():
        if hasattr(value, "get_params") and not isinstance(value, type):
            yield value


def check_pipeline(pipeline) -> None:
    """Check every parameter of the library's estimators in ``pipeline`` against their
    declared constraints, and the checks their ``fit`` adds (``_check_params``: a heat
    signature's times in range, a resolution's length...), as their ``fit`` does."""
    eigen = pipeline.named_steps.get("eigen") if hasattr(pipeline, "named_steps") else None
    solved = None if eigen is None else eigen.get_params().get("n_eigenpairs")
    for estimator in _estimators(pipeline):
        if not type(estimator).__module__.startswith(__package__ + "."):
            continue
        needed = estimator.get_params().get("n_eigenpairs") if estimator is not eigen else None
        if isinstance(solved, int) and isinstance(needed, int) and needed > solved:
            # known now, found by fit only after every sample's eigensolve
            raise ValueError(
                f"{type(estimator).__name__}(n_eigenpairs={needed}) needs {needed} "
                f"eigenpairs and the eigen stage solves {solved}: raise eigen__n_eigenpairs "
                "(--n-eigenpairs) or lower it"
            )
        if callable(getattr(estimator, "_check_params", None)):
            estimator._check_params()  # the constraints, then the rest
            continue
        constraints = getattr(estimator, "_parameter_constraints", None)
        if constraints:
            check_params(constraints, estimator.get_params(deep=False), type(estimator).__name__)


def build_pipeline(args):
    """The pipeline of ``--preset`` with the eigen options and ``--set`` applied, every
    parameter checked; a bad one is a :class:`UsageError`."""
    try:
        pipeline = make_mesh_distance(
            "default" if args.preset is None else args.preset,  # unless choose_preset ran
            memory=args.memory,
            n_jobs=args.n_jobs,
            random_state=args.random_state,
            verbose=args.verbose,
        )
        overrides = {
            f"eigen__{name}": getattr(args, name)
            for name in EIGEN_OPTIONS
            if getattr(args, name) is not None
        }
        pipeline.set_params(**overrides)
        for name, value in args.assignments:
            pipeline.set_params(**{name: value})
        check_pipeline(pipeline)
        signature = pipeline.named_steps["eigen"].get_params().get("signature")
        if args.eigen_index is not None and SIGNATURES[signature].value is not None:
            raise UsageError(
                f"--eigen-index picks eigenfunctions, which the signature {signature!r} does "
                "not use (it sums over the eigenpairs); add --signature eigenfunctions"
            )
    except (ValueError, TypeError, KeyError) as exc:  # InvalidParameterError is both
        # scikit-learn names an unknown parameter's estimator by its whole repr (1,500
        # characters for the default pipeline): its class name says where.
        text = re.sub(
            r"for estimator (\w+)\(.*?\)\. Valid parameters",
            r"for estimator \1. Valid parameters",
            one_line(exc),
        )
        raise UsageError(text) from None
    return pipeline
