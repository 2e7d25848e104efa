"""The default pipeline's cost per mesh on watertight_dev, before and after the cheaper
eigensolve, and its accuracy.

    python benchmarks/bench_default_cost.py [--collection watertight_dev] [--out FILE]
        [--memory-meshes 3] [--fewer N]

Runs ``make_mesh_distance()`` with ``memory=None`` (no eigen cache: every solve is
done), ``n_jobs=1`` and one BLAS thread, and measures CPU time (``time.process_time``,
meaningful on a shared machine where wall time is not). The eigen stage is timed mesh
by mesh under two settings, interleaved (each mesh solved by one, then the other, so
that a load that changes during the run weighs on both alike):

- ``former``: the default before issue 29: 56 eigenpairs and a Shape-DNA of 50
  (``FORMER_PARAMS``), solved by ARPACK to machine precision (``tol=0``) with a basis of
  twice the eigenpairs plus one;
- ``current``: the library's default as it is: an unrestarted Lanczos run with partial
  reorthogonalization (``sklearn_meshph.spectral.lanczos``), checked by the inertia of
  ``L - tau M``, ARPACK at the former settings when the check fails (counted:
  ``fallbacks``).

``--fewer N`` adds a third setting, ``fewer``: the current solve of ``N`` eigenpairs, with
the Shape-DNA of ``N`` (``eigen__n_eigenpairs`` and ``distance__dna__spectrum__n_eigenpairs``
set to ``N``), timed and scored in the same way (its peak memory is not measured).

The distance stage (extended persistence of the signatures, the four distance matrices
and their combination) is then timed over all meshes for each setting, and the accuracy
is leave-one-out 1-NN on the full matrix of each. Loading is not counted. Peak memory per mesh is
the growth of the resident set of a fresh process solving one mesh (the
``--memory-meshes`` largest) over the same process after a warm-up on a small mesh
(Linux: the high-water mark is reset through ``/proc/self/clear_refs`` first).
``--memory-only`` measures that alone.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from contextlib import contextmanager

import numpy as np
from _common import DATA, loo_1nn

from sklearn_meshph.spectral import eigensolver

PEAK = r"""
import sys
sys.path.insert(0, sys.argv[3])
from bench_default_cost import FORMER_PARAMS, settings
from sklearn_meshph import make_mesh_distance, make_shapes
path, name = sys.argv[1], sys.argv[2]
eigen = make_mesh_distance(memory=None, n_jobs=1).named_steps["eigen"]
if name == "former":
    eigen.set_params(n_eigenpairs=FORMER_PARAMS["eigen__n_eigenpairs"])
eigen.fit_transform(make_shapes(n_per_class=1, random_state=0, return_X_y=True)[0][:1])

def status(field):
    with open("/proc/self/status") as f:
        return next(int(line.split()[1]) / 1e3 for line in f if line.startswith(field))

with open("/proc/self/clear_refs", "w") as f:  # the peak so far (imports) forgotten
    f.write("5")
before = status("VmRSS:")
with settings(name):
    eigen.fit_transform([path])  # read, cleaned and solved
print(status("VmHWM:") - before)
"""

# The solve before issue 29: ARPACK alone, at machine precision, a basis of 2k + 1
# vectors; and the default's eigenpairs then.
FORMER = {"_LANCZOS": False}
FORMER_PARAMS = {"eigen__n_eigenpairs": 56, "distance__dna__spectrum__n_eigenpairs": 50}
SETTINGS = ("former", "current")


@contextmanager
def settings(name):
    """The eigensolver's settings ``name`` ("former" or "current") for the block."""
    saved = {key: getattr(eigensolver, key) for key in FORMER}
    if name == "former":
        for key, value in FORMER.items():
            setattr(eigensolver, key, value)
    try:
        yield
    finally:
        for key, value in saved.items():
            setattr(eigensolver, key, value)


