"""Structure and spectrum of graphs as features: what the graph pipeline adds to the
diagrams of its signatures (size, degrees, the spectrum's histogram, the signatures'
quantiles, histograms of the distances between pairs of nodes, and hashed counts of the
Weisfeiler-Lehman patterns of the degrees)."""

from __future__ import annotations

from numbers import Integral, Real

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components, shortest_path
from sklearn.utils.validation import check_is_fitted

from .._base import SampleTransformer
from .._param_validation import Interval
from ..mesh.scalar_field import ScalarField
from ..spectral.eigensolver import DENSE_LIMIT

__all__ = ["GraphFeatures"]

_SIZE_NAMES = (
    "n_nodes",
    "n_edges",
    "n_components",
    "n_cycles",
    "n_triangles",
    "transitivity",
    "degree_max",
    "degree_mean",
    "degree_std",
    "isolated_nodes",
    "leaf_fraction",
)
_SPECTRUM_NAMES = (
    "eigenvalue_min_positive",
    "eigenvalue_max",
    "zero_eigenvalues",
    "eigenvalue_mean_square",
)
_QUANTILES = (0.0, 0.1, 0.25, 0.5, 0.75, 0.9, 1.0)
# Log-spaced edges of the histogram of harmonic distances (the normalized Laplacian's
# pseudo-inverse; its values between neighbours are about 1).
_HARMONIC_RANGE = (0.05, 50.0)
# Dense pair matrices above this many nodes would not fit a laptop's memory: larger
# graphs' pair histograms are over the pairs of this many of their nodes (a fixed
# sample), the resistances refused.
_MAX_PAIR_NODES = 4000
# The harmonic distances' dense eigendecomposition of the whole graph bounds the pair
# histograms' graphs, as it bounds the eigen stage's every-eigenpair solve (about three
# n x n arrays: 3.5 GB at 12,000 nodes).
_MAX_DENSE_NODES = DENSE_LIMIT
_ZERO = 1e-8
# Decimals kept of the effective resistances: far above the eigensolver's rounding,
# far below the gaps between the resistances of small rings.
_DECIMALS = 9
# splitmix64's constants: a fixed, platform-independent hash of the pattern labels.
_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_MIX = (np.uint64(0xBF58476D1CE4E5B9), np.uint64(0x94D049BB133111EB))
_SHIFTS = (np.uint64(30), np.uint64(27), np.uint64(31))
_PRIME = np.uint64(1000003)


def _adjacency(field: ScalarField) -> sp.csr_matrix:
    n, edges = field.n_vertices, field.edges
    ones = np.ones(2 * len(edges))
    rows, cols = np.r_[edges[:, 0], edges[:, 1]], np.r_[edges[:, 1], edges[:, 0]]
    return sp.csr_matrix((ones, (rows, cols)), shape=(n, n))


def _size(adjacency) -> np.ndarray:
    n = adjacency.shape[0]
    degree = np.asarray(adjacency.sum(axis=1)).ravel()
    m = degree.sum() / 2
    components = connected_components(adjacency, directed=False)[0]
    triangles = (adjacency @ adjacency).multiply(adjacency).sum() / 6
    wedges = (degree * (degree - 1) / 2).sum()
    return np.array(
        [
            n,
            m,
            components,
            m - n + components,
            triangles,
            3 * triangles / wedges if wedges else 0.0,
            degree.max(),
            degree.mean(),
            degree.std(),
            np.count_nonzero(degree == 0),
            np.count_nonzero(degree == 1) / n,
        ]
    )


def _spectrum(spectrum: np.ndarray, n_bins: int) -> np.ndarray:
    # Rounded as the resistances are: eigenvalues such as 0.5, 1 and 1.5 fall on the
    # bins' edges, where rounding of the eigensolver (which follows the nodes' order)
    # would decide the bin.
    binned = np.clip(np.round(spectrum, _DECIMALS), 0.0, 2.0)
    counts = np.histogram(binned, np.linspace(0.0, 2.0, n_bins + 1))[0]
    positive = spectrum[spectrum > _ZERO]
    return np.r_[
        counts,
        counts / len(spectrum),
        positive.min() if positive.size else 0.0,
        spectrum.max(),
        np.count_nonzero(spectrum <= _ZERO),
        np.mean(spectrum**2),
    ]


def _signatures(values: np.ndarray) -> np.ndarray:
    quantiles = np.quantile(values, _QUANTILES, axis=0)  # (n_quantiles, n_functions)
    return np.vstack([quantiles, values.mean(axis=0), values.std(axis=0)]).T.ravel()


