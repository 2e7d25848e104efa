"""The command line's main job: classify a folder of meshes (or built-in synthetic
shapes) end to end.

Run ``python -m sklearn_meshph --help`` (or the ``sklearn-meshph`` console script). The
choices of ``--laplacian``, ``--filtration`` and ``--metric`` come from the registries
of the stages.
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from sklearn.metrics import accuracy_score, confusion_matrix
from sklearn.model_selection import StratifiedKFold
from sklearn.neighbors import KNeighborsClassifier

from .datasets import load_mesh_folder, make_shapes
from .diagrams import METRICS, DiagramDistance
from .persistence import FILTRATIONS, LowerStarPersistence
from .spectral import LAPLACIANS, LaplacianEigenTransformer, RepeatedEigenvalueWarning


def _parse_index(text: str) -> int | tuple[int, ...]:
    parts = [p for p in text.replace(" ", "").split(",") if p]
    try:
        values = tuple(int(p) for p in parts)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an int or a comma list, got {text!r}") from None
    if not values or min(values) < 0:
        raise argparse.ArgumentTypeError(f"indices must be non-negative, got {text!r}")
    return values[0] if len(values) == 1 else values


def _add_option(parser, flag, registry, default):
    """An option whose choices and help come from a stage's registry."""
    parser.add_argument(flag, choices=registry.names, default=default, help=registry.help())


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m sklearn_meshph",
        description=(
            "Classify triangle meshes by persistent homology of a Laplacian eigenfunction "
            "(Zhang, Liu, Rosen & Hajij): eigenfunction per mesh -> lower-star persistence "
            "diagrams -> bottleneck/Wasserstein distances -> k-NN, scored by stratified "
            "cross-validation. Prints accuracy, a confusion matrix and the time per stage, "
            "and writes a t-SNE embedding, example diagrams and an eigenfunction as PNGs."
        ),
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    parser.add_argument(
        "path",
        nargs="?",
        help="mesh folder with one sub-folder per class (like sklearn's load_files); "
        "without it, a built-in synthetic shape set (make_shapes) is generated",
    )
    parser.add_argument(
        "--eigen-index",
        type=_parse_index,
        default=LaplacianEigenTransformer().eigen_index,
        help="eigenfunction index (1 = Fiedler vector, the paper's choice) or a comma list",
    )
    _add_option(parser, "--laplacian", LAPLACIANS, LaplacianEigenTransformer().laplacian)
    parser.add_argument(
        "--normalization",
        choices=("area", "none"),
        default="area",
        help="'area': unit-area mesh, scale and resolution free; 'none': the paper's literal",
    )
    _add_option(parser, "--filtration", FILTRATIONS, LowerStarPersistence().filtration)
    _add_option(parser, "--metric", METRICS, DiagramDistance().metric)
    parser.add_argument("--order", type=float, default=2.0, help="Wasserstein order q")
    parser.add_argument("--folds", type=int, default=5, help="stratified CV folds")
    parser.add_argument("--neighbors", type=int, default=1, help="k of the k-NN classifier")
    parser.add_argument(
        "--n-jobs", type=int, default=-1, help="parallel jobs (joblib); -1 = all cores"
    )
    parser.add_argument(
        "--n-per-class", type=int, default=12, help="synthetic meshes per class (no PATH)"
    )
    parser.add_argument("--random-state", type=int, default=0)
    parser.add_argument(
        "--output", type=Path, default=Path("meshph-output"), help="folder for the pictures"
    )
    parser.add_argument("--no-plots", action="store_true", help="skip the pictures")
    return parser


class _Progress:
    """One status line on stderr, rewritten in place."""

    def __init__(self, label: str, total: int):
        self.label, self.total, self.start = label, total, time.perf_counter()
        self.update(0)

    def update(self, done: int) -> None:
        if not sys.stderr.isatty() and done < self.total:
            return
        width = 30
        filled = int(width * done / max(self.total, 1))
        elapsed = time.perf_counter() - self.start
        sys.stderr.write(
            f"\r  {self.label:<12} [{'#' * filled}{'.' * (width - filled)}] "
            f"{done}/{self.total}  {elapsed:6.1f} s"
        )
        sys.stderr.flush()

    def close(self) -> None:
        sys.stderr.write("\n")


