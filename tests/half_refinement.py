"""Refine part of a mesh and keep it conforming: the test of resolution invariance that
a graph Laplacian cannot pass (uniform refinement scales every vertex's degree alike)."""

import numpy as np


def refine_faces(vertices, faces, selected):
    """Split the ``selected`` faces in four at their edge midpoints, and their neighbours
    in two or three along the split edges, so that no vertex hangs on an edge (no
    T-junction). The surface is unchanged (midpoints lie on it); the original vertices
    come first, in order."""
    vertices = np.asarray(vertices, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    selected = np.asarray(selected, dtype=bool).copy()
    edges = np.sort(np.stack([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]], 1), -1)
    while True:  # a face with all three edges split is split in four too
        split = {tuple(e) for e in edges[selected].reshape(-1, 2)}
        count = np.array([sum(tuple(e) in split for e in face) for face in edges])
        more = ~selected & (count == 3)
        if not more.any():
            break
        selected |= more
    split = sorted({tuple(e) for e in edges[selected].reshape(-1, 2)})
    midpoint = {e: len(vertices) + k for k, e in enumerate(split)}
    new_vertices = np.array([(vertices[a] + vertices[b]) / 2 for a, b in split])
    out = []
    for face, face_edges in zip(faces, edges, strict=True):
        marks = [midpoint.get(tuple(e)) for e in face_edges]  # on (a,b), (b,c), (c,a)
        n = sum(m is not None for m in marks)
        if n == 0:
            out.append(face)
            continue
        if n == 3:
            (a, b, c), (m0, m1, m2) = face, marks
            out += [(a, m0, m2), (m0, b, m1), (m2, m1, c), (m0, m1, m2)]
            continue
        # Rotate so that the first edge (a, b) is split, and for two, the second too.
        for shift in range(3):
            rolled = [marks[(k + shift) % 3] for k in range(3)]
            if rolled[0] is not None and (n == 1 or rolled[1] is not None):
                break
        a, b, c = (face[(k + shift) % 3] for k in range(3))
        if n == 1:
            out += [(a, rolled[0], c), (rolled[0], b, c)]
        else:
            m0, m1 = rolled[0], rolled[1]
            out += [(m0, b, m1), (a, m0, m1), (a, m1, c)]
    return np.vstack([vertices, new_vertices]), np.array(out, dtype=np.int64)


def refine_upper_half(vertices, faces):
    """:func:`refine_faces` on the faces whose centroid has ``z > 0``."""
    centroids = np.asarray(vertices)[np.asarray(faces)].mean(axis=1)
    return refine_faces(vertices, faces, centroids[:, 2] > 0)
