"""Point clouds through the same pipeline as meshes: input, operator, graph, persistence.

Tolerances are from measurements (in ``docs/point_clouds.md``), with a margin of about
two or more: the 2,562 vertices of a jittered ellipsoid as a cloud give eigenvalues
within 0.3% of the mesh's, eigenfunctions within 0.4% of their range and diagrams
within 0.07% of it; two samplings of 3,000 and 6,000 points give diagrams within 1.2%;
a rotation or a scale of 1e-100 or 1e100 changes them by 1e-14 of the range.
"""

import pickle
import warnings

import numpy as np
import pytest
import scipy.linalg
import scipy.sparse as sp
import trimesh
from conftest import irregular_ellipsoid
from scipy.spatial.distance import cdist
from scipy.spatial.transform import Rotation

from sklearn_meshph import (
    LaplacianEigenTransformer,
    LowerStarPersistence,
    MeshCleaningWarning,
    ScalarField,
    bottleneck_distance,
    check_point_cloud,
    laplacian_eigenfunctions,
    lower_star_persistence,
    make_mesh_distance,
    make_shapes,
    point_cloud_laplacian,
    sample_point_cloud,
)
from sklearn_meshph.mesh import unit_box
from sklearn_meshph.pointcloud.cleaning import clean_cloud
from sklearn_meshph.pointcloud.graph import (
    GRAPH_NEIGHBORS,
    canonical_order,
    knn_graph,
    surface_graph,
)
from sklearn_meshph.pointcloud.laplacians import CLOUD_LAPLACIANS, cloud_operator
from sklearn_meshph.spectral.cache import CacheWarning
from sklearn_meshph.spectral.laplacians import LAPLACIANS

MESH = irregular_ellipsoid(4)  # 2,562 vertices, simple low eigenvalues


def unit_sphere_points(n, seed=0):
    points = np.random.default_rng(seed).normal(size=(n, 3))
    return points / np.linalg.norm(points, axis=1)[:, None]


def fields(X, **params):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # repeated eigenvalues of spheres
        return LaplacianEigenTransformer(**params).fit_transform(X)


def relative_bottleneck(a, b, values):
    """Bottleneck distance between the diagrams of two samples, over the value range."""
    scale = np.ptp(values)
    return max(bottleneck_distance(x, y) for x, y in zip(a, b, strict=True)) / scale


@pytest.fixture(scope="module")
def mesh_and_cloud_fields():
    return fields([MESH, MESH[0]])


# The operator


def test_unit_sphere_spectrum():
    # 5,000 uniform random points: measured errors below 1% in each eigenspace.
    values, _ = laplacian_eigenfunctions(unit_sphere_points(5000), 16)
    assert values[0] == pytest.approx(0.0, abs=1e-8)
    expected = np.repeat([2.0, 6.0, 12.0], [3, 5, 7])
    np.testing.assert_allclose(values[1:], expected, rtol=0.01)


def test_operator_is_symmetric_semidefinite_with_the_area_as_mass():
    L, M = point_cloud_laplacian(unit_sphere_points(2000))
    assert abs(L - L.T).max() < 1e-12
    assert abs(L.sum(axis=1)).max() < 1e-10
    assert M.sum() == pytest.approx(4 * np.pi, rel=0.01)
    # Semidefinite: cotangent weights can be negative, so this is not implied by the
    # above; the whole spectrum of a small cloud's stiffness, densely.
    L, _ = point_cloud_laplacian(unit_sphere_points(300))
    spectrum = scipy.linalg.eigvalsh(L.toarray())
    assert spectrum[0] >= -1e-10 * spectrum[-1]


def test_every_laplacian_has_a_point_cloud_discretization():
    assert CLOUD_LAPLACIANS.names == LAPLACIANS.names


@pytest.mark.parametrize("laplacian", LAPLACIANS.names)
def test_each_laplacian_runs_on_a_cloud(laplacian):
    (field,) = fields([MESH[0]], laplacian=laplacian, eigen_index=1)
    assert field.values.shape == (len(MESH[0]),)
    assert len(field.faces) == 0 and len(field.edges) > 0


# Mesh and cloud agree


