"""Diagrams into any scikit-learn model: vectorizations (fixed-length features) and
kernels (precomputed kernel matrices) of persistence diagrams."""

from .curves import BettiCurve, EntropyCurve, PersistenceLandscape, Silhouette
from .distance_kernel import DistanceKernel
from .graph_features import GraphFeatures
from .graph_pairs import GraphPairDistances
from .graph_svc import KernelSumSVC
from .images import PersistenceImage
from .kernels import (
    PersistenceScaleSpaceKernel,
    PersistenceWeightedGaussianKernel,
    SlicedWassersteinKernel,
)
from .scaling import DistanceScaler
from .summaries import DiagramStatistics, PersistenceEntropy

__all__ = [
    "BettiCurve",
    "DiagramStatistics",
    "DistanceKernel",
    "DistanceScaler",
    "EntropyCurve",
    "GraphFeatures",
    "GraphPairDistances",
    "KernelSumSVC",
    "PersistenceEntropy",
    "PersistenceImage",
    "PersistenceLandscape",
    "PersistenceScaleSpaceKernel",
    "PersistenceWeightedGaussianKernel",
    "Silhouette",
    "SlicedWassersteinKernel",
]
