"""The point-cloud operator on thin and close parts, and the complex that follows it.

A strip folded in two (a hairpin: two flat arms a few sampling spacings apart, joined by
a half cylinder) is the smallest picture of a leg against a body or the two sides of a
finger: its spectrum is the rectangle's, ``(pi k / length)^2`` along the unfolded strip,
however close the arms. Neighbourhoods that reach from one arm to the other
short-circuit the strip: measured, the first eigenvalue of a 1,500-point sample with the
arms 3.9 spacings apart was 4.2 times the strip's when the whole neighbourhood was
triangulated, within 1% once the far arm is left out.
"""

import numpy as np
import pytest
import scipy.linalg
import scipy.sparse

from sklearn_meshph import point_cloud_laplacian
from sklearn_meshph.mesh.graph import connected_components
from sklearn_meshph.pointcloud._triangulation import surface_neighbours
from sklearn_meshph.pointcloud.graph import surface_graph
from sklearn_meshph.spectral.eigensolver import generalized_eigenpairs


def hairpin(n, gap, width=0.3, arm=1.0, seed=0):
    """``n`` uniform points on a strip of ``width`` folded in two: arms of length ``arm``
    at heights 0 and ``gap``, joined by a half cylinder; and the unfolded length."""
    rng = np.random.default_rng(seed)
    radius = gap / 2
    length = 2 * arm + np.pi * radius
    s, y = rng.random(n) * length, rng.random(n) * width
    t = np.clip((s - arm) / radius, 0.0, np.pi)
    x = np.where(s < arm, arm - s, -radius * np.sin(t))
    x = np.where(s > arm + np.pi * radius, s - arm - np.pi * radius, x)
    z = np.where(s < arm, 0.0, radius - radius * np.cos(t))
    return np.column_stack([x, y, z]), length, width


def two_sheets(n, gap, seed=0):
    rng = np.random.default_rng(seed)
    lower = np.column_stack([rng.random((n, 2)), np.zeros(n)])
    upper = np.column_stack([rng.random((n, 2)), np.full(n, gap)])
    return np.vstack([lower, upper])


def low_spectrum(points, k=3):
    L, M = point_cloud_laplacian(points)
    values, _ = generalized_eigenpairs(L, M, k, points=points)
    return values, M.diagonal().sum()


def test_a_folded_strip_is_not_short_circuited():
    points, length, width = hairpin(1500, gap=0.08)  # arms 3.9 spacings apart
    values, area = low_spectrum(points)
    assert area == pytest.approx(length * width, rel=0.1)
    assert values[1] == pytest.approx((np.pi / length) ** 2, rel=0.05)
    assert values[2] == pytest.approx((2 * np.pi / length) ** 2, rel=0.05)


def test_a_thin_cylinder_keeps_its_area_and_spectrum():
    # A finger: radius 0.05, about 18 points around (1,000 points over a length of 1).
    rng = np.random.default_rng(1)
    angle, height = rng.random(1000) * 2 * np.pi, rng.random(1000)
    points = np.column_stack([0.05 * np.cos(angle), 0.05 * np.sin(angle), height])
    values, area = low_spectrum(points)
    assert area == pytest.approx(2 * np.pi * 0.05, rel=0.05)
    assert values[1] == pytest.approx(np.pi**2, rel=0.05)


def test_the_far_side_of_a_thin_part_is_not_a_surface_neighbour():
    points, _, _ = hairpin(1500, gap=0.08)
    neighbors, usable, normal, _ = surface_neighbours(points)
    flat = np.abs(points[:, 0]) > 0.2  # on the arms, away from the fold
    upper = points[:, 2] > 0.04
    across = (upper[neighbors] != upper[:, None]) & flat[:, None]
    assert across.any()  # the 30 nearest do reach across ...
    assert not (usable & across).any()  # ... and are left out
    np.testing.assert_allclose(np.abs(normal[flat, 2]), 1.0, atol=1e-12)


def test_sheets_apart_are_separate_components_of_operator_and_complex():
    points = two_sheets(1500, gap=0.1)
    L, _ = point_cloud_laplacian(points)
    coupled = L.tocoo()
    coupled = np.column_stack([coupled.row, coupled.col])[coupled.data != 0]
    upper = points[:, 2] > 0.05
    assert (upper[coupled[:, 0]] == upper[coupled[:, 1]]).all()
    edges = surface_graph(points)
    assert (upper[edges[:, 0]] == upper[edges[:, 1]]).all()
    assert connected_components(len(points), edges)[0] == 2


