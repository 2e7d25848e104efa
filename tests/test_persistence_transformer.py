"""LowerStarPersistence: inputs, output layout, policies, sign invariance, estimator contract."""

import numpy as np
import pytest
import trimesh
from sklearn.base import clone

from sklearn_meshph import LowerStarPersistence, ScalarField, lower_star_persistence


def sorted_rows(diagram):
    diagram = np.asarray(diagram, dtype=float).reshape(-1, 2)
    return diagram[np.lexsort(diagram.T[::-1])]


def sphere(subdivisions=2):
    mesh = trimesh.creation.icosphere(subdivisions)
    return np.asarray(mesh.vertices), np.asarray(mesh.faces)


def test_default_output_is_exactly_sign_invariant():
    vertices, faces = sphere(3)
    values = np.column_stack([vertices[:, 2] ** 3 + vertices[:, 0], vertices[:, 1]])
    est = LowerStarPersistence()
    plus, minus = est.fit_transform([((vertices, faces), values), ((vertices, faces), -values)])
    assert len(plus) == 4  # (H0, essential) for each of the two functions
    for a, b in zip(plus, minus, strict=True):
        np.testing.assert_array_equal(sorted_rows(a), sorted_rows(b))


def test_transformer_accepts_fields_and_pairs_alike():
    vertices, faces = sphere(2)
    values = np.column_stack([vertices[:, 0], vertices[:, 1] ** 2])
    field = ScalarField(vertices, faces, values)
    est = LowerStarPersistence(filtration="sublevel")
    from_field, from_pair = est.fit_transform([field, ((vertices, faces), values)])
    assert isinstance(from_field, tuple) and len(from_field) == 2
    for a, b in zip(from_field, from_pair, strict=True):
        np.testing.assert_array_equal(a, b)
    single = est.fit_transform([((vertices, faces), values[:, 1])])[0]
    np.testing.assert_array_equal(single, from_field[1])


def test_essential_policies_and_min_persistence():
    vertices, faces = sphere(2)
    values = vertices[:, 0] + 0.1 * np.sin(7 * vertices[:, 1])
    sample = [((vertices, faces), values)]
    keep = LowerStarPersistence(filtration="sublevel").fit_transform(sample)[0]
    drop = LowerStarPersistence(filtration="sublevel", essential="drop").fit_transform(sample)[0]
    close = LowerStarPersistence(filtration="sublevel", essential="max").fit_transform(sample)[0]
    assert np.isinf(keep[:, 1]).sum() == 1 and np.isfinite(drop).all()
    np.testing.assert_array_equal(close[-1], [values.min(), values.max()])
    pruned = LowerStarPersistence(filtration="sublevel", min_persistence=0.05).fit_transform(
        sample
    )[0]
    assert ((pruned[:, 1] - pruned[:, 0]) > 0.05).all()
    assert len(pruned) < len(keep)


@pytest.mark.parametrize(
    "values, message",
    [
        (np.zeros(5), r"sample 1: values must have shape \(42,\)"),
        (np.full(42, np.nan), "sample 1: values contain NaN"),
        # Found probing stop 52's fixes: complex values lost their imaginary parts with
        # only a ComplexWarning (a graph's were refused); an int beyond float64 was a
        # bare OverflowError.
        (np.zeros(42) + 1j, "sample 1: values must be real numbers, got complex ones"),
        ([0] * 41 + [10**400], "sample 1: values must be finite, got one beyond float64"),
    ],
)
def test_bad_values_name_the_sample(values, message):
    vertices, faces = sphere(1)
    good = ((vertices, faces), vertices[:, 0])
    with pytest.raises(ValueError, match=message):
        LowerStarPersistence().fit_transform([good, ((vertices, faces), values)])


def test_bad_sample_type():
    with pytest.raises(TypeError, match="sample 0: expected a ScalarField"):
        LowerStarPersistence().fit_transform([np.zeros(3)])


def test_identical_for_any_n_jobs_clone_and_pickle(estimator_round_trip):
    vertices, faces = sphere(2)
    rng = np.random.default_rng(3)
    samples = [((vertices, faces), rng.normal(size=len(vertices))) for _ in range(5)]
    est = LowerStarPersistence(filtration="extended")
    one = estimator_round_trip(est, samples, {"filtration": "sublevel", "min_persistence": 0.1})
    assert len(one) == 5 and all(isinstance(d, tuple) and len(d) == 4 for d in one)
    two = clone(est).set_params(n_jobs=2).fit_transform(samples)
    for a, b in zip(one, two, strict=True):
        for x, y in zip(a, b, strict=True):
            np.testing.assert_array_equal(x, y)


def test_sublevel_setting_is_the_papers_single_diagram():
    vertices, faces = sphere(3)
    values = vertices[:, 0] + 0.1 * np.sin(9 * vertices[:, 2])
    (diagram,) = LowerStarPersistence(filtration="sublevel").fit_transform(
        [((vertices, faces), values)]
    )
    assert isinstance(diagram, np.ndarray) and diagram.dtype == np.float64
    np.testing.assert_array_equal(diagram, lower_star_persistence((vertices, faces), values))


