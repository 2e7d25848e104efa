"""Lower-star persistence: gudhi as the oracle for sublevel and extended H0, sign symmetry."""

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

from sklearn_meshph import LowerStarPersistence, lower_star_persistence

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


@pytest.mark.parametrize(
    "values, message",
    [
        (np.zeros(41), r"shape \(42,\) or \(42, k\)"),
        (np.zeros((42, 2)), "use LowerStarPersistence"),
        (np.r_[np.zeros(41), np.inf], "NaN or inf"),
        (np.zeros(42, dtype=complex), "must be real numbers, got complex ones"),
        ([[0.0]] * 41 + [[0.0, 1.0]], "values must be a numeric array"),  # ragged
    ],
)
def test_bad_values_are_refused(values, message):
    with pytest.raises(ValueError, match=message):
        lower_star_persistence(sphere(1), values)


def test_float64_values_are_not_rounded():
    vertices, faces = sphere(1)
    values = 1.0 + np.arange(len(vertices)) * 1e-12  # distinct in float64, equal in float32
    values[5] = 0.5
    values = values[::-1].copy()
    diagram = lower_star_persistence((vertices, faces), values)
    # One pair per local minimum (the values are distinct in float64): rounded to
    # float32 they are all equal but one, and every pair but the essential one vanishes.
    edges = trimesh.Trimesh(vertices, faces, process=False).edges_unique
    lower = np.ones(len(vertices), dtype=bool)
    for a, b in edges:
        lower[a if values[a] > values[b] else b] = False
    assert np.count_nonzero(lower) > 1
    assert len(diagram) == np.count_nonzero(lower)
    assert len(np.unique(diagram[:, 0])) == len(diagram)


def diagrams_of(vertices, faces, values, filtration="extended"):
    sample = ((vertices, faces), values)
    diagrams = LowerStarPersistence(filtration=filtration).fit_transform([sample])[0]
    return list(diagrams) if isinstance(diagrams, tuple) else [diagrams]


def torus(n_major=24, n_minor=12):
    mesh = trimesh.creation.torus(
        major_radius=1.0, minor_radius=0.4, major_sections=n_major, minor_sections=n_minor
    )
    return np.asarray(mesh.vertices), np.asarray(mesh.faces)


def two_spheres():
    a, fa = sphere(1)
    b, fb = sphere(2)
    return np.vstack([a, b + 3.0]), np.vstack([fa, fb + len(a)])


def gudhi_extended(faces, values):
    """gudhi's extended persistence, as our three diagrams and gudhi's H1 parts."""
    tree = lower_star_tree(faces, values)
    tree.extend_filtration()
    ordinary, relative, extended_plus, extended_minus = tree.extended_persistence()
    ord0 = [p for dim, p in ordinary if dim == 0]
    rel1 = [(d, b) for dim, (b, d) in relative if dim == 1]  # reported (max, saddle)
    ext0 = [p for dim, p in extended_plus if dim == 0]
    ext1_plus = [p for dim, p in extended_plus if dim == 1]
    ord1 = [p for dim, p in ordinary if dim == 1]
    ext1_minus = [p for dim, p in extended_minus if dim == 1]
    return (ord0, rel1, ext0, ext1_plus), ord1, ext1_minus


def smooth_function(vertices):
    return vertices[:, 0] + 0.3 * np.sin(5 * vertices[:, 1]) + 0.2 * vertices[:, 2] ** 2


@pytest.mark.parametrize(
    "mesh", [sphere(2), torus(), two_spheres()], ids=["sphere", "torus", "two spheres"]
)
def test_extended_matches_gudhi_extended_persistence(mesh):
    vertices, faces = mesh
    values = smooth_function(vertices)
    reference, _, _ = gudhi_extended(faces, values)
    ours = diagrams_of(vertices, faces, values)
    for mine, expected in zip(ours, reference, strict=True):
        expected = np.asarray(expected, dtype=float).reshape(-1, 2)
        expected = expected[expected[:, 1] > expected[:, 0]]
        # extend_filtration rescales values and back: equal up to the last bit
        np.testing.assert_allclose(sorted_rows(mine), sorted_rows(expected), rtol=0, atol=1e-12)


