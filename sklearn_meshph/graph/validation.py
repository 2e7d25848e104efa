"""Graphs: the validated form every stage reads, and the one validator of graph samples.

A graph sample is one of

- a :class:`Graph` (validated when made, returned as is);
- a ``networkx.Graph`` (networkx is imported by nobody here: the object is read through
  its own methods). Nodes are numbered in sorted order when they sort, else in insertion
  order; an edge's ``"weight"`` attribute is its weight (1 when absent); the node
  attributes ``"label"`` (a number) and ``"attributes"`` (a sequence of numbers) become
  the columns of ``node_values`` (the label first). Directed graphs and multigraphs are
  refused (``to_undirected()``, ``networkx.Graph(g)`` make one);
- a scipy sparse adjacency matrix: square, symmetric (up to rounding), entries
  non-negative and finite; stored zeros are no edge. Never made dense;
- an ``(n_nodes, edges)`` pair, ``edges`` an ``(m, 2)`` integer array of node indices
  ``0 <= i < n_nodes``: repeated edges and both directions of an edge are one edge of
  weight 1.

Whatever the form, self-loops are dropped (a loop joins a node to itself: no simplex of
the graph, no cycle, and in the Laplacians of a graph it only shifts a node's degree),
and so are edges of weight 0. Isolated nodes and several components are valid: an
isolated node is a component of one node. Which components the eigen stage keeps is its
``components`` policy, not this validator's. A graph without nodes is refused.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from numbers import Integral, Number

import numpy as np
import scipy.sparse as sp

from ..mesh.validation import where

__all__ = ["Graph", "check_graph", "holds_text", "is_graph", "real_numbers"]

# Relative difference tolerated between a[i, j] and a[j, i] of a symmetric adjacency.
_SYMMETRY_RTOL = 1e-10

# Most nodes a graph may have: scipy's sparse graph routines index nodes with 32-bit
# integers, and an edge (i, j) is keyed by i * n_nodes + j, which must fit in 64 bits.
MAX_NODES = 2**31 - 1
# The smallest normal float64: the Laplacians divide by degrees.
_TINY = float(np.finfo(np.float64).tiny)


def _frozen(array: np.ndarray) -> np.ndarray:
    array = np.array(array, copy=True)
    array.flags.writeable = False
    return array


def _n_nodes(n_nodes, place: str) -> int:
    if isinstance(n_nodes, bool) or not isinstance(n_nodes, Integral):
        raise TypeError(f"{place}: n_nodes must be a positive int, got {n_nodes!r}")
    if n_nodes < 1:
        raise ValueError(f"{place}: a graph needs at least one node, got n_nodes={n_nodes}")
    if n_nodes > MAX_NODES:
        raise ValueError(
            f"{place}: n_nodes={n_nodes} is more than the {MAX_NODES} nodes a graph may have"
        )
    return int(n_nodes)


def _edge_array(edges, place: str) -> np.ndarray:
    """``edges`` as an ``(m, 2)`` int64 array, or an error saying what it is."""
    try:
        array = np.asarray(edges)
    except (ValueError, TypeError):
        raise ValueError(f"{place}: edges must be an (m, 2) integer array") from None
    if array.size == 0 and (array.ndim == 1 or array.shape == (0, 2)):  # [] or (0, 2)
        return np.empty((0, 2), dtype=np.int64)
    if array.ndim != 2 or array.shape[1] != 2:
        raise ValueError(f"{place}: edges must be an (m, 2) integer array, got shape {array.shape}")
    if array.dtype.kind not in "iu":
        raise TypeError(f"{place}: edges must be integers, got dtype {array.dtype}")
    if array.dtype.kind == "u" and array.size and array.max() > np.iinfo(np.int64).max:
        row = int(np.argmax((array > np.iinfo(np.int64).max).any(axis=1)))
        raise ValueError(
            f"{place}: edge {row} {tuple(array[row].tolist())} has a node beyond int64"
        )
    return array.astype(np.int64, copy=False)


def holds_text(values, none: bool = False) -> bool:
    """Whether ``values`` (an array or a sequence) hold text, which
    ``np.asarray(..., float64)`` reads as numbers ("3" as 3.0), or with ``none`` a None
    (read as NaN). Booleans are numbers, 0 and 1, as scikit-learn reads them (a sparse
    boolean adjacency, one-hot node attributes). A ragged sequence is not looked into."""
    if isinstance(values, np.ndarray) and values.dtype.kind in "biuf":
        return False
    try:
        raw = values if isinstance(values, np.ndarray) else np.asarray(values, dtype=object)
    except (ValueError, TypeError):
        return False
    if raw.dtype.kind in "US":
        return True
    kinds = (str, bytes, type(None)) if none else (str, bytes)
    return raw.dtype.kind == "O" and any(isinstance(v, kinds) for v in raw.flat)


def _numbers_only(values, what: str, place: str) -> None:
    """Refuse text (:func:`holds_text`), so that every form of a graph takes the same
    values."""
    if holds_text(values):
        raise TypeError(f"{place}: {what} must be numbers, not text")


def real_numbers(values, what: str, place: str) -> np.ndarray:
    """``values`` as float64: a ``TypeError`` naming ``place`` and ``what`` for text,
    complex numbers (numpy would drop their imaginary parts with only a warning) or
    other objects; a ``ValueError`` for an integer beyond float64's range."""
    _numbers_only(values, what, place)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", np.exceptions.ComplexWarning)
            if np.iscomplexobj(values):
                raise np.exceptions.ComplexWarning
            return np.asarray(values, dtype=np.float64)
    except OverflowError:  # an int beyond float64
        raise ValueError(f"{place}: {what} must be finite, got one beyond float64") from None
    except (ValueError, TypeError, np.exceptions.ComplexWarning):
        raise TypeError(f"{place}: {what} must be real numbers") from None


