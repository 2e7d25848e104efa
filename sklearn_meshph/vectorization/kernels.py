"""Kernels between persistence diagrams: precomputed kernel matrices for kernel methods
(``SVC(kernel="precomputed")``, ``KernelPCA(kernel="precomputed")``...).

Each kernel is computed by a compiled loop over blocks of pairs of packed samples,
blocks in parallel (joblib); a pair's value does not depend on the block it falls in,
nor on the order of its two diagrams, so the matrices are identical for any ``n_jobs``,
and ``transform`` of the fitted samples equals ``fit_transform`` bit for bit.
"""

from __future__ import annotations

import math
from functools import partial
from numbers import Integral

import numba
import numpy as np

from .._param_validation import Interval, Options
from ..diagrams.distances import MAX_DIRECTIONS
from ..diagrams.pairwise import (
    SLICED,
    PairwiseTransformer,
    as_packed,
    pack_for_metric,
    pair_distances,
    pair_matrix,
    precedes,
)
from ._base import (
    BANDWIDTH,
    COMBINATIONS,
    COMBINE_PARAMETERS,
    COMMON_CONSTRAINTS,
    PER_POSITION,
    WEIGHT_CONSTRAINTS,
    WEIGHT_PARAMETER,
    PolicyTransformer,
    check_finite_output,
    combine_positions,
    common_sections,
    point_weights,
    position_bandwidths,
    position_weights,
)

__all__ = [
    "PersistenceScaleSpaceKernel",
    "PersistenceWeightedGaussianKernel",
    "SlicedWassersteinKernel",
]


class _DiagramKernel(PolicyTransformer, PairwiseTransformer):
    """What the three kernels share: ``fit`` stores the diagrams after the ``infinite``
    policy, ``transform`` the kernel with them, ``fit_transform`` the symmetric matrix,
    each pair computed once (:class:`PairwiseTransformer`), on :class:`Packed` samples.

    Subclasses define ``_pack(packed)`` (what the compiled loop reads), ``_pairs()``, a
    picklable function ``(left, right, rows, cols, n_parts, bandwidth)`` returning the
    kernel values of the pairs ``(rows[k], cols[k])`` with the parts combined as
    ``_natural`` says, and ``_natural`` itself (``"product"`` or ``"sum"``): the
    combination of the compiled loop over the parts, the default of ``combine``.
    """

    _natural = "sum"

    def _fit(self, X):
        packed = self._fit_packed(X)
        self._positions()  # per-position parameters refused at fit, not at transform
        self.diagrams_ = packed.samples()

    def _positions(self):
        """The bandwidth and weight of each position, or None when one bandwidth and
        the natural combination make the compiled loop's kernel."""
        n_parts = self.n_diagrams_
        bandwidths = position_bandwidths(self.bandwidth, n_parts)
        weights = position_weights(self.diagram_weights, self.combine, n_parts)
        natural = self.combine == self._natural and self.diagram_weights is None
        if natural and np.ndim(self.bandwidth) == 0:
            return None
        return bandwidths, weights

    def _matrix(self, left, right):
        left = as_packed(left)
        right = None if right is None else as_packed(right)
        positions = self._positions()
        if positions is None:
            function = partial(
                self._pairs(), n_parts=self.n_diagrams_, bandwidth=float(self.bandwidth)
            )
        else:
            function = partial(
                _combined_pairs,
                function=self._pairs(),
                n_parts=self.n_diagrams_,
                bandwidths=positions[0],
                weights=positions[1],
                combine=self.combine,
            )
        matrix = pair_matrix(
            function,
            self._pack(left),
            None if right is None else self._pack(right),
            len(left),
            len(left if right is None else right),
            n_jobs=self.n_jobs,
            dtype=np.float64,
            diagonal=None,
            desc="kernel",
        )
        return check_finite_output(matrix, "kernel values", self.dtype)


def _combined_pairs(left, right, rows, cols, function, n_parts, bandwidths, weights, combine):
    """The kernel of the pairs from the kernel of each position, with its bandwidth:
    diagram ``sample * n_parts + part`` is sample ``sample * n_parts + part`` of one
    part."""
    kernels = [
        function(left, right, rows * n_parts + part, cols * n_parts + part, 1, bandwidth)
        for part, bandwidth in enumerate(bandwidths)
    ]
    return combine_positions(kernels, combine, weights)


