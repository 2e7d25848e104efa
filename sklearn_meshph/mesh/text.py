"""Bounds on text read from files: the first line longer than a limit, found by NumPy a
block at a time (no Python object per line, no copy of the text)."""

from __future__ import annotations

import numpy as np

__all__ = ["long_line_offset"]

# Bytes looked at a time (8 bytes per line end in them, for the line ends' positions).
_SCAN = 8 << 20


def long_line_offset(content: bytes, limit: int, start: int = 0) -> int | None:
    """The byte offset of the first line of ``content[start:]`` longer than ``limit``
    bytes, or None. A line ends at ``\\n`` or ``\\r`` (``\\r\\n`` is an empty line more,
    which is never long); its length does not count its end."""
    data = np.frombuffer(content, np.uint8)
    line_start = start
    for first in range(start, len(data), _SCAN):
        chunk = data[first : first + _SCAN]
        ends = np.flatnonzero((chunk == 10) | (chunk == 13)) + first
        if len(ends):
            starts = np.r_[line_start, ends[:-1] + 1]
            long = np.flatnonzero(ends - starts > limit)
            if len(long):
                return int(starts[long[0]])
            line_start = int(ends[-1]) + 1
        if first + len(chunk) - line_start > limit:
            return line_start
    return None