def _check_node_values(values, n_nodes: int, place: str):
    if values is None:
        return None
    values = real_numbers(values, "node values", place)
    if values.ndim == 1:
        values = values[:, None]
    if values.ndim != 2 or len(values) != n_nodes:
        raise ValueError(
            f"{place}: node values must have shape ({n_nodes}, n_values), got {values.shape}"
        )
    if not np.isfinite(values).all():
        node = int(np.flatnonzero(~np.isfinite(values).all(axis=1))[0])
        raise ValueError(f"{place}: node {node} has a NaN or infinite value")
    return values


@dataclass(frozen=True, eq=False)
class Graph:
    """An undirected graph, validated: what the stages read of a graph sample.

    Parameters
    ----------
    n_nodes : int
        Number of nodes (isolated nodes included), at least 1.
    edges : ndarray of shape (n_edges, 2)
        Each undirected edge once, as node indices ``i < j``, rows sorted.
    weights : ndarray of shape (n_edges,)
        Positive finite edge weights (ones for an unweighted graph).
    node_values : ndarray of shape (n_nodes, n_values), optional
        Node labels or attributes that travel with the graph (finite; one value per
        node may be given as an ``(n_nodes,)`` array).

    Raises
    ------
    ValueError, TypeError
        When a field breaks the rules above (the checks are linear in the size).
        :func:`check_graph` makes a ``Graph`` from looser forms.
    """

    n_nodes: int
    edges: np.ndarray
    weights: np.ndarray
    node_values: np.ndarray | None = field(default=None, repr=False)

    def __post_init__(self):
        place = "graph"
        n_nodes = _n_nodes(self.n_nodes, place)
        edges = _edge_array(self.edges, place)
        weights = real_numbers(self.weights, "edge weights", place).reshape(-1)
        if len(weights) != len(edges):
            raise ValueError(f"{place}: {len(edges)} edges but {len(weights)} weights")
        i, j = edges[:, 0], edges[:, 1]
        if len(edges) and (i.min() < 0 or j.max() >= n_nodes):
            raise ValueError(f"{place}: an edge has a node outside 0..{n_nodes - 1}")
        if not (i < j).all():
            raise ValueError(f"{place}: each edge must be given as (i, j) with i < j")
        keys = i * n_nodes + j  # increasing exactly when the rows are sorted and unique
        if not (keys[1:] > keys[:-1]).all():
            raise ValueError(f"{place}: edges must be sorted rows without repeats")
        if not ((weights > 0) & (weights < np.inf)).all():  # NaN fails both
            raise ValueError(f"{place}: edge weights must be positive and finite")
        if (weights < _TINY).any():  # a subnormal degree's inverse is inf
            raise ValueError(
                f"{place}: edge weights must be at least {_TINY:.3g} (smaller ones are "
                f"subnormal floats, whose inverse overflows), got {weights.min():.3g}"
            )
        node_values = _check_node_values(self.node_values, n_nodes, place)
        object.__setattr__(self, "n_nodes", n_nodes)
        object.__setattr__(self, "edges", _frozen(edges))
        object.__setattr__(self, "weights", _frozen(weights))
        if node_values is not None:
            object.__setattr__(self, "node_values", _frozen(node_values))

    def __reduce__(self):  # unpickled through __init__: checked, arrays read-only again
        return type(self), (self.n_nodes, self.edges, self.weights, self.node_values)

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
    edges)`` pair (a number first), a scipy sparse matrix or a networkx graph."""
    if isinstance(sample, Graph) or sp.issparse(sample):
        return True
    if isinstance(sample, tuple | list) and len(sample) == 2:
        return isinstance(sample[0], Number)
    return hasattr(sample, "adj") and hasattr(sample, "nodes")


def _graph(place: str, *fields) -> Graph:
    """``Graph(*fields)``, its errors naming ``place`` (the sample) rather than "graph"."""
    try:
        return Graph(*fields)
    except ValueError as error:
        text = str(error)
        if not text.startswith("graph: "):
            raise
        raise ValueError(f"{place}: {text.removeprefix('graph: ')}") from None


def _from_edges(n_nodes: int, edges: np.ndarray, weights, node_values, place: str) -> Graph:
    """The :class:`Graph` of edges in any order and direction: self-loops and edges of
    weight 0 dropped, repeats (both directions too) made one, of the first one's weight
    (all ones for a pair; a networkx graph has no repeats)."""
    if len(edges) and (edges.min() < 0 or edges.max() >= n_nodes):
        row = int(np.flatnonzero(((edges < 0) | (edges >= n_nodes)).any(axis=1))[0])
        raise ValueError(
            f"{place}: edge {row} {tuple(edges[row].tolist())} has a node outside 0..{n_nodes - 1}"
        )
    weights = np.ones(len(edges)) if weights is None else weights
    keep = (edges[:, 0] != edges[:, 1]) & (weights != 0)
    low = np.minimum(edges[keep, 0], edges[keep, 1])
    high = np.maximum(edges[keep, 0], edges[keep, 1])
    keys, first = np.unique(low * n_nodes + high, return_index=True)
    pairs = np.column_stack([keys // n_nodes, keys % n_nodes])
    return _graph(place, n_nodes, pairs, weights[keep][first], node_values)


def _weight(value, place: str) -> float:
    # Text is not a weight, though float() reads "2.5" (True is 1, as everywhere).
    if isinstance(value, (str, bytes)):
        raise TypeError(f"{place}: edge weight {value!r} is not a number")
    try:
        if np.iscomplexobj(value):  # float() refuses complex, numpy's drops the imaginary
            raise TypeError
        weight = float(value)
    except OverflowError:  # an int beyond float64
        weight = np.inf
    except (ValueError, TypeError):
        raise TypeError(f"{place}: edge weight {value!r} is not a number") from None
    if not np.isfinite(weight) or weight < 0:
        raise ValueError(f"{place}: edge weights must be non-negative and finite, got {weight}")
    return weight


def _networkx_node_values(data: list[dict], place: str):
    """The ``"label"`` and ``"attributes"`` of the nodes as columns, or None."""
    columns = []
    for key in ("label", "attributes"):
        present = [key in d for d in data]
        if not any(present):
            continue
        if not all(present):
            node = present.index(False)
            raise ValueError(f"{place}: node {node} has no {key!r} while other nodes have one")
        try:
            raw = np.array([d[key] for d in data])
            if holds_text(raw) or np.iscomplexobj(raw):  # "3" would be read as 3
                raise TypeError
            column = raw.astype(np.float64)
        except OverflowError:  # an int beyond float64
            raise ValueError(
                f"{place}: node {key!r} values must be finite, got one beyond float64"
            ) from None
        except (ValueError, TypeError):
            raise TypeError(
                f"{place}: node {key!r} values must be real numbers, as many on every node "
                "(encode text labels first)"
            ) from None
        columns.append(column.reshape(len(data), -1))
    return np.hstack(columns) if columns else None


def _from_networkx(graph, place: str) -> Graph:
    if graph.is_directed():
        raise TypeError(f"{place}: a directed networkx graph; pass graph.to_undirected()")
    if graph.is_multigraph():
        raise TypeError(f"{place}: a networkx multigraph; pass networkx.Graph(graph)")
    nodes = list(graph.nodes)
    try:
        nodes = sorted(nodes)
    except TypeError:  # nodes of kinds that do not compare: insertion order
        pass
    position = {node: k for k, node in enumerate(nodes)}
    n_nodes = _n_nodes(len(nodes), place)
    attributes = graph.nodes(data=True)
    node_values = _networkx_node_values([attributes[node] for node in nodes], place)
    triples = [
        (position[u], position[v], _weight(d.get("weight", 1.0), place))
        for u, v, d in graph.edges(data=True)
    ]
    edges = np.array([t[:2] for t in triples], dtype=np.int64).reshape(-1, 2)
    weights = np.array([t[2] for t in triples], dtype=np.float64)
    return _from_edges(
        n_nodes, edges, weights, _check_node_values(node_values, n_nodes, place), place
    )


def _asymmetry(rows, cols, values, n: int, place: str) -> None:
    """Refuse an adjacency whose upper and lower triangles differ; name one entry. The
    entries come in row order, so the upper triangle's keys are sorted."""
    upper, lower = rows < cols, rows > cols
    up_keys, up_values = rows[upper] * n + cols[upper], values[upper]
    low_keys = cols[lower] * n + rows[lower]
    low_order = np.argsort(low_keys, kind="stable")
    low_keys, low_values = low_keys[low_order], values[lower][low_order]
    if len(up_keys) == len(low_keys) and np.array_equal(up_keys, low_keys):
        close = np.abs(up_values - low_values) <= _SYMMETRY_RTOL * np.maximum(up_values, low_values)
        if close.all():
            return
        k = int(np.flatnonzero(~close)[0])
        i, j = divmod(int(up_keys[k]), n)
        a, b = up_values[k], low_values[k]
    else:
        missing = np.setxor1d(up_keys, low_keys)[0]
        i, j = divmod(int(missing), n)
        a = up_values[up_keys == missing][0] if np.isin(missing, up_keys) else 0.0
        b = low_values[low_keys == missing][0] if np.isin(missing, low_keys) else 0.0
    raise ValueError(
        f"{place}: the adjacency matrix is not symmetric: entry ({i}, {j}) is {float(a)!r} "
        f"but ({j}, {i}) is {float(b)!r}"
    )


