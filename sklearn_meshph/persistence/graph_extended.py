"""Extended persistence of a function on a graph's nodes: all four diagrams.

The lower-star filtration of a graph (node ``v`` at ``f(v)``, edge ``uv`` at
``max(f(u), f(v))``) and its extension by the superlevel sets give four diagrams (the
names gudhi's ``SimplexTree.extended_persistence`` uses):

- ``ord0``: the finite sublevel H0 pairs (min, saddle), by union-find (elder rule);
- ``rel1``: the relative H1 pairs, one per finite superlevel H0 pair, as
  (max, saddle);
- ``ext0``: each connected component's (min, max);
- ``ext1``: one point (birth, death) per independent cycle: birth the level at which
  the ascending sweep creates the class, death the level at which the descending sweep
  has it, ``birth >= death``.

``ext1`` is the relative position of two flags of the cycle space: the cycles of the
sublevel sets and those of the superlevel sets. The edges that close a cycle in the
ascending sweep (its positive edges, the non-tree edges of the ascending spanning
forest) are coordinates in which the sublevel flag is the standard flag; each positive
edge of the descending sweep gives its fundamental cycle in the descending spanning
forest, whose coordinates are computed over Z/2 as bitsets (the XOR of two root-path
labels); reducing those columns left to right with the highest ascending index as
pivot pairs each descending edge with the ascending edge that creates its class.
"""

from __future__ import annotations

from typing import NamedTuple

import numba
import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from ..graph.validation import Graph, holds_text
from ..inputs import check_input
from ..mesh.graph import find_root
from ..mesh.validation import check_values
from .extended import rooted_forest
from .lower_star import elder_merge

__all__ = [
    "GRAPH_DIAGRAMS",
    "GraphCycles",
    "batch_diagrams",
    "extended_persistence",
]

#: The keys of :func:`extended_persistence`, in the order of :func:`batch_diagrams`.
GRAPH_DIAGRAMS = ("ord0", "rel1", "ext0", "ext1")


# Bytes at most of ext1's bitset table for one graph: (nodes + cycles) rows of one bit
# per independent cycle. It grows with the square of the cycles (the complete graph on
# 700 nodes, 243,951 cycles, needs 7.4 GB), where the rest is linear.
MAX_CYCLE_TABLE_BYTES = 4 << 30


