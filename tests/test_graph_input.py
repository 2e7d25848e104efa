"""Graphs as input: every form check_graph accepts gives the same Graph, and every bad
graph is refused with a message naming the sample."""

import pickle
import subprocess
import sys

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import given, settings
from hypothesis import strategies as st

from sklearn_meshph import Graph, check_graph
from sklearn_meshph.inputs import check_input, sample_kind

# A path 0-1-2, a triangle 3-4-5 and an isolated node 6: three components.
EDGES = np.array([[0, 1], [1, 2], [3, 4], [3, 5], [4, 5]])
N_NODES = 7


def _adjacency(edges, weights, n_nodes):
    i, j = edges.T
    return sp.csr_array(
        (np.r_[weights, weights], (np.r_[i, j], np.r_[j, i])), shape=(n_nodes, n_nodes)
    )


def _same(graph, edges, weights, n_nodes=N_NODES):
    assert isinstance(graph, Graph)
    assert graph.n_nodes == n_nodes
    np.testing.assert_array_equal(graph.edges, edges)
    np.testing.assert_array_equal(graph.weights, weights)
    assert graph.edges.dtype == np.int64 and graph.weights.dtype == np.float64


# The forms ---------------------------------------------------------------------


def test_a_pair_is_a_graph_whose_repeats_directions_and_loops_collapse():
    messy = np.array([[1, 0], [0, 1], [2, 1], [5, 3], [4, 3], [4, 5], [5, 4], [2, 2], [6, 6]])
    graph = check_graph((N_NODES, messy))
    _same(graph, EDGES, np.ones(5))
    assert graph.node_values is None
    assert sample_kind((N_NODES, messy)) == "graph"
    first, second = check_input((np.int32(N_NODES), messy.astype(np.uint16)), index=2)
    _same(first, EDGES, np.ones(5))
    assert second is None


def test_a_pair_without_edges_is_a_graph_of_isolated_nodes():
    for no_edges in ([], np.empty((0, 2), dtype=int), np.empty(0)):
        graph = check_graph((3, no_edges))
        assert graph.n_nodes == 3 and graph.edges.shape == (0, 2) and graph.n_edges == 0


def test_a_sparse_adjacency_is_read_without_making_it_dense():
    weights = np.array([1.0, 2.0, 0.5, 3.0, 4.0])
    for matrix in (
        _adjacency(EDGES, weights, N_NODES),
        sp.coo_matrix(_adjacency(EDGES, weights, 7)),
    ):
        _same(check_graph(matrix), EDGES, weights)
    # explicit zeros are no edge, the diagonal (self-loops) is dropped, duplicates summed
    matrix = sp.coo_array(
        (
            [1.0, 1.0, 0.0, 0.0, 5.0, 0.5, 0.5, 0.5, 0.5],
            ([0, 1, 1, 2, 3, 0, 0, 2, 2], [1, 0, 2, 1, 3, 2, 2, 0, 0]),
        ),
        shape=(4, 4),
    )
    _same(check_graph(matrix), [[0, 1], [0, 2]], [1.0, 1.0], n_nodes=4)
    assert matrix.nnz == 9  # the caller's matrix is left as it was
    booleans = _adjacency(EDGES, np.ones(5), N_NODES).astype(bool)
    _same(check_graph(booleans), EDGES, np.ones(5))
    # repeated entries of small integer types are summed as floats, not wrapped
    small = sp.coo_matrix(
        (np.array([200, 100, 150, 150], np.uint8), ([0, 0, 1, 1], [1, 1, 0, 0])),
        shape=(2, 2),
    )
    assert small.dtype == np.uint8
    _same(check_graph(small), [[0, 1]], [300.0], n_nodes=2)
    # weights below the smallest normal float (their degrees' inverse overflows) are
    # named with the sample, as the other weight errors are
    tiny = sp.coo_matrix(([1e-310, 1e-310], ([0, 1], [1, 0])), shape=(2, 2))
    with pytest.raises(ValueError, match="^sample 3: edge weights must be at least"):
        check_input(tiny, index=3)


