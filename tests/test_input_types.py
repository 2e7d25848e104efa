"""Any iterable of samples is read once; a dict or a single sample is refused clearly."""

import numpy as np
import pytest
from conftest import irregular_ellipsoid
from sklearn.base import clone
from sklearn.pipeline import make_pipeline

from sklearn_meshph import (
    CombinedDistance,
    DiagramDistance,
    FeatureDistance,
    LaplacianEigenTransformer,
    LowerStarPersistence,
    PersistenceImage,
    ShapeDNA,
    SlicedWassersteinKernel,
)
from sklearn_meshph.inputs import KINDS, check_input, sample_kind

MESHES = [irregular_ellipsoid(1, seed=s) for s in range(3)]
DIAGRAMS = [np.array([[0.0, 1.0], [0.2, 0.5]]), np.array([[0.1, 0.9]]), np.empty((0, 2))]


@pytest.mark.parametrize(
    "estimator, samples",
    [
        (LaplacianEigenTransformer(random_state=0), MESHES),
        (DiagramDistance(), DIAGRAMS),
        (DiagramDistance(normalization="median"), DIAGRAMS),
        (PersistenceImage(resolution=(3, 3)), DIAGRAMS),
        (SlicedWassersteinKernel(), DIAGRAMS),
    ],
    ids=lambda e: type(e).__name__ if not isinstance(e, list) else "",
)
def test_a_generator_is_read_once_and_gives_the_same_result(estimator, samples):
    expected = estimator.fit_transform(list(samples))
    result = estimator.fit_transform(sample for sample in samples)
    if isinstance(expected, list):  # fields
        assert all(
            np.array_equal(a.values, b.values) for a, b in zip(expected, result, strict=True)
        )
    else:
        np.testing.assert_array_equal(result, expected)


def test_a_generator_through_persistence_and_a_combination():
    fields = LaplacianEigenTransformer(
        signature="hks", n_eigenpairs=10, random_state=0
    ).fit_transform(iter(MESHES))
    diagrams = LowerStarPersistence().fit_transform(iter(fields))
    assert len(diagrams) == len(MESHES)
    spectrum = make_pipeline(ShapeDNA(n_eigenpairs=6), FeatureDistance())
    combined = CombinedDistance(
        [("dna", spectrum), ("again", clone(spectrum))], normalization="none"
    )
    # Both parts see X (a generator is read once): twice the one part's distances.
    twice = combined.fit_transform(f for f in fields)
    np.testing.assert_allclose(twice, 2 * clone(spectrum).fit_transform(fields))


@pytest.mark.parametrize(
    "estimator", [LaplacianEigenTransformer(), DiagramDistance(), PersistenceImage()]
)
def test_a_dict_or_a_single_sample_is_refused_with_a_clear_message(estimator):
    with pytest.raises(TypeError, match="dict.*keys"):
        estimator.fit({"a": MESHES[0], "b": MESHES[1]})
    with pytest.raises(TypeError, match="single str"):
        estimator.fit("meshes/")


# The kind of a sample is decided in one place: sklearn_meshph.inputs


def test_check_input_decides_the_kind_of_every_sample(tmp_path):
    vertices, faces = MESHES[0]
    trimesh = pytest.importorskip("trimesh")
    np.savetxt(tmp_path / "scan.xyz", vertices)
    trimesh.Trimesh(vertices, faces, process=False).export(tmp_path / "mesh.ply")
    clouds = [vertices, trimesh.PointCloud(vertices), tmp_path / "scan.xyz"]
    meshes = [(vertices, faces), trimesh.Trimesh(vertices, faces, process=False)]
    meshes.append(tmp_path / "mesh.ply")
    for sample in clouds:
        assert sample_kind(sample) == "point cloud"
        points, no_faces = check_input(sample, index=2)
        assert no_faces is None and points.shape == vertices.shape
    for sample in meshes:
        assert sample_kind(sample) == "mesh"
        np.testing.assert_array_equal(check_input(sample)[1], faces)
    assert [kind.name for kind in KINDS] == ["graph", "point cloud", "mesh"]
    with pytest.raises(
        TypeError, match="sample 4: expected a trimesh.Trimesh.*point cloud.*or a graph"
    ):
        check_input(42, index=4)
    with pytest.raises(ValueError, match="sample 1: a point cloud needs at least 4 points"):
        check_input(vertices[:3], index=1)