def _chunks(n: int, n_chunks: int):
    bounds = np.linspace(0, n, min(n, n_chunks) + 1).astype(int)
    return [(a, b) for a, b in zip(bounds[:-1], bounds[1:], strict=True) if b > a]


def compute_fields(meshes, eigen: LaplacianEigenTransformer):
    progress = _Progress("eigensolves", len(meshes))
    fields = []
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", RepeatedEigenvalueWarning)
        for a, b in _chunks(len(meshes), 10):
            chunk = eigen.transform(meshes[a:b])
            fields.extend(chunk)
            progress.update(b)
    progress.close()
    repeated = sum(issubclass(w.category, RepeatedEigenvalueWarning) for w in caught)
    if repeated:
        print(f"  note: {repeated} mesh(es) have a repeated eigenvalue at the requested index")
    return fields


def compute_distances(diagrams, distance: DiagramDistance) -> np.ndarray:
    """The symmetric distance matrix, by blocks of rows against the rows below them."""
    n = len(diagrams)
    matrix = np.zeros((n, n))
    blocks = _chunks(n, 10)
    progress = _Progress("distances", n)
    for a, b in blocks:
        block = distance.fit(diagrams[a:]).transform(diagrams[a:b])
        matrix[a:b, a:] = block
        matrix[a:, a:b] = block.T
        progress.update(b)
    progress.close()
    return matrix


def cross_validate(matrix, y, folds, neighbors, random_state):
    cv = StratifiedKFold(n_splits=folds, shuffle=True, random_state=random_state)
    predicted = np.empty_like(y)
    scores = []
    for train, test in cv.split(matrix, y):
        knn = KNeighborsClassifier(n_neighbors=neighbors, metric="precomputed")
        knn.fit(matrix[np.ix_(train, train)], y[train])
        predicted[test] = knn.predict(matrix[np.ix_(test, train)])
        scores.append(accuracy_score(y[test], predicted[test]))
    return np.array(scores), predicted


def format_confusion(y, predicted, names) -> str:
    matrix = confusion_matrix(y, predicted, labels=np.arange(len(names)))
    width = max(6, *(len(n) for n in names))
    lines = [" " * width + " | " + " ".join(f"{n[:width]:>{width}}" for n in names)]
    lines.append("-" * len(lines[0]))
    for name, row in zip(names, matrix, strict=True):
        lines.append(f"{name:>{width}} | " + " ".join(f"{v:>{width}d}" for v in row))
    return "\n".join(lines)


def _finite(matrix: np.ndarray) -> np.ndarray:
    """Infinite distances (different numbers of essential classes) capped for t-SNE."""
    finite = matrix[np.isfinite(matrix)]
    cap = 2.0 * finite.max() if finite.size and finite.max() > 0 else 1.0
    return np.where(np.isfinite(matrix), matrix, cap)


def write_pictures(output: Path, matrix, y, names, fields, diagrams, labels, random_state):
    from sklearn.manifold import TSNE

    from . import plotting

    output.mkdir(parents=True, exist_ok=True)
    plt = plotting._pyplot()
    perplexity = min(30.0, (len(y) - 1) / 3.0)
    embedding = TSNE(
        metric="precomputed", init="random", perplexity=perplexity, random_state=random_state
    ).fit_transform(_finite(matrix))
    written = []
    fig, ax = plt.subplots(figsize=(6, 5))
    plotting.plot_embedding(embedding, y, names, ax=ax)
    ax.set_title("t-SNE of the diagram distance matrix")
    written.append(_save(fig, output / "tsne.png"))

    examples = [int(np.flatnonzero(y == c)[0]) for c in range(len(names))]
    cols = min(3, len(examples))
    rows = -(-len(examples) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4 * cols, 3.6 * rows), squeeze=False)
    for ax, i in zip(axes.ravel(), examples, strict=False):
        plotting.plot_diagram(diagrams[i], ax=ax, labels=labels)
        ax.set_title(names[y[i]])
    for ax in axes.ravel()[len(examples) :]:
        ax.set_axis_off()
    written.append(_save(fig, output / "diagrams.png"))

    fig = plt.figure(figsize=(4 * cols, 3.6 * rows))
    for k, i in enumerate(examples):
        ax = fig.add_subplot(rows, cols, k + 1, projection="3d")
        field = fields[i]
        values = field.columns()[0]
        plotting.plot_mesh_function(field.vertices, field.faces, values, ax=ax)
        ax.set_title(names[y[i]])
    written.append(_save(fig, output / "eigenfunctions.png"))
    return written


