"""Mesh cleaning: our compiled steps against trimesh's equivalents, same process.

    python benchmarks/bench_cleaning.py [--quick]

The cleaning policy of ``clean_mesh`` has four steps that trimesh (already a dependency)
also offers; a step stays compiled in this package only while it is faster than
trimesh's. Irregular icospheres (radially perturbed, vertex order shuffled) of 10k to
655k vertices; times are medians of repeats, peak memory is the largest resident-set
growth of one call (Linux: the high-water mark is reset before it; 0 means the call
reused memory the process already held). "whole policy" is ``clean_mesh`` against
``trimesh.Trimesh(process=True, validate=True)``, which does more (it also merges
vertices): the per-step rows are the like-for-like comparison.
"""

from __future__ import annotations

import argparse

import numpy as np
import trimesh
from _common import median_time, peak_memory

from sklearn_meshph import clean_mesh
from sklearn_meshph.mesh._geometry import (
    DEGENERATE_SINE,
    face_double_areas,
    first_of_duplicate_faces,
    nondegenerate_faces,
)
from sklearn_meshph.mesh.graph import connected_components


def irregular_sphere(subdivisions, seed=0):
    mesh = trimesh.creation.icosphere(subdivisions)
    rng = np.random.default_rng(seed)
    vertices = mesh.vertices * (1 + 0.05 * rng.random((len(mesh.vertices), 1)))
    shuffle = rng.permutation(len(vertices))
    faces = np.argsort(shuffle)[mesh.faces]
    return np.ascontiguousarray(vertices[shuffle]), np.ascontiguousarray(faces, dtype=np.int64)


def steps(V, F):
    """(step, ours, trimesh's) callables."""
    n = len(V)
    return [
        (
            "degenerate faces",
            lambda: nondegenerate_faces(V, F, DEGENERATE_SINE),
            lambda: trimesh.triangles.nondegenerate(V[F]),
        ),
        (
            "duplicate faces",
            lambda: first_of_duplicate_faces(F),
            lambda: trimesh.grouping.unique_rows(np.sort(F, axis=1)),
        ),
        (
            "components",
            lambda: connected_components(n, F),
            lambda: trimesh.graph.connected_components(
                trimesh.geometry.faces_to_edges(F), nodes=np.arange(n), engine="scipy"
            ),
        ),
        (
            "face areas",
            lambda: face_double_areas(V, F),
            lambda: trimesh.triangles.area(V[F]),
        ),
        (
            "whole policy",
            lambda: clean_mesh(V, F),
            lambda: trimesh.Trimesh(V, F, process=True, validate=True),
        ),
    ]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smaller meshes, fewer repeats")
    args = parser.parse_args()
    sizes, repeats = ((4, 5), 5) if args.quick else ((5, 6, 7, 8), 9)
    print("| vertices | step | ours ms | trimesh ms | ours / trimesh | peak MB ours | trimesh |")
    print("|---|---|---|---|---|---|---|")
    for subdivisions in sizes:
        V, F = irregular_sphere(subdivisions)
        for name, ours, theirs in steps(V, F):
            ours(), theirs()  # compile, warm caches
            t_ours = median_time(repeats, ours) * 1e3
            t_theirs = median_time(repeats, theirs) * 1e3
            peaks = [peak_memory(func) for func in (ours, theirs)]
            print(
                f"| {len(V):,} | {name} | {t_ours:.2f} | {t_theirs:.2f} | "
                f"{t_ours / t_theirs:.2f} | {peaks[0]:.1f} | {peaks[1]:.1f} |"
            )


if __name__ == "__main__":
    main()
