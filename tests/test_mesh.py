"""Mesh input validation and the cleaning policy."""

import numpy as np
import pytest
import trimesh

from sklearn_meshph import check_mesh, clean_mesh


def tetrahedron():
    vertices = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    faces = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    return vertices, faces


def test_accepts_trimesh_pair_and_path(tmp_path):
    mesh = trimesh.creation.icosphere(1)
    path = tmp_path / "sphere.ply"
    mesh.export(path)
    for given in (mesh, (mesh.vertices, mesh.faces), path, str(path)):
        vertices, faces = check_mesh(given)
        assert vertices.dtype == np.float64 and faces.dtype == np.int64
        np.testing.assert_allclose(vertices, mesh.vertices)
        np.testing.assert_array_equal(faces, mesh.faces)


@pytest.mark.parametrize("suffix", ["obj", "off", "stl", "glb"])
def test_reads_file_formats(tmp_path, suffix):
    mesh = trimesh.creation.box()
    path = tmp_path / f"box.{suffix}"
    mesh.export(path)
    vertices, faces = check_mesh(path)
    assert faces.shape == (12, 3)
    assert np.isclose(trimesh.Trimesh(vertices, faces, process=False).area, mesh.area)


def test_float_faces_with_integer_values_are_accepted():
    vertices, faces = tetrahedron()
    _, checked = check_mesh((vertices, faces.astype(float)), index=0)
    np.testing.assert_array_equal(checked, faces)


@pytest.mark.parametrize(
    "make, message",
    [
        (lambda v, f: (np.where(np.arange(12).reshape(4, 3) == 4, np.nan, v), f), "vertex 1"),
        (lambda v, f: (np.where(np.arange(12).reshape(4, 3) == 7, np.inf, v), f), "non-finite"),
        (lambda v, f: (v, np.vstack([f, [0, 1, 4]])), "out of range"),
        (lambda v, f: (v, np.vstack([f, [0, -1, 2]])), "out of range"),
        (lambda v, f: (v, f + 0.5), "integers"),
        (lambda v, f: (v, f.astype(str)), "integers"),
        (lambda v, f: (v, np.zeros((0, 3), int)), "no faces"),
        (lambda v, f: (np.zeros((0, 3)), f[:0]), "no vertices"),
        (lambda v, f: (v[:, :2], f), r"shape \(n_vertices, 3\)"),
        (lambda v, f: (v, f[:, :2]), r"shape \(n_faces, 3\)"),
        (lambda v, f: (v.astype(str), f), "numeric"),
    ],
)
def test_invalid_arrays_name_the_sample_and_problem(make, message):
    vertices, faces = make(*tetrahedron())
    with pytest.raises(ValueError, match=f"sample 7: .*{message}"):
        check_mesh((vertices, faces), index=7)


def test_wrong_type_is_a_type_error():
    with pytest.raises(TypeError, match="sample 2: expected a trimesh.Trimesh"):
        check_mesh(42, index=2)


def test_missing_and_malformed_files(tmp_path):
    with pytest.raises(ValueError, match="sample 0: mesh file .* does not exist"):
        check_mesh(tmp_path / "nope.obj", index=0)
    bad = tmp_path / "bad.off"
    bad.write_text("OFF\n3 1 0\n0 0 0\n1 0\n")
    with pytest.raises(ValueError, match="sample 1: .*bad.off"):
        check_mesh(bad, index=1)


def test_clean_mesh_keeps_a_clean_mesh_unchanged():
    vertices, faces = tetrahedron()
    clean = clean_mesh(vertices, faces)
    np.testing.assert_array_equal(clean.vertices, vertices)
    np.testing.assert_array_equal(clean.faces, faces)
    np.testing.assert_array_equal(clean.vertex_indices, np.arange(4))


def test_clean_mesh_drops_degenerate_duplicate_faces_and_unreferenced_vertices():
    vertices, faces = tetrahedron()
    midpoint = (vertices[0] + vertices[1]) / 2
    vertices = np.vstack([[9.0, 9, 9], vertices + 0, midpoint])  # vertex 0 unreferenced
    faces = faces + 1
    faces = np.vstack(
        [
            faces,
            [1, 1, 2],  # repeated index
            [1, 2, 5],  # collinear: zero area
            faces[2][::-1],  # same triangle, other orientation
        ]
    )
    clean = clean_mesh(vertices, faces)
    np.testing.assert_array_equal(clean.vertex_indices, [1, 2, 3, 4])
    np.testing.assert_array_equal(clean.faces, faces[:4] - 1)
    np.testing.assert_array_equal(clean.vertices, vertices[1:5])


def test_components_largest_by_area_or_error():
    small = trimesh.creation.icosphere(2, radius=0.5)
    large = trimesh.creation.icosphere(1, radius=2.0)  # fewer vertices, larger area
    vertices = np.vstack([small.vertices, large.vertices])
    faces = np.vstack([small.faces, large.faces + len(small.vertices)])
    clean = clean_mesh(vertices, faces)
    np.testing.assert_array_equal(
        clean.vertex_indices, np.arange(len(small.vertices), len(vertices))
    )
    np.testing.assert_allclose(clean.vertices, large.vertices)
    with pytest.raises(ValueError, match="sample 4: the mesh has 2 connected components"):
        clean_mesh(vertices, faces, components="error", index=4)


def test_all_degenerate_faces_raise():
    vertices = np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0]])
    with pytest.raises(ValueError, match="sample 0: every face is degenerate"):
        clean_mesh(vertices, np.array([[0, 1, 2]]), index=0)


def test_compiled_duplicates_and_components_match_references():
    """The hash table and the union-find against a set of sorted triples and SciPy."""
    import scipy.sparse as sp
    from scipy.sparse.csgraph import connected_components

    from sklearn_meshph.mesh._geometry import first_of_duplicate_faces
    from sklearn_meshph.mesh._graph import connected_components as vertex_components

    rng = np.random.default_rng(0)
    n = 300
    faces = rng.integers(0, n, size=(500, 3))
    # Repeat a fifth of the faces with their indices in another order.
    repeats = faces[rng.integers(0, len(faces), 100)]
    faces = np.vstack([faces, np.array([rng.permutation(f) for f in repeats])])
    seen, expected = set(), []
    for face in faces:
        key = tuple(sorted(face))
        expected.append(key not in seen)
        seen.add(key)
    np.testing.assert_array_equal(first_of_duplicate_faces(faces), expected)

    faces = faces[:120]  # sparse enough for several components and lone vertices
    count, labels = vertex_components(n, faces)
    edges = np.vstack([faces[:, [0, 1]], faces[:, [1, 2]]])
    graph = sp.coo_matrix((np.ones(len(edges)), edges.T), shape=(n, n))
    ref_count, ref_labels = connected_components(graph, directed=False)
    assert count == ref_count
    np.testing.assert_array_equal(labels, ref_labels)  # both numbered by lowest vertex
