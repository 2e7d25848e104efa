"""Exact bottleneck and Wasserstein distances between two diagrams, and the registry
of diagram metrics read by ``DiagramDistance`` and the command line."""

from __future__ import annotations

from numbers import Real

import numpy as np

from .._param_validation import Interval, validate_params
from .._registry import Option, Registry
from ._assignment import DIAGONAL, precedes
from ._batch import BOTTLENECK, WASSERSTEIN, pack_one, pair_distances
from ._bottleneck import bottleneck_finite, bottleneck_partners
from ._wasserstein import transport
from .validation import check_diagram

__all__ = ["METRICS", "bottleneck_distance", "kernel_metric", "wasserstein_distance"]

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


def _one_pair(a, b, metric, order=2.0, internal_p=np.inf) -> float:
    a, b = check_diagram(a, index=0), check_diagram(b, index=1)
    zero = np.zeros(1, dtype=np.int64)
    code, order = kernel_metric(metric, order, internal_p)
    return float(
        pair_distances(pack_one(a), pack_one(b), zero, zero, 1, code, order, internal_p)[0]
    )


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
