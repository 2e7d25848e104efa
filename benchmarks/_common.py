"""Helpers shared by the benchmark scripts."""

import time

import numpy as np


def median_time(repeats, func, *args, **kwargs):
    """Median wall time of ``repeats`` calls of ``func(*args, **kwargs)``."""
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        func(*args, **kwargs)
        times.append(time.perf_counter() - start)
    return float(np.median(times))


def _status_mb(field):
    with open("/proc/self/status") as status:
        for line in status:
            if line.startswith(field):
                return int(line.split()[1]) / 1024
    return float("nan")


def peak_memory(func, *args):
    """Peak resident-set growth (MB) while ``func`` runs (Linux: resets VmHWM first)."""
    try:
        with open("/proc/self/clear_refs", "w") as refs:
            refs.write("5")
    except OSError:
        return float("nan")
    before = _status_mb("VmRSS")
    func(*args)
    return _status_mb("VmHWM") - before
