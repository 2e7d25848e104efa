"""Retrieval in fitted collections: exact nearest neighbours under the package's
distance pipelines, pruned by lower bounds in bounded memory
(:class:`ShapeNeighbors`, :class:`ShapeNeighborsClassifier`), and the retrieval
measures of SHREC (:func:`retrieval_scores`)."""

from .index import ShapeNeighbors, ShapeNeighborsClassifier
from .scores import retrieval_scores

__all__ = ["ShapeNeighbors", "ShapeNeighborsClassifier", "retrieval_scores"]
