"""What the main job reports: the confusion summary, the data files (``summary.json``
always valid JSON) and the pictures, each labelled by what it shows."""

from __future__ import annotations

import contextlib
import csv
import json
import os
import textwrap
import uuid
from pathlib import Path

import numpy as np
from sklearn.metrics import confusion_matrix

DATA_FILES = ("distances.npy", "diagrams.npz", "predictions.csv", "summary.json")
#: Every file the main job may write in ``--output``.
RESULT_FILES = (*DATA_FILES, "tsne.png", "diagrams.png", "eigenfunctions.png")
MAX_WIDTH = 100


def format_confusion(y, predicted, names, max_width: int = MAX_WIDTH) -> str:
    """The confusion matrix in lines of at most ``max_width`` characters.

    Up to 8 classes: the whole matrix (class names shortened to ``c0, c1, ...`` with a
    key when they do not fit). More: the accuracy of each class, what it is most often
    mistaken for, and the most confused pairs.
    """
    n = len(names)
    matrix = confusion_matrix(y, predicted, labels=np.arange(n))
    if n > 8:
        return _confusion_summary(matrix, names, max_width)
    width = max(3, len(str(matrix.max())))
    fit = (max_width - 3) // (n + 1) - 1
    longest = max(len(str(name)) for name in names)
    if longest <= fit:
        labels, key = [str(name) for name in names], []
        width = max(width, longest)
    else:
        labels = [f"c{i}" for i in range(n)]
        key = [_clip(f"  c{i} = {name}", max_width) for i, name in enumerate(names)]
        width = max(width, *(len(label) for label in labels))
    lines = [" " * width + " | " + " ".join(f"{label:>{width}}" for label in labels)]
    lines.append("-" * len(lines[0]))
    for label, row in zip(labels, matrix, strict=True):
        lines.append(f"{label:>{width}} | " + " ".join(f"{v:>{width}d}" for v in row))
    if key:
        lines += ["key:"] + key
    return "\n".join(lines)


def _clip(text: str, width: int) -> str:
    """``text`` in at most ``width`` characters, keeping its start and its end (names
    often differ only at the end)."""
    if len(text) <= width:
        return text
    tail = (width - 3) // 2
    return text[: width - 3 - tail] + "..." + text[len(text) - tail :]


def _confusion_summary(matrix, names, max_width) -> str:
    name_width = min(34, max(5, *(len(str(name)) for name in names)))
    lines = [f"{'class':<{name_width}}  correct  accuracy  most often mistaken for"]
    for c, name in enumerate(names):
        row = matrix[c]
        total = int(row.sum())
        wrong = row.copy()
        wrong[c] = 0
        other = (
            f"{_clip(str(names[int(np.argmax(wrong))]), 34)} ({int(wrong.max())})"
            if wrong.max() > 0
            else "-"
        )
        accuracy = f"{row[c] / total:.2f}" if total else "-"
        line = (
            f"{_clip(str(name), name_width):<{name_width}}  {f'{row[c]}/{total}':>7}  "
            f"{accuracy:>8}  {other}"
        )
        lines.append(_clip(line, max_width))
    off = matrix.copy()
    np.fill_diagonal(off, 0)
    pairs = [(int(off[i, j]), i, j) for i, j in zip(*np.nonzero(off), strict=True)]
    pairs.sort(key=lambda p: (-p[0], p[1], p[2]))
    if pairs:
        lines.append("most confused pairs (true -> predicted: count)")
        for count, i, j in pairs[:10]:
            line = f"  {_clip(str(names[i]), 40)} -> {_clip(str(names[j]), 40)}: {count}"
            lines.append(_clip(line, max_width))
    return "\n".join(lines)


def wrap(text: str, width: int = MAX_WIDTH) -> str:
    return "\n".join(textwrap.wrap(text, width, subsequent_indent="  ", break_long_words=False))


def _finite(matrix: np.ndarray) -> np.ndarray:
    """Infinite distances (different numbers of essential classes) capped for t-SNE."""
    finite = matrix[np.isfinite(matrix)]
    cap = 2.0 * finite.max() if finite.size and finite.max() > 0 else 1.0
    return np.where(np.isfinite(matrix), matrix, cap)


def json_safe(value):
    """``value`` as plain JSON data: estimators by their class name, numbers as Python
    numbers, infinite and NaN floats as the strings ``"inf"``, ``"-inf"`` and ``"nan"``,
    tuples and arrays as lists, anything else by its ``repr``."""
    if isinstance(value, dict):
        return {str(key): json_safe(item) for key, item in value.items()}
    if isinstance(value, list | tuple | np.ndarray):
        return [json_safe(item) for item in value]
    if isinstance(value, np.generic):
        value = value.item()
    if value is None or isinstance(value, bool | int | str):
        return value
    if isinstance(value, float):
        return value if np.isfinite(value) else str(value)
    if isinstance(value, Path):
        return str(value)
    if hasattr(value, "get_params") and not isinstance(value, type):
        return type(value).__name__
    return repr(value)


