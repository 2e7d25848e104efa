"""The mesh-quality check of the eigen stage: a mesh made mostly of needle triangles
has an ill-conditioned Laplacian, and its eigenpairs mean little."""

from __future__ import annotations

import warnings

import numpy as np

from ..mesh import smallest_angle_sines, unit_box

__all__ = ["NEEDLE_SHARE", "NEEDLE_SINE", "MeshQualityWarning", "needle_share", "warn_if_needles"]

#: A triangle whose smallest angle has a sine below this is a needle: its cotangent
#: weight is above 1e6, and a mesh made mostly of them has a meaningless spectrum.
NEEDLE_SINE = 1e-6
#: The share of needle triangles from which a mesh is warned about.
NEEDLE_SHARE = 0.5


class MeshQualityWarning(UserWarning):
    """Most triangles of a mesh are needles: its Laplacian, hence its eigenpairs, mean
    little."""


def needle_share(vertices: np.ndarray, faces: np.ndarray) -> float:
    """The share of triangles whose smallest angle has a sine below ``NEEDLE_SINE``
    (computed in a unit box, so at any scale)."""
    if not len(faces):
        return 0.0
    sines = smallest_angle_sines(unit_box(np.asarray(vertices, dtype=np.float64))[0], faces)
    return float(np.mean(~(sines >= NEEDLE_SINE)))


def warn_if_needles(clean, sample: int, stacklevel: int) -> None:
    """Warn when most triangles of the cleaned mesh of ``sample`` are needles."""
    share = needle_share(clean.vertices, clean.faces)
    if share > NEEDLE_SHARE:
        warnings.warn(
            f"sample {sample}: {100 * share:.3g}% of the triangles are needles (an angle "
            f"with sine below {NEEDLE_SINE:g}); the Laplacian of such a mesh is "
            "ill-conditioned and its eigenpairs mean little: remesh it",
            MeshQualityWarning,
            stacklevel=stacklevel + 1,
        )
