"""sklearn-meshph: learning from triangle meshes with persistent homology of Laplacian
eigenfunctions, as scikit-learn estimators."""

from ._mesh import check_mesh, clean_mesh
from .converters import from_giotto, from_gudhi, from_persim, to_giotto, to_gudhi, to_persim
from .datasets import load_mesh_folder, make_shapes
from .distance_transformer import DiagramDistance
from .distances import bottleneck_distance, wasserstein_distance
from .eigen import LaplacianEigenTransformer, RepeatedEigenvalueWarning
from .laplacian import cotangent_laplacian, graph_laplacian, laplacian_eigenfunctions
from .persistence import lower_star_persistence
from .persistence_transformer import LowerStarPersistence
from .scalar_field import ScalarField

__version__ = "0.1.0.dev0"

__all__ = [
    "DiagramDistance",
    "LaplacianEigenTransformer",
    "LowerStarPersistence",
    "RepeatedEigenvalueWarning",
    "ScalarField",
    "bottleneck_distance",
    "check_mesh",
    "clean_mesh",
    "cotangent_laplacian",
    "from_giotto",
    "from_gudhi",
    "from_persim",
    "graph_laplacian",
    "laplacian_eigenfunctions",
    "load_mesh_folder",
    "lower_star_persistence",
    "make_shapes",
    "to_giotto",
    "to_gudhi",
    "to_persim",
    "wasserstein_distance",
]
