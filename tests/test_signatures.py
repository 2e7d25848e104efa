"""Spectral signatures: closed forms on the sphere, sign and basis independence, scale and
resolution invariance, one cached solve for every signature grid."""

from pathlib import Path

import joblib
import numpy as np
import pytest
import trimesh
from conftest import irregular_ellipsoid
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
    # The same surface, each triangle split in four: the values at the original
    # vertices agree to discretization error.
    fine_v, fine_f = trimesh.remesh.subdivide(vertices, faces)
    fine = est.fit_transform([(fine_v, fine_f)])[0].values[: len(vertices)]
    if signature == "log-hks":  # a log: compare the ratio of the signatures, exp(diff)
        relative = np.abs(fine - reference).max(axis=0)
    else:
        relative = np.abs(fine - reference).max(axis=0) / np.abs(reference).max(axis=0)
    tolerance = 0.1 if signature == "log-hks" else 0.05
    assert relative.max() < tolerance, relative


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
