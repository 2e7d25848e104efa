"""Vertex welding: STL triangle soups and OBJ UV seams give the indexed mesh's results."""

import pickle
import warnings

import numpy as np
import pytest
import trimesh
from conftest import irregular_ellipsoid

from sklearn_meshph import (
    LaplacianEigenTransformer,
    LowerStarPersistence,
    MeshCleaningWarning,
    clean_mesh,
    laplacian_eigenfunctions,
    weld_vertices,
)


@pytest.fixture(scope="module")
def ellipsoid():
    return irregular_ellipsoid(3, seed=1)


def _sorted_diagrams(diagrams):
    parts = diagrams if isinstance(diagrams, tuple) else (diagrams,)
    return [d[np.lexsort(d.T[::-1])] if len(d) else d for d in parts]


def _assert_same_results(mesh, reference):
    transformer = LaplacianEigenTransformer()
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # welding alone warns about nothing
        field, expected = transformer.fit_transform([mesh, reference])
    np.testing.assert_allclose(field.eigenvalues, expected.eigenvalues, rtol=1e-10)
    assert field.n_vertices == expected.n_vertices
    diagrams, expected_diagrams = LowerStarPersistence().fit_transform([field, expected])
    for a, b in zip(_sorted_diagrams(diagrams), _sorted_diagrams(expected_diagrams), strict=True):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-10)
    return field


def _seam_mesh(vertices, faces):
    """The mesh with its vertices split along the seam of longitude u = 0 ~ 1: each
    face crossing the seam gets copies of its vertices of small u, with u + 1."""
    u = np.arctan2(vertices[:, 1], vertices[:, 0]) / (2 * np.pi) + 0.5
    v = np.arccos(np.clip(vertices[:, 2] / np.abs(vertices[:, 2]).max(), -1, 1)) / np.pi
    crossing = np.ptp(u[faces], axis=1) > 0.5
    faces = faces.copy()
    new_vertices, new_uv, copies = [vertices], [np.column_stack([u, v])], {}
    n = len(vertices)
    for f in np.flatnonzero(crossing):
        for k in range(3):
            i = faces[f, k]
            if u[i] < 0.5:
                if i not in copies:
                    copies[i] = n + len(copies)
                    new_vertices.append(vertices[i : i + 1])
                    new_uv.append([[u[i] + 1, v[i]]])
                faces[f, k] = copies[i]
    assert copies
    return np.concatenate(new_vertices), faces, np.concatenate(new_uv)


def test_stl_triangle_soup(ellipsoid, tmp_path):
    vertices, faces = ellipsoid
    path = tmp_path / "ellipsoid.stl"
    trimesh.Trimesh(vertices, faces, process=False).export(path)
    loaded = trimesh.load(path, process=False)
    assert len(loaded.vertices) == 3 * len(faces)  # really a soup
    # STL stores float32: the reference is the indexed mesh at that precision.
    reference = (vertices.astype(np.float32).astype(np.float64), faces)
    field = _assert_same_results(loaded, reference)
    assert field.cleaning is None
    # The map to input vertices: every soup vertex gets its position's value.
    assert field.input_to_kept.shape == (len(loaded.vertices),)
    assert (field.input_to_kept >= 0).all()
    np.testing.assert_array_equal(field.vertices[field.input_to_kept], loaded.vertices)
    per_input = field.values[field.input_to_kept]
    assert per_input.shape == (len(loaded.vertices), field.n_functions)
    np.testing.assert_array_equal(
        loaded.vertices[field.vertex_indices], field.vertices
    )  # vertex_indices: the lowest input index at each position
    _assert_same_results(str(path), reference)


def test_array_triangle_soup(ellipsoid):
    vertices, faces = ellipsoid
    soup = (vertices[faces].reshape(-1, 3), np.arange(3 * len(faces)).reshape(-1, 3))
    field = _assert_same_results(soup, ellipsoid)
    np.testing.assert_array_equal(field.vertices[field.input_to_kept], soup[0])
    clean = clean_mesh(*soup)
    assert clean.report.n_welded == len(soup[0]) - len(vertices)
    assert clean.report.vertex_share == 0 and not clean.report.dropped
    # The survivors are the first occurrences, in input order.
    assert (np.diff(clean.vertex_indices) > 0).all()
    values, _ = laplacian_eigenfunctions(soup, 4)
    expected, _ = laplacian_eigenfunctions(ellipsoid, 4)
    np.testing.assert_allclose(values, expected, rtol=1e-10, atol=1e-12)


