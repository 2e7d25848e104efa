"""LaplacianEigenTransformer: invariances, determinism, caching, warnings, estimator API."""

import warnings
from pathlib import Path

import joblib
import numpy as np
import pytest
import trimesh
from conftest import irregular_ellipsoid
from half_refinement import refine_upper_half
from scipy.spatial.transform import Rotation

from sklearn_meshph import (
    LaplacianEigenTransformer,
    RepeatedEigenvalueWarning,
    ScalarField,
    make_graph_classifier,
)
from sklearn_meshph.spectral.cache import CacheWarning
from sklearn_meshph.spectral.quality import MeshQualityWarning


def bumpy(subdivisions=3):
    """A shape without symmetry, geometric or combinatorial: low eigenvalues are simple."""
    sphere = trimesh.creation.icosphere(subdivisions)
    centers = sphere.triangles_center
    refine = np.flatnonzero((centers[:, 0] > 0.2) & (centers[:, 1] > -0.3))
    vertices, faces = trimesh.remesh.subdivide(sphere.vertices, sphere.faces, refine)
    vertices = vertices / np.linalg.norm(vertices, axis=1, keepdims=True)
    x, y, z = vertices.T
    radius = 1 + 0.25 * x + 0.15 * y * z + 0.1 * x * y
    return trimesh.Trimesh(vertices * radius[:, None] * [1.0, 1.4, 2.0], faces, process=False)


def test_returns_scalar_fields_with_requested_columns():
    meshes = [bumpy(2), bumpy(3)]
    fields = LaplacianEigenTransformer(eigen_index=1).fit_transform(meshes)
    assert all(isinstance(f, ScalarField) for f in fields)
    assert fields[1].values.shape == (len(meshes[1].vertices),)
    assert fields[1].eigenvalues.shape == (1,)
    several = LaplacianEigenTransformer(eigen_index=(1, 2, 5)).fit_transform(meshes)
    assert several[0].values.shape == (len(meshes[0].vertices), 3)
    np.testing.assert_array_equal(several[1].values[:, 0], fields[1].values)
    assert np.all(np.diff(several[1].eigenvalues) > 0)


def test_area_normalization_gives_unit_mean_square():
    fields = LaplacianEigenTransformer(eigen_index=(1, 2)).fit_transform([bumpy()])
    field = fields[0]
    mesh = trimesh.Trimesh(field.vertices, field.faces, process=False)
    mass = np.zeros(len(field.vertices))
    np.add.at(mass, field.faces.ravel(), np.repeat(mesh.area_faces / 3, 3))
    mass /= mass.sum()
    np.testing.assert_allclose(mass @ field.values**2, 1.0, rtol=1e-10)


@pytest.mark.parametrize("laplacian", ["cotangent", "graph"])
def test_invariant_to_rotation_translation_and_scale(laplacian):
    mesh = bumpy()
    rotation = Rotation.from_euler("xyz", [0.3, -1.1, 2.0]).as_matrix()
    moved = trimesh.Trimesh(
        mesh.vertices @ rotation.T * 7.5 + [3.0, -2.0, 10.0], mesh.faces, process=False
    )
    est = LaplacianEigenTransformer(eigen_index=(1, 2, 3), laplacian=laplacian)
    original, transformed = est.fit_transform([mesh, moved])
    np.testing.assert_allclose(transformed.values, original.values, atol=1e-7)
    np.testing.assert_allclose(transformed.eigenvalues, original.eigenvalues, rtol=1e-8)


def _half_refined_errors(laplacian):
    """Relative errors of eigenfunctions 1-4 (at the shared vertices, up to sign) and
    of their eigenvalues, between a mesh and the same surface refined on half of it."""
    vertices, faces = irregular_ellipsoid(3, seed=1)
    fine_v, fine_f = refine_upper_half(vertices, faces)
    np.testing.assert_array_equal(fine_v[: len(vertices)], vertices)
    assert len(fine_v) > 1.8 * len(vertices)
    est = LaplacianEigenTransformer(eigen_index=(1, 2, 3, 4), laplacian=laplacian)
    coarse, fine = est.fit_transform([(vertices, faces), (fine_v, fine_f)])
    shared = fine.values[: len(vertices)]
    difference = np.minimum(np.abs(shared - coarse.values), np.abs(shared + coarse.values))
    functions = difference.max(axis=0) / np.abs(coarse.values).max(axis=0)
    return functions, np.abs(fine.eigenvalues / coarse.eigenvalues - 1)


