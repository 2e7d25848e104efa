"""The code layout the architecture map promises: layers, private names, module sizes.

Every import between the package's modules is read from the source (no import is run)
and checked against the layer order of ``docs/architecture.md``: a module may import
from its own layer or a lower one, never from a higher one, and never a private name
(``_name``) or a private module of another sub-package.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1] / "sklearn_meshph"

# Low to high. A module belongs to the first entry naming its sub-package or its
# top-level module; the package's own __init__ re-exports everything and is exempt.
LAYERS = (
    ("_param_validation", "_registry", "_threads", "_progress", "_base", "_version"),
    ("_feature_distances", "_interrupt"),
    ("mesh",),
    ("pointcloud",),
    ("graph",),
    ("inputs",),
    ("spectral",),
    ("persistence",),
    ("diagrams",),
    ("vectorization",),
    ("combine", "leaf_forest", "size_switch"),
    ("graph_classifier",),
    ("shapes",),
    ("pipelines", "datasets", "plotting", "retrieval"),
    ("_report", "_cli_args", "_cli_messages", "cli", "__main__"),
)
MAX_LINES = 600


def _rank(unit: str) -> int:
    for rank, names in enumerate(LAYERS):
        if unit in names:
            return rank
    raise AssertionError(f"{unit!r} is in no layer of tests/test_layout.py: add it")


def _modules():
    for path in sorted(ROOT.rglob("*.py")):
        parts = path.relative_to(ROOT).with_suffix("").parts
        if parts != ("__init__",):
            yield path, parts


def _imports(path: Path, parts: tuple[str, ...]):
    """``(line, target parts, imported names)`` of every import of the package's own
    modules in ``path``."""
    package = list(parts[:-1])
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[: len(package) - node.level + 1]
                module = node.module.split(".") if node.module else []
            elif node.module and node.module.split(".")[0] == "sklearn_meshph":
                base, module = [], node.module.split(".")[1:]
            else:
                continue
            names = [alias.name for alias in node.names]
            target = base + module
            if not target:  # from .. import x: a top-level module, or a name of __init__
                for name in names:
                    module = (ROOT / f"{name}.py").exists() or (ROOT / name).is_dir()
                    yield node.lineno, [name] if module else ["__init__"], []
            else:
                yield node.lineno, target, names
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.split(".")[0] == "sklearn_meshph":
                    yield node.lineno, alias.name.split(".")[1:] or ["__init__"], []


def _violations():
    found = []
    for path, parts in _modules():
        unit = parts[0]
        for line, target, names in _imports(path, parts):
            where = f"{'/'.join(parts)}.py:{line} imports {'.'.join(target)}"
            if target[0] == "__init__":
                found.append(f"{where}: the package's __init__, which imports everything")
                continue
            if _rank(target[0]) > _rank(unit):
                found.append(f"{where}: a higher layer")
            if target[0] != unit:
                private_modules = [p for p in target[1:] if p.startswith("_") and p != "__init__"]
                private_names = [n for n in names if n.startswith("_")]
                if private_modules or private_names:
                    found.append(
                        f"{where}: private {', '.join(private_modules + private_names)} of "
                        "another sub-package"
                    )
    return found


def test_no_import_from_a_higher_layer_or_of_another_package_private_name():
    found = _violations()
    assert not found, "\n".join(found)


def test_the_checker_sees_violations(tmp_path, monkeypatch):
    """The check is not vacuous: planted higher-layer and private imports are found."""
    fake = tmp_path / "sklearn_meshph"
    (fake / "mesh").mkdir(parents=True)
    (fake / "mesh" / "bad.py").write_text(
        "from ..pipelines import make_mesh_distance\nfrom ..spectral.solve import _x\n"
    )
    monkeypatch.setitem(globals(), "ROOT", fake)
    found = _violations()
    assert any("a higher layer" in f for f in found)
    assert any("private _x" in f for f in found)


@pytest.mark.parametrize("path", [p for p, _ in _modules()], ids=lambda p: p.name)
def test_modules_stay_small(path):
    lines = len(path.read_text().splitlines())
    assert lines <= MAX_LINES, f"{path.relative_to(ROOT)} has {lines} lines: split it by concept"
