"""make_mesh_distance: the default pipeline and the settings one argument away, their
invariances, and their place in scikit-learn (grid search, one solve per mesh, pickle)."""

import pickle

import joblib
import numpy as np
import pytest
import trimesh
from conftest import irregular_ellipsoid
from scipy.spatial.transform import Rotation
from sklearn.base import clone
from sklearn.model_selection import GridSearchCV, StratifiedKFold
from sklearn.neighbors import KNeighborsClassifier
from sklearn.pipeline import make_pipeline

from sklearn_meshph import (
    CombinedDistance,
    DiagramDistance,
    LaplacianEigenTransformer,
    LowerStarPersistence,
    make_mesh_distance,
    make_shapes,
)
from sklearn_meshph.pipelines import PRESETS


@pytest.fixture(scope="module")
def shapes():
    return make_shapes(n_per_class=4, random_state=3, return_X_y=True)


@pytest.fixture(scope="module")
def default_matrix(shapes):
    meshes, _ = shapes
    return make_mesh_distance(random_state=0).fit_transform(meshes)


def test_default_separates_the_synthetic_classes(shapes, default_matrix):
    _, y = shapes
    matrix = np.array(default_matrix)
    assert matrix.shape == (len(y), len(y))
    np.testing.assert_allclose(matrix, matrix.T)
    assert np.isfinite(matrix).all() and (np.diag(matrix) == 0).all()
    np.fill_diagonal(matrix, np.inf)
    assert np.mean(y[np.argmin(matrix, axis=1)] == y) >= 0.9  # chance is 1/6


def test_the_eigenfunctions_and_paper_presets_are_the_estimators_they_name(shapes):
    meshes, _ = shapes
    meshes = meshes[:6]
    chains = {
        "eigenfunctions": (
            LaplacianEigenTransformer(random_state=0),
            LowerStarPersistence(),
            DiagramDistance(),
        ),
        "paper": (
            LaplacianEigenTransformer(
                eigen_index=1, laplacian="graph", normalization="none", random_state=0
            ),
            LowerStarPersistence(filtration="sublevel"),
            DiagramDistance(metric="bottleneck"),
        ),
    }
    for preset, (eigen, persistence, distance) in chains.items():
        expected = distance.fit_transform(persistence.fit_transform(eigen.fit_transform(meshes)))
        pipe = make_mesh_distance(preset, random_state=0)
        np.testing.assert_array_equal(pipe.fit_transform(meshes), expected)
    with pytest.warns(FutureWarning, match="'0.1' is renamed 'eigenfunctions'"):
        former = make_mesh_distance("0.1")
    assert str(former) == str(make_mesh_distance("eigenfunctions"))


def test_every_preset_fits_clones_and_pickles(shapes):
    meshes, _ = shapes
    for preset in [p for p in PRESETS if p != "graph"]:  # graphs: test_graph_learning.py
        pipe = make_mesh_distance(preset, random_state=0)
        assert [name for name, _ in pipe.steps] == ["eigen", "distance"]
        twin = clone(pipe)
        assert set(twin.get_params()) == set(pipe.get_params())
        matrix = pipe.fit_transform(meshes[:5])
        restored = pickle.loads(pickle.dumps(pipe))
        np.testing.assert_array_equal(restored.transform(meshes[5:7]), pipe.transform(meshes[5:7]))
        np.testing.assert_array_equal(twin.fit_transform(meshes[:5]), matrix)


def test_an_unknown_preset_is_refused_with_the_choices():
    with pytest.raises(ValueError, match="'preset' parameter .*'eigenfunctions', 'paper'"):
        make_mesh_distance("best")


@pytest.mark.parametrize(
    "params, message",
    [
        ({"memory": 3}, "'memory' parameter"),
        ({"memory": ""}, "memory must be a folder.*got an empty path"),
        ({"random_state": -1}, r"'random_state' parameter .*\[0, 2\*\*32 - 1\]"),
        ({"random_state": 2**32}, "'random_state' parameter"),
        ({"random_state": 0.5}, "'random_state' parameter"),
        ({"random_state": "seed"}, "'random_state' parameter"),
        ({"n_jobs": "all"}, "'n_jobs' parameter"),
    ],
)
def test_make_mesh_distance_validates_its_parameters(params, message):
    with pytest.raises(ValueError, match=message):
        make_mesh_distance(**params)


