"""The command line's main job as a tool: options, errors, result files, many classes,
the preset pipeline fitted per fold, the cache, skipped files and pipes."""

import csv
import gzip
import importlib.util
import json
import os
import subprocess
import sys
import tempfile

import numpy as np
import pytest
import trimesh

import sklearn_meshph
from sklearn_meshph import (
    DiagramDistance,
    LaplacianEigenTransformer,
    LowerStarPersistence,
    cli,
    load_mesh_folder,
    make_mesh_distance,
    make_shapes,
    pairwise_diagram_distances,
)
from sklearn_meshph._cli_messages import printable
from sklearn_meshph.cli import build_parser, format_confusion, main

FAST = ["--no-plots", "--verbose", "0", "--n-jobs", "1"]


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
            mesh = trimesh.creation.icosphere(2)  # enough vertices for the default's eigenpairs
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
    assert "no mesh or point-cloud files" in _one_error_line(capfd)
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


def test_a_single_class_is_refused(tmp_path, capfd):
    # It printed "accuracy: 1.000" and exited 0.
    _write_classes(tmp_path / "data", 1, 3)
    assert main([str(tmp_path / "data"), "--folds", "3", "--output", str(tmp_path / "o")]) == 2
    assert "holds one class ('class_with_a_rather_long_name_00')" in _one_error_line(capfd)


@pytest.fixture
def no_computation(monkeypatch):
    """Any sample generated, loaded or solved fails the test."""

    def refuse(*args, **kwargs):
        raise AssertionError("computation started before the options were checked")

    monkeypatch.setattr(cli, "make_shapes", refuse)
    monkeypatch.setattr(cli, "_load", refuse)
    monkeypatch.setattr(cli, "compute_fields", refuse)


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (["--folds", "1"], "--folds must be at least 2"),
        (["--neighbors", "0"], "--neighbors must be at least 1"),
        (["--n-jobs", "0"], "--n-jobs must not be 0"),
        (["--preset", "nope"], "'preset' parameter of make_mesh_distance"),
        (["--memory", ""], "--memory must name a folder"),
        # not a folder, nor under one: the cache went unused, a warning per sample
        (["--memory", "/dev/null"], "'/dev/null' is not a folder"),
        (["--memory", "/dev/null/cache"], "is under '/dev/null', which is not a folder"),
        (["--n-scales", "0"], "'n_scales' parameter of LaplacianEigenTransformer"),
        (["--set", "eigen__n_scales=0"], "'n_scales' parameter of LaplacianEigenTransformer"),
        (["--set", "distance__ord1__distance__order=0.5"], "'order' parameter of DiagramDistance"),
        (["--set", "distance__ord1__persistence__filtration=up"], "'filtration' parameter"),
        (["--set", "eigen__laplacian=nope"], "'laplacian' parameter"),
        (["--set", "eigen__no_such_thing=1"], "no_such_thing"),
        (["--set", "nowhere__x=1"], "nowhere"),
        (["--preset", "paper", "--set", "distance__ord1__x=1"], "ord1"),
        (["--neighbors", "10", "--folds", "2"], "--neighbors 10 is larger than the smallest"),
        # beyond the declared constraints, the checks fit adds (they were status 1, after
        # the samples were generated)
        (["--set", "eigen__times=[1e-300]"], "times must be finite and between 1e-150"),
        (["--n-per-class", "1000000000"], "--n-per-class 1000000000 for 6 classes is more"),
        # an option that would do nothing: the default's signature uses no eigenfunction
        (["--eigen-index", "2"], "the signature 'log-hks' does not use"),
        (["--set", 'distance__weights={"zzz": 1}'], "weights name unknown parts ['zzz']"),
        (["--set", "distance__weights=[1, 2]"], "weights holds 2 numbers for 4 parts"),
        (["--set", "distance__weights=[0, 0, 0, 0]"], "weights are all 0"),
        (["--set", "distance__ord1__distance__order=inf"], "order=inf with a finite internal_p"),
        (["--set", "distance__dna__distance__metric=nope"], "metric 'nope' cannot be computed"),
        (["--set", "distance__dna__distance__metric=mahalanobis"], "'VI' parameter is required"),
        (["--n-eigenpairs", "10"], "ShapeDNA(n_eigenpairs=48) needs 48 eigenpairs and the eigen"),
        (["--set", "eigen__eigen_index=()", "--preset", "eigenfunctions"], "eigen_index must"),
    ],
)
def test_bad_options_are_one_line_and_status_2_before_computing(
    tmp_path, capfd, no_computation, options, message
):
    argv = ["--folds", "2", "--n-per-class", "3", "--output", str(tmp_path / "out")]
    assert main([*FAST, *argv, *options]) == 2
    line = _one_error_line(capfd)
    assert message in line
    assert len(line) < 400  # an unknown parameter printed the pipeline's repr: 1,500
    assert not (tmp_path / "out").exists()