def test_eigenpairs_of_a_mesh_and_its_vertices_agree(mesh_and_cloud_fields):
    mesh, cloud = mesh_and_cloud_fields
    np.testing.assert_allclose(cloud.eigenvalues, mesh.eigenvalues, rtol=0.005)
    for a, b in zip(mesh.columns(), cloud.columns(), strict=True):
        # Up to sign: the sign rule reads the masses, which differ slightly.
        gap = min(np.abs(a - b).max(), np.abs(a + b).max())
        assert gap < 0.01 * np.ptp(a)


def test_diagrams_of_a_mesh_and_its_vertices_agree(mesh_and_cloud_fields):
    mesh, cloud = mesh_and_cloud_fields
    a, b = LowerStarPersistence().fit_transform([mesh, cloud])
    assert relative_bottleneck(a, b, mesh.values) < 0.002


# Invariances


@pytest.fixture(scope="module")
def sampled():
    return sample_point_cloud(MESH, 3000, random_state=0)


def test_rotation_and_scale_change_nothing(sampled):
    rotation = Rotation.random(random_state=0).as_matrix()
    variants = [sampled, sampled @ rotation.T, sampled * 1e-100, sampled * 1e100]
    results = fields(variants)
    diagrams = LowerStarPersistence().fit_transform(results)
    for field, diagram in zip(results[1:], diagrams[1:], strict=True):
        np.testing.assert_allclose(field.eigenvalues, results[0].eigenvalues, rtol=1e-9)
        assert relative_bottleneck(diagram, diagrams[0], results[0].values) < 1e-9


def test_two_densities_give_close_diagrams(sampled):
    dense = sample_point_cloud(MESH, 6000, random_state=1)
    results = fields([sampled, dense])
    a, b = LowerStarPersistence().fit_transform(results)
    # Measured 0.33% (docs/point_clouds.md); an operator that is not the surface's
    # (the graph Laplacian of the kNN graph in its place) gives 1.7%.
    assert relative_bottleneck(a, b, results[0].values) < 0.01


def test_a_permutation_permutes_the_output_exactly(sampled):
    order = np.random.default_rng(0).permutation(len(sampled))
    first, permuted = fields([sampled, sampled[order]])
    np.testing.assert_array_equal(permuted.values, first.values[order])
    np.testing.assert_array_equal(permuted.eigenvalues, first.eigenvalues)
    mapped = np.sort(order[permuted.edges], axis=1)
    mapped = mapped[np.lexsort((mapped[:, 1], mapped[:, 0]))]
    np.testing.assert_array_equal(mapped, first.edges)
    for a, b in zip(*LowerStarPersistence().fit_transform([first, permuted]), strict=True):
        np.testing.assert_array_equal(a, b)


# Input


@pytest.mark.parametrize(
    "points, message",
    [
        (np.full((10, 3), np.nan), "sample 0: point 0 has a non-finite coordinate"),
        (np.zeros((3, 3)), "sample 0: a point cloud needs at least 4 points, got 3"),
        (np.zeros((10, 2)), r"sample 0: a point cloud must be .* shape \(n_points, 3\)"),
        (np.zeros((10, 3)), "sample 0: the point cloud has 1 distinct points"),
    ],
)
def test_bad_clouds_name_the_sample_and_problem(points, message):
    with pytest.raises(ValueError, match=message):
        LaplacianEigenTransformer().fit_transform([points])


def test_a_single_cloud_must_be_wrapped_in_a_list():
    with pytest.raises(TypeError, match="wrap it in a list"):
        LaplacianEigenTransformer().fit_transform(MESH[0])


def test_the_error_for_other_types_names_meshes_and_clouds():
    with pytest.raises(TypeError, match="sample 0: expected a trimesh.Trimesh.*point cloud"):
        LaplacianEigenTransformer().fit_transform([42])


def test_duplicate_points_are_merged_with_the_index_map(sampled):
    doubled = np.vstack([sampled, sampled[:100]])
    plain, merged = fields([sampled, doubled])
    assert merged.n_vertices == len(sampled)
    np.testing.assert_array_equal(merged.vertex_indices, np.arange(len(sampled)))
    np.testing.assert_array_equal(merged.input_to_kept[len(sampled) :], np.arange(100))
    np.testing.assert_array_equal(merged.values, plain.values)
    assert merged.cleaning is None  # merging is not dropping