@pytest.mark.parametrize(
    "filtration, per_function",
    [("symmetric", 2), ("sublevel", 1), ("superlevel", 1), ("extended", 4)],
)
def test_several_functions_are_function_major_and_named(filtration, per_function):
    vertices, faces = sphere(2)
    values = np.column_stack([vertices[:, 0], vertices[:, 1] ** 3, vertices[:, 2]])
    est = LowerStarPersistence(filtration=filtration)
    (together,) = est.fit_transform([((vertices, faces), values)])
    together = together if isinstance(together, tuple) else (together,)
    assert len(together) == 3 * per_function == len(est.diagram_names(3))
    for k in range(3):
        (alone,) = est.fit_transform([((vertices, faces), values[:, k])])
        alone = alone if isinstance(alone, tuple) else (alone,)
        assert len(alone) == per_function == len(est.diagram_names())
        for a, b in zip(together[k * per_function : (k + 1) * per_function], alone, strict=True):
            np.testing.assert_array_equal(a, b)


def test_essential_classes_one_per_component():
    a, fa = sphere(1)
    b, fb = sphere(1)
    vertices, faces = np.vstack([a, b + 3.0]), np.vstack([fa, fb + len(a)])
    values = vertices[:, 0]
    sample = [((vertices, faces), values)]
    keep = LowerStarPersistence(filtration="sublevel").fit_transform(sample)[0]
    closed = LowerStarPersistence(filtration="sublevel", essential="max").fit_transform(sample)[0]
    np.testing.assert_array_equal(keep[np.isinf(keep[:, 1]), 0], [-1.0, 2.0])
    np.testing.assert_array_equal(sorted_rows(closed[-2:]), [[-1.0, 1.0], [2.0, 4.0]])
    _, extremes = LowerStarPersistence().fit_transform(sample)[0]
    np.testing.assert_array_equal(
        sorted_rows(extremes), [[-4.0, -2.0], [-1.0, 1.0], [-1.0, 1.0], [2.0, 4.0]]
    )


def test_fit_is_stateless_and_a_single_sample_is_refused():
    vertices, faces = sphere(1)
    est = LowerStarPersistence()
    assert est.fit([((vertices, faces), vertices[:, 0])]) is est
    assert not [k for k in vars(est) if k.endswith("_")]
    with pytest.raises(TypeError, match="sequence of scalar fields"):
        est.fit_transform(ScalarField(vertices, faces, vertices[:, 0]))


def test_invalid_parameters_are_refused_at_fit():
    vertices, faces = sphere(1)
    sample = [((vertices, faces), vertices[:, 0])]
    with pytest.raises(ValueError, match="filtration"):
        LowerStarPersistence(filtration="upper").fit(sample)
    with pytest.raises(ValueError, match="min_persistence"):
        LowerStarPersistence(min_persistence=-1.0).fit(sample)


def test_parts_keep_the_named_diagrams_of_each_function():
    sphere = trimesh.creation.icosphere(2)
    values = np.column_stack([sphere.vertices[:, 0], sphere.vertices[:, 1] ** 2])
    sample = [(sphere, values)]
    full = LowerStarPersistence(filtration="extended").fit_transform(sample)[0]
    parts = ("superlevel H0 (saddle, max)", "essential H1")
    est = LowerStarPersistence(filtration="extended", parts=parts)
    kept = est.fit_transform(sample)[0]
    assert len(kept) == 4
    for got, expected in zip(kept, (full[1], full[3], full[5], full[7]), strict=True):
        np.testing.assert_array_equal(got, expected)
    assert est.diagram_names(2) == [f"f{k}: {p}" for k in (1, 2) for p in parts]
    single = LowerStarPersistence(filtration="extended", parts=("(min, max)",))
    np.testing.assert_array_equal(single.fit_transform([(sphere, values[:, 0])])[0], full[2])
    with pytest.raises(
        ValueError, match=r"'symmetric': parts must be .*'h0'.*got \('ordinary H0',\)"
    ):
        LowerStarPersistence(parts=("ordinary H0",)).fit_transform(sample)


@pytest.mark.parametrize(
    "filtration, ids",
    [
        ("extended", ("ord0", "ord1", "ext0", "ext1")),
        ("symmetric", ("h0", "ext0")),
        ("sublevel", ("h0",)),
        ("superlevel", ("h0",)),
    ],
)
def test_parts_take_short_ids_or_names(filtration, ids):
    torus = trimesh.creation.torus(major_radius=1.0, minor_radius=0.4)
    sample = [(torus, torus.vertices[:, 0] + 0.1 * torus.vertices[:, 1])]
    names = LowerStarPersistence(filtration=filtration).diagram_names()
    full = LowerStarPersistence(filtration=filtration).fit_transform(sample)[0]
    full = full if isinstance(full, tuple) else (full,)
    for k, (short, name) in enumerate(zip(ids, names, strict=True)):
        by_id = LowerStarPersistence(filtration=filtration, parts=(short,))
        np.testing.assert_array_equal(by_id.fit_transform(sample)[0], full[k])
        assert by_id.diagram_names() == [name]
    # Ids and names mix; the diagrams keep the filtration's order, each once.
    mixed = LowerStarPersistence(filtration=filtration, parts=(ids[-1], names[-1], ids[0]))
    assert mixed.diagram_names() == sorted({names[0], names[-1]}, key=names.index)