def test_set_values_are_read_as_json_or_python_literals(tmp_path):
    parser = build_parser()
    argv = ["--set", "eigen__eigen_index=(1, 2)", "--set", "eigen__laplacian=graph"]
    argv += ["--set", 'distance__weights={"ord1": 1, "ext0": 0, "ext1": 1, "dna": 0}']
    argv += ["--set", "distance__ord1__distance__order=inf", "--set", "eigen__n_eigenpairs=null"]
    argv += ["--set", "distance__ord1__distance__internal_p=inf"]  # the bottleneck distance
    argv += ["--signature", "eigenfunctions"]  # else --eigen-index would do nothing
    args = parser.parse_args([*argv, "--eigen-index", "2", "--output", str(tmp_path)])
    pipeline = cli.build_pipeline(args)
    eigen = pipeline.named_steps["eigen"]
    assert eigen.eigen_index == (1, 2)  # --set comes after the eigen options
    assert eigen.laplacian == "graph" and eigen.n_eigenpairs is None
    assert pipeline.get_params()["distance__weights"]["ext0"] == 0
    assert pipeline.get_params()["distance__ord1__distance__order"] == float("inf")
    with pytest.raises(SystemExit):
        parser.parse_args(["--set", "no_equals_sign"])


def test_the_eigen_options_override_only_when_given(tmp_path):
    from sklearn_meshph.pipelines import PRESETS, make_mesh_distance

    for preset in PRESETS.names:
        args = build_parser().parse_args(["--preset", preset, "--random-state", "3"])
        built = cli.build_pipeline(args).get_params()
        expected = make_mesh_distance(preset, random_state=3, n_jobs=-1, verbose=1).get_params()
        assert {k: repr(v) for k, v in built.items()} == {k: repr(v) for k, v in expected.items()}
    args = build_parser().parse_args(["--n-scales", "2", "--laplacian", "graph"])
    eigen = cli.build_pipeline(args).named_steps["eigen"]
    assert (eigen.n_scales, eigen.laplacian, eigen.signature) == (2, "graph", "log-hks")


def test_an_output_that_cannot_be_written_is_refused(tmp_path, capfd, no_computation):
    a_file = tmp_path / "results.txt"
    a_file.write_text("not a folder")
    for output, message in [
        (a_file, "exists and is not a folder"),
        (a_file / "sub" / "dir", "which is a file"),
    ]:
        assert main(["--n-per-class", "5", "--output", str(output), *FAST]) == 2
        assert message in _one_error_line(capfd)


def test_a_read_only_output_folder_is_refused(tmp_path, capfd, no_computation, monkeypatch):
    locked = tmp_path / "locked"
    locked.mkdir()
    if os.geteuid() != 0:  # root writes anywhere: stand in for the refusal
        locked.chmod(0o500)
    else:

        def refuse(*args, **kwargs):
            raise PermissionError(13, "Permission denied")

        monkeypatch.setattr(tempfile, "TemporaryFile", refuse)
    try:
        assert main(["--n-per-class", "5", "--output", str(locked / "out"), *FAST]) == 2
    finally:
        locked.chmod(0o700)
    assert "cannot be written" in _one_error_line(capfd)
    assert not (locked / "out").exists()


