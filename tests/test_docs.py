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
