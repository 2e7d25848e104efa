"""Cleaning reports what it dropped: MeshCleaningWarning and ScalarField.cleaning."""

import dataclasses
import pickle
import warnings

import numpy as np
import pytest
import trimesh
from conftest import irregular_ellipsoid

from sklearn_meshph import (
    CleaningReport,
    LaplacianEigenTransformer,
    MeshCleaningWarning,
    clean_mesh,
    laplacian_eigenfunctions,
)


def _area(vertices, faces):
    return trimesh.Trimesh(vertices, faces, process=False).area


@pytest.fixture(scope="module")
def ellipsoid():
    return irregular_ellipsoid(3, seed=2)


@pytest.fixture(scope="module")
def with_island(ellipsoid):
    """The ellipsoid and a small sphere beside it (42 vertices, 80 faces)."""
    vertices, faces = ellipsoid
    small = trimesh.creation.icosphere(1)
    island = np.asarray(small.vertices) * 0.1 + [5.0, 0, 0]
    mesh = (
        np.concatenate([vertices, island]),
        np.concatenate([faces, np.asarray(small.faces) + len(vertices)]),
    )
    share = _area(island, small.faces) / (_area(*ellipsoid) + _area(island, small.faces))
    return mesh, len(island) / (len(vertices) + len(island)), share


def test_island_warns_with_shares(with_island):
    mesh, vertex_share, area_share = with_island
    clean = clean_mesh(*mesh)
    report = clean.report
    assert isinstance(report, CleaningReport)
    assert report.n_other_components == 1
    assert (report.n_component_vertices, report.n_component_faces) == (42, 80)
    assert report.n_degenerate_faces == report.n_repeated_faces == 0
    assert report.n_unreferenced_vertices == report.n_welded == 0
    np.testing.assert_allclose(report.vertex_share, vertex_share, rtol=1e-12)
    np.testing.assert_allclose(report.area_share, area_share, rtol=1e-9)
    with pytest.warns(MeshCleaningWarning) as record:
        fields = LaplacianEigenTransformer().fit_transform([mesh, mesh])
    messages = [str(w.message) for w in record if w.category is MeshCleaningWarning]
    assert len(messages) == 2
    assert messages[0].startswith("sample 0: ") and messages[1].startswith("sample 1: ")
    assert f"{100 * vertex_share:.3g}% of the vertices" in messages[0]
    assert f"{100 * area_share:.3g}% of the area" in messages[0]
    assert "1 other components (42 vertices, 80 faces)" in messages[0]
    field = fields[0]
    # The eigen stage cleans the mesh in a unit box (any scale works): the area share,
    # a ratio of areas, agrees to rounding, the counts exactly.
    assert field.cleaning.area_share == pytest.approx(report.area_share, rel=1e-12)
    assert dataclasses.replace(field.cleaning, area_share=report.area_share) == report
    # Values line up with the input vertices; the island's are -1.
    assert field.input_to_kept.shape == (len(mesh[0]),)
    assert (field.input_to_kept[-42:] == -1).all()
    np.testing.assert_array_equal(field.input_to_kept[:-42], np.arange(len(mesh[0]) - 42))
    assert pickle.loads(pickle.dumps(field)).cleaning == field.cleaning


def test_warning_names_the_file(with_island, ellipsoid, tmp_path):
    mesh, _, _ = with_island
    path = tmp_path / "with_island.ply"
    trimesh.Trimesh(*mesh, process=False).export(path)
    with pytest.warns(MeshCleaningWarning, match=r"sample 1 \(file '.*with_island\.ply'\)"):
        LaplacianEigenTransformer().fit_transform([ellipsoid, str(path)])
    with pytest.warns(MeshCleaningWarning, match=r"^mesh \(file '.*with_island\.ply'\)"):
        laplacian_eigenfunctions(path, 3)