def test_extended_matches_gudhi_on_a_real_closed_mesh(sumner_dir):
    mesh = trimesh.load(sumner_dir / "lion" / "lion-01.obj", process=False)
    vertices, faces = np.asarray(mesh.vertices), np.asarray(mesh.faces)
    values = vertices[:, 1] + 0.01 * np.sin(40 * vertices[:, 0])
    reference, _, _ = gudhi_extended(faces, values)
    for mine, expected in zip(diagrams_of(vertices, faces, values), reference, strict=True):
        expected = np.asarray(expected, dtype=float).reshape(-1, 2)
        expected = expected[expected[:, 1] > expected[:, 0]]
        np.testing.assert_allclose(sorted_rows(mine), sorted_rows(expected), rtol=0, atol=1e-12)


@pytest.mark.parametrize("mesh, genus", [(sphere(2), 0), (torus(), 1)], ids=["sphere", "torus"])
def test_h1_of_a_closed_surface_is_determined_by_the_returned_diagrams(mesh, genus):
    vertices, faces = mesh
    values = smooth_function(vertices) + 0.05 * np.random.default_rng(4).normal(size=len(vertices))
    _, ord1, ext1_minus = gudhi_extended(faces, values)
    _, saddle_max, _, ext1_plus = diagrams_of(vertices, faces, values)
    ord1 = np.asarray(ord1, dtype=float).reshape(-1, 2)
    np.testing.assert_allclose(  # gudhi rescales
        sorted_rows(saddle_max), sorted_rows(ord1[ord1[:, 1] > ord1[:, 0]]), rtol=0, atol=1e-12
    )
    assert len(ext1_plus) == len(ext1_minus) == genus  # Ext1- is Ext1+ transposed
    np.testing.assert_allclose(
        sorted_rows(ext1_plus),
        sorted_rows(np.asarray(ext1_minus, dtype=float).reshape(-1, 2)[:, ::-1]),
        rtol=0,
        atol=1e-12,
    )


def reflect(diagram):
    return np.column_stack([-diagram[:, 1], -diagram[:, 0]])


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**31), levels=st.sampled_from([None, 3]))
def test_sign_flip_reflects_extended_and_fixes_symmetric(seed, levels):
    vertices, faces = torus()
    rng = np.random.default_rng(seed)
    values = (
        rng.normal(size=len(vertices))
        if levels is None
        else rng.integers(0, levels, len(vertices)).astype(float)
    )
    plus = diagrams_of(vertices, faces, values)
    minus = diagrams_of(vertices, faces, -values)
    for mine, reflected in zip(minus, (plus[1], plus[0], plus[2], plus[3]), strict=True):
        np.testing.assert_array_equal(sorted_rows(mine), sorted_rows(reflect(reflected)))
    symmetric_plus = diagrams_of(vertices, faces, values, "symmetric")
    symmetric_minus = diagrams_of(vertices, faces, -values, "symmetric")
    for a, b in zip(symmetric_plus, symmetric_minus, strict=True):
        np.testing.assert_array_equal(sorted_rows(a), sorted_rows(b))


def two_tori():
    a, fa = torus()
    b, fb = torus(16, 10)
    return np.vstack([a, b[:, ::-1] + 3.0]), np.vstack([fa, fb + len(a)])


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**31), levels=st.sampled_from([None, 3]))
def test_essential_h1_matches_gudhi_on_tori(seed, levels):
    vertices, faces = two_tori()
    rng = np.random.default_rng(seed)
    n = len(vertices)
    smooth = vertices @ rng.normal(size=3) + 0.3 * np.sin(rng.uniform(1, 6) * vertices[:, 0])
    values = smooth if levels is None else rng.integers(0, levels, n).astype(float)
    reference, _, _ = gudhi_extended(faces, values)
    ext1 = diagrams_of(vertices, faces, values)[3]
    expected = np.asarray(reference[3], dtype=float).reshape(-1, 2)
    np.testing.assert_allclose(sorted_rows(ext1), sorted_rows(expected), rtol=0, atol=1e-12)


def test_essential_h1_of_a_torus_and_a_sphere_pinched_at_a_vertex_matches_gudhi():
    a, fa = torus()
    b, fb = sphere(1)
    fb = fb + len(a) - 1  # the sphere's vertex 0 becomes the torus's last vertex
    vertices = np.vstack([a, b[1:] + 3.0])
    faces = np.vstack([fa, fb])
    values = vertices[:, 0] + 0.2 * np.sin(4 * vertices[:, 1])
    reference, _, ext1_minus = gudhi_extended(faces, values)
    ext1 = diagrams_of(vertices, faces, values)[3]
    # Still a closed surface, of genus 1: one Ext1 pair (and its transpose in Ext1-)
    assert len(ext1) == len(ext1_minus) == 1
    expected = np.asarray(reference[3], dtype=float).reshape(-1, 2)
    np.testing.assert_allclose(sorted_rows(ext1), sorted_rows(expected), rtol=0, atol=1e-12)