def test_a_huge_sparse_graph_stays_linear_in_memory():
    n = 10**7  # a dense adjacency would need 8e14 bytes
    path = np.column_stack([np.arange(0, n - 1, 10**4), np.arange(1, n, 10**4)])
    graph = check_graph(_adjacency(path, np.ones(1000), n))
    assert graph.n_nodes == n and graph.n_edges == 1000
    np.testing.assert_array_equal(check_graph((n, path[::-1, ::-1])).edges, path)


def test_a_symmetric_adjacency_up_to_rounding_is_accepted():
    matrix = _adjacency(EDGES, np.full(5, 0.1), N_NODES).tolil()
    matrix[1, 0] = 0.1 * (1 + 1e-13)
    graph = check_graph(matrix.tocsr())
    assert graph.n_edges == 5 and np.allclose(graph.weights, 0.1)


def test_a_networkx_graph_keeps_weights_labels_and_attributes():
    nx = pytest.importorskip("networkx")
    g = nx.Graph()
    for node, label in [("c", 3), ("a", 1), ("b", 2)]:
        g.add_node(node, label=label, attributes=[label / 2, -label])
    g.add_edge("a", "c", weight=2.5)
    g.add_edge("c", "b")
    g.add_edge("b", "b")  # a loop: dropped
    graph = check_graph(g)
    # nodes sorted (a, b, c); "weight" read, 1 when absent; label first, then attributes
    _same(graph, [[0, 2], [1, 2]], [2.5, 1.0], n_nodes=3)
    np.testing.assert_array_equal(graph.node_values, [[1, 0.5, -1], [2, 1.0, -2], [3, 1.5, -3]])
    assert sample_kind(g) == "graph"


def test_networkx_nodes_that_do_not_sort_keep_insertion_order():
    nx = pytest.importorskip("networkx")
    g = nx.Graph()
    g.add_nodes_from([3, "x", 1.5])
    g.add_edge("x", 1.5, weight=0.0)  # weight 0: no edge
    g.add_edge(3, 1.5)
    graph = check_graph(g)
    _same(graph, [[0, 2]], [1.0], n_nodes=3)
    assert graph.node_values is None