def test_a_far_cluster_is_dropped_or_refused(sampled):
    far = sample_point_cloud(MESH, 200, random_state=2) + 100.0
    cloud = np.vstack([sampled, far])
    with pytest.warns(MeshCleaningWarning, match="sample 0: cleaning dropped"):
        (field,) = LaplacianEigenTransformer(eigen_index=1).fit_transform([cloud])
    assert field.n_vertices == len(sampled) and field.cleaning.n_other_components == 1
    with pytest.raises(ValueError, match="sample 0: the point cloud has 2 connected comp"):
        LaplacianEigenTransformer(components="error").fit_transform([cloud])


@pytest.fixture(scope="module")
def shape_clouds():
    """1,500 points on each of two make_shapes meshes per class, and the first cloud
    with one stray point ten diameters away and with a cluster of five points there."""
    meshes, y = make_shapes(n_per_class=2, random_state=0, return_X_y=True)
    clouds = [sample_point_cloud(m, 1500, random_state=i) for i, m in enumerate(meshes)]
    first = clouds[0]
    rng = np.random.default_rng(5)
    direction = rng.normal(size=3)
    far = first.mean(axis=0) + 10 * np.linalg.norm(np.ptp(first, axis=0)) * direction / (
        np.linalg.norm(direction)
    )
    stray = np.vstack([first, far])
    cluster = np.vstack([first[:700], far + 1e-3 * rng.normal(size=(5, 3)), first[700:]])
    return clouds, np.asarray(y), stray, cluster


def test_stray_points_are_other_components_and_change_nothing(shape_clouds):
    clouds, y, stray, cluster = shape_clouds
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        distances = make_mesh_distance().fit_transform([*clouds, stray, cluster])
    n = len(clouds)
    median = np.median(distances[:n, :n][y[:, None] != y[None, :]])
    # Before: 5.3 and 4.8 times the median distance between classes.
    assert distances[n, 0] < 0.05 * median and distances[n + 1, 0] < 0.05 * median
    clean, one, five, tiny = fields([clouds[0], stray, cluster, cluster * 1e-100], eigen_index=1)
    assert one.cleaning.n_other_components == five.cleaning.n_other_components == 1
    assert (one.cleaning.n_component_vertices, five.cleaning.n_component_vertices) == (1, 5)
    assert one.n_vertices == five.n_vertices == clean.n_vertices
    np.testing.assert_array_equal(tiny.input_to_kept, five.input_to_kept)  # scale-free
    np.testing.assert_array_equal(np.delete(five.input_to_kept, range(700, 705)), range(1500))
    np.testing.assert_array_equal(five.input_to_kept[700:705], -1)
    np.testing.assert_allclose(five.eigenvalues, clean.eigenvalues, rtol=1e-9)
    for cloud in (stray, cluster):
        with pytest.raises(ValueError, match="sample 0: the point cloud has 2 connected comp"):
            LaplacianEigenTransformer(components="error").fit_transform([cloud])


def test_a_stray_point_is_warned_about_whatever_its_share(shape_clouds):
    clouds, _, stray, _ = shape_clouds
    with pytest.warns(MeshCleaningWarning, match=r"sample 1: .* of which 1 far points"):
        LaplacianEigenTransformer(eigen_index=1).fit_transform([clouds[0], stray])
    with warnings.catch_warnings():
        warnings.simplefilter("error", MeshCleaningWarning)  # a clean cloud: no warning
        LaplacianEigenTransformer(eigen_index=1).fit_transform([clouds[0]])


def test_uneven_density_is_not_taken_for_far_points(shape_clouds):
    # A sixteenth of the points on one half: still one component, nothing dropped.
    cloud = shape_clouds[0][1]
    centred = cloud - cloud.mean(axis=0)
    rng = np.random.default_rng(0)
    uneven = cloud[(centred[:, 0] > 0) | (rng.random(len(cloud)) < 1 / 16)]
    (field,) = fields([uneven], eigen_index=1)
    assert field.cleaning is None and field.n_vertices == len(uneven)


