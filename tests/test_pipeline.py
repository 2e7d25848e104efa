"""The paper's pipeline end to end: scikit-learn composition, grid search, pickling."""

import pickle

import joblib
import numpy as np
import pytest
import trimesh
from scipy.spatial.transform import Rotation
from sklearn.manifold import TSNE
from sklearn.model_selection import GridSearchCV, StratifiedKFold, cross_val_score
from sklearn.neighbors import KNeighborsClassifier
from sklearn.pipeline import make_pipeline

from sklearn_meshph import (
    DiagramDistance,
    LaplacianEigenTransformer,
    LowerStarPersistence,
    make_shapes,
)


@pytest.fixture(scope="module")
def shapes():
    return make_shapes(n_per_class=6, random_state=0, return_X_y=True)


def pipeline(**eigen_params):
    return make_pipeline(
        LaplacianEigenTransformer(**eigen_params),
        LowerStarPersistence(),
        DiagramDistance(),
        KNeighborsClassifier(n_neighbors=1, metric="precomputed"),
    )


def test_cross_val_score_of_the_default_pipeline(shapes):
    meshes, y = shapes
    scores = cross_val_score(pipeline(), meshes, y, cv=StratifiedKFold(3))
    assert scores.mean() >= 0.85  # chance is 1/6; 4 training meshes per class


def test_pipeline_cv_equals_cv_on_the_precomputed_matrix(shapes):
    # The main job computes the full matrix once; that is the pipeline's result because
    # the first three stages are per-sample or pairwise and learn nothing else.
    meshes, y = shapes
    cv = StratifiedKFold(3, shuffle=True, random_state=1)
    pipe_scores = cross_val_score(pipeline(), meshes, y, cv=cv)
    fields = LaplacianEigenTransformer().fit_transform(meshes)
    matrix = DiagramDistance().fit_transform(LowerStarPersistence().fit_transform(fields))
    knn = KNeighborsClassifier(n_neighbors=1, metric="precomputed")
    scores = cross_val_score(knn, matrix, y, cv=cv)  # slices matrix[test][:, train]
    np.testing.assert_allclose(scores, pipe_scores)


def test_grid_search_over_eigen_index_solves_each_mesh_once(shapes, tmp_path):
    meshes, y = shapes
    memory = joblib.Memory(tmp_path, verbose=0)
    grid = GridSearchCV(
        pipeline(memory=memory),
        {"laplacianeigentransformer__eigen_index": [1, 2, 3, 4, 5]},
        cv=StratifiedKFold(3),
    )
    grid.fit(meshes, y)
    assert sum(1 for _ in tmp_path.rglob("header.json")) == len(meshes)
    assert grid.best_params_["laplacianeigentransformer__eigen_index"] in range(1, 6)


def test_tsne_on_the_distance_matrix(shapes):
    meshes, y = shapes
    diagrams = make_pipeline(LaplacianEigenTransformer(), LowerStarPersistence()).fit_transform(
        meshes
    )
    matrix = DiagramDistance().fit_transform(diagrams)
    assert matrix.shape == (len(meshes), len(meshes))
    np.testing.assert_array_equal(matrix, matrix.T)
    assert np.all(np.diag(matrix) == 0) and np.isfinite(matrix).all()
    embedding = TSNE(metric="precomputed", init="random", perplexity=5, random_state=0)
    assert embedding.fit_transform(matrix).shape == (len(meshes), 2)


def test_fitted_pipeline_pickles_with_identical_predictions(shapes):
    meshes, y = shapes
    fitted = pipeline().fit(meshes[::2], y[::2])
    restored = pickle.loads(pickle.dumps(fitted))
    np.testing.assert_array_equal(restored.predict(meshes[1::2]), fitted.predict(meshes[1::2]))


def test_moved_rescaled_and_refined_copies_are_classified_like_originals(shapes):
    meshes, y = shapes
    fitted = pipeline().fit(meshes, y)
    rng = np.random.default_rng(0)
    copies = []
    for mesh in meshes:
        vertices, faces = trimesh.remesh.subdivide(mesh.vertices, mesh.faces)
        rotation = Rotation.random(random_state=rng.integers(1 << 31)).as_matrix()
        copies.append((vertices @ rotation.T * rng.uniform(0.2, 5.0) + rng.normal(size=3), faces))
    np.testing.assert_array_equal(fitted.predict(copies), y)
