"""How the matrices between diagrams are cut into blocks of pairs: each row's estimated
cost is the sum of its pairs' (checked against a sum pair by pair), the blocks cover
every row once, hold about equal costs and never more pairs than a task may hold.
Which blocks and in which order never changes a value (tests/test_cluster.py)."""

import numpy as np
import pytest

import sklearn_meshph.diagrams.pairwise as pairwise

rng = np.random.default_rng(0)


@pytest.mark.parametrize("degree", [1, 2])
def test_row_costs_are_the_sums_of_the_pair_costs(degree):
    left, right = rng.integers(0, 30, (9, 3)), rng.integers(0, 30, (5, 3))

    def pair(a, b):
        return (pairwise._PAIR_COST + (a + b) ** degree).sum()

    for first in (0, 1):
        expected = [sum(pair(left[i], left[j]) for j in range(i + first, 9)) for i in range(9)]
        np.testing.assert_allclose(pairwise._row_costs(left, None, first, degree), expected)
    expected = [sum(pair(a, b) for b in right) for a in left]
    np.testing.assert_allclose(pairwise._row_costs(left, right, 1, degree), expected)


@pytest.mark.parametrize("symmetric", [True, False])
def test_blocks_cover_every_row_once_with_equal_costs(symmetric, monkeypatch):
    monkeypatch.setattr(pairwise, "_MAX_TASK_PAIRS", 2_000)
    n, m = 300, 200
    sizes = rng.integers(0, 60, (n, 1)) ** 2 // 60  # a few samples much larger
    request = pairwise.PairRequest(
        None,
        None,
        None if symmetric else (),
        n,
        n if symmetric else m,
        sizes=(sizes, None if symmetric else rng.integers(0, 60, (m, 1))),
    )
    target = request.row_costs.sum() / 16
    blocks = request.blocks(target)
    starts, stops, costs = map(np.array, zip(*blocks, strict=True))
    assert starts[0] == 0
    assert request.row_pairs[stops[-1] :].sum() == 0  # rows left out have no pair
    np.testing.assert_array_equal(starts[1:], stops[:-1])
    pairs = [request.row_pairs[a:b].sum() for a, b in zip(starts, stops, strict=True)]
    assert max(pairs) <= 2_000
    np.testing.assert_allclose(costs.sum(), request.row_costs.sum())
    # Blocks cut by cost, not by pairs: none is much over the target (a row at most).
    assert costs.max() <= target + request.row_costs.max()