LINE = np.linspace(0.0, 1.0, 50)[:, None]


@pytest.mark.parametrize(
    "points, message",
    [
        (LINE * [1.0, 2.0, 3.0], "sample 0: .* degenerate: its 50 distinct points lie on one"),
        (
            np.vstack([LINE * [1.0, 0.0, 0.0], LINE * [0.0, 1.0, 0.0] + [0.0, 0.0, 1.0]]),
            "sample 0: .* degenerate: fewer than 4 of its points are in a local triangle",
        ),
        (np.ones((6, 3)), "sample 0: the point cloud has 1 distinct points"),
    ],
    ids=["collinear", "two-lines", "all-equal"],
)
@pytest.mark.parametrize("laplacian", ["cotangent", "graph", "random_walk"])
def test_degenerate_clouds_are_refused(points, message, laplacian):
    """Found by an adversarial review for the graph operators (the paper's preset):
    mass 1 at every point kept the two lines, with a complex of no edge."""
    with pytest.raises(ValueError, match=message):
        LaplacianEigenTransformer(laplacian=laplacian).fit_transform([points])


@pytest.mark.parametrize("laplacian", ["graph", "normalized", "random_walk"])
def test_a_graph_operator_keeps_the_points_and_complex_of_the_cotangent_one(laplacian):
    """A helix's points are in local triangles only where its turns are near enough:
    the graph operators kept every point (a complex of several components, whose
    essential classes made the paper preset's distances infinite). They keep the
    cotangent operator's points, and are rebuilt on them: rows summing to zero."""
    t = np.linspace(0, 6 * np.pi, 200)
    helix = np.c_[np.cos(t), np.sin(t), 0.1 * t]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MeshCleaningWarning)
        (cotangent,) = LaplacianEigenTransformer().fit_transform([helix])
        (graph,) = LaplacianEigenTransformer(laplacian=laplacian).fit_transform([helix])
    assert cotangent.n_vertices < len(helix)
    np.testing.assert_array_equal(graph.vertex_indices, cotangent.vertex_indices)
    np.testing.assert_array_equal(graph.edges, cotangent.edges)
    unit = unit_box(helix)[0]
    options = dict(components="largest", index=0, weld=True)
    clean, L, M, _, _ = clean_cloud(helix, unit, laplacian=laplacian, **options)
    expected = CLOUD_LAPLACIANS[laplacian].value.build(unit[clean.vertex_indices])
    # The operator of the kept points (in solve order: compare spectra).
    spectrum = scipy.linalg.eigvalsh(L.toarray(), M.toarray())
    np.testing.assert_allclose(
        spectrum, scipy.linalg.eigvalsh(expected[0].toarray(), expected[1].toarray()), atol=1e-9
    )


def test_a_plane_is_a_surface_patch():
    points = np.random.default_rng(0).random((400, 3)) * [1.0, 1.0, 0.0]
    (field,) = fields([points], eigen_index=1)
    assert field.cleaning is None and field.eigenvalues[0] > 0


def test_a_file_whose_content_is_refused_is_named(tmp_path):
    """Found by an adversarial review: a NaN in a .xyz given by path was reported as
    "sample 1: point 2 has a non-finite coordinate", naming no file (the CLI did)."""
    path = tmp_path / "scan.xyz"
    path.write_text("0 0 0\n1 0 0\nnan 1 0\n0 0 1\n1 1 1\n")
    message = r"sample 1: point 2 has a non-finite coordinate .*read from '.*scan\.xyz'"
    with pytest.raises(ValueError, match=message):
        LaplacianEigenTransformer().fit_transform([MESH, path])