_KERNEL_CONSTRAINTS: dict = {
    "bandwidth": [*BANDWIDTH, PER_POSITION],
    "combine": [Options(COMBINATIONS)],
    "diagram_weights": [PER_POSITION, None],
    **COMMON_CONSTRAINTS,
}

_SECTIONS = common_sections(
    """diagrams_ : list of tuple of ndarray
        The fitted samples' finite diagrams, after the ``infinite`` policy."""
)

_BANDWIDTH = """bandwidth : float or array-like of shape (n_diagrams,), default=1.0
        Standard deviation ``s`` of the Gaussians, in the diagrams' units: neither so
        small that its square underflows nor so large that the Gaussian's peak does.
        A sequence gives each diagram position its own (positions on different
        scales)."""


def _sliced_kernel(left, right, rows, cols, n_parts, bandwidth):
    """``exp(-SW / (2 bandwidth^2))``, SW summed over the parts."""
    distances = pair_distances(left, right, rows, cols, n_parts, SLICED)
    return np.exp(-distances / (2.0 * bandwidth * bandwidth))


class SlicedWassersteinKernel(_DiagramKernel):
    __doc__ = f"""Sliced Wasserstein kernel between persistence diagrams (Carrière, Cuturi & Oudot
    2017), as a precomputed kernel matrix.

    ``k(D1, D2) = exp(-SW(D1, D2) / (2 bandwidth^2))``, with ``SW`` the sliced
    Wasserstein distance of :func:`sliced_wasserstein_distance`: the mean, over
    ``n_directions`` lines, of the L1 distance between the sorted projections of ``D1``
    plus the diagonal projections of ``D2``, and those of ``D2`` plus the diagonal
    projections of ``D1``. ``fit`` stores diagrams, ``transform(X)`` returns the
    ``(len(X), n_fitted)`` kernel matrix, ready for ``SVC(kernel="precomputed")``, and
    ``fit_transform(X)`` the symmetric ``(n, n)`` matrix, each pair computed once.

    Parameters
    ----------
    bandwidth : float or array-like of shape (n_diagrams,), default=1.0
        The scale ``sigma`` of ``exp(-SW / (2 sigma^2))``; SW is in the diagrams' units,
        and so is ``sigma^2``: neither so small that its square underflows nor so
        large that the Gaussian's peak does. A sequence gives each diagram position its
        own (positions on different scales).
    n_directions : int, default=10
        Number of lines: the angles ``-pi/2 + k pi / (n_directions + 1)``,
        ``k = 0, ..., n_directions - 1`` (see Notes for gudhi's convention).
    {COMBINE_PARAMETERS.format(default="product")}
    {_SECTIONS}

    See Also
    --------
    sliced_wasserstein_distance : The distance between two diagrams.
    DiagramDistance : The distance matrix (``metric="sliced-wasserstein"``).
    PerDiagramDistance, DistanceKernel : The same kernel in two stages, for bandwidth
        searches that compute the distances once.
    PersistenceScaleSpaceKernel, PersistenceWeightedGaussianKernel : Other kernels.

    Notes
    -----
    Equals ``gudhi.representations.SlicedWassersteinKernel(num_directions=n_directions
    + 1, bandwidth=2 * bandwidth**2)`` to rounding (tested to 1e-10): gudhi's kernel is
    ``exp(-SW / bandwidth)``, and its lines are the first ``num_directions - 1`` of
    ``num_directions`` angles evenly spaced in ``[-pi/2, pi/2)`` (its default
    ``num_directions=10`` uses 9 lines).

    The kernel is positive semi-definite for every bandwidth and any set of lines: on
    each line, SW is the L1 distance between two functions of one diagram each (the
    cumulative count of its projections minus that of its diagonal projections), so it
    is conditionally negative definite (Carrière et al. 2017). SW is at most
    ``2 sqrt(2)`` times the 1-Wasserstein distance with the L-infinity ground metric.

    With ``combine="product"`` (the default), a tuple of diagrams is compared as the
    typed disjoint union of its diagrams: ``exp(-(SW_1 + ... + SW_K) / (2 bandwidth^2))``,
    the product of the per-position kernels. ``combine="sum"`` gives
    ``sum_k w_k exp(-SW_k / (2 sigma_k^2))`` (the sum of PersLay's graph kernels, one
    term per diagram), which a single far position cannot drive to 0. Each diagram's
    projections are sorted once (``O(n log n)`` per line), and a pair then costs one
    merge per line, ``O(n + m)``. To search the bandwidth without computing the
    distances again for each candidate, compute them once with
    :class:`PerDiagramDistance` and make the kernel with :class:`DistanceKernel`.

    Examples
    --------
    Two samples of two diagrams each (say H0 and H1):

    >>> import numpy as np
    >>> from sklearn_meshph import SlicedWassersteinKernel
    >>> h0, h1 = np.array([[0.0, 1.0]]), np.array([[0.5, 2.0]])
    >>> pairs = [(h0, h1), (np.array([[0.0, 1.5]]), np.empty((0, 2)))]
    >>> SlicedWassersteinKernel(bandwidth=2.0).fit_transform(pairs).round(3)
    array([[1.  , 0.87],
           [0.87, 1.  ]])
    """

    _parameter_constraints: dict = {
        **_KERNEL_CONSTRAINTS,
        "n_directions": [Interval(Integral, 1, MAX_DIRECTIONS, closed="both")],
    }

    _natural = "product"

    def __init__(
        self,
        bandwidth=1.0,
        n_directions=10,
        combine="product",
        diagram_weights=None,
        infinite="drop",
        n_jobs=None,
        dtype="float64",
        essential="deprecated",
    ):
        self.bandwidth = bandwidth
        self.n_directions = n_directions
        self.combine, self.diagram_weights = combine, diagram_weights
        self.infinite, self.n_jobs, self.dtype = infinite, n_jobs, dtype
        self.essential = essential

    def _pack(self, packed):
        return pack_for_metric(packed, SLICED, self.n_directions)

    def _pairs(self):
        return _sliced_kernel