def test_resolution_invariance_under_refinement_of_half_the_surface():
    # Half the surface at twice the resolution: the cotangent operator, a discretization
    # of the surface's own Laplacian, does not see it (measured: functions within 0.6%,
    # eigenvalues within 0.4%); the graph Laplacian, which counts edges, does (functions
    # 70-95% off, eigenvalues 9-27%). Uniform refinement cannot tell them apart.
    functions, values = _half_refined_errors("cotangent")
    assert functions.max() < 0.015, functions
    assert values.max() < 0.01, values
    functions, values = _half_refined_errors("graph")
    assert functions.min() > 0.5, functions
    assert values.min() > 0.05, values


def test_graph_laplacian_is_not_resolution_invariant():
    mesh = bumpy(3)
    vertices, faces = trimesh.remesh.subdivide(mesh.vertices, mesh.faces)
    est = LaplacianEigenTransformer(laplacian="graph", normalization="none")
    coarse, fine = est.fit_transform([mesh, (vertices, faces)])
    # Unit-norm vectors shrink with the vertex count: the paper's trap.
    ratio = np.abs(coarse.values).max() / np.abs(fine.values).max()
    assert ratio > 1.5


def test_identical_output_for_any_n_jobs_and_runs(make_irregular_ellipsoid):
    meshes = [bumpy(2), make_irregular_ellipsoid(3), bumpy(3)]
    est = LaplacianEigenTransformer(eigen_index=(1, 2))
    one = est.set_params(n_jobs=1).transform(meshes)
    two = est.set_params(n_jobs=2).transform(meshes)
    again = est.set_params(n_jobs=1).transform(meshes)
    for a, b, c in zip(one, two, again, strict=True):
        np.testing.assert_array_equal(a.values, b.values)
        np.testing.assert_array_equal(a.values, c.values)
        np.testing.assert_array_equal(a.eigenvalues, b.eigenvalues)


def test_repeated_eigenvalue_warns_with_multiplicity():
    sphere = trimesh.creation.icosphere(3)
    with pytest.warns(RepeatedEigenvalueWarning, match="sample 0: eigenvalue 1 .*multiplicity 3"):
        LaplacianEigenTransformer(eigen_index=1).fit_transform([sphere])
    with pytest.warns(RepeatedEigenvalueWarning, match="eigenvalue 4 .*multiplicity 5"):
        LaplacianEigenTransformer(eigen_index=4).fit_transform([sphere])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        LaplacianEigenTransformer(eigen_index=(1, 2, 3)).fit_transform([bumpy()])


def cached_calls(location: Path) -> int:
    return sum(1 for _ in location.rglob("header.json"))


def test_memory_solves_each_mesh_once_across_eigen_indices(tmp_path, make_irregular_ellipsoid):
    meshes = [bumpy(2), make_irregular_ellipsoid(2)]
    memory = joblib.Memory(tmp_path, verbose=0)
    results = {}
    for index in (1, 2, 3, 4, 5):
        est = LaplacianEigenTransformer(eigen_index=index, memory=memory)
        results[index] = est.fit_transform(meshes)
    assert cached_calls(tmp_path) == len(meshes)
    uncached = LaplacianEigenTransformer(eigen_index=3).fit_transform(meshes)
    np.testing.assert_array_equal(results[3][1].values, uncached[1].values)
    # A changed mesh is a new cache entry.
    moved = trimesh.Trimesh(meshes[0].vertices * 1.01, meshes[0].faces, process=False)
    LaplacianEigenTransformer(memory=str(tmp_path)).fit_transform([moved])
    assert cached_calls(tmp_path) == len(meshes) + 1


def test_cleaned_meshes_report_their_vertex_indices():
    mesh = bumpy(2)
    vertices = np.vstack([[50.0, 50, 50], mesh.vertices])
    field = LaplacianEigenTransformer().fit_transform([(vertices, mesh.faces + 1)])[0]
    np.testing.assert_array_equal(field.vertex_indices, np.arange(1, len(vertices)))
    reference = LaplacianEigenTransformer().fit_transform([mesh])[0]
    assert reference.vertex_indices is None
    np.testing.assert_allclose(field.values, reference.values, atol=1e-10)


def test_several_components_policy():
    big, small = bumpy(2), trimesh.creation.icosphere(1, radius=0.1)
    vertices = np.vstack([small.vertices, big.vertices])
    faces = np.vstack([small.faces, big.faces + len(small.vertices)])
    field = LaplacianEigenTransformer().fit_transform([(vertices, faces)])[0]
    assert field.n_vertices == len(big.vertices)
    with pytest.raises(ValueError, match="sample 1: the mesh has 2 connected components"):
        LaplacianEigenTransformer(components="error").fit_transform([big, (vertices, faces)])