def _from_sparse(matrix, place: str) -> Graph:
    if matrix.ndim != 2 or matrix.shape[0] != matrix.shape[1]:
        raise ValueError(f"{place}: an adjacency matrix must be square, got shape {matrix.shape}")
    n_nodes = _n_nodes(matrix.shape[0], place)
    if matrix.dtype.kind not in "biuf":
        raise TypeError(f"{place}: adjacency entries must be real numbers, got {matrix.dtype}")
    # A float64 copy (the caller's matrix is left alone) before repeated entries are
    # summed: in uint8, 200 + 100 would wrap to 44.
    coo = sp.coo_array(matrix, dtype=np.float64, copy=True)
    if not np.isfinite(coo.data).all():
        raise ValueError(f"{place}: the adjacency matrix has a NaN or infinite entry")
    with np.errstate(over="ignore", invalid="ignore"):
        coo.sum_duplicates()  # also sorts the entries by row, then column
    values = coo.data
    if not np.isfinite(values).all():
        k = int(np.flatnonzero(~np.isfinite(values))[0])
        raise ValueError(
            f"{place}: the repeated entries of ({int(coo.row[k])}, {int(coo.col[k])}) of "
            "the adjacency matrix sum beyond float64's range"
        )
    if (values < 0).any():
        k = int(np.flatnonzero(values < 0)[0])
        raise ValueError(
            f"{place}: the adjacency matrix has a negative entry ({int(coo.row[k])}, "
            f"{int(coo.col[k])}) = {values[k]:g}; edge weights must be non-negative"
        )
    rows, cols = coo.row.astype(np.int64), coo.col.astype(np.int64)
    kept = (values != 0) & (rows != cols)
    rows, cols, values = rows[kept], cols[kept], values[kept]
    _asymmetry(rows, cols, values, n_nodes, place)
    upper = rows < cols
    edges = np.column_stack([rows[upper], cols[upper]])
    return _graph(place, n_nodes, edges, values[upper])


