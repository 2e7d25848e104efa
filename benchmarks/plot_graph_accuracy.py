"""Bar chart of graph_classification.py's accuracies beside PersLay's published ones.

python benchmarks/graph_classification.py | tee graph_classification.log
python benchmarks/plot_graph_accuracy.py graph_classification.log docs/images/graph_accuracy.png
"""

import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def read(log):
    """``(names, means, stds, perslay)`` from the rows of the benchmark's table."""
    rows = []
    with open(log) as lines:
        for line in lines:
            parts = line.split()
            if len(parts) >= 8 and parts[3] == "±":
                rows.append((parts[0], float(parts[2]), float(parts[4]), float(parts[5])))
    if not rows:
        raise SystemExit(f"{log}: no table rows of graph_classification.py")
    return [np.array(c) if i else list(c) for i, c in enumerate(zip(*rows, strict=True))]


def main():
    log, out = sys.argv[1:3]
    names, means, stds, perslay = read(log)
    x = np.arange(len(names))
    fig, ax = plt.subplots(figsize=(7, 3.2))
    ax.bar(x - 0.2, perslay, 0.4, label="PersLay (published)", color="0.7")
    ax.bar(x + 0.2, means, 0.4, yerr=stds, label="make_graph_classifier()", color="C0")
    ax.set_xticks(x, names)
    ax.set_ylim(60, 100)
    ax.set_ylabel("accuracy (%)")
    ax.set_title("10 x 10-fold shuffled CV, graph structure only")
    ax.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    fig.savefig(out, dpi=110)


if __name__ == "__main__":
    main()
