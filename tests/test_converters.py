"""Converters to and from gudhi, persim and giotto-tda formats."""

import numpy as np
import pytest

from sklearn_meshph import bottleneck_distance
from sklearn_meshph.converters import (
    from_giotto,
    from_gudhi,
    from_persim,
    to_giotto,
    to_gudhi,
    to_persim,
)

A = np.array([[0.0, 1.0], [0.5, 0.75], [0.2, np.inf]])
B = np.array([[0.1, 0.4]])


def test_gudhi_round_trip_and_gudhi_accepts_it():
    gudhi = pytest.importorskip("gudhi")
    pairs = to_gudhi(A, dimension=1)
    assert pairs[0] == (1, (0.0, 1.0))
    np.testing.assert_array_equal(from_gudhi(pairs + [(0, (3.0, 4.0))], dimension=1), A)
    tree = gudhi.SimplexTree()
    tree.insert([0], 0.0)
    tree.insert([1], 0.5)
    tree.insert([0, 1], 2.0)
    np.testing.assert_array_equal(from_gudhi(tree.persistence()), [[0.0, np.inf], [0.5, 2.0]])


def test_persim_round_trip():
    diagrams = to_persim((A, B))
    assert len(diagrams) == 2
    np.testing.assert_array_equal(from_persim(diagrams, 1), B)
    np.testing.assert_array_equal(to_persim(A)[0], A)


def test_giotto_padding_is_ignored_by_distances():
    array = to_giotto([(A, B), (B, A[:1])])
    assert array.shape == (2, 4, 3)
    back = from_giotto(array, dimensions=(0, 1))
    np.testing.assert_array_equal(back[0][0], A)
    np.testing.assert_array_equal(back[1][1], A[:1])
    padded = array[1, :, :2][array[1, :, 2] == 1]
    assert bottleneck_distance(padded, A[:1]) == 0
    with pytest.raises(ValueError, match="n_samples, n_points, 3"):
        from_giotto(np.zeros((2, 3)))
