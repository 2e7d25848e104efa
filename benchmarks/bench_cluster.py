"""The default pipeline's two costly stages on a dask.distributed cluster.

    python benchmarks/bench_cluster.py [--per-class 5] [--copies 10] [--json FILE]
                                       [--rounds 1]
    python benchmarks/bench_cluster.py --distances-only [--memory DIR]
    python benchmarks/bench_cluster.py --schedule

A ``LocalCluster`` of 2 worker processes against one of 1, through
``joblib.parallel_backend("dask")``, on the stages of ``make_mesh_distance()`` that
hold the time: the eigen stage (one solve per mesh, no cache) on ``--per-class``
meshes of each ``watertight_dev`` class (10 is all 200), and the distance blocks of the
default's diagram parts (each kind's 1-Wasserstein distance at five times: one
parallel call of the blocks of all fifteen matrices, as the default's
``CombinedDistance`` makes it) on their diagrams and
``--copies - 1`` jittered copies of them (each point moved by up to 5% of its
persistence), so that the matrices hold enough pairs to share. Each worker runs one
task at a time, and both clusters show joblib 2 threads: joblib runs everything in
the calling process when a cluster has a single thread, so the 1-worker cluster has
two threads and one task slot (a worker resource), and both get the same tasks. The
2-worker cluster has one thread per worker and no resource: dask never steals a task
restricted to a resource. Beside
them, a local run on one core (the reference) and one on two loky workers. Every
output is checked to be bitwise identical to the reference's.

Reported: wall times and speed-ups (from the 1-worker cluster to the 2-worker one,
target 1.7); from dask's task stream, each stage's tasks, their compute seconds on the
workers (the work), the longest task (the least tail a schedule can leave), the
workers' busy share of the wall time (work / (workers x wall)), the tasks each worker
ran and the longest time a worker sat idle within the stage: measures of the schedule,
which hold on a busy machine where the wall times do not; the CPU seconds of the
calling process (its serial share: sending, receiving, assembling). For the distance
blocks, also the CPU seconds of each block measured inside it on its worker (its
thread's CPU time): their sum on 2 workers against 1 tells the blocks' own work
growing (caches, memory, a slower core) from their wall time growing while another
process holds their core. Then the cost of
shipping the meshes: their pickled bytes, and the seconds of one task per mesh that
only receives it, the mesh sent with its task or scattered first, against the same
tasks without a mesh.
With ``--rounds N`` the two clusters are measured N times, 1 then 2 workers and 2 then
1 in turn, and the speed-up of each round and their median are reported: the machine's
own speed drifts over minutes (a third from run to run on a shared host), and a pair
measured back to back shares the drift. The tables below the verdict are the last
round's.
Workers are started and warmed (imports, numba's kernels loaded from its cache) before
anything is timed; that start-up is reported apart. ``--distances-only`` times the
distance blocks alone (the reference's eigen stage read from or written to the eigen
cache ``--memory``).

``--schedule`` measures instead what the tasks allow, whatever the machine's load:
the CPU seconds of each task run one at a time in this process (each mesh's solve,
largest first as the eigen stage dispatches them; each block of pairs of each
parallel call, cut as for 2 workers), and the speed-up of joblib's schedule (tasks in
order, each to the first free worker) on 2 workers against 1.

Wall times need a quiet machine with at least 2 cores: the speed-ups are meaningless
while other jobs share the cores.
"""

from __future__ import annotations

import argparse
import json
import pickle
import time
from contextlib import ExitStack

import numpy as np
from _common import DATA
from joblib import parallel_backend
from sklearn.base import clone

from sklearn_meshph import load_mesh_folder, make_mesh_distance, make_shapes
from sklearn_meshph.diagrams.pairwise import fit_transform_plan, run_plans
from sklearn_meshph.mesh.reading import read_mesh_file

# Both clusters show joblib 2 threads (it runs in the caller when a cluster has 1),
# so both get the same tasks; each worker runs one task at a time (a resource "slot").
WORKERS = (1, 2)
TARGET = 1.7


def load(per_class):
    """The ``watertight_dev`` meshes, the first ``per_class`` of each class (all: None)."""
    bunch = load_mesh_folder(DATA / "watertight_dev", load=False)
    y = np.asarray(bunch.target)
    keep = [i for i in range(len(y)) if per_class is None or np.sum(y[:i] == y[i]) < per_class]
    return [read_mesh_file(bunch.filenames[i]) for i in keep]


