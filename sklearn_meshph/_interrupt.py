"""Ctrl-C while the package is imported for the main job: one line, not a traceback.

``python -m sklearn_meshph`` and the ``sklearn-meshph`` script import the whole package
(NumPy, SciPy, scikit-learn, numba: 2 to 4 s) before :func:`sklearn_meshph.cli.main`
can catch anything. Imported first by the package, this module installs a
``sys.excepthook`` that reports an uncaught ``KeyboardInterrupt`` as ``interrupted``,
only when the package is being run as the main job (``python -m sklearn_meshph``, as
the interpreter's own command line says, or the script's name); Python still ends the
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
    """Whether the command line runs this package: ``-m sklearn_meshph`` (not another
    module run with ``-m`` that imports it), or the script."""
    first = sys.argv[0] if sys.argv else ""
    if first == "-m":
        return _module_run(list(getattr(sys, "orig_argv", []))[1:]) == __package__
    return os.path.basename(first) in (SCRIPT, f"{SCRIPT}.exe")


def _module_run(options: list) -> str | None:
    """The module of the interpreter's ``-m`` among its ``options``: ``-m name``,
    ``-Im name``, ``-mname``... (letters before ``m`` are flags; ``-W``, ``-X`` and
    ``-c`` take an argument, glued or next, and ``-c`` or a script ends the options)."""
    position = 0
    while position < len(options):
        option = options[position]
        if option == "--" or not option.startswith("-") or option.startswith("--"):
            return None  # the end of the options, a script, or a long option
        for k, letter in enumerate(option[1:], start=1):
            if letter in "mcWX":
                rest = option[k + 1 :]
                if not rest:
                    position += 1
                    rest = options[position] if position < len(options) else ""
                if letter == "m":
                    return rest
                if letter == "c":
                    return None
                break
        position += 1
    return None


if _run_as_main_job() and sys.excepthook is sys.__excepthook__:
    sys.excepthook = _quiet
