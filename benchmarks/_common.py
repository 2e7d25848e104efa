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
