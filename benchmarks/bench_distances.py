"""Diagram distances: sklearn-meshph against gudhi, hera, POT and persim, same process.

    python benchmarks/bench_distances.py [--quick] [--clustered-only]

Table 1, per pair: random diagrams of n points, median time of each exact method and of
hera's approximate default (delta=0.01) beside. Table 2: the full distance matrix of 300
small diagrams (5 to 30 points, the size of real Fiedler-vector diagrams), ours through
DiagramDistance against a loop of the anchor over the same 44,850 pairs. Table 3:
clustered, tied and duplicated diagrams (births all equal with deaths within 1%, Rips
H0 diagrams with births all 0, integer grids, a few points repeated) of 1,000 to 20,000
points, against hera (delta=0) and POT's exact solver, with the peak resident memory of
a fresh process computing only our distance (the random family beside, for scale).
"""

from __future__ import annotations

import argparse
import resource
import subprocess
import sys
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


FAMILIES = ("random", "births equal, deaths 1%", "births zero", "integer grid", "duplicates")


def clustered(family, n, seed):
    """A diagram of ``n`` points of a family (seeded: the memory probe rebuilds it)."""
    rng = np.random.default_rng([seed, n, FAMILIES.index(family)])
    if family == "random":
        return random_diagram(rng, n)
    if family == "births equal, deaths 1%":
        return np.column_stack([np.zeros(n), 1.0 + 0.01 * rng.random(n)])
    if family == "births zero":
        return np.column_stack([np.zeros(n), rng.random(n)])
    if family == "integer grid":
        births = rng.integers(0, 10, n)
        return np.column_stack([births, births + rng.integers(1, 10, n)]).astype(float)
    base = rng.random((20, 2)) @ [[1, 1], [0, 0.5]]
    return base[rng.integers(0, 20, n)]


_PROBE = """
import sys
import numpy as np
sys.path.insert(0, {here!r})
from bench_distances import clustered
from sklearn_meshph import bottleneck_distance, wasserstein_distance
a, b = clustered({family!r}, {n}, 1), clustered({family!r}, {n}, 2)
bottleneck_distance(a[:50], b[:50]), wasserstein_distance(a[:50], b[:50])
def status(key):
    for line in open("/proc/self/status"):
        if line.startswith(key):
            return float(line.split()[1]) / 1024
with open("/proc/self/clear_refs", "w") as f:  # Linux: reset the peak to the current
    f.write("5")
before = status("VmRSS")
{func}(a, b)
print(status("VmHWM") - before)
"""


def peak_mb(family, n, func):
    """Peak resident memory (MB) a fresh process adds while computing one distance
    (Linux: the peak is reset after the imports and the compilation)."""
    from pathlib import Path

    code = _PROBE.format(here=str(Path(__file__).parent), family=family, n=n, func=func)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return float(out.stdout.split()[-1])


def clustered_table(sizes, pot_up_to):
    import gudhi.hera
    import gudhi.wasserstein

    print(
        "\n| family | n points | ours bottleneck s | hera delta=0 s | ratio | ours W2 s | "
        "POT exact s | ratio | ours bottleneck MB | ours W2 MB |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    for family in FAMILIES:  # compile the large-diagram paths before timing them
        a, b = clustered(family, 400, 3), clustered(family, 400, 4)
        bottleneck_distance(a, b), wasserstein_distance(a, b)
    for n in sizes:
        for family in FAMILIES:
            a, b = clustered(family, n, 1), clustered(family, n, 2)
            ours_b = median_time(1, bottleneck_distance, a, b)
            hera_b = median_time(
                1, lambda x, y: gudhi.hera.bottleneck_distance(x, y, delta=0), a, b
            )
            ours_w = median_time(1, wasserstein_distance, a, b)
            if n <= pot_up_to:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    pot = median_time(
                        1,
                        lambda x, y: gudhi.wasserstein.wasserstein_distance(
                            x, y, order=2, internal_p=np.inf
                        ),
                        a,
                        b,
                    )
            else:
                pot = float("nan")  # a dense (n+1)^2 cost matrix: beyond this machine
            mem_b = peak_mb(family, n, "bottleneck_distance")
            mem_w = peak_mb(family, n, "wasserstein_distance")
            print(
                f"| {family} | {n} | {ours_b:.3f} | {hera_b:.3f} | {ours_b / hera_b:.3f} | "
                f"{ours_w:.3f} | {pot:.3f} | {ours_w / pot:.3f} | {mem_b:.0f} | {mem_w:.0f} |",
                flush=True,
            )


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="per-pair sizes up to 1000")
    parser.add_argument("--n-jobs", type=int, default=2)
    parser.add_argument("--clustered-only", action="store_true", help="only table 3")
    parser.add_argument(
        "--pot-up-to", type=int, default=10000, help="largest n for POT in table 3 (0: none)"
    )
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    if not args.clustered_only:
        sizes = (10, 100, 1000) if args.quick else (10, 100, 1000, 2000, 5000)
        per_pair(sizes, rng)
        full_matrix(300, rng, args.n_jobs)
    clustered_sizes = (1000, 2000) if args.quick else (1000, 2000, 5000, 10000, 20000)
    clustered_table(clustered_sizes, pot_up_to=args.pot_up_to)
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"\npeak resident memory: {peak:.0f} MB")


if __name__ == "__main__":
    main()