def write_data(output: Path, matrix, diagrams, predictions, names, filenames, summary):
    """The result files (see the command line's help); returns their paths. An
    earlier run's data files are written over (``summary.json`` replaced whole); its
    ``diagrams.npz`` when this run has none, and its pictures (this run's come after
    the data), are removed first, so none is left beside this run's matrix.

    ``diagrams`` is ``(per-sample tuples of diagrams, their names)``, or None for no
    ``diagrams.npz``; ``predictions`` is ``(true labels, predicted labels, fold of each
    sample)``.
    """
    y, predicted, fold_of = predictions
    output.mkdir(parents=True, exist_ok=True)
    paths = [output / f for f in DATA_FILES if diagrams is not None or "diagrams" not in f]
    for name in RESULT_FILES:
        if output / name not in paths:
            (output / name).unlink(missing_ok=True)
    np.save(output / "distances.npy", np.asarray(matrix, dtype=np.float64))
    if diagrams is not None:
        samples, diagram_names = diagrams
        arrays = {}
        for i, sample in enumerate(samples):
            for k, d in enumerate(sample):
                arrays[f"sample_{i}_diagram_{k}"] = np.asarray(d, np.float64).reshape(-1, 2)
        np.savez(
            output / "diagrams.npz",
            filenames=np.asarray(filenames, dtype=str),
            labels=np.asarray(y),
            target_names=np.asarray(names, dtype=str),
            diagram_names=np.asarray(diagram_names, dtype=str),
            **arrays,
        )
    with open(output / "predictions.csv", "w", newline="", encoding="utf-8") as f:
        writer = csv.writer(f)
        writer.writerow(["index", "file", "true label", "predicted label", "fold"])
        for i in range(len(y)):
            writer.writerow([i, filenames[i], names[y[i]], names[predicted[i]], int(fold_of[i])])
    write_summary(output, dict(summary, files=[p.name for p in paths]))
    return paths


def write_summary(output: Path, summary: dict) -> None:
    """``summary.json``, replaced whole or not at all: written to a new temporary file
    of the folder (the permissions of the umask, as the other result files), then
    renamed over the old one (a full disk leaves the old one)."""
    text = json.dumps(json_safe(summary), indent=2, allow_nan=False) + "\n"
    temporary = output / f".summary.{os.getpid()}.{uuid.uuid4().hex}.tmp"
    # Created new (never through a link or over a file), with the umask's permissions.
    descriptor = os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
    try:
        with os.fdopen(descriptor, "w", encoding="utf-8") as f:
            f.write(text)
        os.replace(temporary, output / "summary.json")
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(temporary)
        raise


def write_pictures(output: Path, matrix, y, names, fields, random_state, diagrams=None):
    """``tsne.png`` (of ``matrix``), ``eigenfunctions.png`` (the first column of the
    first field of each class, labelled by its ``column_names``) and, with ``diagrams`` as
    ``(per-sample tuples, names)``, ``diagrams.png``; returns their paths."""
    from sklearn.manifold import TSNE

    from . import plotting

    output.mkdir(parents=True, exist_ok=True)
    plt = plotting.pyplot()
    written = []
    n_classes = len(names)
    if len(y) > 2:
        perplexity = min(30.0, max(1.0, (len(y) - 1) / 3.0))
        embedding = TSNE(
            metric="precomputed", init="random", perplexity=perplexity, random_state=random_state
        ).fit_transform(_finite(matrix))
        legend_cols = 1 if n_classes <= 20 else 2
        fig, ax = plt.subplots(figsize=(6 + 1.8 * legend_cols, 5))
        plotting.plot_embedding(embedding, y, names, ax=ax)
        ax.set_title("t-SNE of the distance matrix (pipeline fitted on all samples)")
        written.append(_save(fig, output / "tsne.png"))

    examples = [int(np.flatnonzero(y == c)[0]) for c in range(n_classes)]
    cols = min(3 if n_classes <= 9 else 5, len(examples))
    rows = -(-len(examples) // cols)
    if diagrams is not None:
        samples, labels = diagrams
        fig, axes = plt.subplots(rows, cols, figsize=(4 * cols, 3.6 * rows), squeeze=False)
        for ax, i in zip(axes.ravel(), examples, strict=False):
            plotting.plot_diagram(tuple(samples[i]), ax=ax, labels=labels)
            ax.set_title(_clip(str(names[y[i]]), 40))
        for ax in axes.ravel()[len(examples) :]:
            ax.set_axis_off()
        written.append(_save(fig, output / "diagrams.png"))

    if fields[0].is_graph:  # a graph's nodes have no positions to draw the function on
        return written
    fig = plt.figure(figsize=(4 * cols, 3.8 * rows))
    for k, i in enumerate(examples):
        ax = fig.add_subplot(rows, cols, k + 1, projection="3d")
        field = fields[i]
        label = field.column_names[0]
        plotting.plot_mesh_function(
            field.vertices, field.faces, field.columns()[0], ax=ax, colorbar_label=label
        )
        ax.set_title(f"{_clip(str(names[y[i]]), 30)}:\n{label}", fontsize=8)
    fig.suptitle("The first function of the eigen stage, first sample of each class")
    written.append(_save(fig, output / "eigenfunctions.png"))
    return written


def _save(fig, path: Path) -> Path:
    fig.tight_layout()
    fig.savefig(path, dpi=110, bbox_inches="tight")
    fig.clf()
    return path
