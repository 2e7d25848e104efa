"""The user guide and the API reference build without a warning, and the code blocks
of README.md and docs/*.md run as written."""

import contextlib
import json
import os
import re
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import DATA_DIR

DOCS = Path(__file__).resolve().parents[1] / "docs"


def test_sphinx_builds_the_docs_without_warnings(tmp_path):
    build = pytest.importorskip("sphinx.cmd.build")
    pytest.importorskip("numpydoc")
    pytest.importorskip("myst_parser")
    source = tmp_path / "docs"
    shutil.copytree(DOCS, source, ignore=shutil.ignore_patterns("_build", "generated"))
    status = build.build_main(
        ["-q", "-W", "--keep-going", "-b", "html", str(source), str(tmp_path / "html")]
    )
    assert status == 0
    assert (tmp_path / "html" / "generated" / "sklearn_meshph.DiagramDistance.html").exists()


def test_option_tables_are_generated_from_the_registries():
    """Each registry's table is in the docs, as `python docs/update_tables.py` writes it."""
    from sklearn_meshph._registry import update_tables
    from sklearn_meshph.pipelines import all_registries

    pages = {page: page.read_text() for page in DOCS.glob("*.md")}
    for page, text in pages.items():
        updated = update_tables(text, all_registries())
        assert updated == text, f"run python docs/update_tables.py ({page.name})"
    for family, registry in all_registries().items():
        assert any(registry.table() in text for text in pages.values()), family


def test_estimators_and_command_line_offer_exactly_the_registered_options():
    from sklearn_meshph import DiagramDistance, LaplacianEigenTransformer, LowerStarPersistence
    from sklearn_meshph.cli import build_parser
    from sklearn_meshph.pipelines import all_registries

    registries = all_registries()
    actions = {a.dest: a for a in build_parser()._actions}
    for estimator, family in [
        (LaplacianEigenTransformer, "laplacian"),
        (LaplacianEigenTransformer, "solver"),
        (LaplacianEigenTransformer, "signature"),
        (LowerStarPersistence, "filtration"),
        (DiagramDistance, "metric"),
    ]:
        names = registries[family].names
        (constraint,) = estimator._parameter_constraints[family]
        assert all(constraint(name) for name in names)
        assert not constraint("not-an-option")
        if family in actions:
            assert tuple(actions[family].choices) == names


# ---------------------------------------------------------------------------------------
# Every ```python block of README.md and docs/*.md runs as written, each in a fresh
# namespace and an empty folder of its own. A block right after the marker
# `<!-- skip-snippet: reason -->` is skipped with that reason (kept for blocks that need
# something no test has, such as a running dask scheduler).
# ---------------------------------------------------------------------------------------

ROOT = DOCS.parent
_BLOCK = re.compile(
    r"(?:<!-- skip-snippet: (?P<skip>[^\n]*?) -->\n)?^```python\n(?P<code>.*?)^```$",
    re.S | re.M,
)
SNIPPET_TIMEOUT = 300.0  # seconds per block, against deadlocks: each takes seconds


def _snippets():
    found = []
    for page in [ROOT / "README.md", *sorted(DOCS.glob("*.md"))]:
        text = page.read_text()
        for match in _BLOCK.finditer(text):
            line = text.count("\n", 0, match.start("code"))
            found.append((f"{page.relative_to(ROOT)}:{line}", match["code"], match["skip"]))
    return found


SNIPPETS = _snippets()


def _watertight_subset(folder):
    """The folder ``watertight_dev`` the snippets read: the 5 smallest meshes of each of
    its 2 classes of smallest such meshes (linked from the shared data), so that a
    snippet takes seconds, not a minute."""
    source = DATA_DIR / "watertight_dev"
    if not source.is_dir():
        pytest.skip(f"needs the Watertight data at {source} (set SKLEARN_MESHPH_DATA)")
    smallest = {
        label: sorted(label.iterdir(), key=lambda p: (p.stat().st_size, p.name))[:5]
        for label in source.iterdir()
        if label.is_dir()
    }
    for label in sorted(smallest, key=lambda c: sum(p.stat().st_size for p in smallest[c]))[:2]:
        (folder / "watertight_dev" / label.name).mkdir(parents=True)
        for path in smallest[label]:
            (folder / "watertight_dev" / label.name / path.name).symlink_to(path)