def test_essential_h1_is_empty_with_a_boundary():
    vertices, faces = torus()
    values = vertices[:, 0] + 0.3 * vertices[:, 2]
    assert len(diagrams_of(vertices, faces, values)[3]) == 1
    assert len(diagrams_of(vertices, faces[1:], values)[3]) == 0


def test_superlevel_is_the_sublevel_diagram_of_the_negated_function():
    vertices, faces = sphere(3)
    values = vertices[:, 2] + 0.2 * np.random.default_rng(2).normal(size=len(vertices))
    (sup,) = diagrams_of(vertices, faces, values, "superlevel")
    np.testing.assert_array_equal(sup, lower_star_persistence((vertices, faces), -values))


def test_constant_component_leaves_no_diagonal_point():
    vertices, faces = two_spheres()
    values = np.zeros(len(vertices))
    values[:42] = np.arange(42.0)  # the second sphere is constant
    _, extremes = diagrams_of(vertices, faces, values, "symmetric")
    np.testing.assert_array_equal(sorted_rows(extremes), [[-41.0, 0.0], [0.0, 41.0]])


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


@pytest.mark.parametrize("filtration", ["symmetric", "sublevel", "superlevel", "extended"])
def test_diagrams_ignore_face_orientation_and_corner_order(filtration):
    """Edges are undirected and a face's corners unordered: the diagrams of a mesh do
    not change when faces are flipped, their corners rotated or the faces shuffled."""
    vertices, faces = torus(16, 10)
    values = smooth_function(vertices)
    rng = np.random.default_rng(5)
    flipped = faces[:, ::-1]
    rotated = np.roll(faces, 1, axis=1)
    shuffled = np.where(rng.random(len(faces))[:, None] < 0.5, flipped, rotated)
    shuffled = shuffled[rng.permutation(len(faces))]
    expected = diagrams_of(vertices, faces, values, filtration)
    for other in (flipped, rotated, shuffled):
        diagrams = diagrams_of(vertices, other, values, filtration)
        for mine, reference in zip(diagrams, expected, strict=True):
            np.testing.assert_array_equal(sorted_rows(mine), sorted_rows(reference))


def test_symmetric_diagrams_of_a_function_without_ties():
    """Two diagrams; H0(f) + H0(-f) matches gudhi's H0 of f and of -f."""
    vertices, faces = sphere(1)
    values = np.arange(42.0)
    est = LowerStarPersistence(filtration="symmetric", essential="keep", min_persistence=0)
    (diagrams,) = est.fit_transform([((vertices, faces), values)])
    assert isinstance(diagrams, tuple) and len(diagrams) == 2
    both = np.vstack([gudhi_h0(vertices, faces, values), gudhi_h0(vertices, faces, -values)])
    both = both[np.isfinite(both[:, 1])]
    np.testing.assert_array_equal(sorted_rows(diagrams[0]), sorted_rows(both))
    np.testing.assert_array_equal(sorted_rows(diagrams[1]), [[-41.0, 0.0], [0.0, 41.0]])


@pytest.mark.parametrize(
    "mesh", [sphere(2), torus(), two_spheres()], ids=["sphere", "torus", "two spheres"]
)
def test_each_part_of_extended_persistence_alone_is_the_same_diagram(mesh):
    # parts= computes only the kept diagrams: each must be exactly that diagram of the
    # full computation, for every kind (ordinary, superlevel, ranges, essential H1).
    vertices, faces = mesh
    values = np.random.default_rng(3).normal(size=len(vertices))
    full = LowerStarPersistence(filtration="extended").fit_transform([(mesh, values)])[0]
    names = LowerStarPersistence(filtration="extended").diagram_names()
    for k, name in enumerate(names):
        alone = LowerStarPersistence(filtration="extended", parts=(name,))
        np.testing.assert_array_equal(alone.fit_transform([(mesh, values)])[0], full[k])
    pair = LowerStarPersistence(filtration="extended", parts=(names[3], names[1]))
    kept = pair.fit_transform([(mesh, values)])[0]
    np.testing.assert_array_equal(kept[0], full[1])  # the filtration's order, not parts'
    np.testing.assert_array_equal(kept[1], full[3])