def peak_memory(paths, name):
    """Peak resident growth (MB) of a fresh process solving each mesh."""
    out = []
    for path in paths:
        result = subprocess.run(
            [sys.executable, "-c", PEAK, str(path), name, str(os.path.dirname(__file__))],
            capture_output=True,
            text=True,
            check=True,
            env={**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"},
        )
        out.append(float(result.stdout.split()[-1]))
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--collection", default="watertight_dev")
    parser.add_argument("--memory-meshes", type=int, default=3)
    parser.add_argument("--memory-only", action="store_true", help="peak memory alone")
    parser.add_argument("--fewer", type=int, default=None, help="also the current solve of N")
    parser.add_argument("--out", default=None, help="write the results as JSON")
    args = parser.parse_args()

    from sklearn_meshph import load_mesh_folder, make_mesh_distance

    bunch = load_mesh_folder(DATA / args.collection)
    meshes, y = bunch.data, np.asarray(bunch.target)
    if args.memory_only:
        largest = np.argsort([len(mesh.vertices) for mesh in meshes])[::-1][: args.memory_meshes]
        for name in SETTINGS:
            paths = [bunch.filenames[i] for i in largest]
            sizes = [len(meshes[i].vertices) for i in largest]
            print(name, dict(zip(sizes, peak_memory(paths, name), strict=True)))
        return
    names = SETTINGS + (("fewer",) if args.fewer else ())
    pipes = {name: make_mesh_distance(memory=None, n_jobs=1) for name in names}
    pipes["former"].set_params(**FORMER_PARAMS)
    if args.fewer:
        pipes["fewer"].set_params(
            eigen__n_eigenpairs=args.fewer, distance__dna__spectrum__n_eigenpairs=args.fewer
        )
    for name in names:  # compiles what is compiled once per process, not timed
        with settings(name):
            pipes[name].fit_transform(meshes[:4])
    fields = {name: [] for name in names}
    seconds = {name: [] for name in names}
    arpack, fallbacks = eigensolver._shift_invert, []

    def counted(*args):  # ARPACK under the current settings: the check failed
        fallbacks.append(args[0].shape[0])
        return arpack(*args)

    for i, mesh in enumerate(meshes):
        for name in names:
            with settings(name):
                if name == "current":
                    eigensolver._shift_invert = counted
                start = time.process_time()
                fields[name].extend(pipes[name].named_steps["eigen"].fit_transform([mesh]))
                seconds[name].append(time.process_time() - start)
                eigensolver._shift_invert = arpack
        if i % 20 == 19:
            print(i + 1, {k: round(sum(v), 1) for k, v in seconds.items()}, flush=True)
    sizes = [len(field.vertices) for field in fields["current"]]
    largest = np.argsort(sizes)[::-1][: args.memory_meshes]
    result = {"meshes": len(meshes), "vertices": int(np.sum(sizes))}
    for name in names:
        eigen_seconds = float(np.sum(seconds[name]))
        entry = {
            "eigen_seconds": eigen_seconds,
            "eigen_ms_per_mesh": 1e3 * eigen_seconds / len(meshes),
            "per_mesh_seconds": seconds[name],
        }
        if name in SETTINGS:
            paths = [bunch.filenames[i] for i in largest]
            entry["peak_mb"] = dict(
                zip((str(sizes[i]) for i in largest), peak_memory(paths, name), strict=True)
            )
        if name != "former":
            entry["max_relative_eigenvalue_change"] = max(  # the constant's 0 left out
                float(np.max(np.abs(a.spectrum[1:] / b.spectrum[1 : len(a.spectrum)] - 1)))
                for a, b in zip(fields[name], fields["former"], strict=True)
            )
        if name == "current":
            entry["fallbacks"] = fallbacks
        start = time.process_time()
        matrix = pipes[name].named_steps["distance"].fit_transform(fields[name])
        entry["distance_seconds"] = time.process_time() - start
        entry["per_mesh_ms"] = 1e3 * (eigen_seconds + entry["distance_seconds"]) / len(meshes)
        entry["loo_1nn"] = loo_1nn(matrix, y)
        if name != "former":
            entry["ratio_eigen"] = eigen_seconds / result["former"]["eigen_seconds"]
            entry["ratio_per_mesh"] = entry["per_mesh_ms"] / result["former"]["per_mesh_ms"]
        result[name] = entry
        print(name, json.dumps({k: v for k, v in entry.items() if k != "per_mesh_seconds"}))
    if args.out:
        with open(args.out, "w") as f:
            json.dump(result, f)


if __name__ == "__main__":
    main()