def test_graphs_need_networkx_only_for_networkx_graphs():
    # networkx is an optional extra: with it missing, the other forms are read
    code = (
        "import sys; sys.modules['networkx'] = None; import scipy.sparse as sp; "
        "from sklearn_meshph import check_graph; "
        "assert check_graph((3, [[0, 1]])).n_edges == 1; "
        "assert check_graph(sp.csr_array([[0, 1], [1, 0]])).n_edges == 1"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


@settings(max_examples=60, deadline=None)
@given(
    n_nodes=st.integers(1, 12),
    pairs=st.lists(st.tuples(st.integers(0, 11), st.integers(0, 11)), max_size=40),
)
def test_every_form_of_a_graph_gives_the_same_graph(n_nodes, pairs):
    nx = pytest.importorskip("networkx")
    edges = np.array([(i % n_nodes, j % n_nodes) for i, j in pairs], dtype=np.int64)
    edges = edges.reshape(-1, 2)
    expected = {(min(i, j), max(i, j)) for i, j in edges.tolist() if i != j}
    from_pair = check_graph((n_nodes, edges))
    assert from_pair.edges.tolist() == sorted(map(list, expected))
    weights = 1.0 + np.arange(len(from_pair.edges))  # distinct weights follow their edges
    matrix = _adjacency(from_pair.edges, weights, n_nodes).tocoo()
    order = np.random.default_rng(n_nodes).permutation(matrix.nnz)  # any entry order
    entries = (matrix.data[order], (matrix.row[order], matrix.col[order]))
    shuffled = sp.coo_array(entries, shape=(n_nodes, n_nodes))
    networkx_graph = nx.Graph()
    networkx_graph.add_nodes_from(range(n_nodes)[::-1])  # inserted backwards, sorted back
    networkx_graph.add_weighted_edges_from(
        [(j, i, w) for (i, j), w in zip(from_pair.edges.tolist(), weights, strict=True)]
    )
    for graph in (check_graph(shuffled), check_graph(networkx_graph)):
        _same(graph, from_pair.edges, weights, n_nodes=n_nodes)


def test_a_graph_is_returned_as_is_and_checked_when_made():
    graph = Graph(3, [[0, 1], [1, 2]], [1.0, 2.0], node_values=[1.0, 2.0, 3.0])
    assert check_graph(graph) is graph
    assert graph.node_values.shape == (3, 1)
    assert not graph.edges.flags.writeable
    adjacency = graph.adjacency()
    assert (adjacency != adjacency.T).nnz == 0 and adjacency[2, 1] == 2.0
    restored = pickle.loads(pickle.dumps(graph))  # as joblib sends samples to workers
    assert restored.n_nodes == 3 and not restored.edges.flags.writeable
    np.testing.assert_array_equal(restored.node_values, graph.node_values)


@pytest.mark.parametrize(
    "fields, error, message",
    [
        ((0, np.empty((0, 2), int), []), ValueError, "at least one node"),
        ((True, np.empty((0, 2), int), []), TypeError, "n_nodes must be a positive int"),
        ((10**11, [[0, 1]], [1.0]), ValueError, "more than the 2147483647 nodes"),
        ((2**31, np.empty((0, 2), int), []), ValueError, "more than the 2147483647 nodes"),
        ((3, [[1, 0]], [1.0]), ValueError, r"\(i, j\) with i < j"),
        ((3, [[1, 1]], [1.0]), ValueError, r"\(i, j\) with i < j"),
        ((3, [[1, 2], [0, 1]], [1.0, 1.0]), ValueError, "sorted rows without repeats"),
        ((3, [[0, 1], [0, 1]], [1.0, 1.0]), ValueError, "sorted rows without repeats"),
        ((3, [[0, 3]], [1.0]), ValueError, "outside 0..2"),
        ((3, [[-1, 2]], [1.0]), ValueError, "outside 0..2"),
        ((3, [[0, 1]], [0.0]), ValueError, "positive and finite"),
        ((3, [[0, 1]], [np.inf]), ValueError, "positive and finite"),
        ((3, [[0, 1]], [1e-310]), ValueError, "at least 2.23e-308 .*subnormal.*got 1e-310"),
        ((3, [[0, 1]], [1.0, 2.0]), ValueError, "1 edges but 2 weights"),
        ((3, [[0.0, 1.0]], [1.0]), TypeError, "edges must be integers"),
        # Found by an adversarial review (bare TypeError and OverflowError before):
        ((3, [[0, 1]], [1 + 1j]), TypeError, "edge weights must be real numbers"),
        ((3, [[0, 1]], np.array([1 + 0j])), TypeError, "edge weights must be real numbers"),
        ((3, [[0, 1]], [object()]), TypeError, "edge weights must be real numbers"),
        ((3, [[0, 1]], [10**400]), ValueError, "edge weights must be finite, got one beyond"),
        ((2, np.empty((0, 2), int), [], [1j, 1]), TypeError, "node values must be real"),
    ],
)
def test_a_graph_made_by_hand_is_checked(fields, error, message):
    with pytest.raises(error, match=f"^graph: .*{message}"):
        Graph(*fields)


def test_node_values_of_a_graph_are_checked():
    with pytest.raises(ValueError, match=r"graph: node 1 has a NaN"):
        Graph(2, [[0, 1]], [1.0], node_values=[0.0, np.nan])
    with pytest.raises(ValueError, match=r"shape \(2, n_values\), got \(3, 1\)"):
        Graph(2, [[0, 1]], [1.0], node_values=[[0.0], [1.0], [2.0]])
    with pytest.raises(TypeError, match="node values must be numbers"):
        Graph(2, [[0, 1]], [1.0], node_values=["C", "O"])
    with pytest.raises(ValueError, match="node values must be finite, got one beyond float64"):
        Graph(2, [[0, 1]], [1.0], node_values=[10**400, 1])
    # Text is refused in every form of a graph (np.asarray read "3" as 3.0); booleans are
    # 0 and 1, as scikit-learn reads them.
    with pytest.raises(TypeError, match="node values must be numbers, not text"):
        Graph(2, [[0, 1]], [1.0], node_values=np.array(["1", "2"]))
    with pytest.raises(TypeError, match="edge weights must be numbers, not text"):
        Graph(2, [[0, 1]], ["2.5"])
    flags = Graph(2, [[0, 1]], [True], node_values=np.array([[True, False], [False, True]]))
    assert flags.weights.tolist() == [1.0] and flags.node_values.tolist() == [[1, 0], [0, 1]]


# Bad graphs, named -------------------------------------------------------------


def _asymmetric():
    matrix = _adjacency(EDGES, np.ones(5), N_NODES).tolil()
    matrix[4, 3] = 2.0
    return matrix.tocsr()


def _one_sided():
    matrix = _adjacency(EDGES, np.ones(5), N_NODES).tolil()
    matrix[0, 6] = 0.5
    return matrix.tocsr()


@pytest.mark.parametrize(
    "sample, error, message",
    [
        (_asymmetric, ValueError, r"not symmetric: entry \(3, 4\) is 1.0 but \(4, 3\) is 2.0"),
        (_one_sided, ValueError, r"not symmetric: entry \(0, 6\) is 0.5 but \(6, 0\) is 0"),
        (lambda: -_adjacency(EDGES, np.ones(5), 7), ValueError, "negative entry"),
        (lambda: _adjacency(EDGES, np.r_[1, 1, np.nan, 1, 1], 7), ValueError, "NaN or infinite"),
        (lambda: _adjacency(EDGES, np.r_[1, 1, np.inf, 1, 1], 7), ValueError, "NaN or infinite"),
        (lambda: sp.csr_array((3, 4)), ValueError, r"must be square, got shape \(3, 4\)"),
        (lambda: sp.csr_array((0, 0)), ValueError, "at least one node"),
        (lambda: sp.csr_array(np.eye(2, dtype=complex)), TypeError, "real numbers"),
        (lambda: (0, []), ValueError, "at least one node"),
        (lambda: (-2, []), ValueError, "at least one node"),
        (lambda: (2.0, [[0, 1]]), TypeError, "n_nodes must be a positive int, got 2.0"),
        (lambda: (True, [[0, 1]]), TypeError, "n_nodes must be a positive int"),
        (lambda: (10**11, [[0, 1]]), ValueError, "n_nodes=100000000000 is more than the"),
        (lambda: sp.csr_array((2**31, 2**31)), ValueError, "n_nodes=2147483648 is more than"),
        (lambda: (3, [[0, 3]]), ValueError, r"edge 0 \(0, 3\) has a node outside 0..2"),
        (lambda: (3, [[0, 1], [-1, 2]]), ValueError, r"edge 1 \(-1, 2\) has a node outside"),
        (lambda: (3, np.array([[0.0, 1.0]])), TypeError, "edges must be integers"),
        (lambda: (3, [[0, 1, 2]]), ValueError, r"\(m, 2\) integer array, got shape \(1, 3\)"),
        (lambda: (3, [0, 1]), ValueError, r"\(m, 2\) integer array, got shape \(2,\)"),
        (lambda: (3, [[0, 1], [2]]), ValueError, r"\(m, 2\) integer array"),
        # empty, but not (0, 2): not "no edges"
        (lambda: (3, np.empty((5, 0), int)), ValueError, r"got shape \(5, 0\)"),
        (lambda: (3, np.empty((0, 3), int)), ValueError, r"got shape \(0, 3\)"),
        (
            lambda: (3, np.array([[0, 2**63 + 1]], np.uint64)),
            ValueError,
            r"edge 0 \(0, 9223372036854775809\) has a node beyond int64",
        ),
    ],
)
def test_a_bad_graph_is_refused_naming_the_sample(sample, error, message):
    with pytest.raises(error, match=f"^sample 3: .*{message}"):
        check_graph(sample(), index=3)
    with pytest.raises(error, match=f"^sample 5: .*{message}"):
        check_input(sample(), index=5)


def test_a_bad_networkx_graph_is_refused_naming_the_sample():
    nx = pytest.importorskip("networkx")
    cases = [
        (nx.DiGraph([(0, 1)]), TypeError, "directed networkx graph; pass graph.to_undirected"),
        (nx.MultiGraph([(0, 1)]), TypeError, r"multigraph; pass networkx.Graph\(graph\)"),
        (nx.Graph(), ValueError, "at least one node"),
        (nx.Graph([(0, 1, {"weight": -1.0})]), ValueError, "non-negative and finite, got -1"),
        (nx.Graph([(0, 1, {"weight": np.nan})]), ValueError, "non-negative and finite"),
        (nx.Graph([(0, 1, {"weight": "heavy"})]), TypeError, "weight 'heavy' is not a number"),
    ]
    labelled = nx.Graph([(0, 1)])
    labelled.nodes[1]["label"] = 2
    cases.append((labelled, ValueError, "node 0 has no 'label' while other nodes have one"))
    text = nx.Graph([(0, 1)])
    nx.set_node_attributes(text, {0: "C", 1: "O"}, "label")
    cases.append((text, TypeError, "'label' values must be real numbers"))
    missing = nx.Graph([(0, 1)])
    nx.set_node_attributes(missing, {0: np.nan, 1: 1.0}, "label")
    cases.append((missing, ValueError, "node 0 has a NaN"))
    # Python ints beyond float64: refused as such, not a bare OverflowError
    cases.append((nx.Graph([(0, 1, {"weight": 10**400})]), ValueError, "finite, got inf"))
    huge = nx.Graph([(0, 1)])
    nx.set_node_attributes(huge, {0: 10**400, 1: 2}, "label")
    cases.append((huge, ValueError, "'label' values must be finite, got one beyond float64"))
    # text is not a number, though float() reads "2.5"
    cases.append((nx.Graph([(0, 1, {"weight": "2.5"})]), TypeError, "weight '2.5' is not a"))
    digits = nx.Graph([(0, 1)])
    nx.set_node_attributes(digits, {0: "3", 1: "4"}, "label")
    cases.append((digits, TypeError, "'label' values must be real numbers"))
    for sample, error, message in cases:
        with pytest.raises(error, match=f"^sample 3: .*{message}"):
            check_graph(sample, index=3)


def test_other_objects_are_not_graphs():
    with pytest.raises(TypeError, match="^sample 1: not a graph: dict"):
        check_graph({}, index=1)
    with pytest.raises(TypeError, match="^graph: not a graph: str"):
        check_graph("graph.txt")


def test_every_form_refuses_complex_values_and_names_repeated_entries_that_overflow():
    """Found by an adversarial review: a networkx label 1j was read as 0 with only a
    ComplexWarning (a Graph refused it); repeated sparse entries summing beyond float64
    leaked a RuntimeWarning and were called "a NaN or infinite entry"; an asymmetry was
    shown as "entry (0, 1) is 1 but (1, 0) is 1"."""
    import warnings

    nx = pytest.importorskip("networkx")
    graph = nx.Graph()
    graph.add_node(0, label=1j)
    graph.add_node(1, label=1)
    with pytest.raises(TypeError, match="sample 0: node 'label' values must be real numbers"):
        check_graph(graph, index=0)
    graph.nodes[0]["label"] = 2
    graph.add_edge(0, 1, weight=1j)
    with pytest.raises(TypeError, match="sample 0: edge weight 1j is not a number"):
        check_graph(graph, index=0)
    repeated = sp.coo_matrix(([1e308] * 4, ([0, 0, 1, 1], [1, 1, 0, 0])), shape=(2, 2))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(ValueError, match=r"repeated entries of \(0, 1\) .* sum beyond"):
            check_graph(repeated)
    close = sp.csr_matrix(np.array([[0, 1.0], [1 + 1e-9, 0]]))
    with pytest.raises(ValueError, match=r"\(0, 1\) is 1.0 but \(1, 0\) is 1.000000001"):
        check_graph(close)