def check_graph(sample, *, index: int | None = None) -> Graph:
    """``sample`` as a validated :class:`Graph`; errors name the sample.

    Parameters
    ----------
    sample : Graph, networkx.Graph, scipy sparse matrix or (n_nodes, edges) pair
        See the module's documentation for what each form means.
    index : int, optional
        The sample's position, for the messages (``"sample 3: ..."``).

    Returns
    -------
    Graph

    Raises
    ------
    TypeError
        A sample of none of these forms; a directed graph or multigraph; ``n_nodes`` not
        an int; edges or entries that are not numbers.
    ValueError
        No node; an edge outside ``0..n_nodes - 1`` or of the wrong shape; an asymmetric,
        non-square adjacency; a negative, NaN or infinite weight; a NaN node value.
    """
    place = where(index, "graph")
    if isinstance(sample, Graph):
        return sample
    if sp.issparse(sample):
        return _from_sparse(sample, place)
    if isinstance(sample, tuple | list) and len(sample) == 2 and isinstance(sample[0], Number):
        n_nodes = _n_nodes(sample[0], place)
        return _from_edges(n_nodes, _edge_array(sample[1], place), None, None, place)
    if hasattr(sample, "adj") and hasattr(sample, "nodes"):
        return _from_networkx(sample, place)
    raise TypeError(f"{place}: not a graph: {type(sample).__name__}")
