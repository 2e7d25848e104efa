"""Re-measure, in one run, every user-facing timing that README.md and docs/ quote.

    python benchmarks/doc_timings.py [--tests] [--data ../shared/data]

From a fresh local clone of this checkout's HEAD (pip's download cache as it is):

1. the README's first command (venv, install, the main job on the built-in shapes),
   then the main job again (numba's kernels now cached);
2. with ``--tests``, the README's second command (test extras, the whole suite), then
   the suite again;
3. the main job on ``watertight_dev`` (200 ``.off.gz`` meshes) with an empty eigen
   cache, then again with it warm, and the default preset's time per stage and per mesh
   from the job's ``summary.json``.

The machine (cores, processor, memory, Python) is printed first: every page quotes the
figures of one run of this script, so per-mesh costs agree across pages.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shlex
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def machine() -> str:
    model = "unknown processor"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
        mem = next(
            int(line.split()[1]) / 2**20
            for line in Path("/proc/meminfo").read_text().splitlines()
            if line.startswith("MemTotal")
        )
    except (OSError, StopIteration):
        mem = float("nan")
    return (
        f"{os.cpu_count()} cores ({model}), {mem:.0f} GiB, Python {platform.python_version()}, "
        f"{time.strftime('%Y-%m-%d')}"
    )


def timed(command: str, cwd: Path, env=None) -> float:
    """Wall time of a shell command; its output goes to a log beside the clone."""
    start = time.perf_counter()
    with open(cwd / "doc_timings.log", "a") as log:
        log.write(f"\n$ {command}\n")
        log.flush()
        done = subprocess.run(command, shell=True, cwd=cwd, stdout=log, stderr=log, env=env)
    if done.returncode:
        tail = (cwd / "doc_timings.log").read_text().splitlines()[-40:]
        sys.exit(f"{command!r} failed ({done.returncode}); the end of its log:\n" + "\n".join(tail))
    return time.perf_counter() - start


def readme_commands() -> tuple[str, str]:
    lines = [
        line.strip()
        for line in (REPO / "README.md").read_text().splitlines()
        if line.startswith("python3 -m venv")
    ]
    return lines[0], lines[1]


def split_install(command: str) -> tuple[str, str]:
    """``install && run`` of a README command: its install part and what it runs."""
    parts = command.split(" && ")
    return " && ".join(parts[:-1]), parts[-1]


def job_timings(output: Path) -> dict:
    return json.loads((output / "summary.json").read_text())["timings"]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tests", action="store_true", help="also time the test command")
    parser.add_argument("--data", default=os.environ.get("SKLEARN_MESHPH_DATA", "../shared/data"))
    args = parser.parse_args()
    data = Path(args.data).resolve()
    rows = []
    print(f"machine: {machine()}")
    with tempfile.TemporaryDirectory(prefix="meshph-timings-") as tmp:
        clone = Path(tmp) / "clone"
        subprocess.run(["git", "clone", "--quiet", str(REPO), str(clone)], check=True)
        first, second = readme_commands()
        install, job = split_install(first)
        t_install = timed(install, clone)
        t_job = timed(job, clone)
        first_run = job_timings(clone / "meshph-output")
        t_again = timed(job, clone)
        rows.append(
            (
                "first command (install + main job)",
                f"{t_install + t_job:.0f} s, of which the job {t_job:.0f} s",
                f"job {t_again:.1f} s",
            )
        )
        if args.tests:
            install, tests = split_install(second)
            t_install = timed(install, clone)
            t_tests = timed(tests, clone)
            t_again = timed(tests, clone)
            rows.append(
                (
                    "second command (install + test suite)",
                    f"{t_install + t_tests:.0f} s, of which the tests {t_tests:.0f} s",
                    f"tests {t_again:.0f} s",
                )
            )
        folder = data / "watertight_dev"
        if folder.is_dir():
            cache, output = Path(tmp) / "eigen-cache", Path(tmp) / "watertight-output"
            command = (
                f".venv/bin/python -m sklearn_meshph {shlex.quote(str(folder))} "
                f"--memory {shlex.quote(str(cache))} --output {shlex.quote(str(output))}"
            )
            t_cold = timed(command, clone)
            cold = job_timings(output)
            accuracy = json.loads((output / "summary.json").read_text())["accuracy"]
            t_warm = timed(command, clone)
            rows.append(
                (
                    "`python -m sklearn_meshph ../shared/data/watertight_dev --memory DIR` "
                    "(200 `.off.gz` meshes, 20 classes)",
                    f"{t_cold:.0f} s (empty eigen cache)",
                    f"{t_warm:.0f} s (warm eigen cache)",
                )
            )
            print(
                f"\nwatertight_dev: 5-fold accuracy {accuracy['mean']:.3f} "
                f"(+/- {accuracy['std']:.3f})"
            )
            print("watertight_dev, empty eigen cache: seconds per stage (and per mesh)")
            for stage, seconds in cold.items():
                print(f"  {stage:<20}{seconds:8.2f}  ({1000 * seconds / 200:6.0f} ms / mesh)")
        else:
            print(f"{folder} not found: the Watertight rows are skipped", file=sys.stderr)
    print("\nbuilt-in shapes, first run (numba compiles): seconds per stage")
    for stage, seconds in first_run.items():
        print(f"  {stage:<20}{seconds:8.2f}")
    print("\n| command | first run | later runs |\n|---|---|---|")
    for row in rows:
        print("| " + " | ".join(row) + " |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
