"""Lower-star persistence on a real-shaped mesh against gudhi, with no data to download.

The real-mesh checks of test_persistence.py read the Sumner meshes and skip on a fresh
clone; this surface is built in code and is never skipped (gudhi is a test extra). It is
a torus with bumps of several frequencies along its normals, a varying tube radius and
jittered, shuffled vertices: 3,600 vertices, irregular triangles and, for its Laplacian
eigenfunctions and a rippled height, many critical points of every kind.
"""

import numpy as np
import pytest
import trimesh
from test_persistence import diagrams_of, gudhi_extended, gudhi_h0, sorted_rows

from sklearn_meshph import LaplacianEigenTransformer, lower_star_persistence

pytest.importorskip("gudhi")


def bumpy_torus(n_major=90, n_minor=40, seed=0):
    torus = trimesh.creation.torus(1.0, 0.35, major_sections=n_major, minor_sections=n_minor)
    vertices, faces = np.asarray(torus.vertices), np.asarray(torus.faces)
    u = np.arctan2(vertices[:, 1], vertices[:, 0])
    ring = np.c_[np.cos(u), np.sin(u), np.zeros_like(u)]  # centre of the tube
    out = vertices - ring
    v = np.arctan2(out[:, 2], np.einsum("ij,ij->i", out, ring))
    radius = 0.35 * (1 + 0.3 * np.sin(2 * u)) + 0.04 * np.sin(7 * u) * np.cos(3 * v)
    radius += 0.02 * np.sin(13 * u + 5 * v)
    rng = np.random.default_rng(seed)
    vertices = ring + out / np.linalg.norm(out, axis=1)[:, None] * radius[:, None]
    vertices += rng.normal(scale=0.002, size=vertices.shape)
    order = rng.permutation(len(vertices))
    return vertices[order], np.argsort(order)[faces]


@pytest.fixture(scope="module")
def surface():
    vertices, faces = bumpy_torus()
    fields = LaplacianEigenTransformer(eigen_index=(20, 40, 60)).fit_transform([(vertices, faces)])
    functions = {f"eigenfunction {i}": fields[0].values[:, k] for k, i in enumerate((20, 40, 60))}
    functions["rippled height"] = vertices[:, 2] + 0.01 * np.sin(40 * vertices[:, 0])
    return vertices, faces, functions


NAMES = ["eigenfunction 20", "eigenfunction 40", "eigenfunction 60", "rippled height"]


@pytest.mark.parametrize("name", NAMES)
def test_sublevel_h0_on_a_real_shaped_mesh_is_gudhis(surface, name):
    vertices, faces, functions = surface
    values = functions[name]
    ours = lower_star_persistence((vertices, faces), values)
    assert len(ours) >= 3  # several minima: not a trivial comparison
    np.testing.assert_array_equal(sorted_rows(ours), sorted_rows(gudhi_h0(vertices, faces, values)))


@pytest.mark.parametrize("name", NAMES)
def test_extended_persistence_on_a_real_shaped_mesh_is_gudhis(surface, name):
    vertices, faces, functions = surface
    values = functions[name]
    reference, _, _ = gudhi_extended(faces, values)
    ours = diagrams_of(vertices, faces, values)
    assert sum(len(diagram) for diagram in ours) >= 6
    for mine, expected in zip(ours, reference, strict=True):
        expected = np.asarray(expected, dtype=float).reshape(-1, 2)
        expected = expected[expected[:, 1] > expected[:, 0]]
        # extend_filtration rescales values and back: equal up to the last bit
        np.testing.assert_allclose(sorted_rows(mine), sorted_rows(expected), rtol=0, atol=1e-12)
