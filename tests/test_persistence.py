"""Lower-star persistence against gudhi, sign symmetry, and the transformer."""

import pickle

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st
from sklearn.base import clone

from sklearn_meshph import LowerStarPersistence, ScalarField, lower_star_persistence
from sklearn_meshph.persistence import edge_adjacency, function_diagrams

gudhi = pytest.importorskip("gudhi")


def sorted_rows(diagram):
    diagram = np.asarray(diagram, dtype=float).reshape(-1, 2)
    return diagram[np.lexsort(diagram.T[::-1])]


def lower_star_tree(faces, values):
    """gudhi SimplexTree of the lower-star filtration: every simplex at its max value."""
    tree = gudhi.SimplexTree()
    for v, value in enumerate(values):
        tree.insert([v], value)
    for face in faces:
        for a, b in ((0, 1), (1, 2), (0, 2)):
            if face[a] != face[b]:  # a face with a repeated index still has its edges
                tree.insert([face[a], face[b]], float(max(values[face[a]], values[face[b]])))
    for face in faces:
        if len(set(face)) == 3:
            tree.insert(list(face), float(values[face].max()))
    return tree


def gudhi_h0(vertices, faces, values):
    """Sublevel H0 of the lower-star filtration by gudhi."""
    tree = lower_star_tree(faces, values)
    tree.compute_persistence(persistence_dim_max=True)  # else a 0-dim complex gives nothing
    diagram = tree.persistence_intervals_in_dimension(0)
    return diagram[diagram[:, 1] > diagram[:, 0]]


def sphere(subdivisions=2):
    mesh = trimesh.creation.icosphere(subdivisions)
    return np.asarray(mesh.vertices), np.asarray(mesh.faces)


FUNCTIONS = {
    "random": lambda v, rng: rng.normal(size=len(v)),
    "heavily tied": lambda v, rng: rng.integers(0, 4, len(v)).astype(float),
    "smooth + noise": lambda v, rng: v[:, 0] + 0.05 * rng.normal(size=len(v)),
    "constant": lambda v, rng: np.zeros(len(v)),
}


@pytest.mark.parametrize("name", FUNCTIONS)
def test_sublevel_h0_identical_to_gudhi(name):
    vertices, faces = sphere(3)
    values = FUNCTIONS[name](vertices, np.random.default_rng(0))
    ours = lower_star_persistence((vertices, faces), values)
    np.testing.assert_array_equal(sorted_rows(ours), sorted_rows(gudhi_h0(vertices, faces, values)))


def test_several_components_and_unreferenced_vertices_match_gudhi():
    a, fa = sphere(1)
    b, fb = sphere(2)
    vertices = np.vstack([a, b + 3.0, [[9.0, 9.0, 9.0]]])
    faces = np.vstack([fa, fb + len(a)])
    values = np.random.default_rng(1).normal(size=len(vertices))
    ours = lower_star_persistence((vertices, faces), values)
    assert np.isinf(ours[:, 1]).sum() == 3  # two components and the lone vertex
    np.testing.assert_array_equal(sorted_rows(ours), sorted_rows(gudhi_h0(vertices, faces, values)))


def test_real_mesh_matches_gudhi(sumner_dir):
    mesh = trimesh.load(sumner_dir / "lion" / "lion-01.obj", process=False)
    values = mesh.vertices[:, 1] + 0.01 * np.sin(40 * mesh.vertices[:, 0])
    ours = lower_star_persistence(mesh, values)
    ref = gudhi_h0(np.asarray(mesh.vertices), np.asarray(mesh.faces), values)
    np.testing.assert_array_equal(sorted_rows(ours), sorted_rows(ref))


def test_float64_values_are_not_rounded():
    vertices, faces = sphere(1)
    values = 1.0 + np.arange(len(vertices)) * 1e-12  # distinct in float64, equal in float32
    values[5] = 0.5
    diagram = lower_star_persistence((vertices, faces), values[::-1].copy())
    assert len(np.unique(diagram[:, 0])) == len(diagram)