def test_neighbors_larger_than_a_training_fold_is_refused_before_loading(
    tmp_path, capfd, no_computation
):
    data = _write_classes(tmp_path / "data", 2, 3)  # 6 meshes, 3 folds: training folds of 4
    argv = [str(data), "--folds", "3", "--neighbors", "5", "--output", str(tmp_path / "o")]
    assert main([*argv, *FAST]) == 2
    assert "--neighbors 5 is larger than the smallest training fold (4 samples)" in (
        _one_error_line(capfd)
    )


def test_unknown_extension_list_is_used(tmp_path, capfd):
    _write_classes(tmp_path / "data", 2, 2)
    code = main([str(tmp_path / "data"), "--extensions", "obj,stl", "--output", str(tmp_path)])
    assert code == 2
    assert ".obj, .stl" in _one_error_line(capfd)


def test_data_files_are_written_and_readable(tmp_path, capsys):
    out = tmp_path / "results"
    argv = ["--n-per-class", "3", "--folds", "3", "--preset", "paper", *FAST]
    assert main([*argv, "--output", str(out)]) == 0
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
        assert archive["diagram_names"].tolist() == LowerStarPersistence(
            filtration="sublevel"
        ).diagram_names(1)
    # The saved diagrams give back the saved distances (the preset fitted on all).
    np.testing.assert_allclose(DiagramDistance("bottleneck").fit_transform(diagrams), matrix)
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
    assert summary["settings"]["folds"] == 3 and "eigen stage" in summary["timings"]
    assert summary["preset"] == "paper" and summary["pipeline"]["eigen__laplacian"] == "graph"


def test_many_classes_wrapped_confusion_and_pictures(tmp_path, capsys):
    pytest.importorskip("matplotlib")
    data = _write_classes(tmp_path / "data", 21, 2)
    out = tmp_path / "out"
    argv = [str(data), "--folds", "2", "--n-jobs", "1", "--output", str(out), "--verbose", "0"]
    argv += ["--preset", "shape-dna"]  # the cheapest: the pictures are what is tested
    assert main(argv) == 0
    stdout = capsys.readouterr().out
    assert "42 meshes, 21 classes" in stdout
    confusion = stdout.split("confusion matrix")[1].split("\nresults in")[0]
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
    from sklearn_meshph import sample_point_cloud

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
    # The same matrix as the default pipeline fitted on the clouds load_mesh_folder reads.
    expected = make_mesh_distance(random_state=0).fit_transform(loaded.data)
    np.testing.assert_allclose(np.load(out / "distances.npy"), expected, rtol=1e-12)
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


def test_summary_is_valid_json_with_the_preset_and_every_parameter(tmp_path):
    out = tmp_path / "out"
    argv = ["--n-per-class", "2", "--folds", "2", "--output", str(out), *FAST]
    assert main([*argv, "--set", "distance__ord1__distance__internal_p=inf"]) == 0
    text = (out / "summary.json").read_text()

    def refuse(constant):
        raise AssertionError(f"{constant} is not JSON")

    summary = json.loads(text, parse_constant=refuse)
    assert summary["preset"] == "default"
    pipeline = cli.build_pipeline(build_parser().parse_args(argv))
    assert set(summary["pipeline"]) == set(pipeline.get_params(deep=True))
    assert summary["pipeline"]["eigen"] == "LaplacianEigenTransformer"
    assert summary["pipeline"]["eigen__signature"] == "log-hks"
    assert summary["pipeline"]["distance__ord1__distance__internal_p"] == "inf"
    assert summary["settings"]["assignments"] == [["distance__ord1__distance__internal_p", "inf"]]