def _count_solves(monkeypatch):
    """A list that grows by one for every mesh the eigen stage actually solves."""
    from sklearn_meshph.spectral import transformer

    solves = []
    solve = transformer.mesh_eigenpairs

    def counting(*args):
        solves.append(len(args[0]))
        return solve(*args)

    monkeypatch.setattr(transformer, "mesh_eigenpairs", counting)
    return solves


def test_the_default_pipeline_caches_each_mesh_once_and_repeats(shapes, tmp_path, monkeypatch):
    meshes, _ = shapes
    meshes = meshes[:6]
    solves = _count_solves(monkeypatch)
    first = make_mesh_distance(memory=str(tmp_path)).fit_transform(meshes)
    assert len(solves) == len(meshes)
    second = make_mesh_distance(memory=str(tmp_path)).fit_transform(meshes)
    assert len(solves) == len(meshes)  # every mesh read from the cache
    np.testing.assert_array_equal(first, second)


def test_default_is_invariant_to_rigid_motion_scale_and_nearly_to_resolution(shapes):
    meshes, _ = shapes
    vertices, faces = irregular_ellipsoid(3, seed=7)
    rotation = Rotation.from_euler("xyz", [0.3, -1.1, 2.0]).as_matrix()
    moved = (vertices @ rotation.T) * 4.5 + [1.0, 2.0, -3.0]
    fine_v, fine_f = trimesh.remesh.subdivide(vertices, faces)
    shuffled = np.random.default_rng(0).permutation(len(fine_v))
    inverse = np.argsort(shuffled)
    remeshed = (fine_v[shuffled], inverse[fine_f])  # finer, and renumbered
    samples = [(vertices, faces), (moved, faces), remeshed] + list(meshes)
    matrix = make_mesh_distance(random_state=0).fit_transform(samples)
    between = np.median(matrix[3:, 3:][np.triu_indices(len(meshes), 1)])
    assert matrix[0, 1] < 1e-6 * between  # rotation, translation, scale: exact
    assert matrix[0, 2] < 0.15 * between  # resolution: discretization error only
    assert matrix[0, 2] < matrix[0, 3:].min()


def test_default_does_not_depend_on_the_solver_start_vector():
    # The heat kernel signature is a sum of squared eigenfunctions: whatever sign or
    # basis of a repeated eigenspace the solver returns (test_signatures checks both),
    # the fields, hence the diagrams, are the same; other start vectors change only
    # the last digits.
    meshes = [irregular_ellipsoid(2, seed=s) for s in range(4)]
    a = make_mesh_distance(random_state=0).fit_transform(meshes)
    b = make_mesh_distance(random_state=12345).fit_transform(meshes)
    np.testing.assert_allclose(a, b, rtol=1e-6, atol=1e-9)


@pytest.mark.parametrize("memory", ["folder", "joblib"])
def test_a_grid_over_weights_and_signature_parameters_solves_each_mesh_once(
    shapes, tmp_path, monkeypatch, memory
):
    # With the default random_state: the start vector's seed is in the cache key, and the
    # fixed default keeps it the same in every fit of the search.
    meshes, y = shapes
    solves = _count_solves(monkeypatch)
    folder = str(tmp_path) if memory == "folder" else joblib.Memory(tmp_path, verbose=0)
    model = make_pipeline(
        make_mesh_distance(memory=folder), KNeighborsClassifier(1, metric="precomputed")
    )
    grid = {
        "pipeline__eigen__n_scales": [3, 5],
        "pipeline__eigen__signature": ["hks", "log-hks"],
        "pipeline__distance__weights": [{"ext0": 0.5, "dna": 0.5}, {"dna": 0.0}],
    }
    search = GridSearchCV(model, grid, cv=StratifiedKFold(2), n_jobs=1).fit(meshes, y)
    assert len(solves) == len(meshes)  # 8 candidates, 2 folds, a refit: one solve each
    assert sum(1 for _ in tmp_path.rglob("header.json")) == len(meshes)
    assert search.best_score_ >= 0.8


def test_the_default_combines_the_parts_it_documents():
    distance = make_mesh_distance().named_steps["distance"]
    assert isinstance(distance, CombinedDistance)
    names = [name for name, _ in distance.transformer_list]
    assert names == ["ord1", "ext0", "ext1", "dna"]
    assert distance.weights == {"ord1": 1.0, "ext0": 0.5, "ext1": 1.0, "dna": 0.5}
    for name in names[:3]:
        part = distance.get_params()[f"{name}__distance"]
        assert part.normalization == "median" and part.metric == "wasserstein"