def test_operator_is_symmetric_semidefinite_with_positive_mass_on_thin_parts():
    points, _, _ = hairpin(400, gap=0.15)  # arms 3.7 spacings apart
    L, M = point_cloud_laplacian(points)
    assert abs(L - L.T).max() < 1e-12
    assert abs(L.sum(axis=1)).max() < 1e-10
    assert (M.diagonal() > 0).all()
    spectrum = scipy.linalg.eigvalsh(L.toarray())
    assert spectrum[0] >= -1e-10 * spectrum[-1]


def test_the_complex_follows_the_operator_and_a_permutation():
    points, _, _ = hairpin(1500, gap=0.08)
    edges = surface_graph(points)
    L, _ = point_cloud_laplacian(points)
    assert (np.asarray(L[edges[:, 0], edges[:, 1]]).ravel() != 0).all()
    assert connected_components(len(points), edges)[0] == 1
    order = np.random.default_rng(2).permutation(len(points))
    permuted = surface_graph(points[order])
    back = np.sort(order[permuted], axis=1)
    np.testing.assert_array_equal(back[np.lexsort(back.T[::-1])], edges)


def _reference_frames(points, neighbors, distances, first=10, slope=0.7, cosine=0.5):
    """The surface neighbours written with NumPy's ``eigh`` (the compiled kernels'
    specification): the principal plane of the first nearest, refitted to the
    neighbours low over it; kept: low over the refitted plane, normals within 60 deg."""
    relative = points[neighbors] - points[:, None, :]
    reach = np.maximum(distances, distances[:, first - 1 : first])

    def frame(weights):
        covariance = np.einsum("nk,nki,nkj->nij", weights, relative, relative)
        return np.linalg.eigh(covariance)[1]

    weights = np.zeros(neighbors.shape)
    weights[:, :first] = 1.0
    normal = frame(weights)[:, :, 0]
    low = np.abs(np.einsum("nki,ni->nk", relative, normal)) <= slope * reach
    directions = frame(low.astype(float))
    normal = directions[:, :, 0]
    low = np.abs(np.einsum("nki,ni->nk", relative, normal)) <= slope * reach
    agree = np.abs(np.einsum("nki,ni->nk", normal[neighbors], normal)) >= cosine
    return low & agree, normal, directions[:, :, 1:]


@pytest.mark.parametrize("seed", [0, 1])
def test_compiled_frames_match_numpy_eigh(seed):
    from sklearn_meshph.pointcloud._triangulation import nearest

    points, _, _ = hairpin(1500, 0.08, seed=seed)
    points = points + np.random.default_rng(seed).normal(scale=1e-3, size=points.shape)
    distances, neighbors = nearest(points, 30)
    usable, normal, basis = _reference_frames(points, neighbors, distances)
    found_neighbors, found_usable, found_normal, found_basis = surface_neighbours(points)
    np.testing.assert_array_equal(found_neighbors, neighbors)
    np.testing.assert_array_equal(found_usable, usable)
    # Normals up to sign, tangent planes equal (any orthonormal basis of them).
    np.testing.assert_allclose(np.abs((found_normal * normal).sum(1)), 1.0, atol=1e-10)
    gram = np.einsum("nik,nil->nkl", found_basis, found_basis)
    np.testing.assert_allclose(gram, np.broadcast_to(np.eye(2), gram.shape), atol=1e-12)
    projector = np.einsum("nik,njk->nij", basis, basis)
    found_projector = np.einsum("nik,njk->nij", found_basis, found_basis)
    np.testing.assert_allclose(found_projector, projector, atol=1e-9)
    np.testing.assert_allclose(
        np.abs(np.einsum("nik,ni->nk", found_basis, found_normal)), 0.0, atol=1e-12
    )