def _pseudo_inverse_distances(eigenvalues, vectors, keep, upper) -> np.ndarray:
    """``L+[i, i] + L+[j, j] - 2 L+[i, j]`` for the pairs ``upper``, ``L+`` the
    pseudo-inverse of a Laplacian from its eigenpairs (those ``keep`` selects)."""
    vectors = vectors[:, keep] / np.sqrt(eigenvalues[keep])
    gram = vectors @ vectors.T
    diagonal = np.diag(gram)
    return diagonal[upper[0]] + diagonal[upper[1]] - 2 * gram[upper]


def _pair_nodes(n: int) -> np.ndarray | None:
    """The nodes whose pairs the histograms count: all (None) up to
    ``_MAX_PAIR_NODES``, else that many drawn without replacement by a generator seeded
    with ``n`` (the same graph always gives the same sample), sorted."""
    if n <= _MAX_PAIR_NODES:
        return None
    return np.sort(np.random.default_rng(n).choice(n, _MAX_PAIR_NODES, replace=False))


def _pairs(adjacency, max_hops: int, n_bins: int) -> np.ndarray:
    """Histograms over the node pairs of the hop distance and of the harmonic distance,
    as fractions of the pairs; pairs in different components count as unreachable.
    Over the pairs of a fixed sample of nodes in graphs of more than
    ``_MAX_PAIR_NODES`` (the distances still those of the whole graph)."""
    n = adjacency.shape[0]
    nodes = _pair_nodes(n)
    upper = np.triu_indices(n if nodes is None else len(nodes), 1)
    n_pairs = max(len(upper[0]), 1)
    if nodes is None:
        hops = shortest_path(adjacency, unweighted=True, directed=False)[upper]
    else:
        hops = shortest_path(adjacency, unweighted=True, directed=False, indices=nodes)
        hops = hops[:, nodes][upper]
    reachable = np.isfinite(hops)
    degree = np.asarray(adjacency.sum(axis=1)).ravel()
    scale = np.divide(1.0, np.sqrt(degree), out=np.zeros(n), where=degree > 0)
    laplacian = np.eye(n) - scale[:, None] * adjacency.toarray() * scale[None, :]
    eigenvalues, vectors = np.linalg.eigh(laplacian)
    del laplacian
    if nodes is not None:
        vectors = vectors[nodes]
    harmonic = _pseudo_inverse_distances(eigenvalues, vectors, eigenvalues > _ZERO, upper)
    harmonic = harmonic[reachable]
    hop_edges = np.r_[np.arange(0.5, max_hops + 1), np.inf]
    harmonic_edges = np.r_[0.0, np.geomspace(*_HARMONIC_RANGE, n_bins - 1), np.inf]
    unreachable = np.count_nonzero(~reachable) / n_pairs
    finite = hops[reachable]
    return np.r_[
        np.histogram(finite, hop_edges)[0] / n_pairs,
        np.histogram(harmonic, harmonic_edges)[0] / n_pairs,
        unreachable,
        finite.mean() if finite.size else 0.0,
        finite.max() if finite.size else 0.0,
    ]


def _resistances(adjacency) -> np.ndarray:
    """The effective resistance between the nodes of each pair in one component (the
    graph as a network of unit resistors): ``L+[i, i] + L+[j, j] - 2 L+[i, j]`` with
    ``L+`` the pseudo-inverse of the combinatorial Laplacian, block by block for the
    components (its null space is their indicator vectors)."""
    n = adjacency.shape[0]
    n_components, labels = connected_components(adjacency, directed=False)
    upper = np.triu_indices(n, 1)
    same = labels[upper[0]] == labels[upper[1]]
    degree = np.asarray(adjacency.sum(axis=1)).ravel()
    eigenvalues, vectors = np.linalg.eigh(np.diag(degree) - adjacency.toarray())
    # Exactly one zero eigenvalue per component: no threshold to mistake a small
    # positive eigenvalue (a long path's is about 1/n^2) for one.
    keep = np.arange(n) >= n_components
    resistance = _pseudo_inverse_distances(eigenvalues, vectors, keep, upper)
    return np.maximum(resistance[same], 0.0)


