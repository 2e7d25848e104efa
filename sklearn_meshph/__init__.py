"""sklearn-meshph: learning from triangle meshes with persistent homology of Laplacian
eigenfunctions, as scikit-learn estimators.

One sub-package per stage over a shared mesh layer (see ``docs/architecture.md``):
:mod:`.mesh` (input, validation, cleaning, ``ScalarField``), :mod:`.pointcloud` (point
clouds as input: validation, files, their Laplacian and neighbourhood graph),
:mod:`.graph` (graphs as input: ``Graph``, ``check_graph``, TU datasets),
:mod:`.spectral` (Laplacians, eigensolver, ``LaplacianEigenTransformer``),
:mod:`.persistence` (lower-star and extended persistence, ``LowerStarPersistence``) and
:mod:`.diagrams` (distances, ``DiagramDistance``, converters); :mod:`.datasets`,
:mod:`.plotting` and :mod:`.cli` beside them.
"""

from . import _interrupt, vectorization  # noqa: F401 (_interrupt first: see its docstring)
from ._version import __version__ as __version__
from .combine import CombinedDistance, FeatureDistance
from .datasets import load_mesh_folder, make_shapes, sample_point_cloud
from .diagrams import (
    DiagramDistance,
    PerDiagramDistance,
    bottleneck_distance,
    from_giotto,
    from_gudhi,
    from_persim,
    pairwise_diagram_distances,
    sliced_wasserstein_distance,
    to_giotto,
    to_gudhi,
    to_persim,
    wasserstein_distance,
)
from .graph import Graph, check_graph, load_tu_dataset
from .graph_classifier import make_graph_classifier
from .mesh import (
    CleaningReport,
    MeshCleaningWarning,
    ScalarField,
    check_mesh,
    clean_mesh,
    weld_vertices,
)
from .persistence import LowerStarPersistence, extended_persistence, lower_star_persistence
from .pipelines import make_mesh_distance, make_mesh_features
from .pointcloud import check_point_cloud
from .pointcloud.laplacians import point_cloud_laplacian
from .retrieval import ShapeNeighbors, ShapeNeighborsClassifier, retrieval_scores
from .spectral import (
    CacheWarning,
    ConstantEigenfunctionWarning,
    LaplacianEigenTransformer,
    MeshQualityWarning,
    RepeatedEigenvalueWarning,
    ShapeDNA,
    cotangent_laplacian,
    graph_laplacian,
    laplacian_eigenfunctions,
)
from .vectorization import *  # noqa: F403 (vectorization.__all__, listed below)

__all__ = [
    "CacheWarning",
    *vectorization.__all__,
    "CombinedDistance",
    "CleaningReport",
    "DiagramDistance",
    "FeatureDistance",
    "Graph",
    "LaplacianEigenTransformer",
    "LowerStarPersistence",
    "MeshCleaningWarning",
    "MeshQualityWarning",
    "PerDiagramDistance",
    "ConstantEigenfunctionWarning",
    "RepeatedEigenvalueWarning",
    "ScalarField",
    "ShapeDNA",
    "ShapeNeighbors",
    "ShapeNeighborsClassifier",
    "bottleneck_distance",
    "check_graph",
    "check_mesh",
    "check_point_cloud",
    "clean_mesh",
    "cotangent_laplacian",
    "extended_persistence",
    "from_giotto",
    "from_gudhi",
    "from_persim",
    "graph_laplacian",
    "laplacian_eigenfunctions",
    "load_mesh_folder",
    "load_tu_dataset",
    "lower_star_persistence",
    "make_graph_classifier",
    "make_mesh_distance",
    "make_mesh_features",
    "make_shapes",
    "point_cloud_laplacian",
    "sample_point_cloud",
    "pairwise_diagram_distances",
    "retrieval_scores",
    "sliced_wasserstein_distance",
    "to_giotto",
    "to_gudhi",
    "to_persim",
    "wasserstein_distance",
    "weld_vertices",
]
