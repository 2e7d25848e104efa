"""sklearn-meshph: learning from triangle meshes with persistent homology of Laplacian
eigenfunctions, as scikit-learn estimators."""

from ._mesh import check_mesh, clean_mesh
from .eigen import LaplacianEigenTransformer, RepeatedEigenvalueWarning
from .laplacian import cotangent_laplacian, graph_laplacian, laplacian_eigenfunctions
from .scalar_field import ScalarField

__version__ = "0.1.0.dev0"

__all__ = [
    "LaplacianEigenTransformer",
    "RepeatedEigenvalueWarning",
    "ScalarField",
    "check_mesh",
    "clean_mesh",
    "cotangent_laplacian",
    "graph_laplacian",
    "laplacian_eigenfunctions",
]
