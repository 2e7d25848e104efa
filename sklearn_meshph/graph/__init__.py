"""Graphs as input: validation (:class:`Graph`, :func:`check_graph`) and TU datasets
(:func:`load_tu_dataset`)."""

from .reading import load_tu_dataset, tu_dataset_names
from .validation import Graph, check_graph, is_graph

__all__ = ["Graph", "check_graph", "is_graph", "load_tu_dataset", "tu_dataset_names"]