def test_point_cloud_objects_and_files(tmp_path, sampled):
    expected = fields([sampled], eigen_index=1)[0].values
    (from_object,) = fields([trimesh.PointCloud(sampled)], eigen_index=1)
    np.testing.assert_array_equal(from_object.values, expected)
    np.savetxt(tmp_path / "scan.xyz", sampled, fmt="%.17g")
    (tmp_path / "scan.pts").write_text(
        f"{len(sampled)}\n"
        + "\n".join(f"{x!r} {y!r} {z!r} 7 1 2 3" for x, y, z in sampled.tolist())
    )
    trimesh.PointCloud(sampled).export(tmp_path / "scan.ply")
    xyz, pts, ply = fields([tmp_path / f"scan.{ext}" for ext in ("xyz", "pts", "ply")])
    np.testing.assert_array_equal(xyz.vertices, sampled)
    np.testing.assert_array_equal(pts.vertices, sampled)
    # PLY stores float32 coordinates.
    np.testing.assert_array_equal(ply.vertices, sampled.astype(np.float32))


def test_malformed_text_files_are_refused(tmp_path):
    bad = tmp_path / "bad.xyz"
    bad.write_text("0 0 0\n1 1\n")
    with pytest.raises(ValueError, match="sample 0: cannot read point cloud file"):
        LaplacianEigenTransformer().fit_transform([bad])
    flat = tmp_path / "flat.xyz"
    flat.write_text("0 0\n1 1\n2 2\n3 4\n")
    with pytest.raises(ValueError, match="2 numbers per line; expected at least 3"):
        LaplacianEigenTransformer().fit_transform([flat])


def test_check_point_cloud_returns_float64_points():
    points = check_point_cloud(np.arange(12).reshape(4, 3))
    assert points.dtype == np.float64 and points.flags.c_contiguous


# Persistence on the graph


def gudhi_graph_h0(points, values):
    """Sublevel H0 of the lower-star filtration of the cloud's complex, by gudhi."""
    gudhi = pytest.importorskip("gudhi")
    tree = gudhi.SimplexTree()
    for v, value in enumerate(values):
        tree.insert([v], filtration=value)
    for a, b in surface_graph(points):
        tree.insert([int(a), int(b)], filtration=max(values[a], values[b]))
    tree.persistence(homology_coeff_field=2, persistence_dim_max=False)
    pairs = tree.persistence_intervals_in_dimension(0)
    return pairs[pairs[:, 1] > pairs[:, 0]]


@pytest.mark.parametrize("seed", range(3))
def test_sublevel_h0_on_the_graph_matches_gudhi(seed):
    rng = np.random.default_rng(seed)
    points = rng.normal(size=(400, 3))
    values = rng.normal(size=400)
    ours = lower_star_persistence(points, values)
    theirs = gudhi_graph_h0(points, values)
    np.testing.assert_array_equal(ours[np.lexsort(ours.T)], theirs[np.lexsort(theirs.T)])


def brute_force_knn_graph(points, k=GRAPH_NEIGHBORS):
    """Edges (a < b, sorted) of the symmetric kNN graph from all pairwise distances."""
    distances = cdist(points, points)
    np.fill_diagonal(distances, np.inf)
    nearest = np.argsort(distances, axis=1, kind="stable")[:, :k]
    a = np.repeat(np.arange(len(points)), k)
    b = nearest.ravel()
    return np.unique(np.column_stack([np.minimum(a, b), np.maximum(a, b)]), axis=0)


def test_knn_graph_is_the_symmetric_knn_graph(sampled):
    np.testing.assert_array_equal(knn_graph(sampled), brute_force_knn_graph(sampled))


def test_the_field_carries_the_edges_of_the_operators_triangles(sampled):
    (field,) = fields([sampled], eigen_index=1)
    np.testing.assert_array_equal(field.edges, surface_graph(sampled))
    L, _ = point_cloud_laplacian(unit_box(sampled)[0])
    a, b = field.edges.T
    assert (np.asarray(L[a, b]).ravel() != 0).all()  # every edge couples its ends
    degree = np.bincount(field.edges.ravel(), minlength=field.n_vertices)
    assert degree.min() >= 3
    assert not field.edges.flags.writeable
    with pytest.raises(ValueError, match="ScalarField: edge 0 has index"):
        ScalarField(field.vertices, field.faces, field.values, edges=[[0, len(sampled)]])


def test_a_field_and_a_points_values_pair_give_the_same_diagrams(sampled):
    (field,) = fields([sampled], eigen_index=(1, 2))
    persistence = LowerStarPersistence(filtration="extended")
    from_field, from_pair = persistence.fit_transform([field, (sampled, field.values)])
    for a, b in zip(from_field, from_pair, strict=True):
        np.testing.assert_array_equal(a, b)
    assert len(from_field[3]) == 0 and len(from_field[7]) == 0  # no essential H1


