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
    ScalarField,
    make_mesh_distance,
    make_shapes,
)
from sklearn_meshph.pipelines import PRESETS

pd = pytest.importorskip("pandas")


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
    # The scores are those of each index computed without the cache, and the best is theirs.
    fields = LaplacianEigenTransformer(eigen_index=(1, 2, 3, 4, 5)).fit_transform(meshes)
    knn = KNeighborsClassifier(n_neighbors=1, metric="precomputed")
    expected = []
    for k in range(5):
        one = [ScalarField(f.vertices, f.faces, f.values[:, k]) for f in fields]
        matrix = DiagramDistance().fit_transform(LowerStarPersistence().fit_transform(one))
        expected.append(cross_val_score(knn, matrix, y, cv=StratifiedKFold(3)).mean())
    np.testing.assert_allclose(grid.cv_results_["mean_test_score"], expected)
    assert grid.best_params_["laplacianeigentransformer__eigen_index"] == 1 + np.argmax(expected)


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


@pytest.mark.parametrize("preset", ["default", "paper", "shape-dna"])
def test_pandas_output_end_to_end(preset, tmp_path):
    """``set_output(transform="pandas")`` on the pipeline configures every step: the
    stages of fields and diagrams keep theirs, the distances come out as DataFrames
    (the presets: a CombinedDistance, a pipeline of diagrams, Shape-DNA's table)."""
    assert preset in PRESETS
    meshes, y = make_shapes(n_per_class=2, random_state=3, return_X_y=True)
    memory = joblib.Memory(tmp_path, verbose=0)
    frame = make_mesh_distance(preset, memory=memory).set_output(transform="pandas")
    frame = frame.fit_transform(meshes)
    assert isinstance(frame, pd.DataFrame) and frame.shape == (len(meshes), len(meshes))
    assert frame.columns[0].endswith("distance0")
    np.testing.assert_array_equal(
        frame.to_numpy(), make_mesh_distance(preset, memory=memory).fit_transform(meshes)
    )
    model = make_pipeline(
        make_mesh_distance(preset, memory=memory),
        KNeighborsClassifier(n_neighbors=1, metric="precomputed"),
    )
    expected = model.fit(meshes[::2], y[::2]).predict(meshes[1::2])
    model.set_output(transform="pandas").fit(meshes[::2], y[::2])
    np.testing.assert_array_equal(model.predict(meshes[1::2]), expected)
    # The stages of fields and diagrams have no feature names (their output is not a
    # table): ask the distance itself.
    last = model[0][-1]
    names = (last[-1] if hasattr(last, "steps") else last).get_feature_names_out()
    assert len(names) == len(meshes[::2]) and names[0].endswith("distance0")
