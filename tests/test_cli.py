"""The command line's main job as a tool: options, errors, result files, many classes."""

import csv
import gzip
import importlib.util
import json

import numpy as np
import pytest
import trimesh

import sklearn_meshph
from sklearn_meshph import (
    DiagramDistance,
    LaplacianEigenTransformer,
    LowerStarPersistence,
    load_mesh_folder,
    pairwise_diagram_distances,
)
from sklearn_meshph.cli import build_parser, format_confusion, main


def _one_error_line(capfd):
    captured = capfd.readouterr()
    lines = [line for line in captured.err.splitlines() if line.strip()]
    assert len(lines) == 1, captured.err
    assert lines[0].startswith("error: ")
    assert "Traceback" not in captured.err + captured.out
    return lines[0]


def _write_classes(root, n_classes, per_class, name="class_with_a_rather_long_name_{:02d}"):
    rng = np.random.default_rng(0)
    for c in range(n_classes):
        folder = root / name.format(c)
        folder.mkdir(parents=True)
        for k in range(per_class):
            mesh = trimesh.creation.icosphere(1)
            scale = 1.0 + 0.15 * c * rng.uniform(0.8, 1.2, size=3) * [1.0, 0.5, 0.25]
            mesh.vertices = mesh.vertices * scale
            mesh.export(folder / f"m{k}.ply")
    return root


def test_version(capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["--version"])
    assert exit_info.value.code == 0
    assert sklearn_meshph.__version__ in capsys.readouterr().out


def test_every_option_has_help():
    for action in build_parser()._actions:
        assert action.help, action.dest


def test_missing_folder_is_one_line_and_status_2(tmp_path, capfd):
    assert main([str(tmp_path / "nowhere"), "--no-plots", "--output", str(tmp_path)]) == 2
    assert "nowhere" in _one_error_line(capfd)


def test_folder_without_meshes_is_one_line_and_status_2(tmp_path, capfd):
    (tmp_path / "data" / "a").mkdir(parents=True)
    (tmp_path / "data" / "a" / "notes.txt").write_text("not a mesh")
    code = main([str(tmp_path / "data"), "--no-plots", "--output", str(tmp_path / "out")])
    assert code == 2
    assert "no mesh files" in _one_error_line(capfd)
    assert not (tmp_path / "out").exists()


def test_small_class_is_refused_before_loading(tmp_path, capfd, monkeypatch):
    _write_classes(tmp_path / "data", 2, 2)
    import sklearn_meshph.cli as cli

    def no_loading(*args, **kwargs):
        raise AssertionError("meshes loaded before the class check")

    monkeypatch.setattr(cli, "_load", no_loading)
    assert main([str(tmp_path / "data"), "--folds", "3", "--output", str(tmp_path)]) == 2
    line = _one_error_line(capfd)
    assert "--folds 3" in line and "class_with_a_rather_long_name_00" in line


@pytest.mark.parametrize(
    "options", [["--folds", "1"], ["--neighbors", "0"], ["--order", "0.5"], ["--n-jobs", "0"]]
)
def test_bad_options_are_one_line_and_status_2(tmp_path, capfd, options):
    assert main([*options, "--n-per-class", "3", "--output", str(tmp_path)]) == 2
    _one_error_line(capfd)


def test_unknown_extension_list_is_used(tmp_path, capfd):
    _write_classes(tmp_path / "data", 2, 2)
    code = main([str(tmp_path / "data"), "--extensions", "obj,stl", "--output", str(tmp_path)])
    assert code == 2
    assert ".obj, .stl" in _one_error_line(capfd)