@pytest.mark.parametrize(
    "bad, error, message",
    [
        ((np.full((4, 3), np.nan), [[0, 1, 2]]), ValueError, "sample 1: vertex 0"),
        ((np.eye(3), [[0, 1, 3]]), ValueError, "sample 1: face 0 .* out of range"),
        ((np.eye(3)[:, :2], [[0, 1, 2]]), ValueError, "sample 1: vertices must"),
        ("no/such/file.obj", ValueError, "sample 1: mesh file .* does not exist"),
        (3.14, TypeError, "sample 1: expected"),
    ],
)
def test_bad_meshes_name_the_sample(bad, error, message):
    with pytest.raises(error, match=message):
        LaplacianEigenTransformer().fit_transform([bumpy(1), bad])


def test_a_sample_too_large_for_the_memory_is_named(monkeypatch):
    # A graph of 10^9 nodes and one edge passes check_graph, then its eigen stage ran
    # out of memory with a bare MemoryError that named no sample.
    from sklearn_meshph.spectral import transformer

    def exhausted(*args, **kwargs):
        raise MemoryError()

    monkeypatch.setattr(transformer, "_cached_solve", exhausted)
    with pytest.raises(MemoryError, match=r"^sample 0: not enough memory to solve its \d+ vert"):
        LaplacianEigenTransformer().fit_transform([bumpy(1)])
    graph = (5, np.array([[0, 1], [1, 2]]))
    with pytest.raises(MemoryError, match=r"^sample 0: .* its 5 nodes \(allocation failed\)"):
        LaplacianEigenTransformer(laplacian="normalized").fit_transform([graph])


def test_index_beyond_the_vertex_count():
    triangle = (np.eye(3), np.array([[0, 1, 2]]))
    # An equilateral triangle: eigenvalues 1 and 2 coincide.
    with pytest.warns(RepeatedEigenvalueWarning, match="sample 0: eigenvalue 2 .*multiplicity 2"):
        field = LaplacianEigenTransformer(eigen_index=2).fit_transform([triangle])[0]
    assert np.isfinite(field.values).all()
    with pytest.raises(ValueError, match="sample 0: eigen_index 3 needs at least 4 vertices"):
        LaplacianEigenTransformer(eigen_index=3).fit_transform([triangle])


@pytest.mark.parametrize(
    "params, message",
    [
        ({"eigen_index": -1}, "'eigen_index' parameter"),
        ({"eigen_index": ()}, "eigen_index must be .* a non-empty tuple"),
        ({"eigen_index": (1, -2)}, r"eigen_index must be a non-negative int.*got \(1, -2\)"),
        ({"eigen_index": (1, 1.5)}, r"eigen_index must be a non-negative int.*got \(1, 1.5\)"),
        ({"laplacian": "x"}, "'laplacian' parameter .* 'cotangent', 'graph'"),
        ({"n_eigenpairs": 1}, "'n_eigenpairs' parameter"),
        ({"n_scales": 0}, "'n_scales' parameter"),
        # Seeds numpy cannot take: refused as parameters, not blamed on a mesh.
        ({"random_state": -1}, r"^The 'random_state' parameter .*\[0, 2\*\*32 - 1\].* Got -1"),
        ({"random_state": 2**32}, r"^The 'random_state' parameter .* Got 4294967296"),
        ({"random_state": 1.5}, r"^The 'random_state' parameter .* Got 1.5"),
        ({"random_state": "0"}, r"^The 'random_state' parameter .* Got '0'"),
    ],
)
def test_invalid_parameters(params, message):
    with pytest.raises(ValueError, match=message):
        LaplacianEigenTransformer(**params).fit([bumpy(1)])
    with pytest.raises(ValueError, match=message):
        LaplacianEigenTransformer(**params).transform([bumpy(1)])


def test_the_constant_eigenfunction_warns_that_it_says_nothing():
    from sklearn_meshph.spectral import ConstantEigenfunctionWarning

    with pytest.warns(ConstantEigenfunctionWarning, match="eigen_index 0 is the constant"):
        field = LaplacianEigenTransformer(eigen_index=(0, 1)).fit_transform([bumpy(1)])[0]
    np.testing.assert_allclose(field.values[:, 0], field.values[0, 0], rtol=1e-8)
    with warnings.catch_warnings():
        warnings.simplefilter("error", ConstantEigenfunctionWarning)
        LaplacianEigenTransformer(eigen_index=1).fit_transform([bumpy(1)])
        LaplacianEigenTransformer(eigen_index=0, signature="hks").fit_transform([bumpy(1)])


def test_single_mesh_instead_of_a_sequence_is_refused():
    with pytest.raises(TypeError, match="sequence of meshes, point clouds or graphs"):
        LaplacianEigenTransformer().fit_transform(bumpy(1))