def stages(n_jobs, memory=None):
    """The default's eigen stage (no cache unless ``memory``) and its diagram parts:
    ``(eigen, [(kind, persistence, distance), ...])``, every stage with ``n_jobs``."""
    pipeline = make_mesh_distance(n_jobs=n_jobs, memory=memory)
    eigen = pipeline.named_steps["eigen"]
    parts = []
    for kind, part in pipeline.named_steps["distance"].transformer_list:
        steps = dict(part.steps)
        if "persistence" in steps:
            parts.append((kind, steps["persistence"], steps["distance"]))
    return eigen, parts


def distance_matrices(parts, diagrams):
    """Each kind's distance matrix of its ``diagrams``, all kinds' blocks in one parallel
    call (what the default's ``CombinedDistance`` does after the persistence steps)."""
    plans = [fit_transform_plan(clone(distance), diagrams[kind]) for kind, _, distance in parts]
    return dict(zip([kind for kind, *_ in parts], run_plans(plans), strict=True))


def jittered(diagrams, copies, seed=0):
    """The samples, then ``copies - 1`` copies with each finite point moved by up to 5%
    of its persistence (births and deaths kept in order)."""
    rng = np.random.default_rng(seed)
    out = list(diagrams)
    for _ in range(copies - 1):
        for sample in diagrams:
            moved = []
            for diagram in sample:
                diagram = np.array(diagram, dtype=float)
                finite = np.isfinite(diagram).all(axis=1)
                span = diagram[finite, 1] - diagram[finite, 0]
                shift = rng.uniform(-0.05, 0.05, size=(finite.sum(), 2)) * span[:, None] / 2
                diagram[finite] = diagram[finite] + shift
                moved.append(diagram)
            out.append(tuple(moved))
    return out


def run_stages(meshes, diagrams, n_jobs, fields=None):
    """Wall times and outputs of the eigen stage (unless its ``fields`` are given) and of
    each kind's distance matrix."""
    eigen, parts = stages(n_jobs)
    times = {}
    if fields is None:
        start = time.perf_counter()
        fields = eigen.fit_transform(meshes)
        times["eigen"] = time.perf_counter() - start
    start = time.perf_counter()
    matrices = distance_matrices(parts, diagrams)
    times["distances"] = time.perf_counter() - start
    return times, fields, matrices


def check_identical(fields, matrices, reference, label):
    ref_fields, ref_matrices = reference
    for i, (a, b) in enumerate(zip(fields, ref_fields, strict=True)):
        for name in ("values", "vertices", "faces", "eigenvalues"):
            x, z = getattr(a, name), getattr(b, name)
            assert (x is None and z is None) or np.array_equal(x, z), (
                f"{label}: mesh {i}: {name} differ from the local run"
            )
    for kind, matrix in matrices.items():
        assert np.array_equal(matrix, ref_matrices[kind]), (
            f"{label}: the {kind} distances differ from the local run"
        )


def task_summary(records, start, stop, n_workers):
    """From dask's task stream, over a stage run from ``start`` to ``stop`` (epoch
    seconds): its tasks, their compute seconds on the workers (the work), the longest
    task, the workers' busy share of the wall time (work / (workers x wall)), the tasks
    each worker ran, and the longest time a worker sat idle within the stage (before
    its first task, between two, after its last). The busy share and the idle gaps
    depend on the schedule, not on how fast the tasks run: they hold under load."""
    spans = {}
    for record in records:
        for s in record["startstops"]:
            if s["action"] == "compute":
                spans.setdefault(record["worker"], []).append((s["start"], s["stop"]))
    computes = np.array([b - a for worker in spans.values() for a, b in worker] or [0.0])
    gaps = [stop - start] * (n_workers - len(spans))  # a worker that ran nothing
    for worker in spans.values():
        end = start
        for a, b in sorted(worker):
            gaps.append(a - end)
            end = max(end, b)
        gaps.append(stop - end)
    return {
        "tasks": len(records),
        "compute_s": float(computes.sum()),
        "largest_task_s": float(computes.max()),
        "median_task_s": float(np.median(computes)),
        "busy": float(computes.sum() / ((stop - start) * n_workers)),
        "tasks_per_worker": sorted((len(worker) for worker in spans.values()), reverse=True),
        "longest_idle_s": float(max(gaps)),
    }


