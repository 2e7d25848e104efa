"""Spectral signatures: closed forms on the sphere, sign and basis independence, scale and
resolution invariance, one cached solve for every signature grid."""

from pathlib import Path

import joblib
import numpy as np
import pytest
import trimesh
from conftest import irregular_ellipsoid
from half_refinement import refine_upper_half
from sklearn.model_selection import GridSearchCV
from sklearn.neighbors import KNeighborsClassifier
from sklearn.pipeline import make_pipeline

from sklearn_meshph import (
    DiagramDistance,
    LaplacianEigenTransformer,
    LowerStarPersistence,
    cotangent_laplacian,
    laplacian_eigenfunctions,
)
from sklearn_meshph.spectral.signatures import (
    heat_kernel_signature,
    hks_times,
    wave_kernel_signature,
    wks_energies,
)


def sphere_hks(t, l_max):
    """HKS of the unit sphere, the same at every point (addition theorem): the sum over
    degrees l of (2l + 1) / (4 pi) exp(-l (l + 1) t)."""
    degrees = np.arange(l_max + 1)
    return np.sum((2 * degrees + 1) / (4 * np.pi) * np.exp(-degrees * (degrees + 1) * t))


@pytest.fixture(scope="module")
def unit_sphere():
    sphere = trimesh.creation.icosphere(5)  # 10,242 vertices
    return np.asarray(sphere.vertices), np.asarray(sphere.faces)


def test_heat_kernel_signature_of_the_unit_sphere_is_its_closed_form(unit_sphere):
    # Degrees 0 to 5 are 36 eigenpairs: whole eigenspaces, so the truncated sum is the
    # closed form truncated at l = 5 (negligible from t = 0.3 on: exp(-42 * 0.3) ~ 3e-6).
    values, vectors = laplacian_eigenfunctions(unit_sphere, 36)
    for t in (0.3, 1.0, 3.0):
        hks = heat_kernel_signature(values, vectors, [t])[:, 0]
        np.testing.assert_allclose(hks, sphere_hks(t, 12), rtol=2e-3)
        assert np.ptp(hks) < 2e-3 * hks.mean()  # constant over the sphere


def test_signatures_do_not_depend_on_signs_or_on_the_basis_of_an_eigenspace(unit_sphere):
    values, vectors = laplacian_eigenfunctions(unit_sphere, 25)  # degrees 0 to 4, whole
    # The mesh splits each eigenvalue l (l + 1) by about 1e-4: make each eigenspace exact
    # (its mean eigenvalue), so that any orthonormal basis of it is a valid one.
    degree_of = np.repeat(np.arange(5), 2 * np.arange(5) + 1)
    values = (np.bincount(degree_of, values) / np.bincount(degree_of))[degree_of]
    rng = np.random.default_rng(0)
    other = vectors * rng.choice([-1.0, 1.0], size=vectors.shape[1])
    # Rotate each eigenspace (l = 1..4, dimension 2l + 1) by a random orthogonal matrix.
    start = 1
    for degree in range(1, 5):
        stop = start + 2 * degree + 1
        q, _ = np.linalg.qr(rng.normal(size=(stop - start, stop - start)))
        other[:, start:stop] = other[:, start:stop] @ q
        start = stop
    times = hks_times(values, 4)
    energies, sigma = wks_energies(values, 4)
    np.testing.assert_allclose(
        heat_kernel_signature(values, other, times),
        heat_kernel_signature(values, vectors, times),
        rtol=1e-10,
    )
    np.testing.assert_allclose(
        wave_kernel_signature(values, other, energies, sigma),
        wave_kernel_signature(values, vectors, energies, sigma),
        rtol=1e-10,
    )


# Largest error of each signature when half the surface is refined, as measured with the
# cotangent Laplacian (hks 2.1%, log-hks 1.0% in log scale, wks 7.6%), with margin; the
# graph Laplacian errs by 20-23% on every one.
HALF_REFINED_TOLERANCE = {"hks": 0.04, "log-hks": 0.03, "wks": 0.1}