def test_json_safe_values():
    from sklearn_meshph._report import json_safe

    value = {
        "a": float("inf"),
        "b": -np.inf,
        "c": np.nan,
        "d": (1, np.float64(2.5), np.int64(3)),
        "e": DiagramDistance(),
        "f": np.arange(2),
        "g": None,
        "h": {"x": True},
        "i": object,
    }
    safe = json_safe(value)
    assert safe == {
        "a": "inf",
        "b": "-inf",
        "c": "nan",
        "d": [1, 2.5, 3],
        "e": "DiagramDistance",
        "f": [0, 1],
        "g": None,
        "h": {"x": True},
        "i": repr(object),
    }
    json.dumps(safe, allow_nan=False)


def test_each_fold_learns_its_medians_from_its_training_samples_only(monkeypatch):
    from sklearn.model_selection import StratifiedKFold
    from sklearn.neighbors import KNeighborsClassifier
    from sklearn.pipeline import Pipeline

    from sklearn_meshph import ScalarField

    mesh = trimesh.creation.icosphere(2)
    rng = np.random.default_rng(0)
    noise = rng.normal(scale=0.1, size=(12, len(mesh.vertices)))
    heights = [mesh.vertices[:, 2] * (1 + k % 3) * (1 + k / 10) + noise[k] for k in range(12)]
    fields = [ScalarField(mesh.vertices, mesh.faces, h) for h in heights]
    y = np.arange(12) % 3
    distance = Pipeline(
        [
            ("persistence", LowerStarPersistence()),
            ("distance", DiagramDistance(normalization="median")),
        ]
    )
    blocks = []

    class Capture(KNeighborsClassifier):
        def fit(self, X, y):
            blocks.append(("train", np.array(X)))
            return super().fit(X, y)

        def predict(self, X):
            blocks.append(("test", np.array(X)))
            return super().predict(X)

    monkeypatch.setattr("sklearn_meshph.cli.KNeighborsClassifier", Capture)
    tables = []
    model = cli.on_indices(distance, fields, tables)
    assert len(tables) == 1  # persistence once, for all samples
    cli.cross_validate(model, y, 3, 1, 0)
    diagrams = LowerStarPersistence().fit_transform(fields)
    everything = DiagramDistance(normalization="median").fit(diagrams)
    cv = StratifiedKFold(3, shuffle=True, random_state=0).split(np.zeros((12, 1)), y)
    for k, (train, test) in enumerate(cv):
        fold = DiagramDistance(normalization="median").fit([diagrams[i] for i in train])
        assert not np.allclose(fold.scales_, everything.scales_)  # the test can tell
        (kind, train_block), (kind2, test_block) = blocks[2 * k], blocks[2 * k + 1]
        assert (kind, kind2) == ("train", "test")
        np.testing.assert_allclose(train_block, fold.transform([diagrams[i] for i in train]))
        np.testing.assert_allclose(test_block, fold.transform([diagrams[i] for i in test]))


def _solves(monkeypatch):
    """A list that grows by one for every mesh the eigen stage solves in this process."""
    from sklearn_meshph.spectral import transformer

    solves = []
    solve = transformer.mesh_eigenpairs

    def counting(*args):
        solves.append(1)
        return solve(*args)

    monkeypatch.setattr(transformer, "mesh_eigenpairs", counting)
    return solves


def test_memory_is_hit_on_a_second_run(tmp_path, monkeypatch):
    solves = _solves(monkeypatch)
    argv = ["--n-per-class", "2", "--folds", "2", "--memory", str(tmp_path / "cache"), *FAST]
    assert main([*argv, "--output", str(tmp_path / "a")]) == 0
    assert len(solves) == 12
    assert main([*argv, "--output", str(tmp_path / "b")]) == 0
    assert len(solves) == 12  # every mesh read from the cache
    first, second = (np.load(tmp_path / o / "distances.npy") for o in "ab")
    np.testing.assert_array_equal(first, second)
    assert main([*FAST, "--n-per-class", "2", "--folds", "2", "--output", str(tmp_path / "c")]) == 0
    assert len(solves) == 24  # no cache unless --memory is given