@numba.njit(cache=True)
def _scale_space_sum(a, b, two_var, var):
    """``sum_{p, q} exp(-|p - q|^2 / 2s^2) - exp(-|p - mirror(q)|^2 / 2s^2)``, as
    ``exp(-|p - q|^2 / 2s^2) (1 - exp(-pers(p) pers(q) / s^2))``: the two squared
    distances differ by ``2 pers(p) pers(q)``."""
    total = 0.0
    for i in range(len(a)):
        birth, death = a[i, 0], a[i, 1]
        persistence = death - birth
        if persistence == 0.0:  # its terms are all 0
            continue
        for j in range(len(b)):
            db, dd = birth - b[j, 0], death - b[j, 1]
            gauss = math.exp(-(db * db + dd * dd) / two_var)
            total += gauss * -math.expm1(-(persistence * (b[j, 1] - b[j, 0])) / var)
    return total


@numba.njit(cache=True)
def _scale_space_pairs(left, right, rows, cols, n_parts, bandwidth):
    """Persistence scale space kernel of the sample pairs: the sum over the parts."""
    points_a, offsets_a = left
    points_b, offsets_b = right
    two_var = 2.0 * bandwidth * bandwidth
    var = bandwidth * bandwidth
    norm = 1.0 / (math.sqrt(2.0 * math.pi) * bandwidth)
    out = np.empty(len(rows))
    for k in range(len(rows)):
        total = 0.0
        for part in range(n_parts):
            da, db = rows[k] * n_parts + part, cols[k] * n_parts + part
            a = points_a[offsets_a[da] : offsets_a[da + 1]]
            b = points_b[offsets_b[db] : offsets_b[db + 1]]
            if precedes(a, b):  # one order for both orders of a pair: same bits
                total += _scale_space_sum(a, b, two_var, var)
            else:
                total += _scale_space_sum(b, a, two_var, var)
        out[k] = norm * total
    return out


def _scale_space_kernel(left, right, rows, cols, n_parts, bandwidth):
    return _scale_space_pairs(left, right, rows, cols, n_parts, bandwidth)


