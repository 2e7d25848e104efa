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


def request(symmetric, n=300, m=200):
    """A matrix of ``n`` rows (of ``m`` columns unless symmetric) whose samples' sizes
    vary much (a few samples much larger)."""
    sizes = rng.integers(0, 60, (n, 1)) ** 2 // 60
    return pairwise.PairRequest(
        None,
        None,
        None if symmetric else (),
        n,
        n if symmetric else m,
        sizes=(sizes, None if symmetric else rng.integers(0, 60, (m, 1))),
    )


@pytest.mark.parametrize("symmetric", [True, False])
def test_guided_blocks_cover_every_row_once_largest_first(symmetric, monkeypatch):
    monkeypatch.setattr(pairwise, "_MAX_TASK_PAIRS", 2_000)
    monkeypatch.setattr(pairwise, "_MIN_TASK_COST", 0.0)
    matrices = [request(symmetric), request(symmetric, n=50)]
    tasks = pairwise._guided_blocks(matrices, workers=2)
    for matrix in matrices:
        own = sorted((a, b) for r, a, b, _ in tasks if r is matrix)
        starts, stops = map(np.array, zip(*own, strict=True))
        assert starts[0] == 0
        assert stops[-1] == matrix.n
        np.testing.assert_array_equal(starts[1:], stops[:-1])
        assert max(matrix.row_pairs[a:b].sum() for a, b in own) <= 2_000
    costs = np.array([cost for *_, cost in tasks])
    total = sum(matrix.cost for matrix in matrices)
    np.testing.assert_allclose(costs.sum(), total)
    assert np.all(np.diff(costs) <= 0)  # costliest first
    # Guided sizes: the first block about an eighth of the work (a row more at most),
    # the last ones far smaller.
    largest_row = max(matrix.row_costs.max() for matrix in matrices)
    assert costs[0] <= total / 8 + largest_row
    assert costs[-1] < costs[0] / 10


def test_one_worker_computes_each_matrix_in_one_block():
    matrices = [request(True), request(False, n=40)]
    tasks = pairwise._guided_blocks(matrices, workers=1)
    assert [(a, b) for _, a, b, _ in tasks] == [(0, 300), (0, 40)]


def counting_pair_matrices(monkeypatch):
    """The requests of each call of pair_matrices, which then computes them."""
    calls, original = [], pairwise.pair_matrices

    def counting(requests, **kwargs):
        calls.append((len(requests), kwargs["n_jobs"]))
        return original(requests, **kwargs)

    monkeypatch.setattr(pairwise, "pair_matrices", counting)
    return calls


def sum_of_pairs(left, right, rows, cols):
    return left[rows] + right[cols]


def plan(n, n_jobs, offset):
    """A plan of two matrices (a symmetric one, a rectangle) finishing to their sum."""
    values = np.arange(n, dtype=float) + offset
    requests = [
        pairwise.PairRequest(lambda a, b, r, c: a[r] + a[c], values, None, n, n),
        pairwise.PairRequest(sum_of_pairs, values, values[:3], n, 3),
    ]
    return pairwise.MatrixPlan(
        requests, lambda matrices: (matrices[0], matrices[1]), n_jobs=n_jobs, verbose=0
    )


def test_plans_of_one_n_jobs_run_in_one_call_each_finishing_on_its_own(monkeypatch):
    calls = counting_pair_matrices(monkeypatch)
    plans = [plan(5, 1, 0.0), plan(4, 2, 10.0), pairwise.MatrixPlan.ready("done"), plan(6, 1, 20.0)]
    outputs = pairwise.run_plans(plans)
    # One call per n_jobs (4 matrices for n_jobs=1), none for the plan already done.
    assert calls == [(4, 1), (2, 2)]
    assert outputs[2] == "done"
    for (square, rectangle), (n, offset) in zip(
        [outputs[0], outputs[1], outputs[3]], [(5, 0.0), (4, 10.0), (6, 20.0)], strict=True
    ):
        values = np.arange(n) + offset
        expected = values[:, None] + values[None, :]
        np.fill_diagonal(expected, 0.0)
        np.testing.assert_array_equal(square, expected)
        np.testing.assert_array_equal(rectangle, values[:, None] + values[None, :3])
