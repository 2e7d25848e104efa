"""CombinedDistance: one persistence per sample for the parts that differ only by the
diagrams they keep (the default's three extended kinds), outputs as before."""

import pickle

import numpy as np
import pytest
from conftest import assert_identical
from joblib import parallel_backend
from sklearn.base import clone
from sklearn.pipeline import make_pipeline

import sklearn_meshph.combine as combine
import sklearn_meshph.persistence.transformer as persistence
from sklearn_meshph import (
    CombinedDistance,
    DiagramDistance,
    LowerStarPersistence,
    make_mesh_distance,
    make_shapes,
)
from sklearn_meshph.spectral import LaplacianEigenTransformer


@pytest.fixture(scope="module")
def meshes():
    return make_shapes(n_per_class=2, classes=("blob", "snake", "tripod"), random_state=0).data


@pytest.fixture(scope="module")
def fields(meshes):
    return make_mesh_distance(n_jobs=1).steps[0][1].fit_transform(meshes)


@pytest.fixture
def count_persistence(monkeypatch):
    """The number of samples whose diagrams were computed (one call of the function
    that builds a sample's complex and computes its functions' diagrams)."""
    calls, original = [], persistence._diagrams_of

    def counting(arrays, **options):
        calls.append(options["keep"])
        return original(arrays, **options)

    monkeypatch.setattr(persistence, "_diagrams_of", counting)
    return calls


def unshared(monkeypatch):
    monkeypatch.setattr(combine, "_persistence_groups", lambda parts: [])


def fit_and_transform(distance, fields):
    """fit_transform on the first four samples, transform of the others, and each
    fitted part's diagrams."""
    fitted = distance.fit_transform(fields[:4])
    transformed = distance.transform(fields[4:])
    diagrams = {name: part.steps[-1][1].diagrams_ for name, part in distance.parts_[:-1]}
    return fitted, transformed, diagrams


@pytest.mark.parametrize("n_jobs", [1, 2])
def test_the_defaults_kinds_share_one_persistence_per_sample(
    fields, count_persistence, monkeypatch, n_jobs
):
    """The default's ord1, ext0 and ext1 parts: one persistence per sample in
    fit_transform and in transform (three before), the matrices and each part's fitted
    diagrams bit for bit those of a run without sharing."""
    distance = make_mesh_distance(n_jobs=n_jobs).named_steps["distance"]
    with parallel_backend("threading"):
        shared = fit_and_transform(clone(distance), fields)
    assert len(count_persistence) == len(fields)
    assert all(keep == [1, 2, 3] for keep in count_persistence)
    count_persistence.clear()
    unshared(monkeypatch)
    with parallel_backend("threading"):
        expected = fit_and_transform(clone(distance), fields)
    assert len(count_persistence) == 3 * len(fields)
    assert_identical(list(shared[:2]), list(expected[:2]))
    assert shared[2].keys() == expected[2].keys() == {"ord1", "ext0", "ext1"}
    for kind in expected[2]:
        assert_identical(shared[2][kind], expected[2][kind])


def test_parts_of_other_settings_are_computed_apart(fields, count_persistence, monkeypatch):
    """Parts share a persistence only with those of equal settings but ``parts``: each
    gets its own diagrams (kinds in the filtration's order, function-major, an array
    alone or a tuple), the others are computed as before; a member refuses its own
    bad ``parts`` by name."""

    def part(**params):
        return make_pipeline(LowerStarPersistence(**params), DiagramDistance())

    extended = {"filtration": "extended"}
    distance = CombinedDistance(
        [
            ("all", part(**extended)),  # parts=None: all four
            ("two", part(**extended, parts=("ext0", "ord0"))),
            ("ext1", part(**extended, parts=("essential H1",))),
            ("apart", part(**extended, parts=("ext0",), min_persistence=0.01)),
            ("symmetric", part(parts=("ext0",))),
            ("symmetric h0", part(parts=("h0",))),
        ]
    )
    shared = distance.fit_transform(fields[:4]), distance.transform(fields[4:])
    # {all, two, ext1}, {apart} and {symmetric, symmetric h0}
    assert len(count_persistence) == 3 * len(fields)
    steps = [part.steps[0][1] for _, part in distance.parts_[:3]]
    for step, own in zip(steps, combine._shared_diagrams(steps, fields, fit=False), strict=True):
        assert_identical(own, clone(step).fit_transform(fields))
    count_persistence.clear()
    unshared(monkeypatch)
    expected = distance.fit_transform(fields[:4]), distance.transform(fields[4:])
    assert len(count_persistence) == 6 * len(fields)
    assert_identical(list(shared), list(expected))
    monkeypatch.undo()
    bad = distance.set_params(two__lowerstarpersistence__parts=("ext0", "bad"))
    with pytest.raises(ValueError, match=r"filtration='extended': .*got \('ext0', 'bad'\)"):
        bad.fit(fields[:4])


def test_one_function_per_sample_gives_arrays(meshes, monkeypatch):
    """One function per sample: a part of one kind gets an array per sample, a part of
    two a tuple, as its own persistence makes them."""
    fields = LaplacianEigenTransformer(n_eigenpairs=6, eigen_index=(2,)).fit_transform(meshes)
    steps = [
        LowerStarPersistence("extended", parts=parts)
        for parts in [("ord1",), ("ext0", "ord1"), ("ext1",)]
    ]
    diagrams = combine._shared_diagrams(steps, fields, fit=True)
    for step, own in zip(steps, diagrams, strict=True):
        assert_identical(own, clone(step).fit_transform(fields))
    assert isinstance(diagrams[0][0], np.ndarray) and len(diagrams[1][0]) == 2
    distance = CombinedDistance(
        [(str(k), make_pipeline(step, DiagramDistance())) for k, step in enumerate(steps)]
    )
    shared = distance.fit_transform(fields[:4]), distance.transform(fields[4:])
    unshared(monkeypatch)
    expected = distance.fit_transform(fields[:4]), distance.transform(fields[4:])
    assert_identical(list(shared), list(expected))


def test_the_defaults_parameters_clone_and_pickle(fields, count_persistence, monkeypatch):
    """The default's parameters are the parts' own (``distance__ext1__...``); a kind
    whose settings change leaves the group, and is computed apart, as before; clone and
    pickle round-trip the fitted default."""
    pipeline = make_mesh_distance(n_jobs=1)
    params = pipeline.get_params()
    assert params["distance__ext1__persistence__parts"] == ("ext1",)
    assert clone(pipeline).get_params().keys() == params.keys()
    distance = clone(pipeline.named_steps["distance"])
    distance.set_params(ext1__persistence__min_persistence=0.05)
    changed = distance.fit_transform(fields[:4]), distance.transform(fields[4:])
    assert len(count_persistence) == 2 * len(fields)  # {ord1, ext0} and {ext1}
    restored = pickle.loads(pickle.dumps(distance))
    assert restored.get_params().keys() == distance.get_params().keys()
    assert_identical(restored.transform(fields[4:]), changed[1])
    unshared(monkeypatch)
    assert_identical(
        [distance.fit_transform(fields[:4]), distance.transform(fields[4:])], list(changed)
    )
