"""The default's distance stage with one extended persistence per sample for its three
diagram kinds (``CombinedDistance`` shares it) against one per kind (the former path),
in CPU time, interleaved; the outputs must be bitwise equal.

    python benchmarks/bench_shared_persistence.py [--memory /tmp/work/eigen_cache]
        [--repeats 8] [--per-class N]

The eigen stage is fitted once (cached in ``--memory``), then
``named_steps["distance"].fit_transform(fields)`` is timed with ``time.process_time``
(one job), alternating which of the two goes first; then the persistence alone (the
three kinds' ``LowerStarPersistence`` one by one against one for the three).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from bench_cluster import load
from sklearn.base import clone

import sklearn_meshph.combine as combine
from sklearn_meshph import make_mesh_distance

SHARED = combine._persistence_groups


def _former(parts):
    return []  # no group: each part's persistence computes its own kind


def _timed(run, repeats):
    """CPU seconds of ``run(shared)`` per repeat, both settings interleaved, and the
    first output of each."""
    times, outputs = {True: [], False: []}, {}
    for r in range(repeats):
        for shared in (True, False) if r % 2 == 0 else (False, True):
            combine._persistence_groups = SHARED if shared else _former
            start = time.process_time()
            output = run(shared)
            times[shared].append(time.process_time() - start)
            outputs.setdefault(shared, output)
    combine._persistence_groups = SHARED
    return times, outputs


def _report(what, times):
    ratios = [a / b for a, b in zip(times[True], times[False], strict=True)]
    print(
        f"{what}: shared median {np.median(times[True]):.2f} s, one per kind "
        f"{np.median(times[False]):.2f} s, ratio per pair median {np.median(ratios):.3f} "
        f"(range {min(ratios):.3f}-{max(ratios):.3f})"
    )


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--memory", default=None, help="the eigen cache's folder")
    parser.add_argument("--repeats", type=int, default=8)
    parser.add_argument("--per-class", type=int, default=None, help="meshes per class")
    args = parser.parse_args()
    meshes = load(args.per_class)
    pipeline = make_mesh_distance(memory=args.memory, n_jobs=1)
    fields = pipeline.named_steps["eigen"].fit_transform(meshes)
    distance = pipeline.named_steps["distance"]
    print(f"{len(meshes)} meshes, {args.repeats} interleaved repeats, CPU seconds")
    times, outputs = _timed(lambda _: clone(distance).fit_transform(fields), args.repeats)
    assert np.array_equal(outputs[True], outputs[False]), "the outputs differ"
    _report("distance stage", times)
    steps = [part.steps[0][1] for _, part in distance.transformer_list[:3]]

    def persistence(shared):
        if shared:
            return combine._shared_diagrams([clone(s) for s in steps], fields, fit=True)
        return [clone(s).fit_transform(fields) for s in steps]

    _report("persistence alone", _timed(persistence, args.repeats)[0])


if __name__ == "__main__":
    main()