def test_the_default_pipeline_runs_on_point_clouds():
    clouds = [sample_point_cloud(MESH, 1500, random_state=s) for s in range(3)]
    clouds.append(sample_point_cloud(irregular_ellipsoid(3, seed=1), 1500, random_state=3))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        distances = make_mesh_distance().fit_transform(clouds)
    assert distances.shape == (4, 4) and np.isfinite(distances).all()
    np.testing.assert_allclose(np.diag(distances), 0.0, atol=1e-12)


# Cache and estimator contract


def test_the_cache_serves_clouds_identically(tmp_path, sampled):
    first = fields([sampled], memory=str(tmp_path), eigen_index=1)[0]
    with warnings.catch_warnings():
        warnings.simplefilter("error", CacheWarning)
        second = fields([sampled], memory=str(tmp_path), eigen_index=1)[0]
    for name in ("vertices", "faces", "values", "eigenvalues", "edges", "spectrum"):
        np.testing.assert_array_equal(getattr(second, name), getattr(first, name))


def test_the_cache_refuses_a_cloud_entry_with_faces(tmp_path, sampled):
    fields([sampled], memory=str(tmp_path), eigen_index=1)
    (header,) = tmp_path.rglob("header.json")
    header.write_text(header.read_text().replace('"n_faces": 0', '"n_faces": 1'))
    estimator = LaplacianEigenTransformer(memory=str(tmp_path), eigen_index=1)
    with pytest.warns(CacheWarning, match="do not fit the point cloud"):
        (field,) = estimator.fit_transform([sampled])
    assert len(field.faces) == 0


def _tamper_edges(folder, edit):
    (path,) = folder.rglob("edges.npy")
    edges = np.load(path)
    np.save(path, edit(edges))


@pytest.mark.parametrize(
    "edit",
    [
        pytest.param(lambda e: e + len(e), id="out of range"),
        pytest.param(lambda e: e[::-1].copy(), id="unsorted"),
        pytest.param(lambda e: e[:, ::-1].copy(), id="reversed ends"),
        pytest.param(lambda e: np.vstack([e, e]), id="repeated"),
        pytest.param(lambda e: e.astype(np.float64), id="float"),
        pytest.param(lambda e: np.zeros((10**6, 2), np.int64), id="too many"),
        pytest.param(lambda e: e[:0], id="none"),
        pytest.param(lambda e: e[e.max(axis=1) < e.max() - 5], id="points left out"),
    ],
)
def test_the_cache_refuses_a_tampered_cloud_complex(tmp_path, sampled, edit):
    first = fields([sampled], memory=str(tmp_path), eigen_index=1)[0]
    _tamper_edges(tmp_path, edit)
    estimator = LaplacianEigenTransformer(memory=str(tmp_path), eigen_index=1)
    with pytest.warns(CacheWarning, match="recomputed"):
        (field,) = estimator.fit_transform([sampled])
    np.testing.assert_array_equal(field.edges, first.edges)


def test_the_complex_of_a_cleaned_cloud_joins_kept_points_only(sampled):
    stray = np.vstack([sampled, sampled.mean(axis=0) + 10 * np.ptp(sampled, axis=0)])
    (field,) = fields([stray], eigen_index=1)  # one point dropped: too few to warn
    assert len(field.vertices) == len(sampled)
    assert field.edges.max() < len(field.vertices)
    (clean,) = fields([sampled], eigen_index=1)
    np.testing.assert_array_equal(field.edges, clean.edges)


def test_the_complex_is_the_edges_of_the_operators_triangles(sampled):
    (field,) = fields([sampled], eigen_index=1)
    order = canonical_order(sampled)
    L, _, triangles = cloud_operator(unit_box(sampled[order])[0])
    a = order[triangles[:, [0, 1, 2]].ravel()]
    b = order[triangles[:, [1, 2, 0]].ravel()]
    expected = np.unique(np.column_stack([np.minimum(a, b), np.maximum(a, b)]), axis=0)
    np.testing.assert_array_equal(field.edges, expected)
    # and those are the couplings of the operator, nothing more
    coupled = sp.triu(L, 1).tocoo()
    pairs = np.sort(np.column_stack([order[coupled.row], order[coupled.col]]), axis=1)
    assert {tuple(p) for p in pairs} <= {tuple(e) for e in expected}


