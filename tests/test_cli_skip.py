"""The main job's ``--skip-unreadable``: files that cannot be read, and samples the
eigen stage refuses, are left out and listed; the rest is what it would be alone."""

import json
import warnings

import numpy as np
import pytest
import trimesh

from sklearn_meshph import LaplacianEigenTransformer
from sklearn_meshph.cli import main
from sklearn_meshph.spectral.transformer import ConstantEigenfunctionWarning

FAST = ["--no-plots", "--verbose", "0", "--n-jobs", "1", "--folds", "2"]
NAN_MESH = "OFF\n4 2 0\n0 0 0\n1 0 0\nnan 1 0\n0 0 1\n3 0 1 2\n3 0 2 3\n"
FLAT_MESH = "OFF\n4 2 0\n0 0 0\n1 0 0\n2 0 0\n3 0 0\n3 0 1 2\n3 1 2 3\n"


def _jittered(seed):
    """An icosphere moved off its symmetries (no repeated eigenvalues)."""
    mesh = trimesh.creation.icosphere(2)
    rng = np.random.default_rng(seed)
    mesh.vertices = mesh.vertices * [1.0, 0.8, 0.6] + rng.normal(0, 0.01, mesh.vertices.shape)
    return mesh


def _folder(root, per_class=3):
    for c, name in enumerate(("round", "long")):
        folder = root / name
        folder.mkdir(parents=True)
        for k in range(per_class):
            mesh = _jittered(10 * c + k)
            mesh.vertices = mesh.vertices * [1.0 + c, 1.0, 1.0]
            mesh.export(folder / f"m{k}.ply")
    return root


def _summary(out):
    return json.loads((out / "summary.json").read_text())


def test_samples_the_eigen_stage_refuses_are_left_out_and_listed(tmp_path, capsys):
    data = _folder(tmp_path / "data")
    clean = tmp_path / "clean"
    assert main([str(data), *FAST, "--output", str(clean)]) == 0
    capsys.readouterr()
    (data / "round" / "nan.off").write_text(NAN_MESH)
    (data / "long" / "flat.off").write_text(FLAT_MESH)
    out = tmp_path / "out"
    assert main([str(data), *FAST, "--skip-unreadable", "--output", str(out)]) == 0
    stdout = capsys.readouterr().out
    assert "left out 2 sample(s) that cannot be used:" in stdout
    assert "(long/flat.off): every face is degenerate" in stdout
    assert "(round/nan.off): vertex 2 has a non-finite coordinate" in stdout
    summary = _summary(out)
    assert sorted(s["file"] for s in summary["skipped"]) == ["long/flat.off", "round/nan.off"]
    assert summary["n_samples"] == 6 and summary["class_counts"] == [3, 3]
    # The other samples, numbered anew, give exactly the run without the bad files.
    np.testing.assert_array_equal(np.load(out / "distances.npy"), np.load(clean / "distances.npy"))
    assert (out / "predictions.csv").read_text() == (clean / "predictions.csv").read_text()


def test_without_the_option_a_refused_sample_stops_the_job_naming_its_file(tmp_path, capfd):
    data = _folder(tmp_path / "data")
    (data / "long" / "flat.off").write_text(FLAT_MESH)
    assert main([str(data), *FAST, "--output", str(tmp_path / "out")]) == 1
    err = capfd.readouterr().err
    assert "long/flat.off" in err and "every face is degenerate" in err


def test_a_class_emptied_by_leaving_out_is_a_usage_error(tmp_path, capfd):
    data = _folder(tmp_path / "data", per_class=2)
    for k in range(2):
        (data / "long" / f"m{k}.ply").unlink()
        (data / "long" / f"flat{k}.off").write_text(FLAT_MESH)
    code = main([str(data), *FAST, "--skip-unreadable", "--output", str(tmp_path / "out")])
    assert code == 2
    assert "the data holds one class ('round')" in capfd.readouterr().err


def test_skipping_transform_returns_the_same_fields_and_the_refusals():
    good = [_jittered(0), _jittered(1)]
    flat = (np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0.0]]), np.array([[0, 1, 2]]))
    line = np.column_stack([np.linspace(0, 1, 50), np.zeros(50), np.zeros(50)])
    eigen = LaplacianEigenTransformer(n_jobs=2).fit(good)
    expected = eigen.transform(good)
    fields, errors = eigen._transform([flat, good[0], line, good[1]], skip=True)
    assert fields[0] is None and fields[2] is None
    assert [i for i, _ in errors] == [0, 2]
    assert errors[0][1].startswith("sample 0: ") and errors[1][1].startswith("sample 2: ")
    for found, field in zip((fields[1], fields[3]), expected, strict=True):
        np.testing.assert_array_equal(found.values, field.values)
    with pytest.raises(ValueError, match="sample 0"):
        eigen.transform([flat, good[0]])


def test_the_constant_eigenfunction_warning_points_at_the_caller():
    eigen = LaplacianEigenTransformer(eigen_index=(0, 1))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        eigen.transform([_jittered(0)])
    [warning] = [w for w in caught if w.category is ConstantEigenfunctionWarning]
    assert warning.filename == __file__