def _save(fig, path: Path) -> Path:
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    fig.clf()
    return path


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``python -m sklearn_meshph`` and the ``sklearn-meshph`` script."""
    args = build_parser().parse_args(argv)
    timings = {}
    start = time.perf_counter()
    if args.path is None:
        data = make_shapes(n_per_class=args.n_per_class, random_state=args.random_state)
        source = f"built-in synthetic shapes (make_shapes, {args.n_per_class} per class)"
    else:
        data = load_mesh_folder(args.path)
        source = str(args.path)
    meshes, y, names = list(data.data), np.asarray(data.target), list(data.target_names)
    timings["load"] = time.perf_counter() - start
    counts = np.bincount(y, minlength=len(names))
    if counts.min() < args.folds:
        print(
            f"error: the smallest class has {counts.min()} meshes, fewer than --folds {args.folds}",
            file=sys.stderr,
        )
        return 2
    print(f"data: {source}: {len(meshes)} meshes, {len(names)} classes ({', '.join(names)})")

    eigen = LaplacianEigenTransformer(
        eigen_index=args.eigen_index,
        laplacian=args.laplacian,
        normalization=args.normalization,
        n_jobs=args.n_jobs,
        random_state=args.random_state,
    )
    persistence = LowerStarPersistence(filtration=args.filtration, n_jobs=args.n_jobs)
    distance = DiagramDistance(metric=args.metric, order=args.order, n_jobs=args.n_jobs)
    print(f"pipeline: {eigen!r} -> {persistence!r} -> {distance!r} -> {args.neighbors}-NN")

    t = time.perf_counter()
    fields = compute_fields(meshes, eigen)
    timings["eigenfunctions"] = time.perf_counter() - t
    t = time.perf_counter()
    diagrams = persistence.fit_transform(fields)
    timings["persistence"] = time.perf_counter() - t
    t = time.perf_counter()
    matrix = compute_distances(diagrams, distance)
    timings["distances"] = time.perf_counter() - t
    t = time.perf_counter()
    scores, predicted = cross_validate(matrix, y, args.folds, args.neighbors, args.random_state)
    timings["cross-validation"] = time.perf_counter() - t

    print(
        f"\n{args.folds}-fold stratified CV accuracy: {scores.mean():.3f} "
        f"(+/- {scores.std():.3f}; folds {', '.join(f'{s:.2f}' for s in scores)})"
    )
    print("\nconfusion matrix (rows: true class, columns: predicted)")
    print(format_confusion(y, predicted, names))

    if not args.no_plots:
        t = time.perf_counter()
        try:
            labels = persistence.diagram_names(fields[0].n_functions)
            written = write_pictures(
                args.output, matrix, y, names, fields, diagrams, labels, args.random_state
            )
        except ImportError as exc:
            print(f"\npictures skipped: {exc}")
        else:
            print("\npictures: " + ", ".join(str(p) for p in written))
        timings["pictures"] = time.perf_counter() - t

    timings["total"] = time.perf_counter() - start
    print("\ntime per stage (s)")
    for name, seconds in timings.items():
        print(f"  {name:<18}{seconds:8.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