@pytest.mark.parametrize("dropped", [0, 1, 40, 1499])
def test_nearest_within_a_subset_is_a_search_of_the_subset(dropped):
    from sklearn_meshph.pointcloud._triangulation import nearest, nearest_within

    rng = np.random.default_rng(dropped)
    points = rng.random((1500, 3))
    keep = np.ones(len(points), dtype=bool)
    keep[rng.choice(len(points), dropped, replace=False)] = False
    expected = nearest(points[keep], 30)
    found = nearest_within(points, nearest(points, 30), keep, 30)
    for a, b in zip(found, expected, strict=True):
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("n_neighbors", [30, 60, 500])
def test_wide_neighbourhoods_fit_their_planes_and_quadrics_locally(n_neighbors):
    import trimesh

    # Up to a hemisphere of neighbours is "low" over a point's plane; a quadric fitted
    # to all of them missed the sphere near the point (the area was 1.9 times 4 pi).
    points = trimesh.sample.sample_surface(trimesh.creation.icosphere(3), 1000, seed=1)[0]
    L, M = point_cloud_laplacian(points, n_neighbors=n_neighbors)
    assert abs(M.sum() / (4 * np.pi) - 1) < 0.01
    values = scipy.linalg.eigh(L.toarray(), M.toarray(), eigvals_only=True)[1:4]
    np.testing.assert_allclose(values, 2.0, rtol=0.02)  # l(l + 1) for l = 1


def _scipy_cotangent(n, triangles, a, b, shares):
    """The cotangent stiffness and lumped mass of measured triangles, each times three
    times its share, then divided by three, by scipy's sparse sums (the compiled
    assembly's oracle)."""
    weight = 3 * shares
    double_area = np.linalg.norm(np.cross(a, b), axis=1)
    opposite_i = (a * b).sum(1) / double_area * weight
    opposite_j = (a * (a - b)).sum(1) / double_area * weight
    opposite_k = (b * (b - a)).sum(1) / double_area * weight
    i, j, k = triangles.T
    half = np.concatenate([opposite_i, opposite_j, opposite_k]) / 2
    rows, cols = np.concatenate([j, i, i]), np.concatenate([k, k, j])
    weights = scipy.sparse.coo_matrix((half, (rows, cols)), shape=(n, n)).tocsr()
    weights = weights + weights.T
    L = scipy.sparse.diags(np.asarray(weights.sum(axis=1)).ravel()) - weights
    mass = np.bincount(triangles.ravel(), np.repeat(double_area / 6 * weight, 3), minlength=n)
    return (L / 3).tocsr(), mass / 3


def _shares_by_sets(n, triangles):
    """:func:`fan_shares` by Python sets: a corner has a say on a triangle when its own
    fan chains around it (each triangle's last corner the first of another of its
    triangles), or reaches the triangle's two other corners."""
    fans = [[] for _ in range(n)]
    for i, j, k in triangles.tolist():
        fans[i].append((j, k))
    closed = [len(fan) >= 3 and {k for _, k in fan} <= {j for j, _ in fan} for fan in fans]
    reached = [{c for pair in fan for c in pair} for fan in fans]
    return np.array(
        [
            1 / (1 + sum(closed[c] or set(t) - {c} <= reached[c] for c in t[1:]))
            for t in triangles.tolist()
        ]
    )


def _folded(n, degrees, seed=0):
    """``n`` uniform points on a 2 x 1 rectangle folded along ``x = 1`` to ``degrees``
    (180: flat; the normal test cuts a crease's far side below 120), and their
    coordinates on the unfolded rectangle."""
    rng = np.random.default_rng(seed)
    u = rng.random((n, 2)) * [2.0, 1.0]
    angle = np.radians(180 - degrees)
    s = np.maximum(u[:, 0] - 1, 0.0)
    x = np.minimum(u[:, 0], 1.0) + s * np.cos(angle)
    return np.column_stack([x, u[:, 1], s * np.sin(angle)]), u


def test_fan_shares_of_hand_made_fans():
    from sklearn_meshph.pointcloud.laplacians import fan_shares

    # Point 0's fan is closed around 1, 2, 3; point 1's fan is (1, 2, 0) alone, point
    # 2's (2, 0, 3) alone (both open); point 3 has none. (0, 1, 2): 0 and 1 have a say,
    # not 2 (open, its fan does not reach 1); (0, 2, 3): 0 and 2; (0, 3, 1): 0 alone
    # (1 and 3 open, not reaching 3 and 0), so it counts once from 0's fan where thirds
    # would count it a third.
    triangles = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 1], [1, 2, 0], [2, 0, 3]])
    shares = fan_shares(4, triangles)
    np.testing.assert_array_equal(shares, [1 / 2, 1 / 2, 1, 1 / 2, 1 / 2])
    np.testing.assert_array_equal(shares, _shares_by_sets(4, triangles))
    # A closed fan that chose other triangles still has a say (the neighbourhoods
    # disagree): (0, 1, 2) back to thirds once 2's fan is closed around 0, 3, 4.
    closed_two = np.vstack([triangles[:4], [[2, 0, 3], [2, 3, 4], [2, 4, 0]]])
    shares = fan_shares(5, closed_two)
    np.testing.assert_array_equal(shares[[0, 3]], [1 / 3, 1 / 3])
    np.testing.assert_array_equal(shares, _shares_by_sets(5, closed_two))
    # A rim corner (0) whose open fan took the square's other diagonal (0, 2) still
    # covers that side: it has a say on (1, 3, 0), which 1's fan holds.
    square = np.array([[0, 1, 2], [0, 2, 3], [1, 3, 0]])
    np.testing.assert_array_equal(fan_shares(4, square), [1, 1, 1 / 2])
    np.testing.assert_array_equal(fan_shares(4, square), _shares_by_sets(4, square))
    assert fan_shares(0, np.empty((0, 3), np.int64)).shape == (0,)