def _warm():
    """Imports and numba's kernels of the whole default, on a worker."""
    meshes = make_shapes(n_per_class=1, classes=("blob", "snake"), random_state=0).data
    make_mesh_distance(n_jobs=1).fit_transform(list(meshes))


def _start_block_clock():
    """On a worker: from now on, record each distance block's CPU seconds (its thread's
    CPU time, measured inside the task), forgetting those recorded before."""
    import time

    import sklearn_meshph.diagrams.pairwise as pairwise

    if not hasattr(pairwise, "_block_clocks"):
        block, pairwise._block_clocks = pairwise._block, []

        def clocked(*args):
            start = time.thread_time()
            values = block(*args)
            pairwise._block_clocks.append(time.thread_time() - start)
            return values

        pairwise._block = clocked  # tasks name it: the workers unpickle this one
    pairwise._block_clocks.clear()


def _block_clocks():
    """On a worker: the CPU seconds of the blocks recorded by ``_start_block_clock``."""
    import sklearn_meshph.diagrams.pairwise as pairwise

    return list(pairwise._block_clocks)


def _received(item):
    return item is not None


def shipping(client, meshes):
    """Seconds to run one task per mesh that only receives it: the mesh sent with its
    task, or scattered to the workers first (the scatter timed with its tasks), against
    the same tasks without a mesh."""

    def timed(arguments):
        start = time.perf_counter()
        client.gather([client.submit(_received, a, pure=False) for a in arguments])
        return time.perf_counter() - start

    empty = timed([0] * len(meshes))
    with_tasks = timed(meshes)
    start = time.perf_counter()
    futures = client.scatter(meshes)
    scattered = time.perf_counter() - start + timed(futures)
    return {
        "empty_tasks_s": empty,
        "with_each_task_s": with_tasks,
        "scatter_then_tasks_s": scattered,
    }


def on_cluster(n_workers, meshes, diagrams, reference, measured):
    from distributed import Client, LocalCluster, get_task_stream

    with ExitStack() as stack:
        start = time.perf_counter()
        # One task slot per worker: a resource where a worker needs two threads
        # (joblib's count), none otherwise (a task restricted to one is never stolen).
        slot = {"slot": 1} if n_workers < max(WORKERS) else None
        cluster = stack.enter_context(
            LocalCluster(
                n_workers=n_workers,
                threads_per_worker=max(WORKERS) // n_workers,
                resources=slot,
                processes=True,
                dashboard_address=None,
            )
        )
        client = stack.enter_context(Client(cluster))
        client.wait_for_workers(n_workers)
        client.run(_warm)
        result = {"start_and_warm_s": time.perf_counter() - start}
        fields, matrices = reference[0], {}
        eigen, parts = stages(n_jobs=-1)

        with parallel_backend("dask", **({"resources": slot} if slot else {})):
            for stage in measured:
                with get_task_stream(client) as stream:
                    start, cpu = time.time(), time.process_time()
                    if stage == "eigen":
                        fields = eigen.fit_transform(meshes)
                    else:
                        client.run(_start_block_clock)
                        matrices = distance_matrices(parts, diagrams)
                    stop, cpu = time.time(), time.process_time() - cpu
                summary = task_summary(stream.data, start, stop, n_workers)
                result[stage] = {"wall_s": stop - start, "client_cpu_s": cpu, **summary}
                if stage == "distances":
                    clocks = [c for worker in client.run(_block_clocks).values() for c in worker]
                    result[stage]["block_cpu_s"] = float(sum(clocks))
        check_identical(fields, matrices, reference, f"{n_workers} dask worker(s)")
        if n_workers == max(WORKERS) and "eigen" in measured:
            result["shipping"] = shipping(client, meshes)
    return result


def _makespan(times, n_workers):
    """The end of tasks of these durations given in order, each to the first free worker."""
    free = np.zeros(n_workers)
    for duration in times:
        free[np.argmin(free)] += duration
    return free.max()


