"""t-SNE of the Sumner meshes under three distances, side by side.

    python benchmarks/plot_gh_tsne.py [--n-samples 400] [--n-jobs 2] [--gh FILE.npz]
                                      [--output docs/images/gh_tsne.png]

Panels: the metric-based comparator of Chazal et al. (SGP 2009; bottleneck distance
between the Rips H0 and H1 diagrams of the sampled geodesic metric, see
``gh_signatures.py``), the paper's literal pipeline (``make_mesh_distance("paper")``:
graph Laplacian, Fiedler vector, sublevel H0, bottleneck) and the library's default
(``make_mesh_distance("default")``). Each is embedded by scikit-learn's t-SNE on the
precomputed matrix (``init="random"``, ``perplexity=15``, ``random_state=0``), as the
paper's figure embeds its matrix; the leave-one-out 1-NN accuracy of each matrix is in
its title. ``--gh`` reuses a ``sumner_gh.npz`` written by ``gh_signatures.py --save``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from sklearn.manifold import TSNE  # noqa: E402

sys.path.insert(0, str(Path(__file__).parent))
from _common import DATA, loo_1nn  # noqa: E402
from gh_signatures import N_SAMPLES, gh_distance_matrices  # noqa: E402

from sklearn_meshph import load_mesh_folder, make_mesh_distance  # noqa: E402

OUTPUT = Path(__file__).parents[1] / "docs" / "images" / "gh_tsne.png"


def embed(matrix):
    """2-D t-SNE of a precomputed distance matrix (non-finite entries set to twice the
    largest finite one)."""
    matrix = np.array(matrix, dtype=float)
    finite = np.isfinite(matrix)
    matrix[~finite] = 2 * matrix[finite].max()
    tsne = TSNE(metric="precomputed", init="random", perplexity=15, random_state=0)
    return tsne.fit_transform(matrix)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n-samples", type=int, default=N_SAMPLES)
    parser.add_argument("--n-jobs", type=int, default=2)
    parser.add_argument("--gh", type=Path, default=None, help="sumner_gh.npz to reuse")
    parser.add_argument("--output", type=Path, default=OUTPUT)
    args = parser.parse_args()
    folder = DATA / "sumner"
    if not folder.is_dir():
        print(f"Sumner meshes not found in {folder}: nothing to plot")
        return
    data = load_mesh_folder(folder, n_jobs=args.n_jobs)
    meshes, y, names = list(data.data), np.asarray(data.target), list(data.target_names)

    matrices = {}
    start = time.perf_counter()
    if args.gh is not None:
        saved = np.load(args.gh)
        if not np.array_equal(saved["y"], y):
            raise ValueError(f"{args.gh} does not hold the Sumner labels in this order")
        gh = saved["H0+H1"]
    else:
        gh = gh_distance_matrices(meshes, args.n_samples, args.n_jobs)["H0+H1"]
    matrices["Chazal et al. 2009: Rips H0+H1 of geodesics, bottleneck"] = gh
    print(f"GH comparator: {time.perf_counter() - start:.0f} s", flush=True)
    for preset, title in (
        ("paper", 'paper literal: Fiedler vector, sublevel H0, bottleneck ("paper")'),
        ("default", 'library default: make_mesh_distance("default")'),
    ):
        start = time.perf_counter()
        pipeline = make_mesh_distance(preset, n_jobs=args.n_jobs, random_state=0)
        matrices[title] = pipeline.fit_transform(meshes)
        print(f"{preset}: {time.perf_counter() - start:.0f} s", flush=True)

    fig, axes = plt.subplots(1, 3, figsize=(12, 4.4))
    colors = plt.get_cmap("tab10")
    for ax, (title, matrix) in zip(axes, matrices.items(), strict=True):
        points = embed(matrix)
        for c, name in enumerate(names):
            mask = y == c
            ax.scatter(*points[mask].T, s=18, color=colors(c), label=name)
        ax.set_title(f"{title}\nleave-one-out 1-NN {loo_1nn(matrix, y):.3f}", fontsize=8)
        ax.set_xticks([])
        ax.set_yticks([])
        print(f"{title}: LOO 1-NN {loo_1nn(matrix, y):.3f}")
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=len(names), fontsize=8, frameon=False)
    fig.suptitle("t-SNE of the Sumner meshes (60 meshes, 6 classes)", fontsize=10)
    fig.tight_layout(rect=(0, 0.06, 1, 1))
    args.output.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.output, dpi=110)
    print(f"saved {args.output}")


if __name__ == "__main__":
    main()