def test_clone_and_pickle(estimator_round_trip, sampled):
    X = [sampled]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        result = estimator_round_trip(
            LaplacianEigenTransformer(eigen_index=1), X, {"eigen_index": 2}
        )
        estimator_round_trip(LowerStarPersistence(), result, {"filtration": "sublevel"})
    restored = pickle.loads(pickle.dumps(result[0]))
    np.testing.assert_array_equal(restored.edges, result[0].edges)


@pytest.mark.parametrize("signature", ["hks", "log-hks", "wks"])
def test_signatures_and_unit_area_normalization(sampled, signature):
    small, large = fields([sampled, sampled * 1e3], signature=signature, n_eigenpairs=16)
    scale = np.abs(small.values).max()
    np.testing.assert_allclose(large.values, small.values, rtol=1e-8, atol=1e-10 * scale)
    assert small.values.shape == (len(sampled), 5)


# Sampling points from meshes


def test_sample_point_cloud_is_uniform_deterministic_and_noisy():
    sphere = trimesh.creation.icosphere(4)
    points = sample_point_cloud(sphere, 2000, random_state=0)
    np.testing.assert_array_equal(points, sample_point_cloud(sphere, 2000, random_state=0))
    assert np.abs(np.linalg.norm(points, axis=1) - 1).max() < 0.01  # on the surface
    # Area-weighted: two triangles of areas 1/2 and 9/2 get a tenth and nine tenths.
    corners = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [10, 0, 0], [13, 0, 0], [10, 3, 0]]
    two = (np.array(corners, dtype=float), [[0, 1, 2], [3, 4, 5]])
    flat = sample_point_cloud(two, 20000, random_state=0)
    assert np.mean(flat[:, 0] < 5) == pytest.approx(0.1, abs=0.01)
    noisy = sample_point_cloud(sphere, 2000, noise=0.01, random_state=0)
    diagonal = np.linalg.norm(np.ptp(sphere.vertices, axis=0))
    assert np.std(noisy - points) / (0.01 * diagonal) == pytest.approx(1.0, abs=0.05)


@pytest.mark.parametrize("m", [0, 1, 50, 5000])
def test_unique_edges_is_numpys_unique_of_the_sorted_pairs(m):
    from sklearn_meshph.pointcloud.graph import unique_edges

    rng = np.random.default_rng(m)
    a, b = rng.integers(0, 40, m), rng.integers(0, 40, m)  # loops and repeats
    pairs = np.column_stack([np.minimum(a, b), np.maximum(a, b)])
    expected = np.unique(pairs[pairs[:, 0] != pairs[:, 1]], axis=0).reshape(-1, 2)
    found = unique_edges(a, b, 40)
    assert found.dtype == np.int64 and found.shape == expected.shape
    np.testing.assert_array_equal(found, expected)


def test_a_cloud_file_of_blank_lines_is_refused_without_reading_it_all(tmp_path):
    """Each blank line is read on its own: 512 MiB of them took 5 minutes to refuse."""
    import gzip
    import time

    from sklearn_meshph.pointcloud.reading import read_point_cloud_file

    path = tmp_path / "blank.xyz.gz"
    path.write_bytes(gzip.compress(b"\n" * 200_000_000 + b"0 0 0\n" * 4))
    start = time.perf_counter()
    with pytest.raises(ValueError, match=r"blank\.xyz\.gz.*1000001 of its first 1000001 lines"):
        read_point_cloud_file(path)
    assert time.perf_counter() - start < 30  # about 1 s; the whole file took about 2 min
    commented = tmp_path / "commented.xyz"  # a comment per point is no problem
    commented.write_text("".join(f"# point {i}\n{i} {i % 7} {i % 5}\n" for i in range(100)))
    assert read_point_cloud_file(commented).shape == (100, 3)