@pytest.mark.parametrize("case", ["folded 90", "folded 180", "hairpin", "sheets"])
def test_fan_shares_are_those_of_the_sets(case):
    from sklearn_meshph.pointcloud._triangulation import tangent_fans
    from sklearn_meshph.pointcloud.laplacians import fan_shares

    if case.startswith("folded"):
        points = _folded(1500, int(case.split()[1]))[0]
    elif case == "hairpin":
        points = hairpin(2000, 0.1)[0]
    else:
        points = two_sheets(800, 0.3)
    triangles = tangent_fans(points)[0]
    shares = fan_shares(len(points), triangles)
    np.testing.assert_array_equal(shares, _shares_by_sets(len(points), triangles))
    # Open fans are where the surface has a rim (and a crease): some share exceeds 1/3.
    assert (shares > 1 / 3).any() and (shares == 1 / 3).mean() > 0.8


@pytest.mark.parametrize("degrees", [180, 90])
def test_a_rim_keeps_its_area(degrees):
    # The points of a rim have open fans: the triangles there are held by the two
    # corners inside, and counted two thirds they would leave the rim light (the mass
    # of the points within 0.02 of the rectangle's edge: 0.79 of the band's area on
    # average over these samples with thirds, 0.85 with the shares). The rectangle
    # folded to a right angle is isometric to the flat one: the same spectrum.
    exact = sorted((np.pi * m / 2) ** 2 + (np.pi * k) ** 2 for m in range(6) for k in range(4))
    band_area = 2 * 0.02 * (2 + 1) - 4 * 0.02**2
    ratios, errors = [], []
    for seed in range(3):
        points, u = _folded(3000, degrees, seed)
        L, M = point_cloud_laplacian(points)
        band = (np.minimum(u[:, 1], 1 - u[:, 1]) < 0.02) | (np.minimum(u[:, 0], 2 - u[:, 0]) < 0.02)
        ratios.append(M.diagonal()[band].sum() / band_area)
        keep = M.diagonal() > 0  # a crease point may be in no triangle (no mass, no stiffness)
        L, M = L[keep][:, keep], M.tocsr()[keep][:, keep]
        values = scipy.linalg.eigh(
            L.toarray(), M.toarray(), eigvals_only=True, subset_by_index=[1, 4]
        )
        errors.append(values / exact[1:5] - 1)
    assert np.mean(ratios) > 0.83
    assert np.abs(np.mean(errors, axis=0)).max() < 0.04


def test_closed_fans_keep_the_thirds_bit_for_bit():
    # On a closed surface every fan chains around its point: every corner has a say,
    # each triangle's share is a third, and the operator is the plain sum of the fans
    # divided by three, to the bit (3 * (1 / 3) is 1.0 in floating point).
    import trimesh

    from sklearn_meshph import sample_point_cloud
    from sklearn_meshph.pointcloud._triangulation import tangent_fans
    from sklearn_meshph.pointcloud.laplacians import _cotangent_csr, cloud_operator, fan_shares

    points = sample_point_cloud(trimesh.creation.icosphere(4), 2000, random_state=0)
    triangles, a, b = tangent_fans(points)
    assert (fan_shares(len(points), triangles) == 1 / 3).all()
    L, M, _ = cloud_operator(points)
    indptr, indices, data, mass = _cotangent_csr(
        len(points), triangles, a, b, np.ones(len(triangles))
    )
    np.testing.assert_array_equal(L.data, data / 3.0)
    np.testing.assert_array_equal(L.indices, indices)
    np.testing.assert_array_equal(M.diagonal(), mass / 3.0)


