"""Graphs: the validated form every stage reads, and the one validator of graph samples."""

from __future__ import annotations

from dataclasses import dataclass, field
from numbers import Integral

import numpy as np
import scipy.sparse as sp

from ..mesh.validation import where

__all__ = ["Graph", "check_graph", "is_graph"]


def _frozen(array: np.ndarray) -> np.ndarray:
    array = np.array(array, copy=True)
    array.flags.writeable = False
    return array


@dataclass(frozen=True, eq=False)
class Graph:
    """An undirected graph, validated: what the stages read of a graph sample.

    Parameters
    ----------
    n_nodes : int
        Number of nodes (isolated nodes included).
    edges : ndarray of shape (n_edges, 2)
        Each undirected edge once, as node indices ``i < j``, rows sorted.
    weights : ndarray of shape (n_edges,)
        Positive finite edge weights (ones for an unweighted graph).
    node_values : ndarray of shape (n_nodes, n_values), optional
        Node labels or attributes that travel with the graph.
    """

    n_nodes: int
    edges: np.ndarray
    weights: np.ndarray
    node_values: np.ndarray | None = field(default=None, repr=False)

    def __post_init__(self):
        object.__setattr__(self, "edges", _frozen(np.asarray(self.edges, dtype=np.int64)))
        object.__setattr__(self, "weights", _frozen(np.asarray(self.weights, dtype=np.float64)))
        if self.node_values is not None:
            object.__setattr__(
                self, "node_values", _frozen(np.asarray(self.node_values, dtype=np.float64))
            )

    @property
    def n_edges(self) -> int:
        """Number of (undirected) edges."""
        return len(self.edges)

    def adjacency(self) -> sp.csr_matrix:
        """The symmetric weighted adjacency matrix, CSR."""
        i, j = self.edges[:, 0], self.edges[:, 1]
        w = np.concatenate([self.weights, self.weights])
        shape = (self.n_nodes, self.n_nodes)
        return sp.csr_matrix((w, (np.concatenate([i, j]), np.concatenate([j, i]))), shape=shape)


def is_graph(sample) -> bool:
    """Whether ``sample`` (not a path) is a graph: a :class:`Graph`, an ``(n_nodes,
    edges)`` pair (an integer first), a scipy sparse matrix or a networkx graph."""
    if isinstance(sample, Graph) or sp.issparse(sample):
        return True
    if isinstance(sample, tuple | list) and len(sample) == 2:
        first = sample[0]
        return isinstance(first, Integral) and not isinstance(first, bool)
    return hasattr(sample, "adj") and hasattr(sample, "nodes")


def check_graph(sample, *, index: int | None = None) -> Graph:
    """``sample`` as a validated :class:`Graph`, errors naming the sample."""
    if isinstance(sample, Graph):
        return sample
    if isinstance(sample, tuple | list) and len(sample) == 2:
        n_nodes, edges = int(sample[0]), np.asarray(sample[1])
        if edges.ndim != 2 or edges.shape[1] != 2 or edges.dtype.kind not in "iu":
            raise ValueError(f"{where(index)}: edges must be an (m, 2) integer array")
        edges = np.unique(np.sort(edges.astype(np.int64), axis=1), axis=0)
        return Graph(n_nodes, edges, np.ones(len(edges)))
    raise TypeError(f"{where(index)}: not a graph: {type(sample).__name__}")
