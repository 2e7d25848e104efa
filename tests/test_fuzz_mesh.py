"""Fuzzing the mesh input and the eigen stage with random small meshes."""

import warnings

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from sklearn_meshph import LaplacianEigenTransformer, RepeatedEigenvalueWarning, ScalarField

coordinates = st.floats(-10, 10, allow_nan=False, width=64)


@st.composite
def random_meshes(draw):
    n = draw(st.integers(3, 12))
    vertices = draw(arrays(np.float64, (n, 3), elements=coordinates))
    m = draw(st.integers(1, 20))
    faces = draw(arrays(np.int64, (m, 3), elements=st.integers(0, n - 1)))
    return vertices, faces


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(mesh=random_meshes(), laplacian=st.sampled_from(["cotangent", "graph"]))
def test_random_meshes_give_finite_fields_or_a_clear_error(mesh, laplacian):
    est = LaplacianEigenTransformer(eigen_index=1, laplacian=laplacian)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RepeatedEigenvalueWarning)
            (field,) = est.fit_transform([mesh])
    except ValueError as exc:
        message = str(exc)
        assert message.startswith("sample 0: ")
        assert "degenerate" in message or "eigen_index" in message
        return
    assert isinstance(field, ScalarField)
    assert np.isfinite(field.values).all() and np.isfinite(field.eigenvalues).all()
    assert field.eigenvalues[0] >= 0
    assert field.values.shape == (field.n_vertices,)
    assert field.faces.max() < field.n_vertices