@pytest.mark.parametrize("case", ["hairpin", "sheets", "right angles", "folded 90"])
def test_compiled_assembly_is_the_scipy_sum_of_the_fans(case):
    from sklearn_meshph.pointcloud._triangulation import tangent_fans
    from sklearn_meshph.pointcloud.laplacians import cloud_operator, fan_shares

    if case == "hairpin":
        points = hairpin(2000, 0.1)[0]
    elif case == "sheets":
        points = two_sheets(800, 0.3)
    elif case == "folded 90":
        points = _folded(1500, 90)[0]
    else:  # a grid: right angles, whose cotangents cancel exactly (entries left out)
        x, y = np.meshgrid(np.arange(20.0), np.arange(20.0))
        points = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)]) / 19
    L, M, triangles = cloud_operator(points)
    expected_triangles, a, b = tangent_fans(points)
    np.testing.assert_array_equal(triangles, expected_triangles)
    shares = fan_shares(len(points), triangles)
    expected, mass = _scipy_cotangent(len(points), triangles, a, b, shares)
    expected.sort_indices()
    assert L.has_sorted_indices
    np.testing.assert_array_equal(L.indptr, expected.indptr)
    np.testing.assert_array_equal(L.indices, expected.indices)
    np.testing.assert_allclose(L.data, expected.data, rtol=1e-12, atol=1e-14)
    np.testing.assert_array_equal(M.diagonal(), mass)
    assert abs(L - L.T).max() == 0.0
    np.testing.assert_allclose(np.asarray(L.sum(axis=1)).ravel(), 0.0, atol=1e-12)


def _lattice():
    x, y = np.meshgrid(np.arange(20.0), np.arange(20.0))
    return np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])


@pytest.mark.parametrize("dropped", [[57], [0, 1, 2, 399], list(range(0, 400, 7))])
def test_nearest_within_a_lattice_is_a_search_of_the_subset(dropped):
    # Many neighbours tie with the 30th on a grid: a k-d tree breaks such ties by its
    # build, so the lists must be ranked (distance, then index) to be the subset's own.
    from sklearn_meshph.pointcloud._triangulation import nearest, nearest_within

    points = _lattice()
    keep = np.ones(len(points), dtype=bool)
    keep[dropped] = False
    expected = nearest(points[keep], 30)
    found = nearest_within(points, nearest(points, 30), keep, 30)
    for a, b in zip(found, expected, strict=True):
        np.testing.assert_array_equal(a, b)
    # Ranked: by distance, ties by index.
    distances, indices = expected
    tied = distances[:, 1:] == distances[:, :-1]
    assert tied.any() and (indices[:, 1:][tied] > indices[:, :-1][tied]).all()


def test_a_welded_twin_leaves_a_lattice_cloud_as_it_was():
    from sklearn_meshph import LaplacianEigenTransformer

    grid = _lattice()
    twin = np.vstack([grid, grid[57] + [1e-6, 0.0, 0.0]])  # merged into grid[57]
    eigen = LaplacianEigenTransformer(eigen_index=(1, 2, 3, 4, 5))
    alone, with_twin = eigen.fit_transform([grid, twin])
    np.testing.assert_array_equal(with_twin.eigenvalues, alone.eigenvalues)
    np.testing.assert_array_equal(with_twin.values[:400], alone.values)
    np.testing.assert_array_equal(with_twin.edges, alone.edges)


def test_a_tie_wider_than_the_search_is_ranked_whole():
    # The centre of the 84 integer points at distance sqrt(50) (and of 5 more beyond
    # them): its 30 nearest are those 84's 30 of lowest index, found through several
    # wider searches; their distances are exact.
    from itertools import product

    from sklearn_meshph.pointcloud._triangulation import nearest, nearest_within

    shell = np.array([p for p in product(range(-7, 8), repeat=3) if np.dot(p, p) == 50], float)
    assert len(shell) == 84
    rng = np.random.default_rng(0)
    points = np.vstack([rng.permutation(shell), [[0.0, 0.0, 0.0]], 20 + rng.random((5, 3))])
    distances, indices = nearest(points, 30)
    np.testing.assert_array_equal(indices[84], np.arange(30))
    np.testing.assert_array_equal(distances[84], np.sqrt(50.0))
    keep = np.ones(len(points), dtype=bool)
    keep[[0, 5, 29]] = False
    expected = nearest(points[keep], 30)
    for a, b in zip(nearest_within(points, (distances, indices), keep, 30), expected, strict=True):
        np.testing.assert_array_equal(a, b)
