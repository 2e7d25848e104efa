"""Diagram distances: sklearn-meshph against gudhi, hera, POT and persim, same process.

    python benchmarks/bench_distances.py [--quick]

Table 1, per pair: random diagrams of n points, median time of each exact method and of
hera's approximate default (delta=0.01) beside. Table 2: the full distance matrix of 300
small diagrams (5 to 30 points, the size of real Fiedler-vector diagrams), ours through
DiagramDistance against a loop of the anchor over the same 44,850 pairs.
"""

from __future__ import annotations

import argparse
import resource
import time
import warnings

import numpy as np
from _common import median_time

from sklearn_meshph import DiagramDistance, bottleneck_distance, wasserstein_distance


def random_diagram(rng, n):
    births = rng.random(n)
    return np.column_stack([births, births + rng.random(n) * 0.5])


def anchors():
    import gudhi
    import gudhi.hera
    import gudhi.wasserstein

    found = {
        "gudhi exact bottleneck": lambda a, b: gudhi.bottleneck_distance(a, b, 0),
        "hera bottleneck delta=0": lambda a, b: gudhi.hera.bottleneck_distance(a, b, delta=0),
        "hera bottleneck delta=0.01": lambda a, b: gudhi.hera.bottleneck_distance(a, b),
        "POT exact W2": lambda a, b: gudhi.wasserstein.wasserstein_distance(
            a, b, order=2, internal_p=np.inf
        ),
        "hera W2 delta=0.01": lambda a, b: gudhi.hera.wasserstein_distance(
            a, b, order=2, internal_p=np.inf
        ),
    }
    try:
        import persim

        found["persim bottleneck"] = lambda a, b: persim.bottleneck(a, b)
    except ImportError:
        pass
    return found


def per_pair(sizes, rng):
    others = anchors()
    ours = {"bottleneck": bottleneck_distance, "W2": wasserstein_distance}
    bottleneck(rng)  # compile
    print(
        "| n points | ours bottleneck s | ours W2 s | " + " | ".join(others) + " | "
        "bottleneck / gudhi exact | bottleneck / hera delta=0 | W2 / POT |"
    )
    print("|---|---|---|" + "---|" * len(others) + "---|---|---|")
    for n in sizes:
        a, b = random_diagram(rng, n), random_diagram(rng, n)
        repeats = 5 if n <= 1000 else 1
        mine = {k: median_time(repeats, f, a, b) for k, f in ours.items()}
        theirs = {}
        for name, func in others.items():
            if n >= 5000 and name in ("persim bottleneck", "gudhi exact bottleneck"):
                theirs[name] = float("nan")  # minutes per pair (ANCHORS.md)
                continue
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                theirs[name] = median_time(repeats, func, a, b)
        print(
            f"| {n} | {mine['bottleneck']:.5f} | {mine['W2']:.5f} | "
            + " | ".join(f"{t:.5f}" for t in theirs.values())
            + f" | {mine['bottleneck'] / theirs['gudhi exact bottleneck']:.3f}"
            f" | {mine['bottleneck'] / theirs['hera bottleneck delta=0']:.3f}"
            f" | {mine['W2'] / theirs['POT exact W2']:.3f} |",
            flush=True,
        )


def bottleneck(rng):
    bottleneck_distance(random_diagram(rng, 5), random_diagram(rng, 5))
    wasserstein_distance(random_diagram(rng, 5), random_diagram(rng, 5))


def full_matrix(n_diagrams, rng, n_jobs):
    diagrams = [random_diagram(rng, int(rng.integers(5, 31))) for _ in range(n_diagrams)]
    others = anchors()
    pairs = [(i, j) for i in range(n_diagrams) for j in range(i + 1, n_diagrams)]
    print(f"\nfull matrix of {n_diagrams} diagrams (5-30 points), {len(pairs):,} pairs")
    print(
        "| metric | ours 1 job s | ours 2 jobs s | anchor | anchor loop s | ours(1 job) / anchor |"
    )
    print("|---|---|---|---|---|---|")
    for metric, anchor in (
        ("bottleneck", "gudhi exact bottleneck"),
        ("bottleneck", "hera bottleneck delta=0"),
        ("wasserstein", "POT exact W2"),
        ("wasserstein", "hera W2 delta=0.01"),
    ):
        est = DiagramDistance(metric=metric)
        one = median_time(3, est.set_params(n_jobs=1).fit_transform, diagrams)
        two = median_time(3, est.set_params(n_jobs=n_jobs).fit_transform, diagrams)
        func = others[anchor]
        start = time.perf_counter()
        for i, j in pairs:
            func(diagrams[i], diagrams[j])
        loop = time.perf_counter() - start
        print(
            f"| {metric} | {one:.3f} | {two:.3f} | {anchor} | {loop:.3f} | {one / loop:.3f} |",
            flush=True,
        )


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="per-pair sizes up to 1000")
    parser.add_argument("--n-jobs", type=int, default=2)
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    sizes = (10, 100, 1000) if args.quick else (10, 100, 1000, 2000, 5000)
    per_pair(sizes, rng)
    full_matrix(300, rng, args.n_jobs)
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"\npeak resident memory: {peak:.0f} MB")


if __name__ == "__main__":
    main()
