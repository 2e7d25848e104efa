"""What the main job says: its two kinds of error, one line each, the names of the samples
in messages, and the notes about warnings and the first run."""

from __future__ import annotations

import glob
import os
import re
import sys
import unicodedata
from pathlib import Path

__all__ = [
    "DataError",
    "Names",
    "UsageError",
    "first_run_note",
    "note",
    "one_line",
    "sample_indices",
]


class UsageError(Exception):
    """A problem with the options or the folder: one line, exit status 2."""


class DataError(Exception):
    """A sample that cannot be processed: one line naming its file, exit status 1."""


#: What is escaped in a printed name: control characters (line breaks, terminal escape
#: sequences), line and paragraph separators, lone surrogates. Not spaces such as a
#: full-width one, nor joiners and direction marks, which names in many scripts hold.
_UNPRINTED = frozenset(("Cc", "Zl", "Zp", "Cs"))


def printable(name) -> str:
    """``name`` with its control characters (a file named with a line break or a terminal
    escape) escaped as Python writes them, so that what names it stays on its line."""
    return "".join(repr(c)[1:-1] if unicodedata.category(c) in _UNPRINTED else c for c in str(name))


def one_line(text) -> str:
    """``text`` with every run of white space (line breaks too) made one space."""
    return " ".join(str(text).split())


class Names:
    """Maps ``sample K`` in messages to the sample's file, for data from a folder."""

    def __init__(self, filenames=None, root=None):
        self.files = None
        if filenames is not None:
            root = Path(root)
            self.files = []
            for f in filenames:
                try:
                    self.files.append(Path(f).relative_to(root).as_posix())
                except ValueError:
                    self.files.append(str(f))

    def subset(self, kept) -> Names:
        """The names of the samples ``kept`` (their indices), numbered anew."""
        subset = Names()
        subset.files = None if self.files is None else [self.files[i] for i in kept]
        return subset

    def name(self, index: int) -> str:
        if self.files is None or not 0 <= index < len(self.files):
            return f"sample {index}"
        return f"sample {index} ({printable(self.files[index])})"

    def message(self, text) -> str:
        """``text`` on one line, with each ``sample K`` naming its file."""
        text = one_line(text)
        if self.files is None:
            return text
        return re.sub(r"\bsample (\d+)\b", lambda m: self.name(int(m.group(1))), text)


def sample_indices(caught, category) -> list[int]:
    """Distinct samples named by the caught warnings of ``category`` (-1: unnamed)."""
    found = set()
    for w in caught:
        if issubclass(w.category, category):
            match = re.search(r"\bsample (\d+)\b", str(w.message))
            found.add(int(match.group(1)) if match else -1)
    return sorted(found)


def note(indices, what: str, names: Names, shown: int = 5) -> int:
    """Print one note line for a kind of warning, and the first ``shown`` samples it
    names; returns the number of distinct samples."""
    if not indices:
        return 0
    known = [i for i in indices if i >= 0]
    print(f"  note: {len(indices)} sample(s) {what}" + (":" if known else ""))
    for i in known[:shown]:
        print(f"    {names.name(i)}")
    if len(known) > shown:
        print(f"    ... and {len(known) - shown} more")
    return len(indices)


def _kernels_cached() -> bool:
    """Whether numba's cache already holds compiled kernels of this package (in the
    package's ``__pycache__`` folders, or in ``NUMBA_CACHE_DIR`` when it is set)."""
    root = os.environ.get("NUMBA_CACHE_DIR") or os.path.dirname(os.path.abspath(__file__))
    return any(glob.iglob(os.path.join(root, "**", "*.nbi"), recursive=True))


def first_run_note() -> None:
    """Say, on the first run only, that the compiled kernels are being built."""
    if not _kernels_cached():
        print(
            "note: first run: compiling the numba kernels once, which takes a while; "
            "later runs load them from the cache",
            file=sys.stdout,
        )