def test_no_sample_is_refused_naming_every_kind_of_input():
    # The eigen stage takes graphs too: "at least one of meshes" misled graph users.
    for estimator in (LaplacianEigenTransformer(), make_graph_classifier()):
        with pytest.raises(ValueError, match="at least one of meshes, point clouds or graphs"):
            estimator.fit([], [])


def test_clone_params_and_pickle_round_trip(estimator_round_trip):
    est = LaplacianEigenTransformer(eigen_index=(1, 3), laplacian="graph", n_jobs=2)
    (field,) = estimator_round_trip(
        est, [bumpy(2)], {"eigen_index": 2, "laplacian": "cotangent"}, fit_X=[bumpy(1)]
    )
    assert est.eigen_index == (1, 3) and field.values.shape == (len(bumpy(2).vertices), 2)


def test_a_corrupted_cache_entry_is_recomputed(tmp_path):
    mesh = bumpy(2)
    est = LaplacianEigenTransformer(memory=str(tmp_path))
    first = est.fit_transform([mesh])[0]
    (entry,) = [p.parent for p in tmp_path.rglob("header.json")]
    (entry / "values.npy").write_bytes(b"not an array")
    with pytest.warns(CacheWarning, match="unusable and is recomputed"):
        again = est.fit_transform([mesh])[0]
    np.testing.assert_array_equal(again.values, first.values)
    assert (entry / "values.npy").read_bytes() != b"not an array"  # rewritten


@pytest.mark.parametrize("scale", [1e-300, 1e-150, 1e-80, 1e80, 1e150, 1e300])
def test_the_same_functions_at_any_scale_float64_can_represent(scale):
    # The mesh is brought into a unit box before cleaning and assembly: nothing
    # underflows (areas of 1e-150 meshes) or overflows (squared lengths of 1e150 ones).
    mesh = bumpy()
    est = LaplacianEigenTransformer(eigen_index=(1, 2, 3), random_state=0)
    reference = est.fit_transform([mesh])[0]
    moved = (np.asarray(mesh.vertices) * scale + 2.0 * scale, np.asarray(mesh.faces))
    field = est.fit_transform([moved])[0]
    np.testing.assert_allclose(field.values, reference.values, atol=1e-9)
    np.testing.assert_allclose(field.eigenvalues, reference.eigenvalues, rtol=1e-9)
    # normalization="none": the eigenpairs of the mesh as given, or a clear refusal
    # when float64 cannot hold them.
    plain = LaplacianEigenTransformer(eigen_index=1, normalization="none", random_state=0)
    if 1e-150 <= scale <= 1e150:
        base = plain.fit_transform([mesh])[0]
        np.testing.assert_allclose(
            plain.fit_transform([moved])[0].eigenvalues * scale**2, base.eigenvalues, rtol=1e-9
        )
    else:
        with pytest.raises(ValueError, match="sample 0: with normalization='none'.*beyond"):
            plain.fit_transform([moved])


def needle_strip(n=40, height=1e-9):
    """A strip of triangles of height ``height`` between two rows of points: every
    triangle a needle, none degenerate enough to be dropped by cleaning."""
    top = np.c_[np.arange(n), np.zeros(n), np.zeros(n)]
    bottom = np.c_[np.arange(n) + 0.5, np.full(n, height), np.zeros(n)]
    faces = []
    for i in range(n - 1):
        faces += [[i, n + i, i + 1], [i + 1, n + i, n + i + 1]]
    return np.vstack([top, bottom]), np.array(faces)


def test_a_mesh_of_needles_warns_that_its_spectrum_means_little():
    with pytest.warns(MeshQualityWarning, match=r"sample 1: 100% of the triangles are needles"):
        LaplacianEigenTransformer(random_state=0).fit_transform([bumpy(), needle_strip()])
    # A well-shaped mesh, and the same strip made taller, do not warn.
    with warnings.catch_warnings():
        warnings.simplefilter("error", MeshQualityWarning)
        LaplacianEigenTransformer(random_state=0).fit_transform([bumpy(), needle_strip(height=0.5)])


def test_scalar_field_column_names_are_checked_and_default_to_function_j():
    vertices, faces = irregular_ellipsoid(1)
    values = np.zeros((len(vertices), 2))
    assert ScalarField(vertices, faces, values).column_names == ("function 0", "function 1")
    named = ScalarField(vertices, faces, values, column_names=["a", "b"])
    assert named.column_names == ("a", "b")
    with pytest.raises(ValueError, match="1 column_names for 2 columns"):
        ScalarField(vertices, faces, values, column_names=("a",))
    with pytest.raises(ValueError, match="column_names must be a sequence of str"):
        ScalarField(vertices, faces, values, column_names="ab")