def test_cross_validation_is_scikit_learns_on_the_preset_pipeline(tmp_path, capsys):
    from sklearn.model_selection import StratifiedKFold, cross_val_score
    from sklearn.neighbors import KNeighborsClassifier
    from sklearn.pipeline import make_pipeline

    cache = str(tmp_path / "cache")
    argv = ["--n-per-class", "3", "--folds", "3", "--memory", cache, "--output", str(tmp_path)]
    assert main([*argv, *FAST]) == 0
    summary = json.loads((tmp_path / "summary.json").read_text())
    # The whole pipeline fitted on each training fold by scikit-learn: the same scores.
    meshes, y = make_shapes(
        n_per_class=3, resolution=cli._BUILT_IN_RESOLUTION, random_state=0, return_X_y=True
    )
    model = make_pipeline(
        make_mesh_distance(memory=cache, random_state=0),
        KNeighborsClassifier(n_neighbors=1, metric="precomputed"),
    )
    cv = StratifiedKFold(3, shuffle=True, random_state=0)
    scores = cross_val_score(model, meshes, y, cv=cv)
    np.testing.assert_allclose(summary["accuracy"]["per_fold"], scores)
    full = make_mesh_distance(memory=cache, random_state=0).fit_transform(meshes)
    np.testing.assert_allclose(np.load(tmp_path / "distances.npy"), full, rtol=1e-12)


def test_unreadable_files_are_skipped_and_listed_on_request(tmp_path, capfd):
    data = _write_classes(tmp_path / "data", 2, 3)
    bad = data / "class_with_a_rather_long_name_01" / "m1.ply"
    bad.write_bytes(b"\x89PNG\r\n\x1a\n not a mesh")
    argv = [str(data), "--folds", "2", "--output", str(tmp_path / "o"), *FAST]
    assert main(argv) == 1
    line = _one_error_line(capfd)
    assert "class_with_a_rather_long_name_01/m1.ply" in line and "not a valid" in line
    assert main([*argv, "--skip-unreadable"]) == 0
    captured = capfd.readouterr()
    assert "skipped 1 file(s) that cannot be read" in captured.out
    assert "m1.ply" in captured.out and "Traceback" not in captured.err
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert summary["n_samples"] == 5 and summary["class_counts"] == [3, 2]
    assert [s["file"] for s in summary["skipped"]] == ["class_with_a_rather_long_name_01/m1.ply"]
    with open(tmp_path / "o" / "predictions.csv", newline="") as f:
        files = [row["file"] for row in csv.DictReader(f)]
    assert "class_with_a_rather_long_name_01/m1.ply" not in files and len(files) == 5


