"""Converters to and from gudhi, persim and giotto-tda formats."""

import numpy as np
import pytest

from sklearn_meshph import (
    bottleneck_distance,
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


def test_giotto_array_has_equal_counts_per_dimension_as_giotto_requires():
    array = to_giotto([(A, np.empty((0, 2))), (B, A)], dimensions=(1, 0))
    for dim, width in ((0, 3), (1, 3)):
        mask = array[:, :, 2] == dim
        assert (mask.sum(axis=1) == width).all()
        array[mask].reshape(2, width, 3)  # giotto-tda's per-dimension reshape
    assert (np.diff(array[0, :, 2]) >= 0).all()  # sorted by dimension
    back = from_giotto(array, dimensions=(1, 0))
    np.testing.assert_array_equal(back[0][0], A)
    np.testing.assert_array_equal(back[1][1], A)
    assert back[0][1].shape == (0, 2)


def test_giotto_refuses_inconsistent_samples_and_dimensions():
    with pytest.raises(ValueError, match="different numbers of diagrams"):
        to_giotto([(A, B), A])
    with pytest.raises(ValueError, match="distinct"):
        to_giotto([(A, B)], dimensions=(0, 0))


def test_ripser_output_reads_as_our_diagram():
    sp = pytest.importorskip("scipy.sparse")
    ripser = pytest.importorskip("ripser")
    # ripser's lower-star recipe on the path 0 - 1 - 2 with values 0, 2, 1: the
    # minimum at vertex 2 dies when vertex 1 joins it to the older one
    rows, cols = [0, 1, 0, 1, 2], [1, 2, 0, 1, 2]
    weights = [2.0, 2.0, 0.0, 2.0, 1.0]
    matrix = sp.coo_matrix((weights, (rows, cols)), shape=(3, 3)).tocsr()
    dgms = ripser.ripser(matrix, maxdim=0, distance_matrix=True)["dgms"]
    got = from_persim(dgms, 0)
    np.testing.assert_array_equal(got[np.lexsort(got.T[::-1])], [[0.0, np.inf], [1.0, 2.0]])


def test_persim_and_gudhi_accept_our_output():
    persim = pytest.importorskip("persim")
    gudhi = pytest.importorskip("gudhi")
    finite = A[np.isfinite(A[:, 1])]
    expected = bottleneck_distance(finite, B)
    assert persim.bottleneck(to_persim(finite)[0], to_persim(B)[0]) == pytest.approx(expected)
    from_list = from_gudhi(to_gudhi(finite, dimension=2), dimension=2)
    assert gudhi.bottleneck_distance(from_list, B, 0) == pytest.approx(expected)
