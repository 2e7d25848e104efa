"""CombinedDistance: the contract of a weighted sum of normalized distance matrices."""

import pickle

import joblib
import numpy as np
import pytest
from sklearn.base import clone
from sklearn.manifold import TSNE
from sklearn.model_selection import GridSearchCV
from sklearn.neighbors import KNeighborsClassifier
from sklearn.pipeline import make_pipeline

from sklearn_meshph import (
    CombinedDistance,
    DiagramDistance,
    FeatureDistance,
    LaplacianEigenTransformer,
    LowerStarPersistence,
    ShapeDNA,
    make_shapes,
)


@pytest.fixture(scope="module")
def fields_and_labels():
    meshes, y = make_shapes(n_per_class=4, random_state=2, return_X_y=True)
    eigen = LaplacianEigenTransformer(signature="hks", n_eigenpairs=24, n_scales=3)
    return eigen.fit_transform(meshes), y


def parts():
    return [
        ("diagrams", make_pipeline(LowerStarPersistence(), DiagramDistance())),
        ("dna", make_pipeline(ShapeDNA(n_eigenvalues=20), FeatureDistance())),
    ]


def off_diagonal_median(matrix):
    return np.median(matrix[~np.eye(len(matrix), dtype=bool)])


def test_the_weighted_sum_of_median_normalized_parts(fields_and_labels):
    fields, _ = fields_and_labels
    train, test = fields[::2], fields[1::2]
    combined = CombinedDistance(parts(), weights={"dna": 0.25})
    matrix = combined.fit_transform(train)
    a = make_pipeline(LowerStarPersistence(), DiagramDistance()).fit(train)
    b = make_pipeline(ShapeDNA(n_eigenvalues=20), FeatureDistance()).fit(train)
    da, db = a.transform(train), b.transform(train)
    expected = da / off_diagonal_median(da) + 0.25 * db / off_diagonal_median(db)
    np.testing.assert_allclose(matrix, expected, rtol=1e-12)
    np.testing.assert_allclose(matrix, matrix.T)
    rectangle = combined.transform(test)
    expected = a.transform(test) / off_diagonal_median(da) + 0.25 * b.transform(
        test
    ) / off_diagonal_median(db)
    np.testing.assert_allclose(rectangle, expected, rtol=1e-12)
    raw = CombinedDistance(parts(), normalization="none").fit_transform(train)
    np.testing.assert_allclose(raw, da + db, rtol=1e-12)


def test_composes_with_grid_search_and_tsne(fields_and_labels, tmp_path):
    fields, y = fields_and_labels
    pipe = make_pipeline(
        CombinedDistance(parts()), KNeighborsClassifier(n_neighbors=1, metric="precomputed")
    )
    grid = GridSearchCV(
        pipe,
        {
            "combineddistance__weights": [{"dna": 0.0}, {"diagrams": 0.0}, None],
            "combineddistance__diagrams__diagramdistance__metric": ["bottleneck", "wasserstein"],
        },
        cv=2,
    ).fit(fields, y)
    assert grid.best_score_ > 0.5
    matrix = CombinedDistance(parts()).fit_transform(fields)
    embedding = TSNE(metric="precomputed", init="random", perplexity=5, random_state=0)
    assert embedding.fit_transform(matrix).shape == (len(fields), 2)


def test_parameters_clone_and_pickle(fields_and_labels):
    fields, _ = fields_and_labels
    combined = CombinedDistance(parts(), weights={"dna": 2.0})
    params = combined.get_params()
    assert params["dna__shapedna__n_eigenvalues"] == 20
    copy = clone(combined).set_params(dna__shapedna__n_eigenvalues=10, weights=None)
    assert copy.get_params()["dna__shapedna__n_eigenvalues"] == 10
    assert combined.get_params()["dna__shapedna__n_eigenvalues"] == 20
    fitted = combined.fit(fields[:8])
    restored = pickle.loads(pickle.dumps(fitted))
    np.testing.assert_array_equal(restored.transform(fields[8:]), fitted.transform(fields[8:]))
    assert joblib.hash(clone(combined).get_params(deep=False)) == joblib.hash(
        combined.get_params(deep=False)
    )


def test_bad_settings_are_refused(fields_and_labels):
    fields, _ = fields_and_labels
    with pytest.raises(ValueError, match="unknown parts"):
        CombinedDistance(parts(), weights={"spectrum": 1.0}).fit(fields)
    with pytest.raises(ValueError, match="distinct names"):
        CombinedDistance(parts() + parts()).fit(fields)
    with pytest.raises(ValueError, match="normalization"):
        CombinedDistance(parts(), normalization="max").fit(fields)


def test_a_part_that_separates_nothing_adds_nothing(fields_and_labels):
    """Essential H1 of genus-0 shapes: every distance is 0; the part must not fail."""
    fields, _ = fields_and_labels
    h1 = make_pipeline(
        LowerStarPersistence(filtration="extended", parts=("essential H1",)), DiagramDistance()
    )
    dna = make_pipeline(ShapeDNA(n_eigenvalues=20), FeatureDistance())
    combined = CombinedDistance([("h1", h1), ("dna", dna)]).fit(fields[:8])
    assert combined.scales_["h1"] == 1.0
    alone = CombinedDistance([("dna", dna)]).fit(fields[:8])
    np.testing.assert_allclose(combined.transform(fields[8:]), alone.transform(fields[8:]))
