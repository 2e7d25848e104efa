"""Exact bottleneck and Wasserstein distances and the sliced Wasserstein distance between
two diagrams, and the registry of diagram metrics read by ``DiagramDistance`` and the
command line."""

from __future__ import annotations

from numbers import Integral, Real

import numpy as np

from .._param_validation import Interval, validate_params
from .._registry import Option, Registry
from ._assignment import DIAGONAL, precedes
from ._batch import BOTTLENECK, SLICED, WASSERSTEIN, pack_one, pack_sliced, pair_distances
from ._bottleneck import bottleneck_finite, bottleneck_partners
from ._wasserstein import transport
from .validation import check_diagram

# Lines of a sliced Wasserstein distance at most (each line is a sort of every diagram;
# 10 to 50 are the usual, and 10**6 lines took 4.8 GB on six small graphs).
MAX_DIRECTIONS = 10_000

__all__ = [
    "METRICS",
    "bottleneck_distance",
    "kernel_metric",
    "sliced_wasserstein_distance",
    "wasserstein_distance",
]

METRICS = Registry(
    "metric",
    [
        Option(
            "bottleneck",
            BOTTLENECK,
            "exact bottleneck distance (L-infinity ground metric, as in the paper)",
        ),
        Option(
            "wasserstein",
            WASSERSTEIN,
            "exact q-Wasserstein distance (an optimal assignment; `order` is q)",
        ),
        Option(
            "sliced-wasserstein",
            SLICED,
            "sliced Wasserstein distance (Carriere et al. 2017) over `n_directions` lines, "
            "as gudhi's: fast, at most 2 sqrt(2) times the 1-Wasserstein distance",
        ),
    ],
)

# With a finite internal_p the scaled costs of an order above this many times
# internal_p can exceed float64's range.
_MAX_ORDER_PER_P = 900.0


def kernel_metric(metric: str, order: float, internal_p: float) -> tuple[int, float]:
    """The compiled kernel's metric code and order for a metric's parameters.

    The infinite-order Wasserstein distance is the bottleneck distance (with the
    L-infinity ground metric; refused with another).
    """
    code = METRICS[metric].value
    order = float(order)
    if code == WASSERSTEIN and np.isinf(order):
        if not np.isinf(internal_p):
            raise ValueError(
                "order=inf with a finite internal_p is not supported; the infinite-order "
                "Wasserstein distance with internal_p=inf is the bottleneck distance"
            )
        return BOTTLENECK, order
    if code == WASSERSTEIN and order / float(internal_p) > _MAX_ORDER_PER_P:
        raise ValueError(
            f"order / internal_p above {_MAX_ORDER_PER_P:g} exceeds float64's range "
            f"(order={order:g}, internal_p={internal_p:g}); use internal_p=inf"
        )
    return code, order


def _one_pair(a, b, metric, order=2.0, internal_p=np.inf, n_directions=10) -> float:
    a, b = check_diagram(a, index=0), check_diagram(b, index=1)
    zero = np.zeros(1, dtype=np.int64)
    code, order = kernel_metric(metric, order, internal_p)
    left, right = pack_one(a), pack_one(b)
    if code == SLICED:
        left, right = pack_sliced(left, n_directions), pack_sliced(right, n_directions)
    return float(pair_distances(left, right, zero, zero, 1, code, order, internal_p)[0])


def _split(diagram):
    """Finite points and the essential points sorted by birth, each with their rows."""
    finite = np.flatnonzero(np.isfinite(diagram[:, 1]))
    essential = np.flatnonzero(~np.isfinite(diagram[:, 1]))
    essential = essential[np.argsort(diagram[essential, 0], kind="stable")]
    return finite, essential


