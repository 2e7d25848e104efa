"""Ctrl-C while the package is imported for the main job: one line, not a traceback.

``python -m sklearn_meshph`` and the ``sklearn-meshph`` script import the whole package
(NumPy, SciPy, scikit-learn, numba: 2 to 4 s) before :func:`sklearn_meshph.cli.main`
can catch anything. Imported first by the package, this module installs a
``sys.excepthook`` that reports an uncaught ``KeyboardInterrupt`` as ``interrupted``,
only when the package is being run as the main job (``sys.argv[0]`` is ``-m`` while
``python -m`` locates the package, or the script's name); Python still ends the
process as interrupted (status 130 from a shell). A library import changes nothing.
"""

from __future__ import annotations

import os
import sys

__all__ = ["SCRIPT"]

#: The console script of the main job (``pyproject.toml``).
SCRIPT = "sklearn-meshph"


def _quiet(kind, value, traceback, _default=sys.excepthook):
    if issubclass(kind, KeyboardInterrupt):
        try:
            print("interrupted", file=sys.stderr, flush=True)
        except (OSError, ValueError, AttributeError):  # no stderr, or a closed one
            pass
        return
    _default(kind, value, traceback)


def _run_as_main_job() -> bool:
    first = sys.argv[0] if sys.argv else ""
    return first == "-m" or os.path.basename(first) in (SCRIPT, f"{SCRIPT}.exe")


if _run_as_main_job() and sys.excepthook is sys.__excepthook__:
    sys.excepthook = _quiet
