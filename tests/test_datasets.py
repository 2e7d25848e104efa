"""Synthetic shapes, mesh folders, plotting and the main job."""

import numpy as np
import pytest
import trimesh

from sklearn_meshph import (
    LaplacianEigenTransformer,
    load_mesh_folder,
    make_shapes,
)
from sklearn_meshph.cli import main


def test_make_shapes_is_reproducible_balanced_and_valid():
    data = make_shapes(n_per_class=3, random_state=7)
    again = make_shapes(n_per_class=3, random_state=7)
    assert len(data.data) == 18 and np.bincount(data.target).tolist() == [3] * 6
    assert list(data.target_names) == ["blob", "snake", "tripod", "quadruped", "star", "hand"]
    for mesh, other in zip(data.data, again.data, strict=True):
        np.testing.assert_array_equal(mesh.vertices, other.vertices)
        assert mesh.is_watertight and mesh.euler_number == 2
        assert len(mesh.split(only_watertight=False)) == 1
        assert mesh.area_faces.min() > 0
    other = make_shapes(n_per_class=3, random_state=8)
    assert not np.array_equal(data.data[0].vertices, other.data[0].vertices)


def test_make_shapes_resolution_does_not_reveal_the_class():
    meshes, y = make_shapes(n_per_class=20, random_state=0, return_X_y=True)
    counts = np.array([len(m.vertices) for m in meshes], dtype=float)
    medians = [np.median(counts[y == c]) for c in range(6)]
    assert max(medians) / min(medians) < 1.5
    # 1-NN on the vertex count alone, leave-one-out: near chance (1/6).
    gaps = np.abs(counts[:, None] - counts[None, :]) + np.diag(np.full(len(y), np.inf))
    assert np.mean(y[np.argmin(gaps, axis=1)] == y) < 0.4


def test_make_shapes_subset_and_errors():
    meshes, y = make_shapes(n_per_class=2, classes=("star", "blob"), return_X_y=True)
    assert len(meshes) == 4 and y.tolist() == [0, 0, 1, 1]
    with pytest.raises(ValueError, match=r"unknown: \['cube'\]"):
        make_shapes(classes=("cube",))
    # none, repeats and non-names: an empty set, two classes named "blob", a TypeError
    for classes in ((), ("blob", "blob"), (["blob"],)):
        with pytest.raises(ValueError, match="classes must be distinct names of"):
            make_shapes(classes=classes)
    # beyond MAX_SHAPES meshes: refused before any is made (10**9 per class ran on)
    with pytest.raises(ValueError, match="6000000000 meshes, more than MAX_SHAPES"):
        make_shapes(n_per_class=10**9)
    # a noise whose radii turn negative (inf: every vertex NaN, with a RuntimeWarning)
    for noise in (np.inf, 10.0, 0.11):
        with pytest.raises(ValueError, match="'noise' parameter of make_shapes"):
            make_shapes(n_per_class=1, noise=noise)


def write_folder(root):
    for name, mesh in (("ball", trimesh.creation.icosphere(1)), ("box", trimesh.creation.box())):
        (root / name).mkdir()
        mesh.export(root / name / "b.obj")
        mesh.export(root / name / "a.ply")
    (root / "_extra").mkdir()  # folders starting with an underscore are skipped
    trimesh.creation.box().export(root / "_extra" / "ignored.obj")
    (root / "box" / "notes.txt").write_text("not a mesh")
    (root / "box" / "._a.ply").write_bytes(b"\0\5\26\7")  # macOS metadata: skipped


def test_load_mesh_folder(tmp_path):
    write_folder(tmp_path)
    data = load_mesh_folder(tmp_path)
    assert data.target_names.tolist() == ["ball", "box"]
    assert data.target.tolist() == [0, 0, 1, 1]
    assert [p.split("/")[-1] for p in data.filenames] == ["a.ply", "b.obj", "a.ply", "b.obj"]
    assert all(isinstance(m, trimesh.Trimesh) for m in data.data)
    lazy = load_mesh_folder(tmp_path, load=False)
    assert lazy.data == list(data.filenames)