@pytest.mark.parametrize("extra", [[], ["--help"]])
def test_a_closed_pipe_ends_quietly(tmp_path, extra):
    argv = ["-m", "sklearn_meshph", "--n-per-class", "2", "--folds", "2", *FAST]
    process = subprocess.Popen(
        [sys.executable, *argv, "--output", str(tmp_path), *extra],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    process.stdout.close()  # as `| head -0` would: every write meets a closed pipe
    stderr = process.stderr.read().decode()
    if extra:  # argparse's help ignores a closed output itself, and exits 0
        assert process.wait(timeout=300) == 0 and stderr == "", stderr
        return
    # Not 0: the job stopped, maybe before its results (141 as a program ended by SIGPIPE).
    assert process.wait(timeout=300) == 141, stderr
    assert stderr == "stopped: standard output was closed by its reader\n"


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full")
def test_a_full_standard_output_is_one_line_not_a_traceback(tmp_path):
    argv = ["-m", "sklearn_meshph", "--n-per-class", "2", "--folds", "2", "--no-plots"]
    with open("/dev/full", "w") as full:
        process = subprocess.run(
            [sys.executable, *argv, "--output", str(tmp_path)],
            stdout=full,
            stderr=subprocess.PIPE,
            timeout=300,
        )
    stderr = process.stderr.decode()
    assert process.returncode == 1, stderr
    assert stderr == "error: No space left on device (writing the results or standard output)\n"


@pytest.mark.parametrize("kind", ["fifo", "folder", "broken link", "link to a file"])
def test_an_output_that_would_hang_or_fail_at_the_end_is_refused_first(tmp_path, capfd, kind):
    """A FIFO named like a result file hung the job after its whole run; a folder or a
    broken link there failed with a traceback after it."""
    output = tmp_path / "out"
    output.mkdir()
    inside = output / "summary.json"
    if kind == "fifo":
        os.mkfifo(inside)
    elif kind == "folder":
        inside.mkdir()
    elif kind == "link to a file":  # written through, over the file it names
        (tmp_path / "precious.txt").write_text("keep")
        inside.symlink_to(tmp_path / "precious.txt")
    else:
        inside.symlink_to(tmp_path / "nowhere")
    assert main(["--output", str(output), "--no-plots"]) == 2
    err = capfd.readouterr().err
    assert "holds 'summary.json', which is not a regular file" in err and "Traceback" not in err
    link = tmp_path / "dangling"
    link.symlink_to(tmp_path / "nowhere")
    assert main(["--output", str(link), "--no-plots"]) == 2
    assert "is a symbolic link to nothing" in capfd.readouterr().err
    loop = tmp_path / "loop"
    loop.symlink_to(loop)
    assert main(["--output", str(loop / "sub"), "--no-plots"]) == 2
    assert "a symbolic link to nothing (or a loop of links)" in capfd.readouterr().err


def test_closed_standard_streams_are_not_a_traceback(tmp_path):
    """Started with `>&-` or `2>&-`, Python has no sys.stdout or sys.stderr: the job
    ended in an AttributeError traceback (or silently, without results)."""
    argv = ["-m", "sklearn_meshph", "--n-per-class", "2", "--folds", "2", "--no-plots"]
    for stream, name in ((1, "a"), (2, "b")):
        process = subprocess.run(
            [sys.executable, *argv, "--output", str(tmp_path / name), "--n-jobs", "1"],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE if stream == 2 else None,
            stderr=subprocess.PIPE if stream == 1 else None,
            timeout=300,
            pass_fds=(),
            preexec_fn=lambda stream=stream: os.close(stream),
        )
        assert process.returncode == 0, (process.stdout, process.stderr)
        assert (tmp_path / name / "summary.json").is_file()


def test_pictures_say_what_they_show(tmp_path, monkeypatch):
    pytest.importorskip("matplotlib")
    from sklearn_meshph import plotting

    labels = []
    draw = plotting.plot_mesh_function

    def recording(*args, colorbar_label=None, **kwargs):
        labels.append(colorbar_label)
        return draw(*args, colorbar_label=colorbar_label, **kwargs)

    monkeypatch.setattr(plotting, "plot_mesh_function", recording)
    argv = ["--n-per-class", "2", "--folds", "2", "--verbose", "0", "--n-jobs", "1"]
    assert main([*argv, "--output", str(tmp_path / "a")]) == 0
    assert len(labels) == 6
    assert all(label.startswith("log heat kernel signature") and "t=" in label for label in labels)
    assert (tmp_path / "a" / "eigenfunctions.png").stat().st_size > 0
    labels.clear()
    paper = [*argv, "--preset", "paper", "--no-plots"]
    assert main([*paper[:-1], "--output", str(tmp_path / "b")]) == 0
    assert labels == ["eigenfunction 1"] * 6


def test_ctrl_c_ends_with_one_line(monkeypatch, capfd):
    import sklearn_meshph.cli as cli

    def interrupted(args):
        raise KeyboardInterrupt

    monkeypatch.setattr(cli, "_run", interrupted)
    assert main(["--no-plots"]) == 130
    assert capfd.readouterr().err == "interrupted\n"


def test_a_disk_that_fills_at_the_pictures_keeps_the_data_files(tmp_path, monkeypatch, capfd):
    """The pictures were written first: a full disk there lost every data file."""
    import errno

    from sklearn_meshph import cli

    def full(output, *args):
        raise OSError(errno.ENOSPC, "No space left on device", str(output / "tsne.png"))

    monkeypatch.setattr(cli, "write_pictures", full)
    output = tmp_path / "out"
    argv = ["--n-per-class", "2", "--folds", "2", "--output", str(output), "--verbose", "0"]
    assert main(argv) == 1
    err = capfd.readouterr().err
    assert err.startswith("error: No space left on device:") and "tsne.png" in err
    summary = json.loads((output / "summary.json").read_text())
    assert np.isfinite(summary["accuracy"]["mean"]) and "pictures" not in summary["timings"]
    assert np.load(output / "distances.npy").shape == (summary["n_samples"],) * 2
    assert sorted(p.name for p in output.iterdir()) == sorted(summary["files"])
    # Rewritten through a temporary file, with the umask's permissions as the others
    # (mkstemp's were 0600: other users could not read it).
    modes = {os.stat(output / name).st_mode & 0o777 for name in summary["files"]}
    assert len(modes) == 1, modes


@pytest.mark.parametrize("argv0", ["/somewhere/bin/sklearn-meshph", "library.py"])
def test_ctrl_c_while_the_package_is_imported_is_one_line(argv0):
    """The package's imports take seconds before main() can catch anything: Ctrl-C
    then printed a traceback of wherever the import was. Run as the main job, an
    uncaught KeyboardInterrupt is one line; imported by a library, it is untouched."""
    code = (
        f"import sys; sys.argv = [{argv0!r}]; import sklearn_meshph._interrupt; "
        "raise KeyboardInterrupt"
    )
    process = subprocess.run([sys.executable, "-c", code], capture_output=True, timeout=300)
    stderr = process.stderr.decode()
    assert process.returncode != 0
    if argv0 == "library.py":
        assert "Traceback" in stderr and "KeyboardInterrupt" in stderr
    else:
        assert stderr == "interrupted\n"
    # Other exceptions keep their traceback.
    other = code.replace("KeyboardInterrupt", "ValueError('kept')")
    process = subprocess.run([sys.executable, "-c", other], capture_output=True, timeout=300)
    assert "Traceback" in process.stderr.decode() and "ValueError: kept" in process.stderr.decode()


@pytest.mark.skipif(os.name != "posix", reason="needs POSIX signals")
def test_ctrl_c_at_the_start_of_the_main_job_is_one_line(tmp_path):
    import signal
    import time

    argv = [sys.executable, "-m", "sklearn_meshph", "--n-per-class", "2", "--no-plots"]
    process = subprocess.Popen(
        [*argv, "--output", str(tmp_path)], stdout=subprocess.PIPE, stderr=subprocess.PIPE
    )
    time.sleep(0.5)  # within the imports on any machine this suite runs on
    process.send_signal(signal.SIGINT)
    _, stderr = process.communicate(timeout=300)
    assert process.returncode in (-signal.SIGINT, 130), stderr
    assert stderr.decode().endswith("interrupted\n") and b"Traceback" not in stderr


def test_another_module_run_with_dash_m_keeps_its_tracebacks(tmp_path):
    """A package run with ``python -m`` that imports this one: ``sys.argv[0]`` is also
    ``-m`` then, and its Ctrl-C lost its traceback."""
    package = tmp_path / "other_tool"
    package.mkdir()
    (package / "__init__.py").write_text("import sklearn_meshph\n")
    (package / "__main__.py").write_text("raise KeyboardInterrupt\n")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(tmp_path), *sys.path]))
    process = subprocess.run(
        [sys.executable, "-m", "other_tool"], capture_output=True, timeout=300, env=env
    )
    assert "Traceback" in process.stderr.decode() and "KeyboardInterrupt" in process.stderr.decode()