def test_data_files_are_written_and_readable(tmp_path, capsys):
    out = tmp_path / "results"
    argv = ["--n-per-class", "3", "--folds", "3", "--no-plots", "--n-jobs", "1"]
    assert main([*argv, "--output", str(out), "--verbose", "0"]) == 0
    stdout = capsys.readouterr().out
    assert sorted(p.name for p in out.iterdir()) == [
        "diagrams.npz",
        "distances.npy",
        "predictions.csv",
        "summary.json",
    ]
    matrix = np.load(out / "distances.npy")
    assert matrix.shape == (18, 18)
    np.testing.assert_array_equal(matrix, matrix.T)
    with np.load(out / "diagrams.npz") as archive:
        n_diagrams = len(archive["diagram_names"])
        diagrams = [
            tuple(archive[f"sample_{i}_diagram_{k}"] for k in range(n_diagrams)) for i in range(18)
        ]
        assert len(archive["filenames"]) == 18 and archive["labels"].tolist() == sorted(
            archive["labels"].tolist()
        )
        assert set(LowerStarPersistence().diagram_names()) < {
            name.split(": ")[-1] for name in archive["diagram_names"]
        } | {""}
    # The saved diagrams give back the saved distances.
    np.testing.assert_allclose(DiagramDistance().fit_transform(diagrams), matrix)
    with open(out / "predictions.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert list(rows[0]) == ["index", "file", "true label", "predicted label", "fold"]
    assert len(rows) == 18 and {row["fold"] for row in rows} == {"0", "1", "2"}
    summary = json.loads((out / "summary.json").read_text())
    assert summary["version"] == sklearn_meshph.__version__
    assert summary["n_samples"] == 18 and summary["class_counts"] == [3] * 6
    assert len(summary["accuracy"]["per_fold"]) == 3
    accuracy = np.mean([row["true label"] == row["predicted label"] for row in rows])
    assert summary["accuracy"]["mean"] == pytest.approx(accuracy, abs=0.02)
    assert f"accuracy: {summary['accuracy']['mean']:.3f}" in stdout
    assert summary["settings"]["folds"] == 3 and "eigenfunctions" in summary["timings"]


def test_many_classes_wrapped_confusion_and_pictures(tmp_path, capsys):
    pytest.importorskip("matplotlib")
    data = _write_classes(tmp_path / "data", 21, 2)
    out = tmp_path / "out"
    argv = [str(data), "--folds", "2", "--n-jobs", "1", "--output", str(out), "--verbose", "0"]
    assert main(argv) == 0
    stdout = capsys.readouterr().out
    assert "42 meshes, 21 classes" in stdout
    confusion = stdout.split("confusion matrix")[1].split("\npictures")[0]
    assert "most often mistaken for" in confusion
    assert max(len(line) for line in confusion.splitlines()) <= 100
    assert (out / "tsne.png").stat().st_size > 0
    assert (out / "eigenfunctions.png").exists()
    with open(out / "predictions.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert rows[0]["file"] == "class_with_a_rather_long_name_00/m0.ply"


def test_confusion_matrix_fits_in_100_columns():
    y = np.repeat(np.arange(8), 2)
    names = [f"a_really_long_class_name_number_{i}" for i in range(8)]
    text = format_confusion(y, np.roll(y, 1), names)
    assert max(len(line) for line in text.splitlines()) <= 100
    assert "c0 = a_really_long_class_name_number_0" in text
    short = format_confusion(np.array([0, 1]), np.array([0, 1]), ["ball", "box"])
    assert "ball" in short.splitlines()[0]


def test_a_broken_mesh_file_is_named(tmp_path, capfd):
    data = _write_classes(tmp_path / "data", 2, 2)
    broken = data / "class_with_a_rather_long_name_01" / "m1.ply"
    broken.write_text("this is not a ply file")
    code = main(
        [str(data), "--folds", "2", "--no-plots", "--verbose", "0", "--output", str(tmp_path / "o")]
    )
    assert code == 1
    assert "class_with_a_rather_long_name_01/m1.ply" in _one_error_line(capfd)


def test_verbose_zero_prints_nothing(capsys):
    pytest.importorskip("tqdm")
    meshes = [trimesh.creation.icosphere(1), trimesh.creation.box()]
    values = [m.vertices[:, 2] for m in meshes]
    samples = list(zip(meshes, values, strict=True))
    LaplacianEigenTransformer(eigen_index=1, verbose=0).fit_transform(meshes)
    diagrams = LowerStarPersistence(verbose=0).fit_transform(samples)
    DiagramDistance(verbose=0).fit_transform(diagrams)
    pairwise_diagram_distances(diagrams, verbose=0)
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err == ""
    again = LowerStarPersistence(verbose=1).fit_transform(samples)
    matrix = DiagramDistance(verbose=1).fit_transform(again)
    np.testing.assert_array_equal(matrix, pairwise_diagram_distances(diagrams, verbose=2))
    assert "persistence" in capsys.readouterr().err
    LaplacianEigenTransformer(eigen_index=1, verbose=1).fit_transform(meshes)
    assert "eigensolves" in capsys.readouterr().err


def _write_clouds(root, n_points=400):
    """A labelled folder of point clouds sampled from make_shapes, in each format read:
    .xyz text, gzipped .pts (count first), PLY of vertices only."""
    from sklearn_meshph import make_shapes, sample_point_cloud

    classes = ("blob", "snake", "star")
    meshes, y = make_shapes(n_per_class=3, classes=classes, random_state=0, return_X_y=True)
    for k, (mesh, label) in enumerate(zip(meshes, y, strict=True)):
        folder = root / classes[label]
        folder.mkdir(parents=True, exist_ok=True)
        points = sample_point_cloud(mesh, n_points, noise=0.002, random_state=k)
        if k % 3 == 0:
            np.savetxt(folder / f"scan{k}.xyz", points, fmt="%.17g")
        elif k % 3 == 1:
            text = f"{len(points)}\n" + "\n".join(" ".join(f"{v:.17g}" for v in p) for p in points)
            (folder / f"scan{k}.pts.gz").write_bytes(gzip.compress(text.encode()))
        else:
            trimesh.PointCloud(points).export(folder / f"scan{k}.ply")
    return root


def test_main_job_on_a_folder_of_point_clouds(tmp_path, capsys):
    data = _write_clouds(tmp_path / "scans")
    loaded = load_mesh_folder(data)
    assert loaded.target.tolist() == [0, 0, 0, 1, 1, 1, 2, 2, 2]
    assert all(isinstance(x, np.ndarray) and x.shape == (400, 3) for x in loaded.data)
    out = tmp_path / "out"
    argv = [str(data), "--folds", "3", "--n-jobs", "1", "--verbose", "0", "--output", str(out)]
    if importlib.util.find_spec("matplotlib") is None:
        argv.append("--no-plots")
    assert main(argv) == 0
    stdout = capsys.readouterr().out
    assert "9 point clouds, 3 classes" in stdout
    # The same matrix as the estimators on the clouds read by load_mesh_folder.
    fields = LaplacianEigenTransformer(random_state=0).fit_transform(loaded.data)
    expected = DiagramDistance().fit_transform(LowerStarPersistence().fit_transform(fields))
    np.testing.assert_allclose(np.load(out / "distances.npy"), expected, rtol=1e-12)
    assert all(len(f.faces) == 0 and len(f.edges) > 0 for f in fields)
    with open(out / "predictions.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert [row["file"] for row in rows[:3]] == [
        "blob/scan0.xyz",
        "blob/scan1.pts.gz",
        "blob/scan2.ply",
    ]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["n_samples"] == 9 and summary["class_counts"] == [3, 3, 3]
    assert summary["accuracy"]["mean"] >= 2 / 3
    if "--no-plots" not in argv:
        assert (out / "eigenfunctions.png").stat().st_size > 0


def test_point_cloud_files_are_named_when_broken(tmp_path, capfd):
    data = _write_clouds(tmp_path / "scans", n_points=50)
    (data / "star" / "scan8.ply").unlink()
    (data / "star" / "scan8.xyz").write_text("1 2\n3 4\n")
    code = main(
        [str(data), "--folds", "2", "--no-plots", "--verbose", "0", "--output", str(tmp_path / "o")]
    )
    assert code == 1
    assert "star/scan8.xyz" in _one_error_line(capfd)
