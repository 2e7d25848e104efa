"""Graphs as input: validation (:class:`Graph`, :func:`check_graph`)."""

from .validation import Graph, check_graph, is_graph

__all__ = ["Graph", "check_graph", "is_graph"]
