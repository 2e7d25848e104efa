"""sklearn-meshph: learning from triangle meshes with persistent homology of Laplacian
eigenfunctions, as scikit-learn estimators."""

from ._mesh import check_mesh, clean_mesh
from .scalar_field import ScalarField

__version__ = "0.1.0.dev0"

__all__ = [
    "ScalarField",
    "check_mesh",
    "clean_mesh",
]
