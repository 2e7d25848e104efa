"""Mesh input validation and the cleaning policy."""

import numpy as np
import pytest
import scipy.sparse as sp
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


def random_faces(seed, n_vertices=300, n_faces=500, n_repeats=100):
    """Random triangles on random points, a fifth repeated with their indices permuted;
    many share no vertex, some repeat an index."""
    rng = np.random.default_rng(seed)
    vertices = rng.normal(size=(n_vertices, 3))
    faces = rng.integers(0, n_vertices, size=(n_faces, 3))
    repeats = faces[rng.integers(0, n_faces, n_repeats)]
    return vertices, np.vstack([faces, [rng.permutation(f) for f in repeats]])


def reference_faces(vertices, faces):
    """The first face of each set of three distinct vertices, by a set of sorted triples
    (random points: no collinear triangle)."""
    seen, kept = set(), []
    for face in faces:
        key = tuple(sorted(face))
        if len(set(key)) == 3 and key not in seen:
            kept.append(face)
        seen.add(key)
    return np.array(kept)


def reference_components(n_vertices, faces):
    """Components of the vertices that faces use, by SciPy: a label per face."""
    from scipy.sparse.csgraph import connected_components

    edges = np.vstack([faces[:, [0, 1]], faces[:, [1, 2]]])
    graph = sp.coo_matrix((np.ones(len(edges)), edges.T), shape=(n_vertices, n_vertices))
    _, labels = connected_components(graph, directed=False)
    return labels[faces[:, 0]]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_duplicates_and_components_match_a_set_of_triples_and_scipy(seed):
    """The policy's hash table and union-find against a set of sorted triples and SciPy."""
    vertices, faces = random_faces(seed)
    expected = reference_faces(vertices, faces)
    assert len(expected) < len(faces) - 90  # repeats and repeated indices are dropped
    clean = clean_mesh(vertices, faces)  # one component: every face is kept
    assert len(np.unique(reference_components(len(vertices), expected))) == 1
    np.testing.assert_array_equal(clean.vertex_indices[clean.faces], expected)
    np.testing.assert_array_equal(clean.vertices, vertices[clean.vertex_indices])

    # Sparse enough for several components (and lone vertices, which do not count).
    faces = faces[:120]
    expected = reference_faces(vertices, faces)
    labels = reference_components(len(vertices), expected)
    n_components = len(np.unique(labels))
    assert n_components > 3
    with pytest.raises(ValueError, match=f"sample 3: the mesh has {n_components} connected"):
        clean_mesh(vertices, faces, components="error", index=3)
    mesh = trimesh.Trimesh(vertices, expected, process=False)
    area = np.bincount(labels, weights=mesh.area_faces)
    largest = expected[labels == np.argmax(area)]
    clean = clean_mesh(vertices, faces)
    np.testing.assert_array_equal(clean.vertex_indices[clean.faces], largest)
    np.testing.assert_array_equal(clean.vertex_indices, np.unique(largest))


def test_equal_components_keep_the_one_with_the_lowest_vertex():
    vertices, faces = tetrahedron()
    twin = np.vstack([vertices + 5.0, vertices])  # the second copy uses vertices 4-7
    faces = np.vstack([faces + 4, faces])  # ... and is listed first
    clean = clean_mesh(twin, faces)
    np.testing.assert_array_equal(clean.vertex_indices, [0, 1, 2, 3])
    np.testing.assert_array_equal(clean.faces, tetrahedron()[1])