def _signature_error(signature, laplacian, vertices, faces, fine_v, fine_f):
    est = LaplacianEigenTransformer(
        signature=signature, n_eigenpairs=40, n_scales=4, laplacian=laplacian
    )
    reference, fine = (f.values for f in est.fit_transform([(vertices, faces), (fine_v, fine_f)]))
    fine = fine[: len(vertices)]
    if signature == "log-hks":  # a log: compare the ratio of the signatures, exp(diff)
        return np.abs(fine - reference).max()
    return (np.abs(fine - reference).max(axis=0) / np.abs(reference).max(axis=0)).max()


@pytest.mark.parametrize("signature", ["hks", "log-hks", "wks"])
def test_signatures_are_invariant_to_scale_rotation_and_nearly_to_resolution(signature):
    vertices, faces = irregular_ellipsoid(3, seed=1)
    est = LaplacianEigenTransformer(signature=signature, n_eigenpairs=40, n_scales=4)
    reference = est.fit_transform([(vertices, faces)])[0].values
    rotation = trimesh.transformations.random_rotation_matrix(np.random.default_rng(2).random(3))
    moved = (vertices @ rotation[:3, :3].T) * 7.5 + [3.0, -1.0, 2.0]
    np.testing.assert_allclose(
        est.fit_transform([(moved, faces)])[0].values, reference, rtol=1e-6, atol=1e-9
    )
    # The same surface, half of it at twice the resolution (a conforming refinement):
    # the values at the original vertices agree to discretization error, which the
    # graph Laplacian, blind to geometry, does not achieve.
    fine_v, fine_f = refine_upper_half(vertices, faces)
    tolerance = HALF_REFINED_TOLERANCE[signature]
    error = _signature_error(signature, "cotangent", vertices, faces, fine_v, fine_f)
    assert error < tolerance, error
    error = _signature_error(signature, "graph", vertices, faces, fine_v, fine_f)
    assert error > 1.5 * tolerance, error


def test_log_hks_is_the_log_of_hks_over_the_heat_trace():
    vertices, faces = irregular_ellipsoid(3, seed=5)
    hks, log_hks = (
        LaplacianEigenTransformer(signature=s, n_eigenpairs=30, n_scales=3).fit_transform(
            [(vertices, faces)]
        )[0]
        for s in ("hks", "log-hks")
    )
    values = hks.spectrum
    times = hks_times(values, 3)
    trace = np.exp(-np.outer(values, times)).sum(axis=0)
    np.testing.assert_allclose(log_hks.values, np.log(hks.values / trace), rtol=1e-12)
    # At unit area the trace is the HKS's mass-weighted mean (M-orthonormal eigenvectors).
    mass = cotangent_laplacian(vertices, faces)[1].diagonal()
    np.testing.assert_allclose(mass @ hks.values / mass.sum(), trace, rtol=1e-10)


def test_fields_have_one_column_per_scale_and_feed_persistence():
    meshes = [irregular_ellipsoid(2, seed=s) for s in range(2)]
    fields = LaplacianEigenTransformer(signature="hks", n_eigenpairs=30, n_scales=3).fit_transform(
        meshes
    )
    assert fields[0].values.shape == (len(meshes[0][0]), 3)
    assert fields[0].eigenvalues is None
    diagrams = LowerStarPersistence().fit_transform(fields)
    assert len(diagrams[0]) == 6  # two diagrams per column


def test_a_grid_over_signatures_and_scales_solves_each_mesh_once(tmp_path: Path):
    meshes = [irregular_ellipsoid(2, seed=s) for s in range(6)]
    y = np.array([0, 0, 0, 1, 1, 1])
    memory = joblib.Memory(tmp_path, verbose=0)
    pipe = make_pipeline(
        LaplacianEigenTransformer(signature="hks", n_eigenpairs=24, memory=memory),
        LowerStarPersistence(),
        DiagramDistance(),
        KNeighborsClassifier(1, metric="precomputed"),
    )
    grid = [
        {
            "laplacianeigentransformer__signature": ["hks", "log-hks", "wks"],
            "laplacianeigentransformer__n_scales": [2, 3],
        },
        {  # the eigenfunctions themselves, from the same solve
            "laplacianeigentransformer__signature": ["eigenfunctions"],
            "laplacianeigentransformer__eigen_index": [1, 4, (2, 3)],
        },
    ]
    search = GridSearchCV(pipe, grid, cv=3).fit(meshes, y)
    assert len(search.cv_results_["params"]) == 9
    assert sum(1 for _ in tmp_path.rglob("header.json")) == len(meshes)