def _resistance_histogram(adjacency, n_bins: int, largest: float) -> np.ndarray:
    """Histogram of the pairs' effective resistances in ``n_bins`` equal bins on
    ``[0, largest]``, the last one also holding the larger values, as fractions of all
    the pairs (pairs in different components are in no bin)."""
    n = adjacency.shape[0]
    n_pairs = max(n * (n - 1) // 2, 1)
    # Rounded so that equal resistances (integers on trees, k(n-k)/n on rings: often on
    # a bin's edge) land in the same bin whatever the order of the nodes.
    resistance = np.minimum(np.round(_resistances(adjacency), _DECIMALS), largest)
    return np.histogram(resistance, np.linspace(0.0, largest, n_bins + 1))[0] / n_pairs


def _mix(labels: np.ndarray) -> np.ndarray:
    """splitmix64 of each label (uint64 arithmetic wraps around by design)."""
    with np.errstate(over="ignore"):
        x = labels + _GOLDEN
        x = (x ^ (x >> _SHIFTS[0])) * _MIX[0]
        x = (x ^ (x >> _SHIFTS[1])) * _MIX[1]
        return x ^ (x >> _SHIFTS[2])


def wl_labels(edges: np.ndarray, n: int, iterations: int):
    """The node labels of each Weisfeiler-Lehman iteration, the degrees first.

    Yields ``iterations + 1`` arrays of ``n`` uint64 labels: the degrees, then at each
    iteration a hash of every node's label and the multiset of its neighbours' labels
    (a sum of their hashes, which ignores the order).
    """
    source, target = np.r_[edges[:, 0], edges[:, 1]], np.r_[edges[:, 1], edges[:, 0]]
    labels = np.bincount(source, minlength=n).astype(np.uint64)
    yield labels
    for _ in range(iterations):
        neighbours = np.zeros(n, dtype=np.uint64)
        with np.errstate(over="ignore"):
            np.add.at(neighbours, source, _mix(labels[target]))
            labels = _mix(labels * _PRIME + neighbours)
        yield labels


def _patterns(edges: np.ndarray, n: int, iterations: int, buckets: int) -> np.ndarray:
    """Counts of the Weisfeiler-Lehman patterns of the degrees, hashed into buckets.

    Iteration 0 is the degree histogram (degrees from ``buckets - 1`` up share the last
    bin); each further iteration counts the new labels (:func:`wl_labels`) modulo
    ``buckets``.
    """
    counts = []
    for i, labels in enumerate(wl_labels(edges, n, iterations)):
        bins = np.minimum(labels, buckets - 1) if i == 0 else labels % np.uint64(buckets)
        counts.append(np.bincount(bins.astype(np.intp), minlength=buckets))
    return np.concatenate(counts).astype(np.float64)


class GraphFeatures(SampleTransformer):
    """Structure and spectrum of each graph as a row of features.

    Reads the graph fields of :class:`LaplacianEigenTransformer` (its ``laplacian``
    on the graph's nodes, every eigenpair: ``n_eigenpairs=None`` behind a signature) and
    gives, per graph:

    - its size: nodes, edges, components, independent cycles, triangles, transitivity,
      the largest, mean and spread of the degrees, isolated nodes, the share of leaves;
    - its spectrum (the field's ``spectrum``): a histogram on ``[0, 2]``, the range of
      the normalized Laplacian's eigenvalues, as counts and as fractions, the smallest
      positive and the largest eigenvalue, the zero eigenvalues (one per component),
      the mean square;
    - each signature column (heat kernel signatures at fixed times): its quantiles
      (0, 0.1, 0.25, 0.5, 0.75, 0.9, 1), mean and spread over the nodes;
    - with ``pairs=True``, histograms over the pairs of nodes of the hop distance
      (1 to ``max_hops`` hops, then farther) and of the harmonic distance of the
      normalized Laplacian (``L+[i, i] + L+[j, j] - 2 L+[i, j]``, its pseudo-inverse
      ``L+``, in ``n_pair_bins`` log-spaced bins), as fractions of the pairs, the
      share of unreachable pairs (different components), the mean and largest hop
      distance. A spectral cousin of FGSD's histograms of spectral distances [1]_;
    - with ``n_resistance_bins > 0``, FGSD's harmonic distance [1]_ itself: the
      effective resistance between the nodes of each pair (the graph as a network of
      unit resistors, from the pseudo-inverse of its combinatorial Laplacian), in
      ``n_resistance_bins`` equal bins on ``[0, max_resistance]`` (the last one also
      holds the larger values), as fractions of the pairs. On a tree it is the hop
      distance; a ring makes fractions (5/6 between neighbours on a hexagon, 3/2
      across it), so fine bins tell rings and their fusions apart;
    - with ``wl_iterations > 0``, the Weisfeiler-Lehman subtree patterns [2]_ with the
      degrees as initial labels: the degree histogram (``wl_buckets`` bins, the last
      one for the larger degrees), then for each iteration the counts of the nodes'
      new labels (a node's label and the multiset of its neighbours' labels, hashed
      by a fixed 64-bit hash) modulo ``wl_buckets``. Learned from no data, so the same
      graph always gives the same counts; on molecules the patterns stand in for the
      atom types a structure-only dataset lacks.

    The graph is read as unweighted (its edges). The pair and resistance histograms
    each cost a dense eigendecomposition of each graph (cubic in its nodes). In graphs
    of more than 4000 nodes the pair histograms count the pairs of 4000 of their nodes
    (a fixed sample: the same graph always gives the same features), the distances
    still those of the whole graph, and graphs of more than 12,000 nodes are refused
    (set ``pairs=False``), as the eigen stage refuses every eigenpair of them; the
    resistance histogram refuses graphs of more than 4000 nodes (set
    ``n_resistance_bins=0``).

    Parameters
    ----------
    n_bins : int, default=20
        Bins of the spectrum's histogram (at most 10,000, as ``max_hops`` and
        ``n_pair_bins``).
    pairs : bool, default=True
        Whether to add the histograms over the pairs of nodes.
    max_hops : int, default=20
        Hop distances with a bin of their own; farther pairs share one.
    n_pair_bins : int, default=30
        Bins of the harmonic distance's histogram.
    wl_iterations : int, default=0
        Weisfeiler-Lehman iterations after the degree histogram; 0 leaves out the
        patterns and the degree histogram (:func:`make_graph_classifier` uses 3); at
        most 100.
    wl_buckets : int, default=64
        Bins of the degree histogram and of each iteration's hashed pattern counts (at
        most 4,096).
    n_resistance_bins : int, default=0
        Bins of the effective resistances' histogram; 0 (the default, and
        :func:`make_graph_classifier`'s) leaves it out; at most 10,000.
    max_resistance : float, default=25.0
        Upper end of the resistances' bins, in units of one edge's resistance (the
        default's bins are half an edge wide); larger resistances share the last bin.

    Attributes
    ----------
    n_features_out_ : int
        The number of features.
    n_functions_ : int
        Signature columns of the fitted fields (the same for every sample).

    See Also
    --------
    ShapeDNA : The first eigenvalues of a mesh as features.
    make_graph_classifier : The graph pipeline these features are part of.

    References
    ----------
    .. [1] S. Verma and Z.-L. Zhang, "Hunt For The Unique, Stable, Sparse And Fast
       Feature Learning On Graphs", NeurIPS 2017.
    .. [2] N. Shervashidze, P. Schweitzer, E. J. van Leeuwen, K. Mehlhorn and
       K. M. Borgwardt, "Weisfeiler-Lehman Graph Kernels", JMLR 12, 2011.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_meshph import GraphFeatures, LaplacianEigenTransformer
    >>> cycle = (5, np.array([[0, 1], [1, 2], [2, 3], [3, 4], [0, 4]]))
    >>> eigen = LaplacianEigenTransformer(laplacian="normalized", normalization="none",
    ...                                   signature="hks", times=(0.1, 10.0))
    >>> features = GraphFeatures().fit(eigen.fit_transform([cycle]))
    >>> features.transform(eigen.transform([cycle]))[0, :4]  # nodes, edges, components, cycles
    array([5., 5., 1., 1.])
    """

    _sample_kind = "scalar fields"
    _parameter_constraints: dict = {
        # Upper bounds keep a row of features a few megabytes at most: a bin count of
        # 2**31 would otherwise ask for gigabytes per graph.
        "n_bins": [Interval(Integral, 1, 10_000, closed="both")],
        "pairs": ["boolean"],
        "max_hops": [Interval(Integral, 1, 10_000, closed="both")],
        "n_pair_bins": [Interval(Integral, 2, 10_000, closed="both")],
        "wl_iterations": [Interval(Integral, 0, 100, closed="both")],
        "wl_buckets": [Interval(Integral, 2, 4096, closed="both")],
        "n_resistance_bins": [Interval(Integral, 0, 10_000, closed="both")],
        # Finite and far from the float limits: the bins' edges are max_resistance / k.
        "max_resistance": [Interval(Real, 1e-6, 1e12, closed="both")],
    }

    def __init__(
        self,
        n_bins=20,
        pairs=True,
        max_hops=20,
        n_pair_bins=30,
        wl_iterations=0,
        wl_buckets=64,
        n_resistance_bins=0,
        max_resistance=25.0,
    ):
        self.n_bins = n_bins
        self.pairs = pairs
        self.max_hops = max_hops
        self.n_pair_bins = n_pair_bins
        self.wl_iterations = wl_iterations
        self.wl_buckets = wl_buckets
        self.n_resistance_bins = n_resistance_bins
        self.max_resistance = max_resistance

    def _fields(self, X, n_functions=None) -> list[ScalarField]:
        fields = self._check_samples(X)
        for i, field in enumerate(fields):
            if not isinstance(field, ScalarField) or not field.is_graph:
                raise TypeError(
                    f"sample {i}: GraphFeatures reads the graph fields of "
                    f"LaplacianEigenTransformer, got {type(field).__name__}"
                    + ("" if not isinstance(field, ScalarField) else " of a mesh or a cloud")
                )
            if field.spectrum is None:
                raise ValueError(f"sample {i}: the field has no spectrum")
            if n_functions is not None and field.n_functions != n_functions:
                raise ValueError(
                    f"sample {i}: {field.n_functions} signature columns, the fitted fields "
                    f"have {n_functions}"
                )
            if self.n_resistance_bins and field.n_vertices > _MAX_PAIR_NODES:
                raise ValueError(
                    f"sample {i}: {field.n_vertices} nodes, more than the "
                    f"{_MAX_PAIR_NODES} the resistance histogram allows; set "
                    "n_resistance_bins=0"
                )
            if self.pairs and field.n_vertices > _MAX_DENSE_NODES:
                raise ValueError(
                    f"sample {i}: {field.n_vertices} nodes, more than the "
                    f"{_MAX_DENSE_NODES} the pair histograms allow; set pairs=False"
                )
        return fields

    def fit(self, X, y=None):
        """Check the parameters and the fields; remember their number of signatures.

        Parameters
        ----------
        X : sequence of ScalarField
            Graph fields of :class:`LaplacianEigenTransformer`.
        y : ignored

        Returns
        -------
        self
        """
        self._check_params()
        fields = self._fields(X)
        self.n_functions_ = fields[0].n_functions
        self._fields(fields, self.n_functions_)
        self.n_features_out_ = len(self._names())
        return self

    def transform(self, X):
        """The features of each graph.

        Parameters
        ----------
        X : sequence of ScalarField
            Graph fields with as many signature columns as the fitted ones.

        Returns
        -------
        ndarray of shape (n_samples, n_features_out_)
        """
        check_is_fitted(self, "n_features_out_")
        self._check_params()
        rows = []
        for field in self._fields(X, self.n_functions_):
            adjacency = _adjacency(field)
            values = field.values.reshape(field.n_vertices, -1)
            parts = [_size(adjacency), _spectrum(field.spectrum, self.n_bins), _signatures(values)]
            if self.pairs:
                parts.append(_pairs(adjacency, self.max_hops, self.n_pair_bins))
            if self.n_resistance_bins:
                parts.append(
                    _resistance_histogram(
                        adjacency, self.n_resistance_bins, float(self.max_resistance)
                    )
                )
            if self.wl_iterations:
                parts.append(
                    _patterns(field.edges, field.n_vertices, self.wl_iterations, self.wl_buckets)
                )
            rows.append(np.concatenate(parts))
        return np.array(rows)

    def _names(self) -> list[str]:
        names = list(_SIZE_NAMES)
        names += [f"spectrum_count_{k}" for k in range(self.n_bins)]
        names += [f"spectrum_fraction_{k}" for k in range(self.n_bins)]
        names += list(_SPECTRUM_NAMES)
        for j in range(self.n_functions_):
            names += [f"signature{j}_q{q:g}" for q in _QUANTILES]
            names += [f"signature{j}_mean", f"signature{j}_std"]
        if self.pairs:
            names += [f"hops_{h}" for h in range(1, self.max_hops + 1)] + ["hops_farther"]
            names += [f"harmonic_{k}" for k in range(self.n_pair_bins)]
            names += ["unreachable_pairs", "hops_mean", "hops_max"]
        names += [f"resistance_{k}" for k in range(self.n_resistance_bins)]
        if self.wl_iterations:
            names += [
                f"wl{i}_{k}" for i in range(self.wl_iterations + 1) for k in range(self.wl_buckets)
            ]
        return names

    def get_feature_names_out(self, input_features=None):
        """Names of the features, in output order.

        Returns
        -------
        ndarray of str
        """
        check_is_fitted(self, "n_features_out_")
        return np.array(self._names(), dtype=object)