def test_warning_from_parallel_workers(with_island):
    mesh, _, _ = with_island
    with pytest.warns(MeshCleaningWarning) as record:
        LaplacianEigenTransformer(n_jobs=2).fit_transform([mesh, mesh])
    messages = sorted(str(w.message)[:8] for w in record if w.category is MeshCleaningWarning)
    assert messages == ["sample 0", "sample 1"]


def test_clean_mesh_does_not_warn(ellipsoid):
    with warnings.catch_warnings():
        warnings.simplefilter("error", MeshCleaningWarning)
        field = LaplacianEigenTransformer().fit_transform([ellipsoid])[0]
        laplacian_eigenfunctions(ellipsoid, 3)
    assert field.cleaning is None
    report = clean_mesh(*ellipsoid).report
    assert not report.dropped and report.vertex_share == report.area_share == 0


def test_welding_is_no_loss(ellipsoid, tmp_path):
    path = tmp_path / "soup.stl"
    trimesh.Trimesh(*ellipsoid, process=False).export(path)
    with warnings.catch_warnings():
        warnings.simplefilter("error", MeshCleaningWarning)
        field = LaplacianEigenTransformer().fit_transform([str(path)])[0]
    assert field.cleaning is None
    loaded = trimesh.load(path, process=False)
    report = clean_mesh(loaded.vertices, loaded.faces).report
    assert report.n_welded == len(loaded.vertices) - len(ellipsoid[0]) > 0
    assert not report.dropped and report.vertex_share == report.area_share == 0


def test_small_losses_recorded_not_warned(ellipsoid):
    vertices, faces = ellipsoid
    n = len(vertices)
    mesh = (
        np.concatenate([vertices, [[9.0, 9, 9]]]),  # one unreferenced vertex
        np.concatenate([faces, faces[:2], [[0, 0, 1]]]),  # two repeated, one degenerate
    )
    with warnings.catch_warnings():
        warnings.simplefilter("error", MeshCleaningWarning)
        field = LaplacianEigenTransformer().fit_transform([mesh])[0]
    report = field.cleaning
    assert report is not None and report.dropped and not report.significant
    assert report.n_degenerate_faces == 1
    assert report.n_repeated_faces == 2
    assert report.n_unreferenced_vertices == 1
    assert report.n_other_components == 0
    np.testing.assert_allclose(report.vertex_share, 1 / (n + 1))
    assert report.area_share == 0
    assert field.input_to_kept[-1] == -1


def test_largest_component_tiny_warns_then_fails_with_a_clear_error(tmp_path):
    """Many separate triangles far apart (a broken scan): welding cannot join them, the
    largest component keeps 3 of 300 vertices; the loss is reported and the eigen
    stage refuses with a message naming the file, never a meaningless diagram."""
    rng = np.random.default_rng(0)
    corners = rng.normal(size=(100, 3, 3)) * 0.1 + 10.0 * np.arange(100)[:, None, None]
    corners[0] *= 1.5  # one triangle larger than the others: a unique largest component
    path = tmp_path / "broken.ply"
    trimesh.Trimesh(corners.reshape(-1, 3), np.arange(300).reshape(100, 3), process=False).export(
        path
    )
    lost = r"broken\.ply.*dropped 99% of the vertices.*99 other components"
    with pytest.warns(MeshCleaningWarning, match=lost):
        with pytest.raises(ValueError, match=r"^sample 0: eigen_index 3 needs at least 4 vertices"):
            LaplacianEigenTransformer(eigen_index=(1, 2, 3)).fit_transform([str(path)])


@pytest.mark.parametrize("far", [1e9, 1e300])
def test_a_far_vertex_that_collapses_the_mesh_is_named(far):
    """Found probing the default on real data (stop 52): a mesh with one vertex at 1e300
    was refused as "every face is degenerate", which named neither the vertex nor why."""
    sphere = trimesh.creation.icosphere(3)
    vertices = np.array(sphere.vertices)
    vertices[5] = far
    with pytest.raises(ValueError, match=r"sample 0: every face is degenerate .*vertex 5 first"):
        LaplacianEigenTransformer().fit_transform([(vertices, sphere.faces)])