def test_load_mesh_folder_reads_point_clouds_beside_meshes(tmp_path):
    from sklearn_meshph.datasets import MESH_EXTENSIONS, SAMPLE_EXTENSIONS

    write_folder(tmp_path)
    points = trimesh.creation.icosphere(2).vertices * [1.0, 1.3, 1.8]  # distinct eigenvalues
    np.savetxt(tmp_path / "ball" / "c.xyz", points, fmt="%.17g")
    trimesh.PointCloud(points * 2).export(tmp_path / "box" / "c.ply")
    (tmp_path / "box" / "d.xyz.zip").write_bytes(b"PK\x03\x04")  # not an ending read
    data = load_mesh_folder(tmp_path)
    assert [p.split("/")[-1] for p in data.filenames] == [
        "a.ply",
        "b.obj",
        "c.xyz",
        "a.ply",
        "b.obj",
        "c.ply",
    ]
    np.testing.assert_array_equal(data.data[2], points)
    np.testing.assert_allclose(data.data[5], points * 2)
    assert isinstance(data.data[0], trimesh.Trimesh) and isinstance(data.data[5], np.ndarray)
    # The mesh endings alone skip the text clouds (a PLY without faces is still a cloud).
    meshes = load_mesh_folder(tmp_path, extensions=MESH_EXTENSIONS)
    assert len(meshes.filenames) == 5
    assert set(MESH_EXTENSIONS) < set(SAMPLE_EXTENSIONS)
    assert {".xyz", ".pts", ".pts.gz", ".xyz.xz"} < set(SAMPLE_EXTENSIONS)
    # Paths are read by the estimators the same way.
    fields = LaplacianEigenTransformer(eigen_index=1).fit_transform(
        [data.data[2], load_mesh_folder(tmp_path, load=False).data[2]]
    )
    np.testing.assert_array_equal(fields[0].values, fields[1].values)


def test_load_mesh_folder_errors(tmp_path):
    with pytest.raises(ValueError, match="does not exist"):
        load_mesh_folder(tmp_path / "missing")
    with pytest.raises(ValueError, match="no mesh or point-cloud files"):
        load_mesh_folder(tmp_path)


def test_a_broken_file_is_named_in_the_error(tmp_path):
    write_folder(tmp_path)
    (tmp_path / "box" / "c.off").write_text("OFF\n3 1 0\n0 0 0\n1 0 0\n")  # truncated
    with pytest.raises(ValueError, match=r"^sample 4: .*c\.off"):
        load_mesh_folder(tmp_path)
    assert load_mesh_folder(tmp_path, load=False).filenames[4].endswith("c.off")


def test_described_classes_are_the_generated_ones():
    data = make_shapes(n_per_class=1, random_state=0)
    for name in data.target_names:
        assert f'"{name}"' in data.DESCR
    for name in ("rod", "tetrapod"):
        assert name not in data.DESCR
        with pytest.raises(ValueError, match="unknown: "):
            make_shapes(classes=(name,))


def test_load_sumner_folder(sumner_dir):
    data = load_mesh_folder(sumner_dir, load=False)
    assert len(data.data) == 60
    assert data.target_names.tolist() == ["cat", "elephant", "face", "head", "horse", "lion"]
    assert np.bincount(data.target).tolist() == [10] * 6