class PersistenceScaleSpaceKernel(_DiagramKernel):
    __doc__ = f"""Persistence scale space kernel between persistence diagrams (Reininghaus, Huber,
    Bauer & Kwitt 2015), as a precomputed kernel matrix.

    Each diagram is the heat diffusion of Dirac masses at its points, with the opposite
    masses at their mirror images across the diagonal (so that it vanishes there); the
    kernel is the L2 inner product of two such functions::

        k(F, G) = 1 / (sqrt(2 pi) s) * sum over p in F, q in G of
                  exp(-|p - q|^2 / (2 s^2)) - exp(-|p - q'|^2 / (2 s^2))

    with ``s = bandwidth`` and ``q' = (death, birth)`` the mirror image of ``q``.

    Parameters
    ----------
    {_BANDWIDTH}
    {COMBINE_PARAMETERS.format(default="sum")}
    {_SECTIONS}

    See Also
    --------
    PersistenceWeightedGaussianKernel : Gaussians weighted by a function of the points.
    SlicedWassersteinKernel : A kernel from the sliced Wasserstein distance.
    PersistenceImage : The same Gaussians on a grid, as features.

    Notes
    -----
    Equals ``gudhi.representations.PersistenceScaleSpaceKernel(bandwidth=bandwidth)``
    (``kernel_approx=None``) to rounding (tested to 1e-10), but for pairs of points
    that both lie on the diagonal (birth == death): gudhi gives such a point's mirror
    image the weight +1 instead of -1, so each such pair adds ``2 / (sqrt(2 pi) s)
    exp(-|p - q|^2 / (2 s^2))`` there, and nothing here, as in the paper (the feature
    map vanishes on the diagonal; the kernel stays continuous as points reach it).

    Reininghaus et al. write the kernel with a scale ``t`` as ``1 / (8 pi t) sum
    exp(-|p - q|^2 / (8t)) - exp(-|p - q'|^2 / (8t))``: with ``t = s^2 / 4`` this one is
    theirs times ``sqrt(2 pi) s``, gudhi's normalization. The two exponentials are
    computed as ``exp(-|p - q|^2 / (2 s^2)) (1 - exp(-pers(p) pers(q) / s^2))`` (the
    squared distances differ by ``2 pers(p) pers(q)``): no cancellation near the
    diagonal. Cost: ``n m`` pairs of exponentials per pair of diagrams.

    A tuple of diagrams is compared as the typed disjoint union of its diagrams (each
    on its own copy of the plane): the kernel is the sum of the per-position kernels
    (``combine="sum"``, the default).

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_meshph import PersistenceScaleSpaceKernel
    >>> diagrams = [np.array([[0.0, 1.0]]), np.array([[0.0, 1.5]]), np.empty((0, 2))]
    >>> PersistenceScaleSpaceKernel().fit_transform(diagrams).round(3)
    array([[0.252, 0.274, 0.   ],
           [0.274, 0.357, 0.   ],
           [0.   , 0.   , 0.   ]])
    """

    _parameter_constraints: dict = dict(_KERNEL_CONSTRAINTS)

    def __init__(
        self,
        bandwidth=1.0,
        combine="sum",
        diagram_weights=None,
        infinite="drop",
        n_jobs=None,
        dtype="float64",
        essential="deprecated",
    ):
        self.bandwidth = bandwidth
        self.combine, self.diagram_weights = combine, diagram_weights
        self.infinite, self.n_jobs, self.dtype = infinite, n_jobs, dtype
        self.essential = essential

    def _pack(self, packed):
        return packed.points, packed.offsets

    def _pairs(self):
        return _scale_space_kernel


@numba.njit(cache=True)
def _weighted_sum(a, wa, b, wb, two_var):
    total = 0.0
    for i in range(len(a)):
        birth, death, weight = a[i, 0], a[i, 1], wa[i]
        if weight == 0.0:
            continue
        for j in range(len(b)):
            db, dd = birth - b[j, 0], death - b[j, 1]
            total += weight * wb[j] * math.exp(-(db * db + dd * dd) / two_var)
    return total


@numba.njit(cache=True)
def _weighted_gaussian_pairs(left, right, rows, cols, n_parts, bandwidth):
    """Persistence weighted Gaussian kernel of the sample pairs: the sum over the parts."""
    points_a, weights_a, offsets_a = left
    points_b, weights_b, offsets_b = right
    two_var = 2.0 * bandwidth * bandwidth
    norm = 1.0 / (math.sqrt(2.0 * math.pi) * bandwidth)
    out = np.empty(len(rows))
    for k in range(len(rows)):
        total = 0.0
        for part in range(n_parts):
            da, db = rows[k] * n_parts + part, cols[k] * n_parts + part
            sa, ea = offsets_a[da], offsets_a[da + 1]
            sb, eb = offsets_b[db], offsets_b[db + 1]
            a, b = points_a[sa:ea], points_b[sb:eb]
            if precedes(a, b):  # one order for both orders of a pair: same bits
                total += _weighted_sum(a, weights_a[sa:ea], b, weights_b[sb:eb], two_var)
            else:
                total += _weighted_sum(b, weights_b[sb:eb], a, weights_a[sa:ea], two_var)
        out[k] = norm * total
    return out


