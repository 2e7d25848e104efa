"""Shape-DNA from the eigen stage's cached spectrum, and FeatureDistance."""

import joblib
import numpy as np
import pytest
import trimesh
from conftest import irregular_ellipsoid
from scipy.spatial.distance import cdist
from sklearn.neighbors import KNeighborsClassifier
from sklearn.pipeline import make_pipeline

from sklearn_meshph import (
    FeatureDistance,
    LaplacianEigenTransformer,
    ShapeDNA,
    laplacian_eigenfunctions,
    make_shapes,
)


def test_spectrum_is_the_unit_area_eigenvalues():
    vertices, faces = irregular_ellipsoid(3, seed=3)
    area = trimesh.Trimesh(vertices, faces, process=False).area
    fields = LaplacianEigenTransformer(n_eigenpairs=12).fit_transform([(vertices, faces)])
    values, _ = laplacian_eigenfunctions((vertices, faces), 12)
    np.testing.assert_allclose(fields[0].spectrum[:12], values * area, rtol=1e-8, atol=1e-9)
    dna = ShapeDNA(n_eigenpairs=11).fit_transform(fields)
    np.testing.assert_allclose(dna[0], values[1:11] * area, rtol=1e-8)


def test_shape_dna_is_invariant_to_scale_and_pose():
    vertices, faces = irregular_ellipsoid(3, seed=4)
    rotation = trimesh.transformations.random_rotation_matrix(np.random.default_rng(5).random(3))
    moved = vertices @ rotation[:3, :3].T * 0.01 + 4.0
    eigen = LaplacianEigenTransformer(signature="hks", n_eigenpairs=16)
    dna = ShapeDNA(n_eigenpairs=16).fit_transform(
        eigen.fit_transform([(vertices, faces), (moved, faces)])
    )
    np.testing.assert_allclose(dna[1], dna[0], rtol=1e-7)


def test_shape_dna_says_how_many_eigenpairs_to_solve():
    fields = LaplacianEigenTransformer(eigen_index=1).fit_transform([irregular_ellipsoid(2)])
    message = r"sample 0: .*needs 31 eigenpairs, the field has 2 eigenpairs.*n_eigenpairs"
    with pytest.raises(ValueError, match=message):
        ShapeDNA().fit_transform(fields)


def test_feature_distance_is_scipy_canberra_and_feeds_knn(tmp_path):
    meshes, y = make_shapes(n_per_class=3, random_state=0, return_X_y=True)
    memory = joblib.Memory(tmp_path, verbose=0)
    pipe = make_pipeline(
        LaplacianEigenTransformer(signature="hks", n_eigenpairs=24, memory=memory),
        ShapeDNA(n_eigenpairs=21),
        FeatureDistance(),
        KNeighborsClassifier(1, metric="precomputed"),
    )
    pipe.fit(meshes[::2], y[::2])
    features = pipe[:2].transform(meshes)
    matrix = pipe[:3].transform(meshes[1::2])
    np.testing.assert_allclose(matrix, cdist(features[1::2], features[::2], "canberra"))
    assert pipe.predict(meshes[1::2]).shape == (len(meshes[1::2]),)
    assert list(pipe[1].get_feature_names_out()[:2]) == ["eigenvalue_1", "eigenvalue_2"]


def test_round_trips(estimator_round_trip):
    fields = LaplacianEigenTransformer(signature="hks", n_eigenpairs=12).fit_transform(
        [irregular_ellipsoid(2, seed=s) for s in range(2)]
    )
    estimator_round_trip(ShapeDNA(n_eigenpairs=6), fields, {"n_eigenpairs": 5})
    features = ShapeDNA(n_eigenpairs=6).fit_transform(fields)
    estimator_round_trip(FeatureDistance(), features, {"metric": "euclidean"})


def test_n_eigenpairs_counts_as_the_eigen_stage_does():
    # ShapeDNA(n_eigenpairs=k) after LaplacianEigenTransformer(n_eigenpairs=k): the k - 1
    # eigenvalues after the constant one, no more and no fewer.
    eigen = LaplacianEigenTransformer(signature="hks", n_eigenpairs=9)
    fields = eigen.fit_transform([irregular_ellipsoid(2, seed=1)])
    assert len(fields[0].spectrum) == 9
    dna = ShapeDNA(n_eigenpairs=9).fit(fields)
    np.testing.assert_array_equal(dna.transform(fields)[0], fields[0].spectrum[1:])
    assert len(dna.get_feature_names_out()) == 8
    with pytest.raises(ValueError, match=r"ShapeDNA\(n_eigenpairs=10\) needs 10 eigenpairs"):
        ShapeDNA(n_eigenpairs=10).fit_transform(fields)


def test_the_former_n_eigenvalues_still_works_with_a_future_warning():
    fields = LaplacianEigenTransformer(signature="hks", n_eigenpairs=9).fit_transform(
        [irregular_ellipsoid(2, seed=1)]
    )
    with pytest.warns(FutureWarning, match=r"write ShapeDNA\(n_eigenpairs=8\)"):
        old = ShapeDNA(n_eigenvalues=7).fit_transform(fields)
    np.testing.assert_array_equal(old, ShapeDNA(n_eigenpairs=8).fit_transform(fields))