def _with_matching(a, b, metric, order=2.0, internal_p=np.inf):
    """The distance and an optimal matching as rows (i, j); -1 stands for the diagonal."""
    a, b = check_diagram(a, index=0), check_diagram(b, index=1)
    distance = _one_pair(a, b, metric, order, internal_p)
    (finite_a, essential_a), (finite_b, essential_b) = _split(a), _split(b)
    if len(essential_a) != len(essential_b):
        return distance, None
    fa, fb = a[finite_a], b[finite_b]
    swap = not precedes(fa, fb)  # the orientation the distance was computed in
    left, right = (fb, fa) if swap else (fa, fb)
    code, order = kernel_metric(metric, order, internal_p)
    if code == BOTTLENECK:
        partner = bottleneck_partners(left, right, bottleneck_finite(left, right))
    else:
        partner = transport(left, right, order, float(internal_p))[2]
        partner[partner == DIAGONAL] = -1
    pairs = [(i, j) for i, j in enumerate(partner)]
    taken = np.zeros(len(right), dtype=bool)
    taken[partner[partner >= 0]] = True
    pairs += [(-1, j) for j in np.flatnonzero(~taken)]
    pairs = np.array(pairs, dtype=np.int64).reshape(-1, 2)
    if swap:
        pairs = pairs[:, ::-1]
    # Back to the rows of the inputs (finite rows first, then the essential pairs).
    index_a, index_b = np.append(finite_a, -1), np.append(finite_b, -1)
    matched = np.vstack(
        [
            np.column_stack([index_a[pairs[:, 0]], index_b[pairs[:, 1]]]),
            np.column_stack([essential_a, essential_b]),
        ]
    )
    return distance, matched.astype(np.int64)


@validate_params({"matching": ["boolean"]})
def bottleneck_distance(a, b, matching: bool = False):
    """Exact bottleneck distance between two persistence diagrams (L-infinity ground).

    Parameters
    ----------
    a, b : array-like of shape (n, 2) and (m, 2)
        Rows (birth, death); death may be ``inf``. Empty diagrams, repeated points and
        points on the diagonal are valid.
    matching : bool, default=False
        Also return a matching that attains the distance.

    Returns
    -------
    distance : float
        ``inf`` when the numbers of essential (infinite) points differ; otherwise the
        smallest ``t`` such that a matching of the points to each other or to the
        diagonal moves no point by more than ``t`` in the L-infinity norm (essential
        points matched among themselves by sorted birth).
    matching : ndarray of shape (k, 2), dtype int64
        Only with ``matching=True``: rows ``(i, j)`` pairing row ``i`` of ``a`` with row
        ``j`` of ``b``; ``j = -1`` (``i = -1``) sends the point of ``a`` (``b``) to the
        diagonal. Every row of both diagrams appears once. ``None`` when the distance is
        infinite.

    See Also
    --------
    wasserstein_distance : The q-Wasserstein distance, whose limit in q this is.
    DiagramDistance : The distance matrix of many samples.

    Examples
    --------
    >>> from sklearn_meshph import bottleneck_distance
    >>> bottleneck_distance([[0.0, 1.0]], [[0.0, 1.25], [0.5, 0.75]])
    0.25
    >>> bottleneck_distance([], [[0.5, 1.0]])
    0.25
    >>> bottleneck_distance([[0.0, 1.0]], [[0.0, 1.25], [0.5, 0.75]], matching=True)
    (0.25, array([[ 0,  0],
           [-1,  1]]))
    """
    if matching:
        return _with_matching(a, b, "bottleneck")
    return _one_pair(a, b, "bottleneck")


@validate_params(
    {
        "order": [Interval(Real, 1, None, closed="left")],
        "internal_p": [Interval(Real, 1, None, closed="left")],
        "matching": ["boolean"],
    }
)
def wasserstein_distance(
    a, b, order: float = 2.0, internal_p: float = np.inf, matching: bool = False
):
    """Exact q-Wasserstein distance between two persistence diagrams.

    Parameters
    ----------
    a, b : array-like of shape (n, 2) and (m, 2)
    order : float, default=2.0
        The exponent q >= 1. ``inf`` gives the bottleneck distance (with
        ``internal_p=inf``); large finite orders approach it. Costs are computed in a
        scaled form, so any order is exact in float64 (with a finite ``internal_p``,
        ``order / internal_p`` may not exceed 900).
    internal_p : float, default=inf
        Ground metric between points: the L-p norm (``inf``: L-infinity, as in the
        paper). The distance of a point to the diagonal is that to its projection.
    matching : bool, default=False
        Also return an optimal matching.

    Returns
    -------
    distance : float
        ``(min over matchings of sum cost^q)^(1/q)``, solved exactly as an assignment
        problem (no approximation); ``inf`` when the numbers of essential points differ.
    matching : ndarray of shape (k, 2), dtype int64
        Only with ``matching=True``: as in :func:`bottleneck_distance` (``-1``: the
        diagonal), the layout of gudhi's ``wasserstein_distance(..., matching=True)``.

    See Also
    --------
    bottleneck_distance, DiagramDistance

    Examples
    --------
    >>> from sklearn_meshph import wasserstein_distance
    >>> wasserstein_distance([[0.0, 1.0]], [[0.0, 1.25], [0.5, 0.75]], order=1.0)
    0.375
    >>> wasserstein_distance([[0.0, 1.0]], [[0.0, 1.25], [0.5, 0.75]], matching=True)[1]
    array([[ 0,  0],
           [-1,  1]])
    """
    if matching:
        return _with_matching(a, b, "wasserstein", order, internal_p)
    return _one_pair(a, b, "wasserstein", order, internal_p)


