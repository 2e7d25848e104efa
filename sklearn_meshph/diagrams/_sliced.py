"""Compiled sliced Wasserstein distance between diagrams (Carrière, Cuturi & Oudot 2017).

Along a line of angle ``theta``, a diagram ``D1`` is compared with ``D2`` through the
sorted projections of ``D1`` plus the diagonal projections of ``D2``, against those of
``D2`` plus the diagonal projections of ``D1``: the L1 distance of the two sorted
lists (the 1-Wasserstein distance on the line). Both lists merge two lists that depend
on one diagram only, so each diagram's projections and diagonal projections are
computed and sorted once (:func:`project`), and a pair costs one merge per line,
``O(n + m)``, instead of two sorts. Each sorted list ends with ``+inf``, so that the
merge needs no bounds tests and no branches.
"""

from __future__ import annotations

import numba
import numpy as np

__all__ = ["directions", "project", "sliced_pairs"]


def directions(n_directions: int) -> tuple[np.ndarray, np.ndarray]:
    """Cosines and sines of the ``n_directions`` angles of the lines, those of gudhi's
    ``num_directions = n_directions + 1``: the first ``n_directions`` of the
    ``n_directions + 1`` angles evenly spaced in ``[-pi/2, pi/2)``."""
    count = int(n_directions)
    thetas = np.linspace(-np.pi / 2, np.pi / 2, num=count + 1, endpoint=False)[:count]
    return np.cos(thetas), np.sin(thetas)


@numba.njit(cache=True)
def project(points, offsets, cos, sin):
    """Sorted projections of each diagram's points and of their diagonal projections.

    ``points[offsets[d]:offsets[d + 1]]`` is diagram ``d``. Returns two arrays of shape
    ``(len(cos), len(points) + n_diagrams)`` whose row ``t`` holds, in the columns
    ``slots[d]:slots[d + 1]`` of diagram ``d`` (``slots = offsets + arange``), the sorted
    ``b cos + d sin`` of its points, then ``+inf``; and likewise the sorted
    ``m cos + m sin`` of their diagonal projections ``(m, m)``, ``m = (b + d) / 2``.
    Returns also ``slots``.
    """
    n_lines, n_diagrams = len(cos), len(offsets) - 1
    slots = offsets + np.arange(n_diagrams + 1)
    projected = np.empty((n_lines, len(points) + n_diagrams))
    diagonal = np.empty((n_lines, len(points) + n_diagrams))
    for t in range(n_lines):
        c, s = cos[t], sin[t]
        for k in range(n_diagrams):
            start, stop = slots[k], slots[k + 1] - 1
            for i in range(offsets[k], offsets[k + 1]):
                b, d = points[i, 0], points[i, 1]
                m = 0.5 * b + 0.5 * d
                projected[t, start + i - offsets[k]] = b * c + d * s
                diagonal[t, start + i - offsets[k]] = m * c + m * s
            projected[t, start:stop] = np.sort(projected[t, start:stop])
            diagonal[t, start:stop] = np.sort(diagonal[t, start:stop])
            projected[t, stop] = np.inf
            diagonal[t, stop] = np.inf
    return projected, diagonal, slots


@numba.njit(cache=True, inline="always")
def _on_line(p1, q1, p2, q2, n):
    """L1 distance between sorted ``p1 + q2`` and sorted ``p2 + q1`` (``p``: a diagram's
    sorted projections, ``q``: its sorted diagonal projections, each ending with
    ``+inf``; ``n`` finite values in all), merging as it goes, without branches.

    Swapping the diagrams swaps the two merged lists: the same terms, the same sum."""
    i1, j1, i2, j2 = 0, 0, 0, 0
    total = 0.0
    for _ in range(n):
        x, y = p1[i1], q2[j2]
        first = x <= y
        i1 += first
        j2 += not first
        u, v = p2[i2], q1[j1]
        second = u <= v
        i2 += second
        j1 += not second
        total += abs(min(x, y) - min(u, v))
    return total


@numba.njit(cache=True)
def sliced_pairs(left, right, rows, cols, n_parts):
    """Sliced Wasserstein distances of the sample pairs ``(rows[k], cols[k])``.

    ``left`` and ``right`` are packed as ``(projected, diagonal, slots, births,
    birth_offsets)`` (diagram ``sample * n_parts + part``, see :func:`project`). Per
    diagram: the mean over the lines of the L1 distances, plus the L1 distance of the
    sorted essential births (``inf`` when their numbers differ); a sample's distance is
    the sum over its parts.
    """
    proj_a, diag_a, off_a, births_a, eoff_a = left
    proj_b, diag_b, off_b, births_b, eoff_b = right
    n_lines = proj_a.shape[0]
    out = np.empty(len(rows))
    for k in range(len(rows)):
        total = 0.0
        for part in range(n_parts):
            da = rows[k] * n_parts + part
            db = cols[k] * n_parts + part
            ea = births_a[eoff_a[da] : eoff_a[da + 1]]
            eb = births_b[eoff_b[db] : eoff_b[db + 1]]
            if len(ea) != len(eb):
                total = np.inf
                break
            a0, a1, b0, b1 = off_a[da], off_a[da + 1], off_b[db], off_b[db + 1]
            n = a1 - a0 + b1 - b0 - 2
            lines = 0.0
            for t in range(n_lines):
                lines += _on_line(
                    proj_a[t, a0:a1], diag_a[t, a0:a1], proj_b[t, b0:b1], diag_b[t, b0:b1], n
                )
            total += lines / n_lines
            for e in range(len(ea)):
                total += abs(ea[e] - eb[e])
        out[k] = total
    return out
