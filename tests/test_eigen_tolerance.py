"""The shift-invert solve's tolerance: a loose one where the spectrum is simple, machine
precision again where it has repeated eigenvalues (symmetric meshes)."""

import numpy as np
import pytest
import trimesh
from conftest import irregular_ellipsoid

from sklearn_meshph.spectral import eigensolver
from sklearn_meshph.spectral.eigensolver import dense_eigenpairs, generalized_eigenpairs
from sklearn_meshph.spectral.laplacians import cotangent_laplacian


def operator(vertices, faces):
    L, M = cotangent_laplacian(np.asarray(vertices, dtype=float), np.asarray(faces))
    return L, M / M.diagonal().sum()


def counting_eigsh(monkeypatch):
    """Record the ``tol`` of every ARPACK call of the eigensolver."""
    calls = []
    original = eigensolver.eigsh

    def eigsh(*args, **kwargs):
        calls.append(kwargs["tol"])
        return original(*args, **kwargs)

    monkeypatch.setattr(eigensolver, "eigsh", eigsh)
    return calls


def test_a_simple_spectrum_is_solved_once_at_the_loose_tolerance(monkeypatch):
    vertices, faces = irregular_ellipsoid(3, seed=1)
    L, M = operator(vertices, faces)
    calls = counting_eigsh(monkeypatch)
    values, vectors = generalized_eigenpairs(L, M, 56, points=vertices)
    assert calls == [eigensolver._TOLERANCE]
    precise, precise_vectors = dense_eigenpairs(L, M.diagonal(), 56)
    np.testing.assert_allclose(values[1:], precise[1:], rtol=1e-10)
    mass = M.diagonal()
    np.testing.assert_allclose((vectors.T * mass) @ vectors, np.eye(56), atol=1e-10)
    # The heat kernel signature at the earliest time the default uses.
    t = 4 * np.log(10) / values[-1]
    hks = vectors**2 @ np.exp(-values * t)
    reference = precise_vectors**2 @ np.exp(-precise * t)
    np.testing.assert_allclose(hks, reference, rtol=1e-8)


@pytest.mark.parametrize("n_eigenpairs", [24, 56])
def test_repeated_eigenvalues_of_a_symmetric_sphere_are_all_found(monkeypatch, n_eigenpairs):
    # The icosphere's spectrum repeats each l (l + 1) 2l + 1 times (to rounding): a
    # single Lanczos vector stopped early misses copies, the precise solve finds them.
    sphere = trimesh.creation.icosphere(3)
    L, M = operator(sphere.vertices, sphere.faces)
    calls = counting_eigsh(monkeypatch)
    values, _ = generalized_eigenpairs(L, M, n_eigenpairs, points=sphere.vertices)
    assert calls == [eigensolver._TOLERANCE, 0.0]
    expected, _ = dense_eigenpairs(L, M.diagonal(), n_eigenpairs)
    np.testing.assert_allclose(values[1:], expected[1:], rtol=1e-9)


def test_repeats_are_eigenvalues_within_the_relative_tolerance():
    assert not eigensolver._has_repeats(np.array([0.0, 1.0, 1.01, 2.0]))
    assert eigensolver._has_repeats(np.array([0.0, 1.0, 1.0 + 1e-9, 2.0]))
    assert eigensolver._has_repeats(np.array([0.0, 1e-17, 1.0, 2.0]))  # two zeros
    assert not eigensolver._has_repeats(np.array([-1e-17, 1.0, 2.0]))
