import os
import pickle
import shutil
from pathlib import Path

import numpy as np
import pytest
import trimesh
from hypothesis import settings
from sklearn.base import clone

from sklearn_meshph import ScalarField

DATA_DIR = Path(
    os.environ.get(
        "SKLEARN_MESHPH_DATA", Path(__file__).resolve().parents[1] / ".." / "shared" / "data"
    )
)


def data_folder(name: str, title: str) -> Path:
    """``$SKLEARN_MESHPH_DATA/name``, or a clean skip when it is absent."""
    path = DATA_DIR / name
    if not path.is_dir():
        pytest.skip(f"{title} data not found at {path} (set SKLEARN_MESHPH_DATA)")
    return path


@pytest.fixture(scope="session")
def sumner_dir():
    """The Sumner meshes (research data, never bundled)."""
    return data_folder("sumner", "Sumner")


@pytest.fixture(scope="session")
def watertight_dir():
    """The SHREC'07 Watertight development half: 200 `.off.gz` meshes, 20 classes."""
    return data_folder("watertight_dev", "Watertight")


@pytest.fixture(scope="session")
def icosphere3():
    mesh = trimesh.creation.icosphere(3)
    return np.asarray(mesh.vertices), np.asarray(mesh.faces)


def irregular_ellipsoid(subdivisions=3, seed=0, jitter=0.1, shuffle=False):
    """An icosphere scaled to the ellipsoid of semi-axes (1, 1.4, 2.1), its vertices
    moved by Gaussian noise of ``jitter`` times ``2 ** -subdivisions`` (about a tenth of
    an edge by default): irregular triangles and simple low eigenvalues, no symmetry.

    ``jitter=0`` gives the plain ellipsoid; ``shuffle`` numbers the vertices at random
    (no helpful vertex order). ``subdivisions=6`` gives 40,962 vertices. Returns
    ``(vertices, faces)`` arrays; the same arguments always give the same mesh, bit for
    bit.
    """
    sphere = trimesh.creation.icosphere(subdivisions)
    vertices = np.asarray(sphere.vertices) * [1.0, 1.4, 2.1]
    faces = np.asarray(sphere.faces)
    rng = np.random.default_rng(seed)
    if jitter:
        vertices = vertices + rng.normal(scale=jitter * 2.0 ** (-subdivisions), size=vertices.shape)
    if shuffle:
        order = rng.permutation(len(vertices))
        vertices, faces = vertices[order], np.argsort(order)[faces]
    return vertices, faces


@pytest.fixture(scope="session")
def make_irregular_ellipsoid():
    """The mesh factory :func:`irregular_ellipsoid`: ``make_irregular_ellipsoid(4)``."""
    return irregular_ellipsoid


def nest_folders(folder, depth):
    """``folder`` made, with ``depth`` folders ``d`` nested in it (deeper than a path
    can name: each made relative to its parent's descriptor), a file in the deepest."""
    folder.mkdir()
    parent = os.open(folder, os.O_RDONLY)
    for _ in range(depth):
        os.mkdir("d", dir_fd=parent)
        inner = os.open("d", os.O_RDONLY, dir_fd=parent)
        os.close(parent)
        parent = inner
    os.close(os.open("data.npy", os.O_CREAT | os.O_WRONLY, dir_fd=parent))
    os.close(parent)


def remove_nested(folder):
    """Remove a tree of :func:`nest_folders` without recursion (pytest's clean-up of
    its temporary folders recurses, and fails on it): each level is lifted up one."""
    while (folder / "d" / "d").is_dir():
        os.rename(folder / "d" / "d", folder / "lifted")
        os.rmdir(folder / "d")
        os.rename(folder / "lifted", folder / "d")
    shutil.rmtree(folder)


def assert_identical(actual, expected):
    """Bit-for-bit equality of transformer outputs: arrays, ScalarFields, and lists or
    tuples of them (types, lengths and dtypes included)."""
    assert type(actual) is type(expected)
    if isinstance(expected, ScalarField):
        for name in ("vertices", "faces", "values", "eigenvalues", "vertex_indices"):
            assert_identical(getattr(actual, name), getattr(expected, name))
    elif isinstance(expected, list | tuple):
        assert len(actual) == len(expected)
        for a, b in zip(actual, expected, strict=True):
            assert_identical(a, b)
    elif expected is not None:
        assert actual.dtype == expected.dtype
        np.testing.assert_array_equal(actual, expected)


def check_estimator_round_trip(estimator, X, new_params, fit_X=None):
    """The scikit-learn estimator contract shared by the three transformers.

    - ``clone`` gives another estimator with equal ``get_params()``;
    - ``set_params(**new_params)`` on the clone changes what its ``get_params()`` reports
      (each new value must differ from the estimator's) and leaves the estimator alone;
      setting the old parameters back restores them;
    - the estimator fitted on ``fit_X`` (default ``X``) survives a pickle round trip:
      same parameters, and ``transform(X)`` identical bit for bit.

    Returns the fitted estimator's ``transform(X)``.
    """
    params = estimator.get_params()
    cloned = clone(estimator)
    assert cloned is not estimator
    assert cloned.get_params() == params
    assert cloned.set_params(**new_params) is cloned
    for name, value in new_params.items():
        assert params[name] != value, f"{name}={value!r} is not a new value"
        assert cloned.get_params()[name] == value
    assert estimator.get_params() == params
    assert cloned.set_params(**params).get_params() == params

    fitted = estimator.fit(X if fit_X is None else fit_X)
    assert fitted is estimator
    expected = fitted.transform(X)
    restored = pickle.loads(pickle.dumps(fitted))
    assert type(restored) is type(fitted)
    assert restored.get_params() == params
    assert_identical(restored.transform(X), expected)
    return expected


@pytest.fixture(scope="session")
def estimator_round_trip():
    """:func:`check_estimator_round_trip`: clone, get/set_params and pickle checks."""
    return check_estimator_round_trip


# CI runs the property tests on a fixed set of examples, so that a run is reproducible;
# locally hypothesis explores new examples every time. `.ci/run` sets CI; with CI set,
# the "ci" profile wins over whatever else selects a profile (`--hypothesis-profile` in
# PYTEST_ADDOPTS, a plugin), since it is loaded after every other plugin has configured.
settings.register_profile("ci", settings.get_profile("ci"), derandomize=True, database=None)


@pytest.hookimpl(trylast=True)
def pytest_configure(config):
    if os.environ.get("CI"):
        settings.load_profile("ci")