def test_plots_are_written(tmp_path):
    plotting = pytest.importorskip("sklearn_meshph.plotting")
    figure = pytest.importorskip("matplotlib.figure")
    fig = figure.Figure()  # no pyplot: drawn on given axes
    axes = fig.subplots(1, 2)
    diagram = np.array([[0.0, 1.0], [0.2, 0.5], [0.1, np.inf]])
    assert plotting.plot_diagram(diagram, ax=axes[0]) is axes[0]
    assert len(axes[0].collections[0].get_offsets()) == 3
    plotting.plot_diagram((diagram, diagram[:2]), ax=axes[1], labels=["H0", "ess"])
    assert [len(c.get_offsets()) for c in axes[1].collections] == [3, 2]
    fig.savefig(tmp_path / "diagrams.png")
    # Fifteen diagrams (the default's): diagrams 0 and 10 had one colour and marker.
    many = plotting.plot_diagram(tuple([diagram] * 14 + [np.empty((0, 2))]), ax=fig.subplots())
    styles = {
        (tuple(c.get_facecolor()[0][:3]), c.get_paths()[0].vertices.tobytes())
        for c in many.collections
        if len(c.get_offsets())
    }
    assert len(styles) == 14 and many.get_legend().get_texts()[-1].get_text().endswith("(empty)")
    ax = plotting.plot_diagram(diagram[:2])  # a new figure of its own
    assert ax not in axes and len(ax.collections[0].get_offsets()) == 2
    # A list of 2-D arrays is several diagrams (it was merged into one); a list of
    # pairs is one.
    listed = plotting.plot_diagram([diagram, diagram[:2]], ax=fig.subplots())
    assert [len(c.get_offsets()) for c in listed.collections] == [3, 2]
    pairs = plotting.plot_diagram([[0.0, 1.0], [0.5, 2.0]], ax=fig.subplots())
    assert [len(c.get_offsets()) for c in pairs.collections] == [2]
    # Other shapes were reshaped into made-up points; NaN deaths drawn as essential.
    with pytest.raises(ValueError, match=r"must have shape \(n, 2\) .*got \(2, 3\)"):
        plotting.plot_diagram(np.array([[0.0, 1.0, 0.0], [0.0, 2.0, 1.0]]))
    with pytest.raises(ValueError, match="diagram 1: row 1 holds NaN"):
        plotting.plot_diagram((diagram, np.array([[0.0, 1.0], [0.0, np.nan]])))
    with pytest.raises(ValueError, match="labels holds 1 entries for 2 diagrams"):
        plotting.plot_diagram((diagram, diagram), labels=["H0"])
    mesh = trimesh.creation.icosphere(1)
    ax = plotting.plot_mesh_function(mesh.vertices, mesh.faces, mesh.vertices[:, 2])
    ax.figure.savefig(tmp_path / "mesh.png")
    ax = plotting.plot_embedding(np.random.default_rng(0).random((6, 2)), [0, 0, 1, 1, 2, 2])
    assert len(ax.collections) == 3
    # -1 took the last of the names; text labels failed deep in NumPy
    points = np.zeros((2, 2))
    for labels in ([0, -1], ["a", "b"], [0, 3]):
        with pytest.raises(ValueError, match="labels must be integers from 0"):
            plotting.plot_embedding(points, labels, target_names=["x", "y", "z"])
    with pytest.raises(ValueError, match=r"embedding must have shape \(n, 2\)"):
        plotting.plot_embedding(np.zeros((2, 3)), [0, 1])
    # whole floats are labels (as a classifier may return them); one pair is one point
    assert len(plotting.plot_embedding(points, [0.0, 1.0], ax=fig.subplots()).collections) == 2
    single = plotting.plot_diagram(np.array([0.0, 1.0]), ax=fig.subplots())
    assert len(single.collections[0].get_offsets()) == 1
    ax.figure.savefig(tmp_path / "embedding.png")
    assert all((tmp_path / f).stat().st_size > 1000 for f in ("diagrams.png", "mesh.png"))
    import matplotlib.pyplot as plt

    plt.close("all")


def test_main_job_end_to_end(tmp_path, capsys):
    pytest.importorskip("matplotlib")
    code = main(["--n-per-class", "2", "--folds", "2", "--output", str(tmp_path), "--n-jobs", "1"])
    assert code == 0
    out = capsys.readouterr().out
    assert "2-fold stratified CV accuracy" in out and "confusion matrix" in out
    assert "time per stage" in out and "preset 'default'" in out
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "diagrams.npz",
        "diagrams.png",
        "distances.npy",
        "eigenfunctions.png",
        "predictions.csv",
        "summary.json",
        "tsne.png",
    ]


def test_main_job_on_a_folder_and_help(tmp_path, capsys):
    write_folder(tmp_path)
    output = ["--output", str(tmp_path / "_out")]  # "_": not a class folder
    argv = [str(tmp_path), "--folds", "2", "--no-plots", "--preset", "paper", *output]
    assert main(argv) == 0
    assert "4 meshes, 2 classes" in capsys.readouterr().out
    with pytest.raises(SystemExit) as exit_info:
        main(["--help"])
    assert exit_info.value.code == 0
    assert "--eigen-index" in capsys.readouterr().out


def test_shape_classes_are_the_generated_ones_in_label_order():
    from sklearn_meshph.datasets import SHAPE_CLASSES

    assert SHAPE_CLASSES == tuple(make_shapes(n_per_class=1, random_state=0).target_names)