def schedule(meshes, copies):
    """CPU seconds per task, one at a time here, and the 2-worker speed-up they allow."""
    import sklearn_meshph.diagrams.pairwise as pairwise
    from sklearn_meshph.spectral.transformer import _size_hint

    eigen, parts = stages(n_jobs=1)
    order = sorted(range(len(meshes)), key=lambda i: -_size_hint(meshes[i]))
    fields, solves = [None] * len(meshes), []
    for i in order:
        start = time.process_time()
        fields[i] = eigen.fit_transform([meshes[i]])[0]
        solves.append(time.process_time() - start)
    calls, block, matrices = [], pairwise._block, pairwise.pair_matrices

    def timed_block(*args):
        start = time.process_time()
        values = block(*args)
        calls[-1].append(time.process_time() - start)
        return values

    def counted_matrices(*args, **kwargs):
        calls.append([])
        return matrices(*args, **kwargs)

    pairwise._block, pairwise.pair_matrices = timed_block, counted_matrices
    pairwise.effective_n_jobs = lambda n_jobs: max(WORKERS)  # the blocks of 2 workers
    diagrams = {kind: jittered(p.fit_transform(fields), copies) for kind, p, _ in parts}
    start = time.process_time()
    distance_matrices(parts, diagrams)
    total = time.process_time() - start
    work = sum(map(sum, calls))
    span = sum(_makespan(c, max(WORKERS)) for c in calls)
    print(
        f"eigen: {len(solves)} tasks, {sum(solves):.1f} CPU s, longest {max(solves):.2f} s; "
        f"2 workers: speed-up {sum(solves) / _makespan(solves, max(WORKERS)):.3f}"
    )
    print(
        f"distances: {len(calls)} parallel calls, {sum(map(len, calls))} tasks, "
        f"{work:.1f} CPU s in the blocks of {total:.1f} s, longest "
        f"{max(map(max, calls)):.2f} s; 2 workers: speed-up {work / span:.3f} "
        f"({total / (total - work + span):.3f} with the caller's own share)"
    )


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--per-class", type=int, default=5, help="meshes per class (of 10)")
    parser.add_argument("--copies", type=int, default=10, help="copies of each diagram sample")
    parser.add_argument("--json", default=None, help="write the results to this file")
    parser.add_argument("--schedule", action="store_true", help="CPU seconds per task only")
    parser.add_argument(
        "--distances-only",
        action="store_true",
        help="time the distance blocks only (the reference's eigen stage cached in --memory)",
    )
    parser.add_argument("--memory", default=None, help="eigen cache of --distances-only")
    parser.add_argument("--rounds", type=int, default=1, help="pairs of cluster runs")
    args = parser.parse_args()

    start = time.perf_counter()
    meshes = load(args.per_class)
    sizes = np.array([len(m.vertices) for m in meshes])
    nbytes = [len(pickle.dumps(m, protocol=5)) for m in meshes]
    print(
        f"{len(meshes)} meshes, {sizes.min()} to {sizes.max()} vertices "
        f"(median {int(np.median(sizes))}), {sum(nbytes) / 1e6:.1f} MB pickled; "
        f"loaded in {time.perf_counter() - start:.1f} s"
    )
    if args.schedule:
        return schedule(meshes, args.copies)

    # The reference: one core, in this process.
    measured = ("distances",) if args.distances_only else ("eigen", "distances")
    eigen, parts = stages(n_jobs=1, memory=args.memory if args.distances_only else None)
    start, cpu = time.perf_counter(), time.process_time()
    ref_fields = eigen.fit_transform(meshes)
    local = {"eigen": time.perf_counter() - start}
    eigen_cpu = time.process_time() - cpu
    diagrams = {
        kind: jittered(persistence.fit_transform(ref_fields), args.copies)
        for kind, persistence, _ in parts
    }
    start, cpu = time.perf_counter(), time.process_time()
    ref_matrices = distance_matrices(parts, diagrams)
    local["distances"] = time.perf_counter() - start
    distances_cpu = time.process_time() - cpu
    reference = (ref_fields, ref_matrices)
    n_samples = len(diagrams[parts[0][0]])
    print(
        f"local, 1 core: eigen {local['eigen']:.1f} s (CPU {eigen_cpu:.1f} s), "
        f"distances of {len(parts)} kinds x {n_samples} samples {local['distances']:.1f} s "
        f"(CPU {distances_cpu:.1f} s)"
    )

    with parallel_backend("loky", n_jobs=2):
        given = ref_fields if args.distances_only else None
        loky, fields, matrices = run_stages(meshes, diagrams, n_jobs=2, fields=given)
    check_identical(fields, matrices, reference, "loky")
    del fields, matrices

    rounds = []
    for k in range(args.rounds):
        order = WORKERS if k % 2 == 0 else WORKERS[::-1]
        done = {n: on_cluster(n, meshes, diagrams, reference, measured) for n in order}
        rounds.append({n: done[n] for n in WORKERS})
    results = rounds[-1]
    print("results bitwise identical to the local run: loky and every cluster")
    print()
    print("| run | " + " | ".join(f"{stage}, s | speed-up" for stage in measured) + " |")
    print("|---|" + "---:|---:|" * len(measured))
    base = results[1]
    print("| local, 1 core | " + " | ".join(f"{local[stage]:.1f} | " for stage in measured) + " |")
    print(
        "| loky, 2 workers | "
        + " | ".join(
            f"{loky[stage]:.1f} | {local[stage] / loky[stage]:.2f} (of local)" for stage in measured
        )
        + " |"
    )
    for n, r in results.items():
        cells = (
            f"{r[stage]['wall_s']:.1f} | {base[stage]['wall_s'] / r[stage]['wall_s']:.2f}"
            for stage in measured
        )
        print(f"| dask, {n} worker(s) | " + " | ".join(cells) + " |")
    print()
    for stage in measured:
        each = [r[1][stage]["wall_s"] / r[max(WORKERS)][stage]["wall_s"] for r in rounds]
        speedup = float(np.median(each))
        verdict = "met" if speedup >= TARGET else "NOT met"
        rounds_note = f" (median of rounds {', '.join(f'{x:.2f}' for x in each)})"
        print(
            f"{stage}: speed-up {speedup:.2f} from 1 to 2 workers"
            + (rounds_note if len(each) > 1 else "")
            + f", target {TARGET}: {verdict}"
        )
    print()
    print(
        "| cluster, stage | tasks | per worker | work, s | longest task, s | busy | "
        "longest idle, s | caller CPU, s |"
    )
    print("|---|---:|---|---:|---:|---:|---:|---:|")
    for n, r in results.items():
        for stage in measured:
            s = r[stage]
            print(
                f"| {n} worker(s), {stage} | {s['tasks']} | "
                f"{' + '.join(map(str, s['tasks_per_worker']))} | {s['compute_s']:.1f} | "
                f"{s['largest_task_s']:.2f} | {s['busy']:.0%} | {s['longest_idle_s']:.2f} | "
                f"{s['client_cpu_s']:.1f} |"
            )
    one, two = results[1]["distances"], results[max(WORKERS)]["distances"]
    print()
    print(
        f"distance blocks' work, 2 workers against 1: {two['compute_s']:.1f} / "
        f"{one['compute_s']:.1f} s of task time ({two['compute_s'] / one['compute_s']:.2f}), "
        f"{two['block_cpu_s']:.1f} / {one['block_cpu_s']:.1f} s of CPU measured inside "
        f"the blocks ({two['block_cpu_s'] / one['block_cpu_s']:.2f})"
    )
    if "shipping" in results[max(WORKERS)]:
        ship = results[max(WORKERS)]["shipping"]
        print()
        print(
            f"shipping {len(meshes)} meshes ({sum(nbytes) / 1e6:.1f} MB pickled) to 2 workers: "
            f"with each task {ship['with_each_task_s']:.2f} s, scattered first "
            f"{ship['scatter_then_tasks_s']:.2f} s, the same tasks without a mesh "
            f"{ship['empty_tasks_s']:.2f} s; workers started and warmed in "
            + ", ".join(f"{r['start_and_warm_s']:.1f} s ({n})" for n, r in results.items())
        )
    if args.json:
        with open(args.json, "w") as out:
            payload = {"local": local, "loky": loky, "meshes": len(meshes)}
            payload["mesh_bytes"] = sum(nbytes)
            payload["rounds"] = [{str(n): r for n, r in done.items()} for done in rounds]
            json.dump({**payload, "dask": {str(n): r for n, r in results.items()}}, out, indent=1)


if __name__ == "__main__":
    main()