@validate_params({"n_directions": [Interval(Integral, 1, MAX_DIRECTIONS, closed="both")]})
def sliced_wasserstein_distance(a, b, n_directions: int = 10) -> float:
    """Sliced Wasserstein distance between two persistence diagrams (Carrière, Cuturi &
    Oudot 2017), computed as gudhi computes it.

    Parameters
    ----------
    a, b : array-like of shape (n, 2) and (m, 2)
        Rows (birth, death); death may be ``inf``.
    n_directions : int, default=10
        Number of lines the diagrams are projected on: the angles
        ``-pi/2 + k pi / (n_directions + 1)``, ``k = 0, ..., n_directions - 1`` (gudhi's
        lines for ``num_directions = n_directions + 1``, see Notes).

    Returns
    -------
    distance : float
        The mean over the lines of the L1 distance between the sorted projections of
        ``a`` plus the diagonal projections of ``b``, and those of ``b`` plus the
        diagonal projections of ``a``. Essential points (death ``inf``) are matched
        among themselves by sorted birth: ``inf`` when their numbers differ, else the L1
        distance of their sorted births is added.

    See Also
    --------
    wasserstein_distance : The exact distance this approximates.
    DiagramDistance : The distance matrix of many samples (``metric="sliced-wasserstein"``).
    SlicedWassersteinKernel : The kernel ``exp(-SW / (2 bandwidth^2))``.

    Notes
    -----
    **Approximation.** On every line the distance is at most twice the exact
    1-Wasserstein distance with the Euclidean ground metric, hence (as
    ``||v||_2 <= sqrt(2) ||v||_inf``)

    ``SW(a, b) <= 2 W1(a, b; internal_p=2) <= 2 sqrt(2) W1(a, b; internal_p=inf)``,

    for any number of lines: the upper bound ``SW <= 2 sqrt(2) d_1`` of Carrière, Cuturi
    & Oudot, "Sliced Wasserstein Kernel for Persistence Diagrams", ICML 2017 (Section
    3), with ``d_1`` their 1-Wasserstein distance with the L-infinity ground metric
    (``wasserstein_distance(a, b, order=1, internal_p=inf)``). (Proof on one line: a
    matched pair ``x, y`` sends the projection of ``x`` to that of ``y`` and the
    diagonal projection of ``y`` to that of ``x``, each at most ``||x - y||_2``; an
    unmatched point goes to its own diagonal projection.) The paper also bounds the
    exact SW, integrated over all lines, from below by ``d_1 / (2M)``, ``M = 1 +
    2N(2N - 1)`` for diagrams of at most ``N`` points; a finite number of lines gives no
    lower bound: SW is then a pseudometric (symmetric, triangle inequality), and two
    different diagrams can have the same projections on every line.

    **gudhi.** ``gudhi.representations.SlicedWassersteinDistance(num_directions=n + 1)``
    gives the same value for diagrams without essential points (to rounding): gudhi
    takes ``num_directions`` evenly spaced angles in ``[-pi/2, pi/2)`` and drops the
    last one, so its ``num_directions=10`` (its default) uses 9 lines, our
    ``n_directions=9``.

    Examples
    --------
    >>> from sklearn_meshph import sliced_wasserstein_distance
    >>> sliced_wasserstein_distance([[0.0, 1.0]], [[0.0, 1.0]])
    0.0
    >>> round(sliced_wasserstein_distance([[0.0, 1.0]], []), 6)
    0.461707
    """
    return _one_pair(a, b, "sliced-wasserstein", n_directions=n_directions)