def test_extended_matches_gudhi_extended_persistence():
    vertices, faces = sphere(2)
    values = vertices[:, 0] + 0.3 * np.sin(5 * vertices[:, 1]) + 0.2 * vertices[:, 2] ** 2
    tree = lower_star_tree(faces, values)
    tree.extend_filtration()
    ordinary, relative, extended_plus, _ = tree.extended_persistence()
    ord0 = [p for dim, p in ordinary if dim == 0]
    rel1 = [(d, b) for dim, (b, d) in relative if dim == 1]  # (saddle, max)
    ext0 = [p for dim, p in extended_plus if dim == 0]
    ours = LowerStarPersistence(filtration="extended").fit_transform([(sphere(2), values)])[0]
    for mine, reference in zip(ours, (ord0, rel1, ext0), strict=True):
        np.testing.assert_allclose(sorted_rows(mine), sorted_rows(reference), rtol=1e-12)


def reflect(diagram):
    return np.column_stack([-diagram[:, 1], -diagram[:, 0]])


def test_sign_flip_reflects_the_diagrams():
    vertices, faces = sphere(3)
    values = vertices[:, 2] + 0.2 * np.random.default_rng(2).normal(size=len(vertices))
    est = LowerStarPersistence(filtration="extended")
    plus, minus = est.fit_transform([((vertices, faces), values), ((vertices, faces), -values)])
    np.testing.assert_array_equal(sorted_rows(minus[0]), sorted_rows(reflect(plus[1])))
    np.testing.assert_array_equal(sorted_rows(minus[1]), sorted_rows(reflect(plus[0])))
    np.testing.assert_array_equal(sorted_rows(minus[2]), sorted_rows(reflect(plus[2])))
    sub = LowerStarPersistence(filtration="sublevel").fit_transform([((vertices, faces), -values)])
    sup = LowerStarPersistence(filtration="superlevel").fit_transform([((vertices, faces), values)])
    np.testing.assert_array_equal(sub[0], sup[0])


def test_default_output_is_exactly_sign_invariant():
    vertices, faces = sphere(3)
    values = np.column_stack([vertices[:, 2] ** 3 + vertices[:, 0], vertices[:, 1]])
    est = LowerStarPersistence()
    plus, minus = est.fit_transform([((vertices, faces), values), ((vertices, faces), -values)])
    assert len(plus) == 4  # (H0, essential) for each of the two functions
    for a, b in zip(plus, minus, strict=True):
        np.testing.assert_array_equal(sorted_rows(a), sorted_rows(b))


@settings(max_examples=40, deadline=None)
@given(
    n=st.integers(3, 30),
    seed=st.integers(0, 2**31),
    levels=st.sampled_from([None, 2, 5]),
)
def test_random_graphs_match_gudhi(n, seed, levels):
    rng = np.random.default_rng(seed)
    faces = rng.integers(0, n, size=(rng.integers(1, 2 * n), 3))
    vertices = rng.normal(size=(n, 3))
    values = rng.normal(size=n) if levels is None else rng.integers(0, levels, n).astype(float)
    ours = lower_star_persistence((vertices, faces), values)
    ref = gudhi_h0(vertices, faces, values)
    finite = ours[np.isfinite(ours[:, 1])]
    np.testing.assert_array_equal(sorted_rows(finite), sorted_rows(ref[np.isfinite(ref[:, 1])]))
    assert np.isinf(ours[:, 1]).sum() == np.isinf(ref[:, 1]).sum()
    assert (ours[:, 1] > ours[:, 0]).all()


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


def test_identical_for_any_n_jobs_clone_and_pickle():
    vertices, faces = sphere(2)
    rng = np.random.default_rng(3)
    samples = [((vertices, faces), rng.normal(size=len(vertices))) for _ in range(5)]
    est = LowerStarPersistence(filtration="extended")
    one = est.fit_transform(samples)
    two = clone(est).set_params(n_jobs=2).fit_transform(samples)
    again = pickle.loads(pickle.dumps(est)).transform(samples)
    for a, b, c in zip(one, two, again, strict=True):
        for x, y, z in zip(a, b, c, strict=True):
            np.testing.assert_array_equal(x, y)
            np.testing.assert_array_equal(x, z)
    assert clone(est).get_params() == est.get_params()


def test_adjacency_is_symmetric_without_self_loops():
    _, faces = sphere(1)
    adjacency = edge_adjacency(faces, 42)
    assert (adjacency != adjacency.T).nnz == 0 and adjacency.diagonal().sum() == 0
    diagrams = function_diagrams(
        adjacency, np.arange(42.0), filtration="symmetric", essential="keep", min_persistence=0
    )
    assert len(diagrams) == 2
