"""The main job's ``--skip-unreadable``: files that cannot be read, and samples the
eigen stage refuses, are left out and listed; the rest is what it would be alone."""

import json
import os
import shutil
import subprocess
import sys
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
    # By file, not by a number (the samples are numbered anew without them).
    assert "  long/flat.off: every face is degenerate" in stdout
    assert "  round/nan.off: vertex 2 has a non-finite coordinate" in stdout
    listed = stdout.split("cannot be used:\n")[1].split("\n")[:2]
    assert all(line.startswith("  ") and "sample" not in line for line in listed)
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


def _lossy():
    """A big triangle and 10 small ones far away: cleaned (with a warning) to three
    vertices, too few for eigenfunction 3."""
    small = [[10 + 3 * k, 0, 0] for k in range(10)]
    vertices = [[0, 0, 0], [1, 0, 0], [0, 1, 0]]
    faces = [[0, 1, 2]]
    for x, y, z in small:
        faces.append([len(vertices), len(vertices) + 1, len(vertices) + 2])
        vertices += [[x, y, z], [x + 0.01, y, z], [x, y + 0.01, z]]
    return trimesh.Trimesh(vertices, faces, process=False)


def test_a_sample_left_out_counts_in_no_warning(tmp_path, capsys):
    data = _folder(tmp_path / "data")
    preset = ["--preset", "eigenfunctions"]
    assert main([str(data), *FAST, *preset, "--output", str(tmp_path / "clean")]) == 0
    _lossy().export(data / "round" / "lossy.off")
    out = tmp_path / "out"
    assert main([str(data), *FAST, *preset, "--skip-unreadable", "--output", str(out)]) == 0
    assert "round/lossy.off: eigen_index 3 needs at least 4 vertices" in capsys.readouterr().out
    assert _summary(out)["warnings"] == _summary(tmp_path / "clean")["warnings"]


def test_a_class_of_refused_samples_is_dropped_as_a_class_of_unreadable_files(tmp_path, capsys):
    data = _folder(tmp_path / "data")
    for name, text in (("unusable", FLAT_MESH), ("unreadable", "not a mesh\n")):
        (data / name).mkdir()
        for k in range(2):
            (data / name / f"m{k}.off").write_text(text)
    out = tmp_path / "out"
    assert main([str(data), *FAST, "--skip-unreadable", "--output", str(out)]) == 0
    summary = _summary(out)
    assert summary["class_names"] == ["long", "round"] and summary["class_counts"] == [3, 3]
    assert len(summary["skipped"]) == 4


def test_a_read_only_result_file_is_refused_not_removed(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "tsne.png").write_bytes(b"kept")
    (out / "tsne.png").chmod(0o444)
    command = [sys.executable, "-m", "sklearn_meshph", "--n-per-class", "2", "--output"]
    command += [str(out), *FAST]
    if os.geteuid() == 0:  # root writes anything: run without that capability
        if shutil.which("setpriv") is None:
            pytest.skip("root without setpriv")
        command = ["setpriv", "--bounding-set", "-dac_override,-dac_read_search", *command]
    done = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert done.returncode == 2, done.stderr
    assert "holds 'tsne.png', which is read-only" in done.stderr
    assert (out / "tsne.png").read_bytes() == b"kept"


def test_a_run_that_writes_the_data_keeps_it_whole_and_drops_only_stale_files(tmp_path):
    out = tmp_path / "out"
    assert main(["--n-per-class", "2", "--output", str(out), *FAST]) == 0
    first = (out / "distances.npy").read_bytes()
    (out / "eigenfunctions.png").write_bytes(b"an earlier run's picture")
    argv = ["--n-per-class", "2", "--preset", "shape-dna", "--output", str(out), *FAST]
    assert main(argv) == 0
    assert not (out / "eigenfunctions.png").exists() and not (out / "diagrams.npz").exists()
    assert (out / "distances.npy").read_bytes() != first
