"""Exact distances on clustered, tied and duplicated diagrams (issue: no cliffs).

Diagrams of functions with plateaus or integer values, and Rips H0 diagrams, put many
points on one line or on the very same spot. Large pairs of them (more than 300 x 300
point pairs: the sizes at which the solvers switch to their sparse paths) must give the
brute-force answer.
"""

import numpy as np
import pytest
from scipy.optimize import linear_sum_assignment
from test_distances import augmented_costs, brute_force_bottleneck, matching_cost

from sklearn_meshph import bottleneck_distance, wasserstein_distance

FAMILIES = ["equal births", "births zero", "equal persistence", "integer grid", "duplicates"]
SIZES = [(310, 310), (320, 345), (420, 300)]


def clustered(family, n, rng):
    """One diagram of ``n`` points of a family."""
    if family == "equal births":  # births all equal, deaths within 1%
        return np.column_stack([np.full(n, 0.3), 1.0 + 0.01 * rng.random(n)])
    if family == "births zero":  # Rips H0: every class born at 0
        return np.column_stack([np.zeros(n), rng.random(n)])
    if family == "equal persistence":  # a plateau the other way: all on one line
        births = rng.random(n)
        return np.column_stack([births, births + 0.25])
    if family == "integer grid":  # integer-valued functions: ties and duplicates
        births = rng.integers(0, 10, n)
        return np.column_stack([births, births + rng.integers(0, 10, n)]).astype(float)
    if family == "duplicates":  # a few points, each many times
        base = rng.random((15, 2)) @ [[1, 1], [0, 0.5]]
        return base[rng.integers(0, 15, n)]
    raise ValueError(family)


def brute_force_wasserstein(a, b, order, internal_p):
    cost = augmented_costs(a, b, order)
    if internal_p != np.inf:
        n, m = len(a), len(b)
        delta = np.abs(a[:, None, :] - b[None, :, :])
        cost[:n, :m] = (np.sum(delta**internal_p, axis=2) ** (1 / internal_p)) ** order
        factor = 2.0 ** (1 / internal_p)
        cost[:n, m:] = ((factor * (a[:, 1] - a[:, 0]) / 2) ** order)[:, None]
        cost[n:, :m] = ((factor * (b[:, 1] - b[:, 0]) / 2) ** order)[None, :]
    rows, cols = linear_sum_assignment(cost)
    return cost[rows, cols].sum() ** (1 / order)


@pytest.mark.parametrize("family", FAMILIES)
@pytest.mark.parametrize(("n", "m"), SIZES)
def test_wasserstein_of_clustered_diagrams_equals_brute_force(family, n, m):
    rng = np.random.default_rng([n, m, FAMILIES.index(family)])
    a, b = clustered(family, n, rng), clustered(family, m, rng)
    for order, internal_p in [(1.0, np.inf), (2.0, np.inf), (3.5, np.inf), (2.0, 2.0)]:
        expected = brute_force_wasserstein(a, b, order, internal_p)
        got = wasserstein_distance(a, b, order=order, internal_p=internal_p)
        assert got == pytest.approx(expected, rel=1e-11, abs=1e-300), (order, internal_p)
        assert wasserstein_distance(b, a, order=order, internal_p=internal_p) == got


@pytest.mark.parametrize("family", FAMILIES)
def test_matchings_of_clustered_diagrams_attain_the_distance(family):
    rng = np.random.default_rng(FAMILIES.index(family))
    a, b = clustered(family, 330, rng), clustered(family, 350, rng)
    for order in (1.0, 2.0):
        distance, matched = wasserstein_distance(a, b, order=order, matching=True)
        assert sorted(matched[matched[:, 0] >= 0, 0]) == list(range(len(a)))
        assert sorted(matched[matched[:, 1] >= 0, 1]) == list(range(len(b)))
        costs = matching_cost(a, b, matched, order)
        assert (costs**order).sum() ** (1 / order) == pytest.approx(distance, rel=1e-12)
    distance, matched = bottleneck_distance(a, b, matching=True)
    assert matching_cost(a, b, matched, 1.0).max() == distance


@pytest.mark.parametrize("family", FAMILIES)
@pytest.mark.parametrize(("n", "m"), SIZES)
def test_bottleneck_of_clustered_diagrams_equals_brute_force(family, n, m):
    rng = np.random.default_rng([m, n, FAMILIES.index(family)])
    a, b = clustered(family, n, rng), clustered(family, m, rng)
    ours = bottleneck_distance(a, b)
    assert ours == brute_force_bottleneck(a, b) == bottleneck_distance(b, a)


def test_many_exact_duplicates_are_exact_at_scale():
    """Thousands of copies of a few points: the Wasserstein solver works on the distinct
    points with multiplicities; the answer of a pair with a known optimum."""
    rng = np.random.default_rng(8)
    births = 2.0 * np.arange(12)  # points far apart, each close to the diagonal
    points = np.column_stack([births, births + 0.1 + 0.01 * np.arange(12)])
    a = np.repeat(points, 500, axis=0)  # 6,000 points
    b = np.repeat(points, 500, axis=0)[rng.permutation(6000)]
    assert wasserstein_distance(a, b) == 0.0
    # Three copies fewer of the first point, one fewer of the last: to the diagonal.
    shorter = np.repeat(points, [497] + [500] * 10 + [499], axis=0)
    halves = (points[[0, -1], 1] - points[[0, -1], 0]) / 2
    expected = np.sqrt(3 * halves[0] ** 2 + halves[1] ** 2)
    assert wasserstein_distance(a, shorter) == pytest.approx(expected, rel=1e-12)
    _, matched = wasserstein_distance(shorter, a, matching=True)
    assert sorted(matched[matched[:, 0] >= 0, 0]) == list(range(len(shorter)))
    assert np.count_nonzero(matched[:, 0] < 0) == 4
    assert bottleneck_distance(a, shorter) == halves[1]
