"""Any iterable of samples is read once; a dict or a single sample is refused clearly."""

import numpy as np
import pytest
from conftest import irregular_ellipsoid

from sklearn_meshph import (
    CombinedDistance,
    DiagramDistance,
    LaplacianEigenTransformer,
    LowerStarPersistence,
    PersistenceImage,
    ShapeDNA,
    SlicedWassersteinKernel,
)

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
    combined = CombinedDistance(
        [("dna", ShapeDNA(n_eigenvalues=5)), ("again", ShapeDNA(n_eigenvalues=5))]
    )
    # ShapeDNA gives features, not distances: what matters here is that both parts see X.
    assert combined.fit_transform(f for f in fields).shape == (3, 5)


@pytest.mark.parametrize(
    "estimator", [LaplacianEigenTransformer(), DiagramDistance(), PersistenceImage()]
)
def test_a_dict_or_a_single_sample_is_refused_with_a_clear_message(estimator):
    with pytest.raises(TypeError, match="dict.*keys"):
        estimator.fit({"a": MESHES[0], "b": MESHES[1]})
    with pytest.raises(TypeError, match="single str"):
        estimator.fit("meshes/")
