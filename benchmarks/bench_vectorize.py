"""Vectorizations and kernels of diagrams: sklearn-meshph against gudhi.representations
and persim, same process, and a streaming run over a million diagrams.

    python benchmarks/bench_vectorize.py [--n 10000] [--stream 1000000] [--n-jobs 2]

Table 1: each vectorizer on ``--n`` random diagrams of 50 points (fit_transform), ours
(1 and ``--n-jobs`` jobs) against gudhi.representations' equivalent and, for images,
persim's PersistenceImager; peak traced memory of each call. Table 2: the kernels'
fit_transform (every pair) on a subset, per pair, against gudhi's. Table 3: a fitted
PersistenceImage on ``--stream`` diagrams made and vectorized in batches of 10,000:
time per 100,000 diagrams along the run and peak memory. giotto-tda is not an anchor:
its releases pin scikit-learn below the version this package needs, so it does not
install beside it.
"""

from __future__ import annotations

import argparse
import resource
import time
import tracemalloc

import numpy as np

from sklearn_meshph import (
    BettiCurve,
    PersistenceEntropy,
    PersistenceImage,
    PersistenceLandscape,
    Silhouette,
)

POINTS = 50


def random_diagrams(n, seed=0, points=POINTS):
    rng = np.random.default_rng(seed)
    births = rng.random((n, points))
    deaths = births + rng.exponential(0.3, size=(n, points))
    return list(np.stack([births, deaths], axis=2))


def measured(function, *args):
    """(seconds, peak traced MB, result): the best time of two untraced calls (tracing
    slows numpy-heavy code several times), then one traced call for the memory."""
    seconds = np.inf
    for _ in range(2):
        start = time.perf_counter()
        result = function(*args)
        seconds = min(seconds, time.perf_counter() - start)
    tracemalloc.start()
    function(*args)
    peak = tracemalloc.get_traced_memory()[1] / 2**20
    tracemalloc.stop()
    return seconds, peak, result


def vectorizer_pairs():
    import gudhi.representations as rep

    image_range = (0.0, 1.0, 0.0, 2.0)
    return {
        "persistence image 20x20": (
            lambda n_jobs: PersistenceImage(
                bandwidth=0.1, resolution=(20, 20), im_range=image_range, n_jobs=n_jobs
            ),
            lambda: rep.PersistenceImage(
                bandwidth=0.1, resolution=[20, 20], im_range=list(image_range)
            ),
        ),
        "landscapes 5 x 100": (
            lambda n_jobs: PersistenceLandscape(5, resolution=100, n_jobs=n_jobs),
            lambda: rep.Landscape(5, resolution=100),
        ),
        "silhouette 100": (
            lambda n_jobs: Silhouette(power=1.0, resolution=100, n_jobs=n_jobs),
            lambda: rep.Silhouette(weight=lambda p: p[1] - p[0], resolution=100),
        ),
        "Betti curve 100": (
            lambda n_jobs: BettiCurve(resolution=100, n_jobs=n_jobs),
            lambda: rep.BettiCurve(resolution=100),
        ),
        "persistence entropy": (
            lambda n_jobs: PersistenceEntropy(n_jobs=n_jobs),
            lambda: rep.Entropy(mode="scalar"),
        ),
    }


