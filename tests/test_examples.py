"""The documentation's examples run (quickly, on synthetic data) and do what they say:
the numbers they print are in range and agree with what they computed, and the pictures
they write are there."""

import re
import runpy
from pathlib import Path

import numpy as np
import pytest

EXAMPLES = sorted((Path(__file__).resolve().parents[1] / "docs" / "examples").glob("*.py"))
PNG = b"\x89PNG\r\n\x1a\n"


def printed_numbers(out):
    return [float(x) for x in re.findall(r"(?<![\w.])\d+\.\d+", out)]


def assert_pictures(folder, *names):
    for name in names:
        data = (folder / name).read_bytes()
        assert data.startswith(PNG) and len(data) > 5000, f"{name} is not a picture"


def check_grid_search(namespace, out, folder):
    grid = namespace["grid"]
    scores = grid.cv_results_["mean_test_score"]
    assert grid.best_score_ == scores.max()
    assert grid.best_params_ == grid.cv_results_["params"][int(np.argmax(scores))]
    assert out.strip() == f"{grid.best_params_} {round(grid.best_score_, 2)}"
    assert 0.5 <= grid.best_score_ <= 1.0  # 6 classes: chance is 1/6


def check_pipeline(namespace, out, folder):
    default, paper = printed_numbers(out)
    assert out.startswith("eigenfunction pipeline: ") and "paper's literal configuration: " in out
    assert paper == round(namespace["scores"].mean(), 2)
    assert 0.8 <= default <= 1.0 and 0.0 <= paper <= 1.0


def check_tsne(namespace, out, folder):
    n = len(namespace["data"].data)
    assert out.strip() == f"({n}, {n}) ({n}, 2)"
    assert np.isfinite(namespace["points"]).all()
    assert_pictures(folder, "tsne_example.png", "diagram_example.png")


def check_vectorizations(namespace, out, folder):
    (accuracy,) = printed_numbers(out)
    assert accuracy == round(np.mean(namespace["scores"]), 2)
    assert 0.5 <= accuracy <= 1.0  # 6 classes: chance is 1/6
    assert_pictures(folder, "vectorization_image.png", "vectorization_landscapes.png")


CHECKS = {
    "grid_search_eigen_index.py": check_grid_search,
    "plot_pipeline.py": check_pipeline,
    "plot_tsne.py": check_tsne,
    "plot_vectorizations.py": check_vectorizations,
}


def test_every_example_is_checked():
    assert sorted(CHECKS) == [path.name for path in EXAMPLES]


@pytest.mark.parametrize("path", EXAMPLES, ids=[p.name for p in EXAMPLES])
def test_example_runs(path, tmp_path, monkeypatch, capsys):
    pytest.importorskip("matplotlib")
    monkeypatch.chdir(tmp_path)
    namespace = runpy.run_path(str(path), run_name="__main__")
    CHECKS[path.name](namespace, capsys.readouterr().out, tmp_path)
