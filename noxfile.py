"""Test the suite against the oldest and the newest dependencies the package accepts.

    nox -s oldest   # every runtime dependency pinned (==) to its declared lower bound
    nox -s latest   # whatever pip resolves today

The pins of ``oldest`` are read from the ``>=`` bounds of ``[project] dependencies`` in
pyproject.toml, the one source of truth: raising a bound there raises the pin. Only the
runtime dependencies are pinned; the ``test`` extra resolves to whatever works with them.
Extra arguments go to pytest: ``nox -s oldest -- tests/test_eigen.py``.
"""

from __future__ import annotations

from pathlib import Path

import nox
import tomllib
from packaging.requirements import Requirement

PYTHON = "3.11"
PYTEST = ("pytest", "-q", "-p", "no:cacheprovider")


def lower_bounds() -> list[str]:
    """``name==version`` for the ``>=`` bound of every runtime dependency."""
    project = tomllib.loads(Path("pyproject.toml").read_text())["project"]
    pins = []
    for line in project["dependencies"]:
        req = Requirement(line)
        bounds = [spec.version for spec in req.specifier if spec.operator == ">="]
        if len(bounds) != 1:
            raise ValueError(f"{line!r}: expected exactly one '>=' lower bound")
        pins.append(f"{req.name}=={bounds[0]}")
    return pins


def run_tests(session: nox.Session, *install_args: str) -> None:
    session.install(*install_args, "-e", ".[test]")
    session.run("python", "-m", "pip", "list", silent=False)
    # numba's on-disk cache lives beside the sources by default: keep this
    # environment's (maybe another numba version) out of the shared tree.
    env = {"NUMBA_CACHE_DIR": session.create_tmp() + "/numba-cache"}
    session.run(*PYTEST, *session.posargs, env=env)


@nox.session(python=PYTHON)
def oldest(session: nox.Session) -> None:
    """The suite with the declared lower bounds of the runtime dependencies."""
    constraints = Path(session.create_tmp()) / "oldest-constraints.txt"
    constraints.write_text("\n".join(lower_bounds()) + "\n")
    session.log("pins: " + ", ".join(lower_bounds()))
    run_tests(session, "-c", str(constraints))


@nox.session(python=PYTHON)
def latest(session: nox.Session) -> None:
    """The suite with the newest release of everything."""
    run_tests(session, "--upgrade")