@pytest.mark.parametrize(
    ("options", "module"),
    [
        (["-m", "sklearn_meshph", "--help"], "sklearn_meshph"),
        (["-Im", "sklearn_meshph"], "sklearn_meshph"),  # combined flags: the hook was missed
        (["-msklearn_meshph"], "sklearn_meshph"),
        (["-X", "dev", "-Wignore::ImportWarning", "-m", "sklearn_meshph"], "sklearn_meshph"),
        (["-m", "pdb", "-m", "sklearn_meshph"], "pdb"),
        (["-c", "import sklearn_meshph", "-m", "x"], None),
        (["script.py", "-m", "sklearn_meshph"], None),
    ],
)
def test_the_module_run_is_read_from_the_interpreters_options(options, module):
    from sklearn_meshph._interrupt import _module_run

    assert _module_run(options) == module


def test_a_memory_link_to_nothing_is_refused(tmp_path, capfd, no_computation):
    (tmp_path / "cache").symlink_to(tmp_path / "gone")
    argv = ["--memory", str(tmp_path / "cache"), "--output", str(tmp_path / "o")]
    assert main([*FAST, "--folds", "2", "--n-per-class", "2", *argv]) == 2
    assert "is a symbolic link to nothing" in _one_error_line(capfd)


def test_an_empty_output_name_is_refused_not_the_current_folder(tmp_path, capfd, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as stop:
        main(["--output", "", *FAST])
    assert stop.value.code == 2
    assert "--output: must name a folder, got an empty name" in capfd.readouterr().err
    assert not list(tmp_path.iterdir())


def test_names_with_line_breaks_stay_on_their_line(tmp_path, capfd):
    # A file named with a line break split the error line; a class folder so named,
    # the confusion matrix.
    root = tmp_path / "da\nta"
    for name in ("ba\nll", "box"):
        (root / name).mkdir(parents=True)
        for k in range(2):
            trimesh.creation.icosphere(2).export(root / name / f"{k}.off")
    (root / "box" / "b\nad.off").write_text("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 9\n")
    argv = [str(root), "--folds", "2", *FAST]
    assert main([*argv, "--output", str(tmp_path / "o")]) == 1
    assert "(box/b\\nad.off)" in _one_error_line(capfd)
    (root / "box" / "b\nad.off").unlink()
    (root / "box").rename(root / "b\x1b[31mox")  # a terminal escape
    plots = [a for a in argv if a != "--no-plots"]
    assert main([*plots, "--output", str(tmp_path / "o\nut")]) == 0
    out = capfd.readouterr().out
    assert "ba\\nll" in out and "ba\nll" not in out and "\x1b" not in out
    for start in ("data: ", "classes: ", "results in ", "pictures in "):
        line = next(line for line in out.splitlines() if line.startswith(start))
        assert "\\n" in line or "\\x1b" in line, line
    # names in other scripts are printed as they are, their spaces included
    assert printable("猫\u3000犬 café\u200f") == "猫\u3000犬 café\u200f"


def test_a_stage_of_one_diagram_per_sample_keeps_its_diagrams_whole():
    # tuple() of a sample's (n, 2) array split its rows into n one-point diagrams (the
    # paper preset's pictures and diagrams.npz).
    class OneDiagram:
        def diagram_names(self, n_functions):
            return ["sublevel H0"]

    diagram = np.array([[0.0, 1.0], [0.5, np.inf], [0.2, 0.3]])
    samples, labels = cli._diagrams([("persistence", OneDiagram(), [diagram])], 1, 1)
    assert labels == ["sublevel H0"] and len(samples[0]) == 1
    np.testing.assert_array_equal(samples[0][0], diagram)


def test_an_earlier_runs_results_are_not_left_beside_this_ones(tmp_path):
    from sklearn_meshph._report import RESULT_FILES

    out = tmp_path / "out"
    out.mkdir()
    for name in RESULT_FILES:  # an earlier run's, with pictures and diagrams
        (out / name).write_bytes(b"earlier run")
    (out / "notes.txt").write_text("the user's own")
    argv = ["--n-per-class", "2", "--folds", "2", "--preset", "shape-dna", "--output", str(out)]
    assert main([*argv, *FAST]) == 0
    summary = json.loads((out / "summary.json").read_text())
    # No diagrams for Shape-DNA and no pictures: only this run's files, and the user's.
    assert sorted(summary["files"]) == ["distances.npy", "predictions.csv", "summary.json"]
    assert sorted(p.name for p in out.iterdir()) == sorted([*summary["files"], "notes.txt"])
    assert (out / "notes.txt").read_text() == "the user's own"