def test_obj_uv_seam(ellipsoid, tmp_path):
    vertices, faces = ellipsoid
    seam_vertices, seam_faces, uv = _seam_mesh(vertices, faces)
    mesh = trimesh.Trimesh(seam_vertices, seam_faces, process=False)
    mesh.visual = trimesh.visual.TextureVisuals(uv=uv)
    path = tmp_path / "seam.obj"
    mesh.export(path)
    loaded = trimesh.load(path, process=False)
    assert len(loaded.vertices) > len(vertices)  # the seam really is split
    assert len(np.unique(loaded.vertices, axis=0)) == len(vertices)
    # The reference goes through the same OBJ writer (same decimal rounding), no UVs.
    plain_path = tmp_path / "plain.obj"
    trimesh.Trimesh(vertices, faces, process=False).export(plain_path)
    reference = trimesh.load(plain_path, process=False)
    assert len(reference.vertices) == len(vertices)
    without = LaplacianEigenTransformer(weld=False).fit_transform([loaded])[0]
    assert without.n_vertices == len(loaded.vertices)  # unwelded: a surface with a cut
    field = _assert_same_results(loaded, (reference.vertices, reference.faces))
    assert not np.allclose(without.eigenvalues, field.eigenvalues, rtol=1e-3)
    _assert_same_results(str(path), (reference.vertices, reference.faces))


def test_no_duplicates_unchanged(ellipsoid):
    vertices, faces = ellipsoid
    assert (weld_vertices(vertices) == np.arange(len(vertices))).all()
    welded = LaplacianEigenTransformer().fit_transform([ellipsoid])[0]
    plain = LaplacianEigenTransformer(weld=False).fit_transform([ellipsoid])[0]
    for name in ("vertices", "faces", "values", "eigenvalues"):
        np.testing.assert_array_equal(getattr(welded, name), getattr(plain, name))
        assert getattr(welded, name).dtype == getattr(plain, name).dtype
    np.testing.assert_array_equal(welded.vertices, vertices)
    np.testing.assert_array_equal(welded.faces, faces)
    assert welded.vertex_indices is None and welded.input_to_kept is None
    clean = clean_mesh(vertices, faces)
    np.testing.assert_array_equal(clean.input_to_kept, np.arange(len(vertices)))


def test_weld_false_keeps_soup(ellipsoid):
    vertices, faces = ellipsoid
    soup_vertices = vertices[faces].reshape(-1, 3)
    soup_faces = np.arange(len(soup_vertices)).reshape(-1, 3)
    clean = clean_mesh(soup_vertices, soup_faces, weld=False)
    assert len(clean.vertices) == 3 and len(clean.faces) == 1  # the old behaviour
    np.testing.assert_array_equal(clean.input_to_kept[clean.vertex_indices], [0, 1, 2])
    assert np.count_nonzero(clean.input_to_kept >= 0) == 3
    assert clean.report.n_other_components == len(faces) - 1


def test_tolerance_and_determinism():
    rng = np.random.default_rng(0)
    base = rng.normal(size=(50, 3))
    jitter = base + rng.uniform(-1e-12, 1e-12, size=base.shape)
    points = np.concatenate([base, jitter, base])
    rep = weld_vertices(points)
    np.testing.assert_array_equal(rep, np.tile(np.arange(50), 3))
    # Exact only: the jittered copies stay apart, the exact ones do not.
    rep0 = weld_vertices(points, rtol=0)
    np.testing.assert_array_equal(rep0[100:], np.arange(50))
    assert (rep0[50:100] == np.arange(50, 100)).all()
    # -0.0 and 0.0 are one position.
    signed = np.array([[0.0, 1.0, 2.0], [-0.0, 1.0, 2.0], [1.0, 0.0, 0.0]])
    np.testing.assert_array_equal(weld_vertices(signed), [0, 0, 2])
    # A far point is not welded; differences above the tolerance are kept.
    apart = np.array([[0.0, 0, 0], [1e-9, 0, 0], [1.0, 0, 0]])
    np.testing.assert_array_equal(weld_vertices(apart), [0, 1, 2])


def test_weld_parameter(ellipsoid):
    transformer = LaplacianEigenTransformer(weld=False)
    assert transformer.get_params()["weld"] is False
    with pytest.raises(ValueError, match="weld"):
        LaplacianEigenTransformer(weld="yes").fit_transform([ellipsoid])
    with pytest.raises((ValueError, TypeError), match="weld"):
        clean_mesh(*ellipsoid, weld="yes")


def test_field_pickles(ellipsoid):
    vertices, faces = ellipsoid
    extra = vertices[:3] + 10
    mesh = (
        np.concatenate([vertices, extra]),
        np.concatenate([faces, [[len(vertices) + i for i in range(3)]]]),
    )
    with pytest.warns(MeshCleaningWarning, match="^sample 0: cleaning dropped .*1 other comp"):
        field = LaplacianEigenTransformer().fit_transform([mesh])[0]
    copy = pickle.loads(pickle.dumps(field))
    np.testing.assert_array_equal(copy.input_to_kept, field.input_to_kept)
    assert copy.cleaning == field.cleaning