def check_cycle_table(n_nodes: int, edges: np.ndarray, place: str) -> None:
    """Refuse, before any allocation, a graph whose ``ext1`` table would need more than
    ``MAX_CYCLE_TABLE_BYTES`` (``edges``: in range, repeats and loops allowed)."""

    def table_bytes(cycles):
        return (n_nodes + cycles) * ((cycles + 63) // 64) * 8

    if table_bytes(len(edges)) <= MAX_CYCLE_TABLE_BYTES:  # cycles <= edges: cheap bound
        return
    simple = _simple_edges(n_nodes, np.ascontiguousarray(edges, dtype=np.int64))
    adjacency = sp.csr_matrix(
        (np.ones(len(simple)), (simple[:, 0], simple[:, 1])), shape=(n_nodes, n_nodes)
    )
    n_components = connected_components(adjacency, directed=False)[0]
    cycles = len(simple) - n_nodes + n_components
    if table_bytes(cycles) > MAX_CYCLE_TABLE_BYTES:
        raise ValueError(
            f"{place}: {cycles} independent cycles; extended persistence's ext1 over them "
            f"would need {table_bytes(cycles) / 2**30:.1f} GiB (at most "
            f"{MAX_CYCLE_TABLE_BYTES / 2**30:.0f} GiB; the table grows with the square of "
            "the cycles: sparsify the graph, or use filtration='sublevel')"
        )


class GraphCycles(NamedTuple):
    """A graph sample as the extended filtration reads it: its node count and its edges
    (in range; repeats and self-loops are left out by the compiled code)."""

    n_nodes: int
    edges: np.ndarray


@numba.njit(cache=True)
def _simple_edges(n_nodes, edges):
    """``edges`` as a simple graph, a new array: each edge once as ``i < j`` in sorted
    rows, self-loops dropped (a loop is no cycle of the lower-star filtration, a
    repeated edge the same simplex). Already simple rows are only copied."""
    simple = True
    for e in range(len(edges)):
        a, b = edges[e, 0], edges[e, 1]
        if a >= b or (e and edges[e - 1, 0] * n_nodes + edges[e - 1, 1] >= a * n_nodes + b):
            simple = False
            break
    if simple:
        return edges.copy()
    keys = np.empty(len(edges), dtype=np.int64)
    count = 0
    for e in range(len(edges)):
        a, b = min(edges[e, 0], edges[e, 1]), max(edges[e, 0], edges[e, 1])
        if a != b:
            keys[count] = a * n_nodes + b
            count += 1
    keys = np.unique(keys[:count])
    out = np.empty((len(keys), 2), dtype=np.int64)
    out[:, 0] = keys // n_nodes
    out[:, 1] = keys % n_nodes
    return out


@numba.njit(cache=True)
def _incidence(n_nodes, edges):
    """CSR of the edges around each node: ``incident[indptr[v]:indptr[v + 1]]``."""
    indptr = np.zeros(n_nodes + 1, dtype=np.int64)
    for e in range(len(edges)):
        indptr[edges[e, 0] + 1] += 1
        indptr[edges[e, 1] + 1] += 1
    for v in range(n_nodes):
        indptr[v + 1] += indptr[v]
    fill = indptr[:-1].copy()
    incident = np.empty(2 * len(edges), dtype=np.int64)
    for e in range(len(edges)):
        for a in (edges[e, 0], edges[e, 1]):
            incident[fill[a]] = e
            fill[a] += 1
    return indptr, incident


@numba.njit(cache=True)
def _sweep(order, indptr, incident, edges):
    """Union-find over the nodes in ``order``, each edge entering with its later node.

    Returns the H0 pairs as (birth node, death node) by the elder rule (a node's own
    zero-length pair left out), the union-find parents, whether each edge is in the
    spanning forest, and the positive edges (closing a cycle) in the order they enter.
    """
    n = len(order)
    position = np.empty(n, dtype=np.int64)
    for r in range(n):
        position[order[r]] = r
    parent = np.arange(n)
    in_forest = np.zeros(len(edges), dtype=np.bool_)
    positive = np.empty(len(edges), dtype=np.int64)
    births = np.empty(n, dtype=np.int64)
    deaths = np.empty(n, dtype=np.int64)
    n_pairs = n_positive = 0
    # index loops, not slices: a slice of an array is a reference to count in each turn
    for r in range(n):
        v = order[r]
        root_v = v
        for k in range(indptr[v], indptr[v + 1]):
            e = incident[k]
            u = edges[e, 0] + edges[e, 1] - v
            if position[u] < r:
                root_u = find_root(parent, u)
                if root_u == root_v:
                    positive[n_positive] = e
                    n_positive += 1
                else:
                    in_forest[e] = True
                    root_v, n_pairs = elder_merge(
                        parent, position, root_u, root_v, v, births, deaths, n_pairs
                    )
    return births[:n_pairs], deaths[:n_pairs], parent, in_forest, positive[:n_positive]


@numba.njit(cache=True)
def _top_bit(word):
    """Index of the highest set bit of a nonzero uint64."""
    top = 0
    for shift in (32, 16, 8, 4, 2, 1):
        if word >> np.uint64(shift):
            word >>= np.uint64(shift)
            top += shift
    return top


@numba.njit(cache=True)
def _root_path_labels(n_nodes, edges, in_forest, bit_of, words):
    """For every node, the XOR of the bits (``bit_of[e] >= 0``) of the forest edges on
    its path to the root of its tree."""
    parent, parent_edge, depth = rooted_forest(n_nodes, edges, in_forest)
    labels = np.zeros((n_nodes, words), dtype=np.uint64)
    for b in np.argsort(depth, kind="mergesort"):
        e = parent_edge[b]
        if e < 0:
            continue
        for w in range(words):
            labels[b, w] = labels[parent[b], w]
        if bit_of[e] >= 0:
            labels[b, bit_of[e] // 64] ^= np.uint64(1) << np.uint64(bit_of[e] % 64)
    return labels


@numba.njit(cache=True)
def _cycle_pairs(values, edges, up_positive, down_positive, down_forest):
    """Ext1 as (ascending edge, descending edge) index pairs (see the module's notes)."""
    k = len(up_positive)
    if k == 0:  # a forest
        return np.empty((0, 2), dtype=np.int64)
    words = (k + 63) // 64
    bit_of = np.full(len(edges), -1, dtype=np.int64)
    for i in range(k):
        bit_of[up_positive[i]] = i
    labels = _root_path_labels(len(values), edges, down_forest, bit_of, words)
    columns = np.empty((len(down_positive), words), dtype=np.uint64)
    for j in range(len(down_positive)):
        e = down_positive[j]
        for w in range(words):
            columns[j, w] = labels[edges[e, 0], w] ^ labels[edges[e, 1], w]
        if bit_of[e] >= 0:
            columns[j, bit_of[e] // 64] ^= np.uint64(1) << np.uint64(bit_of[e] % 64)
    owner = np.full(k, -1, dtype=np.int64)
    pairs = np.empty((len(down_positive), 2), dtype=np.int64)
    n_pairs = 0
    for j in range(len(down_positive)):
        while True:
            low = -1
            for w in range(words - 1, -1, -1):
                if columns[j, w]:
                    low = 64 * w + _top_bit(columns[j, w])
                    break
            if low < 0 or owner[low] < 0:
                break
            for w in range(words):
                columns[j, w] ^= columns[owner[low], w]
        if low >= 0:
            owner[low] = j
            pairs[n_pairs, 0] = up_positive[low]
            pairs[n_pairs, 1] = down_positive[j]
            n_pairs += 1
    return pairs[:n_pairs]


@numba.njit(cache=True)
def _kept(values, births, deaths, min_persistence):
    """Rows ``(values[birth], values[death])`` of the node pairs with ``|death - birth|
    > min_persistence``."""
    out = np.empty((len(births), 2))
    count = 0
    for i in range(len(births)):
        birth, death = values[births[i]], values[deaths[i]]
        if abs(death - birth) > min_persistence:
            out[count, 0] = birth
            out[count, 1] = death
            count += 1
    return out[:count]


@numba.njit(cache=True)
def _graph_diagrams(n_nodes, edges, values, min_persistence):
    """The four diagrams of one function, gudhi's orientation (see the module)."""
    edges = _simple_edges(n_nodes, edges)
    order = np.argsort(values, kind="mergesort")
    indptr, incident = _incidence(n_nodes, edges)
    up_births, up_deaths, up_parent, _, up_positive = _sweep(order, indptr, incident, edges)
    down_births, down_deaths, _, down_forest, down_positive = _sweep(
        order[::-1], indptr, incident, edges
    )
    ord0 = _kept(values, up_births, up_deaths, min_persistence)
    rel1 = _kept(values, down_births, down_deaths, min_persistence)
    # ext0: the ascending roots are the components' minima (in ascending order), their
    # highest nodes the last of each component
    top = np.empty(n_nodes, dtype=np.int64)
    roots = np.empty(n_nodes, dtype=np.int64)
    n_roots = 0
    for v in order:
        root = find_root(up_parent, v)
        top[root] = v
        if root == v:
            roots[n_roots] = v
            n_roots += 1
    ext0 = _kept(values, roots[:n_roots], top[roots[:n_roots]], min_persistence)
    # ext1: each pair (ascending edge, descending edge) as (its upper, its lower node)
    pairs = _cycle_pairs(values, edges, up_positive, down_positive, down_forest)
    for i in range(len(pairs)):
        a, d = pairs[i, 0], pairs[i, 1]
        pairs[i, 0] = edges[a, 0] if values[edges[a, 0]] > values[edges[a, 1]] else edges[a, 1]
        pairs[i, 1] = edges[d, 0] if values[edges[d, 0]] < values[edges[d, 1]] else edges[d, 1]
    ext1 = _kept(values, pairs[:, 0], pairs[:, 1], min_persistence)
    return ord0, rel1, ext0, ext1


@numba.njit(cache=True)
def _batch(job_nodes, job_edges, job_values, edges, values, min_persistence, lower_first):
    """:func:`_graph_diagrams` of every job ``j``: the graph of ``job_nodes[j]`` nodes and
    the edges ``edges[job_edges[j, 0]:job_edges[j, 1]]``, the function
    ``values[job_values[j]:job_values[j] + job_nodes[j]]``. Returns the four diagrams of
    all jobs packed one after the other (``lower_first``: the columns of ``rel1`` and
    ``ext1`` swapped), and the number of rows of each ``(jobs, 4)``."""
    n_total = job_nodes.sum()
    m_total = (job_edges[:, 1] - job_edges[:, 0]).sum()
    packed = (
        np.empty((n_total, 2)),
        np.empty((n_total, 2)),
        np.empty((n_total, 2)),
        np.empty((m_total, 2)),
    )
    counts = np.zeros((len(job_nodes), 4), dtype=np.int64)
    fill = np.zeros(4, dtype=np.int64)
    for j in range(len(job_nodes)):
        n = job_nodes[j]
        start = job_values[j]
        diagrams = _graph_diagrams(
            n, edges[job_edges[j, 0] : job_edges[j, 1]], values[start : start + n], min_persistence
        )
        for k in range(4):
            rows = diagrams[k]
            swap = lower_first and k % 2 == 1
            for i in range(len(rows)):
                packed[k][fill[k] + i, 0] = rows[i, 1] if swap else rows[i, 0]
                packed[k][fill[k] + i, 1] = rows[i, 0] if swap else rows[i, 1]
            fill[k] += len(rows)
            counts[j, k] = len(rows)
    return packed, counts


def batch_diagrams(
    samples, min_persistence: float = 0.0, lower_first: bool = False
) -> list[list[tuple]]:
    """The four diagrams of many functions on many graphs, in one compiled call.

    ``samples``: ``(graph, values)`` pairs, ``graph`` a :class:`GraphCycles` and
    ``values`` finite of shape ``(n_nodes,)`` or ``(n_nodes, k)``. Returns, per sample,
    the list over its functions of ``(ord0, rel1, ext0, ext1)`` as
    :func:`extended_persistence` orients them (views into packed arrays), points with
    ``|death - birth| <= min_persistence`` left out; ``lower_first``: ``rel1`` and
    ``ext1`` as ``(death, birth)``, the library's orientation.
    """
    if not samples:
        return []
    nodes, edge_bounds, columns = [], [], []
    edge_start = 0
    for graph, values in samples:
        n_functions = 1 if values.ndim == 1 else values.shape[1]
        nodes += [graph.n_nodes] * n_functions
        edge_bounds += [(edge_start, edge_start + len(graph.edges))] * n_functions
        edge_start += len(graph.edges)
        columns.append(values.T.ravel())
    job_nodes = np.asarray(nodes, dtype=np.int64)
    job_values = np.concatenate([[0], np.cumsum(job_nodes)[:-1]])
    edges = np.concatenate([graph.edges for graph, _ in samples]).astype(np.int64, copy=False)
    packed, counts = _batch(
        job_nodes,
        np.asarray(edge_bounds, dtype=np.int64).reshape(-1, 2),
        job_values,
        np.ascontiguousarray(edges.reshape(-1, 2)),
        np.concatenate(columns),
        float(min_persistence),
        bool(lower_first),
    )
    bounds = np.vstack([np.zeros((1, 4), np.int64), np.cumsum(counts, axis=0)]).tolist()
    ord0, rel1, ext0, ext1 = packed
    per_job = [
        (ord0[a[0] : b[0]], rel1[a[1] : b[1]], ext0[a[2] : b[2]], ext1[a[3] : b[3]])
        for a, b in zip(bounds[:-1], bounds[1:], strict=True)
    ]
    out, job = [], 0
    for _, values in samples:
        n_functions = 1 if values.ndim == 1 else values.shape[1]
        out.append(per_job[job : job + n_functions])
        job += n_functions
    return out


@numba.njit(cache=True)
def _all_finite(values):
    for value in values:
        if not np.isfinite(value):
            return False
    return True


def _shown(values) -> str:
    text = repr(values)
    return text if len(text) <= 60 else text[:60] + "..."


def _node_values(values, n_nodes: int) -> np.ndarray:
    """``values`` as a contiguous finite float64 ``(n_nodes,)`` array, or the error of
    :func:`~sklearn_meshph.mesh.validation.check_values` (with less overhead: graphs are
    small)."""
    try:
        is_complex = np.iscomplexobj(values)  # converts a sequence: a ragged one raises
    except ValueError:
        return check_values(values, n_nodes, "graph")  # raises, naming the problem
    if is_complex:  # NumPy would drop the imaginary part with a warning
        raise TypeError("graph: values must be real numbers, got complex ones")
    if values is None or holds_text(values, none=True):
        # None became one NaN, text such as "3" a number, None inside a list a NaN (a
        # ValueError, as check_values gives for meshes)
        raise ValueError(
            f"graph: values must be a numeric array of {n_nodes} numbers, got {_shown(values)}"
        )
    try:
        array = np.ascontiguousarray(values, dtype=np.float64)
    except (ValueError, TypeError, OverflowError):
        return check_values(values, n_nodes, "graph")  # raises, naming the problem
    if array.shape != (n_nodes,):
        raise ValueError(f"graph: values must have shape ({n_nodes},), got {array.shape}")
    if not _all_finite(array):
        raise ValueError("graph: values contain NaN or inf")
    return array


def extended_persistence(sample, values) -> dict[str, np.ndarray]:
    """The four extended persistence diagrams of a function on a graph's nodes.

    The lower-star filtration of the graph (node ``v`` at ``values[v]``, edge ``uv`` at
    ``max(values[u], values[v])``), extended by its superlevel sets, as gudhi's
    ``SimplexTree.extend_filtration()`` and ``extended_persistence()`` compute it, in
    linear time for all but the cycles (see Notes).

    Parameters
    ----------
    sample : Graph, (n_nodes, edges) pair, scipy sparse adjacency or networkx graph
        The graph (any graph :func:`sklearn_meshph.check_input` accepts); edge weights
        are ignored.
    values : array-like of shape (n_nodes,)
        The function on the nodes, finite.

    Returns
    -------
    diagrams : dict of str to ndarray of shape (n_points, 2)
        Keyed by gudhi's names, rows (birth, death) oriented as gudhi reports them:

        - ``"ord0"``: (min, saddle) pairs of the sublevel sets' components;
        - ``"rel1"``: (max, saddle) pairs of the superlevel sets' components,
          ``birth > death``;
        - ``"ext0"``: each connected component's (min, max);
        - ``"ext1"``: one point per independent cycle (``n_edges - n_nodes +
          n_components`` of them), birth the value of the edge closing it in the
          sublevel sets, death the level at which the superlevel sets hold it,
          ``birth >= death``.

    See Also
    --------
    LowerStarPersistence : The same diagrams for many graphs and functions, with
        ``filtration="extended"`` (the library's orientation: lower value first).

    Notes
    -----
    ``ord0``, ``rel1`` and ``ext0`` come from union-find sweeps up and down the node
    order (elder rule). ``ext1`` is computed exactly over Z/2 as the relative position
    of the sublevel and superlevel flags of the cycle space, with bitsets: the edges
    closing a cycle in the ascending sweep are the coordinates, and each edge closing a
    cycle in the descending sweep gives a column (its cycle in the descending spanning
    forest), reduced left to right.

    Ties in ``values`` change which zero-length points exist, never the others. Every
    zero-length point is dropped (isolated nodes and constant components in ``ext0``,
    cycles on which ``values`` is constant in ``ext1``), as gudhi's default
    ``min_persistence=0`` does: the output equals gudhi's off the diagonal (gudhi
    rescales the values internally, so its coordinates may differ in the last bits and
    it may keep a few points of length near zero). Rows come in the order the sweeps
    find them.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_meshph import extended_persistence
    >>> square = (4, np.array([[0, 1], [1, 2], [2, 3], [0, 3]]))
    >>> diagrams = extended_persistence(square, [0.0, 3.0, 1.0, 2.0])
    >>> diagrams["ext1"]
    array([[3., 0.]])
    >>> diagrams["rel1"]
    array([[2., 1.]])
    """
    graph, _ = check_input(sample)
    if not isinstance(graph, Graph):
        raise TypeError(
            "extended_persistence takes a graph (a Graph, an (n_nodes, edges) pair, a "
            "sparse adjacency or a networkx graph); for a mesh or a point cloud use "
            "LowerStarPersistence(filtration='extended')"
        )
    values = _node_values(values, graph.n_nodes)
    check_cycle_table(graph.n_nodes, graph.edges, "graph")
    diagrams = _graph_diagrams(graph.n_nodes, graph.edges, values, 0.0)
    return dict(zip(GRAPH_DIAGRAMS, diagrams, strict=True))