def _weighted_gaussian_kernel(left, right, rows, cols, n_parts, bandwidth):
    return _weighted_gaussian_pairs(left, right, rows, cols, n_parts, bandwidth)


class PersistenceWeightedGaussianKernel(_DiagramKernel):
    __doc__ = f"""Persistence weighted Gaussian kernel between persistence diagrams (Kusano,
    Fukumizu & Hiraoka 2016), as a precomputed kernel matrix.

    Each diagram is the sum of Gaussians centred at its points, weighted by a function
    of the points; the kernel is the inner product of two such sums::

        k(F, G) = 1 / (sqrt(2 pi) s) * sum over p in F, q in G of
                  w(p) w(q) exp(-|p - q|^2 / (2 s^2))

    with ``s = bandwidth``.

    Parameters
    ----------
    {_BANDWIDTH}
    {WEIGHT_PARAMETER}
    {COMBINE_PARAMETERS.format(default="sum")}
    {_SECTIONS}

    See Also
    --------
    PersistenceScaleSpaceKernel : Gaussians with their mirror images subtracted.
    SlicedWassersteinKernel : A kernel from the sliced Wasserstein distance.
    PersistenceImage : Weighted Gaussians on a grid, as features.

    Notes
    -----
    Equals ``gudhi.representations.PersistenceWeightedGaussianKernel(bandwidth=
    bandwidth, weight=w, kernel_approx=None)`` to rounding (tested to 1e-10), with
    ``w = lambda x: 1`` for ``"constant"``, ``w = lambda x: (x[1] - x[0]) ** power``
    for ``"persistence"``; a gudhi weight ``w`` of one point ``[b, d]`` is
    ``weight=lambda D: np.array([w(p) for p in D])`` here. Kusano et al.'s weight
    ``arctan(C pers^p)`` is ``weight=lambda D: np.arctan(C * (D[:, 1] - D[:, 0]) ** p)``.
    As gudhi's, this is the linear kernel of the weighted Gaussian embeddings; Kusano et
    al. also apply a Gaussian kernel on top of it (``exp(-|E(F) - E(G)|^2 / (2 tau^2))``,
    with ``|E(F) - E(G)|^2 = k(F, F) + k(G, G) - 2 k(F, G)``).

    Tuples of diagrams: the sum of the per-position kernels (``combine="sum"``, the
    default), as for :class:`PersistenceScaleSpaceKernel`. Weights are computed once per
    diagram; a pair costs ``n m`` exponentials.

    Examples
    --------
    Kernel values of a new diagram with two fitted ones, points weighted by their
    squared persistence:

    >>> import numpy as np
    >>> from sklearn_meshph import PersistenceWeightedGaussianKernel
    >>> fitted = [np.array([[0.0, 2.0], [1.0, 1.5]]), np.array([[0.5, 2.5]])]
    >>> kernel = PersistenceWeightedGaussianKernel(weight="persistence", power=2)
    >>> kernel.fit(fitted).transform([np.array([[0.0, 2.0]])]).round(3)
    array([[6.597, 4.971]])
    """

    _parameter_constraints: dict = {**_KERNEL_CONSTRAINTS, **WEIGHT_CONSTRAINTS}

    def __init__(
        self,
        bandwidth=1.0,
        weight="constant",
        power=1.0,
        combine="sum",
        diagram_weights=None,
        infinite="drop",
        n_jobs=None,
        dtype="float64",
        essential="deprecated",
    ):
        self.bandwidth = bandwidth
        self.weight = weight
        self.power = power
        self.combine, self.diagram_weights = combine, diagram_weights
        self.infinite, self.n_jobs, self.dtype = infinite, n_jobs, dtype
        self.essential = essential

    def _pack(self, packed):
        offsets = packed.offsets
        weights = point_weights(packed, offsets[:-1], offsets[1:], self.weight, self.power)
        return packed.points, weights, offsets

    def _pairs(self):
        return _weighted_gaussian_kernel
