"""Hypothesis strategies for the fuzz tests: meshes that are valid most of the time.

A drawn mesh is a real mesh built in code (an icosphere, a torus, the six shapes of
``make_shapes`` at a coarse resolution), cut to a part of its faces (all of them, a run of
consecutive faces, or a random subset: boundaries, several components, isolated
triangles), its vertices moved by a jitter too small to fold a triangle, rescaled, and
now and then deliberately corrupted in one of the ways of :data:`CORRUPTIONS`. A valid
mesh must go through; a corrupted one must be refused with the corruption's message.
"""

import functools

import numpy as np
import trimesh
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from sklearn_meshph import make_shapes


@functools.cache
def base_meshes():
    """``(vertices, faces, step)`` of the base meshes; ``step`` bounds the jitter per
    coordinate so that no vertex moves by more than a quarter of the smallest altitude
    of a triangle (no fold, no degenerate face)."""
    shapes, _ = make_shapes(n_per_class=1, resolution=(6, 9), random_state=0, return_X_y=True)
    meshes = [
        trimesh.creation.icosphere(1),
        trimesh.creation.torus(1.0, 0.4, major_sections=12, minor_sections=6),
        *shapes,
    ]
    bases = []
    for mesh in meshes:
        vertices, faces = np.asarray(mesh.vertices), np.asarray(mesh.faces)
        corners = vertices[faces]
        edges = np.linalg.norm(corners - np.roll(corners, 1, axis=1), axis=2)
        altitudes = 2.0 * mesh.area_faces[:, None] / edges
        bases.append((vertices, faces, 0.25 * altitudes.min() / np.sqrt(3.0)))
    return bases


def _nan_vertex(vertices, faces):
    vertices[faces[0, 1]] = np.nan
    return vertices, faces


def _face_out_of_range(vertices, faces):
    return vertices, np.vstack([faces, [[0, 1, len(vertices)]]])


def _every_face_degenerate(vertices, faces):
    faces[:, 2] = faces[:, 1]
    return vertices, faces


def _one_point(vertices, faces):
    return np.zeros_like(vertices) + vertices[0], faces


# name -> (corrupt (vertices, faces), the words of the expected error message)
CORRUPTIONS = {
    "NaN vertex": (_nan_vertex, "non-finite coordinate"),
    "face out of range": (_face_out_of_range, "out of range"),
    "every face degenerate": (_every_face_degenerate, "every face is degenerate"),
    "all vertices at one point": (_one_point, "every face is degenerate"),
}

# About one draw in six is corrupted.
_DAMAGE = st.sampled_from((None,) * 20 + tuple(CORRUPTIONS))


@st.composite
def meshes(draw):
    """``(mesh, corruption)``: a ``(vertices, faces)`` pair, and the name of its
    corruption in :data:`CORRUPTIONS` (None: a valid mesh)."""
    vertices, faces, step = draw(st.sampled_from(base_meshes()))
    part = draw(st.sampled_from(["whole", "run", "subset"]))
    if part == "run":
        start = draw(st.integers(0, len(faces) - 1))
        faces = np.roll(faces, -start, axis=0)[: draw(st.integers(1, len(faces)))]
    elif part == "subset":
        keep = draw(arrays(np.bool_, len(faces), elements=st.booleans(), fill=st.nothing()))
        faces = faces[keep] if keep.any() else faces[:1]
    jitter = draw(arrays(np.float64, vertices.shape, elements=st.floats(-1, 1), fill=st.nothing()))
    scale = 10.0 ** draw(st.integers(-3, 3))
    vertices, faces = (vertices + step * jitter) * scale, faces.copy()
    damage = draw(_DAMAGE)
    if damage is not None:
        vertices, faces = CORRUPTIONS[damage][0](vertices, faces)
    return (vertices, faces), damage