def table_vectorizers(diagrams, n_jobs):
    small = diagrams[:1000]
    for make, _ in vectorizer_pairs().values():
        make(1).fit_transform(small)  # compile
    print(
        f"\n{len(diagrams)} diagrams of {POINTS} points, fit_transform:\n\n"
        f"| vectorizer | ours 1 job s | ours {n_jobs} jobs s | gudhi s | ours/gudhi (1 job) | "
        f"ours/gudhi ({n_jobs} jobs) | ours MB | gudhi MB |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for name, (make, theirs) in vectorizer_pairs().items():
        one, peak, ours = measured(make(1).fit_transform, diagrams)
        many, _, _ = measured(make(n_jobs).fit_transform, diagrams)
        anchor, anchor_peak, reference = measured(theirs().fit_transform, diagrams)
        scale = max(1.0, float(np.abs(reference).max()))
        assert np.allclose(ours, reference, rtol=1e-10, atol=1e-12 * scale), name
        print(
            f"| {name} | {one:.3f} | {many:.3f} | {anchor:.3f} | {one / anchor:.3f} | "
            f"{many / anchor:.3f} | {peak:.0f} | {anchor_peak:.0f} |"
        )
    table_persim(diagrams, n_jobs)


def table_persim(diagrams, n_jobs):
    try:
        import persim
    except ImportError:
        print("\npersim not installed: no PersistenceImager row")
        return
    subset = diagrams[:1000]
    imager = persim.PersistenceImager(
        birth_range=(0.0, 1.0),
        pers_range=(0.0, 2.0),
        pixel_size=0.05,
        kernel_params={"sigma": 0.01},
    )
    ours = PersistenceImage(
        bandwidth=0.1,
        resolution=(20, 40),
        im_range=(0.0, 1.0, 0.0, 2.0),
        sampling="pixel",
        weight="persistence",
        n_jobs=1,
    )
    ours.fit_transform(subset[:10])
    one, peak, mine = measured(ours.fit_transform, subset)
    anchor, anchor_peak, theirs = measured(imager.transform, subset)
    theirs = np.array(theirs).transpose(0, 2, 1).reshape(len(subset), -1)
    assert np.allclose(mine, theirs, rtol=1e-10, atol=1e-12 * np.abs(theirs).max())
    print(
        f"\npersim PersistenceImager, {len(subset)} diagrams, 20 x 40 pixels (pixel sampling, "
        f"persistence weight): ours {one:.3f} s, persim {anchor:.3f} s, ours/persim "
        f"{one / anchor:.4f}; peak {peak:.0f} MB vs {anchor_peak:.0f} MB"
    )


def table_kernels(diagrams, n_jobs):
    try:
        from sklearn_meshph.vectorization.kernels import (
            PersistenceScaleSpaceKernel,
            PersistenceWeightedGaussianKernel,
            SlicedWassersteinKernel,
        )
    except ImportError:
        print("\nno kernels module: skipped")
        return
    import gudhi.representations as rep

    pairs = {
        "sliced Wasserstein (10 directions)": (
            lambda: SlicedWassersteinKernel(bandwidth=1.0, n_directions=10, n_jobs=n_jobs),
            # gudhi drops one of its num_directions lines and uses exp(-SW / bandwidth)
            lambda: rep.SlicedWassersteinKernel(num_directions=11, bandwidth=2.0),
        ),
        "persistence scale-space": (
            lambda: PersistenceScaleSpaceKernel(bandwidth=0.1, n_jobs=n_jobs),
            lambda: rep.PersistenceScaleSpaceKernel(bandwidth=0.1),
        ),
        "persistence weighted Gaussian": (
            lambda: PersistenceWeightedGaussianKernel(bandwidth=0.1, n_jobs=n_jobs),
            lambda: rep.PersistenceWeightedGaussianKernel(bandwidth=0.1, weight=lambda p: 1.0),
        ),
    }
    ours_n, theirs_n = 1000, 150
    print(
        f"\nKernels, fit_transform on {ours_n} diagrams (ours, {n_jobs} jobs) and {theirs_n} "
        "(gudhi), per pair:\n\n| kernel | ours us/pair | gudhi us/pair | ours/gudhi | ours MB |"
    )
    print("|---|---|---|---|---|")
    for name, (ours, theirs) in pairs.items():
        ours().fit_transform(diagrams[:5])  # compile
        mine, peak, _ = measured(ours().fit_transform, diagrams[:ours_n])
        anchor, _, reference = measured(theirs().fit_transform, diagrams[:theirs_n])
        check = ours().fit_transform(diagrams[:theirs_n])
        assert np.allclose(check, reference, rtol=1e-9, atol=1e-12 * np.abs(reference).max())
        per_ours = mine / (ours_n * (ours_n + 1) / 2) * 1e6
        per_theirs = anchor / theirs_n**2 * 1e6  # gudhi computes the full square
        print(
            f"| {name} | {per_ours:.3f} | {per_theirs:.3f} | {per_ours / per_theirs:.4f} | "
            f"{peak:.0f} |"
        )


def streaming(total, n_jobs, batch=10_000):
    image = PersistenceImage(
        bandwidth=0.1, resolution=(20, 20), im_range=(0.0, 1.0, 0.0, 2.0), n_jobs=n_jobs
    )
    image.fit(random_diagrams(100))
    checkpoints = {}
    tracemalloc.start()
    vectorizing = 0.0
    checksum = 0.0
    for done in range(batch, total + 1, batch):
        diagrams = random_diagrams(batch, seed=done)
        start = time.perf_counter()
        features = image.transform(diagrams)
        vectorizing += time.perf_counter() - start
        checksum += float(features.sum())
        if done % (total // 10) == 0:
            checkpoints[done] = (vectorizing, tracemalloc.get_traced_memory()[1] / 2**20)
    tracemalloc.stop()
    print(
        f"\nStreaming: a fitted 20x20 PersistenceImage on {total:,} diagrams of {POINTS} points in "
        f"batches of {batch:,} ({n_jobs} jobs), vectorizing time only:\n\n"
        "| diagrams | cumulative s | s per 100,000 since the last row | peak traced MB |"
    )
    print("|---|---|---|---|")
    previous_n, previous_s = 0, 0.0
    for n, (seconds, peak) in checkpoints.items():
        rate = (seconds - previous_s) / (n - previous_n) * 100_000
        print(f"| {n:,} | {seconds:.1f} | {rate:.2f} | {peak:.0f} |")
        previous_n, previous_s = n, seconds
    print(f"(checksum {checksum:.6g})")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=10_000)
    parser.add_argument("--stream", type=int, default=1_000_000)
    parser.add_argument("--n-jobs", type=int, default=2)
    args = parser.parse_args()
    diagrams = random_diagrams(args.n)
    table_vectorizers(diagrams, args.n_jobs)
    table_kernels(diagrams, args.n_jobs)
    if args.stream:
        streaming(args.stream, args.n_jobs)
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"\npeak resident memory of this process: {peak:.0f} MB")


if __name__ == "__main__":
    main()