def test_too_few_eigenpairs_is_refused_clearly():
    with pytest.raises(ValueError, match="n_eigenpairs"):
        LaplacianEigenTransformer(signature="hks", n_eigenpairs=1).fit([irregular_ellipsoid(1)])
    with pytest.raises(ValueError, match="signature"):
        LaplacianEigenTransformer(signature="heat").fit([irregular_ellipsoid(1)])


def test_n_eigenpairs_is_exactly_the_number_of_eigenpairs_used(tmp_path, monkeypatch):
    # The solver works in blocks (49 and 56 share one of 56 eigenpairs, one cached solve),
    # but each signature and spectrum sees exactly the eigenpairs asked for.
    from sklearn_meshph.spectral import transformer

    solves = []
    solve = transformer.mesh_eigenpairs
    monkeypatch.setattr(transformer, "mesh_eigenpairs", lambda *a: solves.append(a[3]) or solve(*a))
    mesh = irregular_ellipsoid(3, seed=2)
    fields = {
        k: LaplacianEigenTransformer(
            signature="hks", n_eigenpairs=k, memory=str(tmp_path)
        ).fit_transform([mesh])[0]
        for k in (49, 56)
    }
    assert [len(fields[k].spectrum) for k in (49, 56)] == [49, 56]
    np.testing.assert_array_equal(fields[49].spectrum, fields[56].spectrum[:49])
    assert np.abs(fields[49].values - fields[56].values).max() > 1e-6
    values, vectors = laplacian_eigenfunctions(mesh, 49)
    area = trimesh.Trimesh(*mesh, process=False).area
    expected = heat_kernel_signature(
        fields[49].spectrum, vectors * np.sqrt(area), hks_times(fields[49].spectrum, 5)
    )
    np.testing.assert_allclose(fields[49].values, expected, rtol=1e-6, atol=1e-9)
    assert solves == [56]  # one solve, of one block, for both


def test_eigenfunctions_need_n_eigenpairs_beyond_the_largest_index():
    with pytest.raises(ValueError, match=r"n_eigenpairs=4 does not reach eigen_index 4"):
        LaplacianEigenTransformer(eigen_index=(1, 4), n_eigenpairs=4).fit([irregular_ellipsoid(1)])
    field = LaplacianEigenTransformer(eigen_index=(1, 4), n_eigenpairs=5).fit_transform(
        [irregular_ellipsoid(2)]
    )[0]
    assert len(field.spectrum) == 5


@pytest.mark.parametrize(
    "signature, label",
    [
        ("eigenfunctions", r"eigenfunction [123]"),
        ("hks", r"heat kernel signature t=[0-9.e-]+"),
        ("log-hks", r"log heat kernel signature t=[0-9.e-]+"),
        ("wks", r"wave kernel signature e=[0-9.e-]+"),
    ],
)
def test_fields_name_their_columns(signature, label):
    import re

    field = LaplacianEigenTransformer(
        signature=signature, n_eigenpairs=20, n_scales=3
    ).fit_transform([irregular_ellipsoid(2, seed=3)])[0]
    assert len(field.column_names) == field.n_functions == 3
    assert all(re.fullmatch(label, name) for name in field.column_names), field.column_names
    if signature == "eigenfunctions":
        assert field.column_names == ("eigenfunction 1", "eigenfunction 2", "eigenfunction 3")
    elif signature != "wks":
        times = hks_times(field.spectrum, 3)
        assert field.column_names[0].endswith(f"t={times[0]:.3g}")
