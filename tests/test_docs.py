"""The user guide and the API reference build without a warning."""

import shutil
from pathlib import Path

import pytest

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