def _scans(folder):
    """The folder ``scans`` of the point-cloud guide: 2 classes of 3 `.xyz` clouds."""
    from sklearn_meshph import make_shapes, sample_point_cloud

    meshes, y = make_shapes(
        n_per_class=3, classes=("blob", "snake"), random_state=0, return_X_y=True
    )
    for i, (mesh, label) in enumerate(zip(meshes, y, strict=True)):
        (folder / "scans" / str(label)).mkdir(parents=True, exist_ok=True)
        cloud = sample_point_cloud(mesh, 1500, random_state=i)
        np.savetxt(folder / "scans" / str(label) / f"{i}.xyz", cloud)


# folder name a snippet reads (as a string literal) -> what puts it in the snippet's folder
_FOLDERS = {"watertight_dev": _watertight_subset, "scans": _scans}

# Runs the snippets in one interpreter (one import of the package), each in its own
# folder; a snippet that has not ended after the timeout is killed with a traceback.
_SNIPPET_RUNNER = """
import faulthandler, json, os, sys, traceback
import sklearn_meshph
timeout = float(sys.argv[2])
for name, code, folder in json.loads(sys.argv[1]):
    os.chdir(folder)
    print(json.dumps({"name": name, "started": True}), flush=True)
    faulthandler.dump_traceback_later(timeout, exit=True)
    try:
        exec(compile(code, name, "exec"), {"__name__": "__main__"})
        error = None
    except BaseException:
        error = traceback.format_exc()
    faulthandler.cancel_dump_traceback_later()
    print(json.dumps({"name": name, "error": error}), flush=True)
"""


def _run_snippets(jobs, folder):
    """``{name: error or None}`` for ``jobs`` (name, code, folder); after a snippet that
    killed the interpreter (timeout, crash), the others run in a new one. The runner
    writes to a file and runs in a session of its own, killed as a whole at the end:
    worker processes a snippet left behind can neither block nor outlive the test."""
    errors = {}
    while jobs:
        out, err = folder / "stdout", folder / "stderr"
        with out.open("w") as stdout, err.open("w") as stderr:
            runner = subprocess.Popen(
                [sys.executable, "-c", _SNIPPET_RUNNER, json.dumps(jobs), str(SNIPPET_TIMEOUT)],
                stdout=stdout,
                stderr=stderr,
                start_new_session=True,
            )
            try:
                runner.wait(timeout=SNIPPET_TIMEOUT * len(jobs) + 60)
            except subprocess.TimeoutExpired:
                pass
            finally:
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(runner.pid, signal.SIGKILL)
                runner.wait()
        started = None
        for line in out.read_text().splitlines():
            if line.startswith('{"name"'):
                record = json.loads(line)
                if record.get("started"):
                    started = record["name"]
                else:
                    errors[record["name"]], started = record["error"], None
        if started is not None:
            errors[started] = (
                f"the interpreter died (exit {runner.returncode}; a timeout after "
                f"{SNIPPET_TIMEOUT:g} s prints the traceback):\n{err.read_text()[-3000:]}"
            )
        jobs = [job for job in jobs if job[0] not in errors]
        if started is None and jobs:  # died before reporting any of them
            errors.update({job[0]: err.read_text()[-3000:] or "not run" for job in jobs})
            break
    return errors


@pytest.fixture(scope="module")
def snippet_errors(tmp_path_factory):
    """``{name: (error or None, skip reason or None)}`` for every snippet."""
    jobs, skipped = [], {}
    for name, code, marker in SNIPPETS:
        if marker:
            skipped[name] = f"marked not runnable: {marker}"
            continue
        folder = tmp_path_factory.mktemp("snippet")
        try:
            for needed, make in _FOLDERS.items():
                if f'"{needed}"' in code:
                    make(folder)
        except pytest.skip.Exception as reason:
            skipped[name] = str(reason)
            continue
        jobs.append((name, code, str(folder)))
    return _run_snippets(jobs, tmp_path_factory.mktemp("runner")), skipped


def test_the_pages_have_snippets():
    assert len(SNIPPETS) >= 10
    assert sum(marker is not None for _, _, marker in SNIPPETS) <= 3  # markers stay rare


@pytest.mark.parametrize("name", [name for name, _, _ in SNIPPETS])
def test_doc_snippet_runs(snippet_errors, name):
    errors, skipped = snippet_errors
    if name in skipped:
        pytest.skip(skipped[name])
    if errors[name] is not None:
        pytest.fail(f"{name} failed:\n{errors[name]}", pytrace=False)
