"""sample_point_cloud's simulated scans: uneven density, holes, outliers."""

import numpy as np
import pytest
import trimesh
from scipy.spatial import cKDTree

from sklearn_meshph import make_shapes, sample_point_cloud
from sklearn_meshph._param_validation import InvalidParameterError

SPHERE = trimesh.creation.icosphere(5)


def uncovered(points, n_drawn, spacings=1.5):
    """Fraction of the unit sphere farther than ``spacings`` mean spacings of a uniform
    sample of ``n_drawn`` points from every point of ``points``."""
    reference = sample_point_cloud(SPHERE, 50_000, random_state=123)
    distances, _ = cKDTree(points).query(reference)
    return float(np.mean(distances > spacings * np.sqrt(4 * np.pi / n_drawn)))


def test_default_options_keep_the_uniform_sample_bit_for_bit():
    mesh = make_shapes(n_per_class=1, classes=("hand",), random_state=0, return_X_y=True)[0][0]
    plain = sample_point_cloud(mesh, 500, noise=0.01, random_state=3)
    explicit = sample_point_cloud(
        mesh, 500, noise=0.01, density=1.0, holes=0, hole_fraction=0.3, outliers=0, random_state=3
    )
    np.testing.assert_array_equal(plain, explicit)
    # The values drawn before the scan options existed (same seed, same stream).
    np.testing.assert_array_equal(
        sample_point_cloud(SPHERE, 3, random_state=0)[0],
        [-0.6521848210954191, -0.7575365392816408, 0.018915513561704858],
    )


def test_uneven_density_makes_one_half_denser_by_the_ratio():
    for density in (4.0, 9.0):
        points = sample_point_cloud(SPHERE, 20_000, density=density, random_state=0)
        assert points.shape == (20_000, 3)
        assert np.abs(np.linalg.norm(points, axis=1) - 1).max() < 1e-3  # on the surface
        # The dense half's pole is where the mean points; the two hemispheres have
        # equal areas, so their counts are in the ratio of the densities.
        pole = points.mean(axis=0) / np.linalg.norm(points.mean(axis=0))
        dense = np.sum(points @ pole > 0)
        assert dense / (len(points) - dense) == pytest.approx(density, rel=0.08)
    uniform = sample_point_cloud(SPHERE, 20_000, random_state=0)
    assert np.linalg.norm(uniform.mean(axis=0)) < 0.02


def test_holes_remove_the_fraction_of_the_surface_asked():
    for holes, fraction in ((1, 0.2), (3, 0.15), (4, 0.4)):
        points = sample_point_cloud(
            SPHERE, 5000, holes=holes, hole_fraction=fraction, random_state=1
        )
        assert points.shape == (5000, 3)  # more points drawn, n_points kept
        # Points of the sphere far from the cloud: the holes, less a thin band at
        # their edges (the points drawn before the holes were cut set the spacing).
        assert 0.75 * fraction < uncovered(points, 5000 / (1 - fraction)) <= fraction
    assert uncovered(sample_point_cloud(SPHERE, 5000, random_state=1), 5000) < 0.002


def test_holes_are_where_the_surface_is_not_sampled():
    points = sample_point_cloud(SPHERE, 4000, holes=1, hole_fraction=0.25, random_state=2)
    # One cap: the uncovered points of the sphere lie within a cone around one axis.
    reference = sample_point_cloud(SPHERE, 20_000, random_state=5)
    distances, _ = cKDTree(points).query(reference)
    far = reference[distances > 2 * np.sqrt(4 * np.pi / 4000)]
    axis = far.mean(axis=0) / np.linalg.norm(far.mean(axis=0))
    # A cap of a quarter of the sphere's area reaches 60 degrees from its centre.
    assert np.degrees(np.arccos(far @ axis)).max() < 62


def test_outliers_are_appended_in_the_grown_bounding_box():
    mesh = make_shapes(n_per_class=1, classes=("star",), random_state=1, return_X_y=True)[0][0]
    plain = sample_point_cloud(mesh, 1000, random_state=4)
    scan = sample_point_cloud(mesh, 1000, outliers=7, random_state=4)
    assert scan.shape == (1007, 3)
    np.testing.assert_array_equal(scan[:1000], plain)
    low, high = mesh.vertices.min(axis=0), mesh.vertices.max(axis=0)
    margin = np.linalg.norm(high - low) / 4
    stray = scan[1000:]
    assert np.all((stray >= low - margin) & (stray <= high + margin))
    assert np.any((stray < low) | (stray > high))  # some outside the shape's own box


def test_scans_are_reproducible_from_the_random_state():
    options = {"noise": 0.005, "density": 3.0, "holes": 2, "outliers": 5}
    first = sample_point_cloud(SPHERE, 2000, random_state=7, **options)
    np.testing.assert_array_equal(
        first, sample_point_cloud(SPHERE, 2000, random_state=7, **options)
    )
    rng = np.random.RandomState(7)
    np.testing.assert_array_equal(
        first, sample_point_cloud(SPHERE, 2000, random_state=rng, **options)
    )
    other = sample_point_cloud(SPHERE, 2000, random_state=8, **options)
    assert not np.array_equal(first, other)


@pytest.mark.parametrize(
    ("name", "value"),
    [
        ("density", 0.5),
        ("density", 1e-300),
        ("density", np.inf),
        ("density", -2.0),
        ("density", np.nan),
        ("noise", np.inf),
        ("noise", -0.01),
        ("holes", -1),
        ("holes", 1.5),
        ("hole_fraction", 0.0),
        ("hole_fraction", 0.6),
        ("hole_fraction", np.inf),
        ("outliers", -1),
        ("outliers", 2.0),
    ],
)
def test_scan_options_are_validated(name, value):
    with pytest.raises(InvalidParameterError, match=f"'{name}' parameter of sample_point_cloud"):
        sample_point_cloud(SPHERE, 100, **{name: value})


def test_holes_too_small_to_remove_a_point_are_refused():
    with pytest.raises(ValueError, match=r"hole_fraction=1e-300 removes 0 .* at least one point"):
        sample_point_cloud(SPHERE, 100, holes=1, hole_fraction=1e-300)
    with pytest.raises(ValueError, match="removes 11 of the points for 12 holes"):
        sample_point_cloud(SPHERE, 100, holes=12)
    assert sample_point_cloud(SPHERE, 100, holes=11, random_state=0).shape == (100, 3)


@pytest.mark.parametrize("scale", [1e-200, 1e154, 1e300])
def test_meshes_near_the_float_limits_are_sampled_on_their_surface(scale):
    # Their areas over- or underflow: they were "without area" or gave NaN probabilities.
    mesh = trimesh.Trimesh(SPHERE.vertices * scale, SPHERE.faces, process=False)
    points = sample_point_cloud(mesh, 50, density=4.0, random_state=0)
    np.testing.assert_allclose(np.linalg.norm(points / scale, axis=1), 1.0, atol=0.01)


def test_samples_beyond_float_range_or_memory_are_refused():
    with pytest.raises(ValueError, match=r"noise=1e\+308 or outliers=0 leave float64's range"):
        sample_point_cloud(SPHERE, 10, noise=1e308, random_state=0)
    with pytest.raises(ValueError, match=r"more than the 10,000,000 points a sample may have"):
        sample_point_cloud(SPHERE, 10**9)
    # Found by an adversarial review: the outliers' box beyond float64's range (finite
    # corners, an infinite width) was numpy's OverflowError, not this ValueError.
    huge = trimesh.Trimesh(SPHERE.vertices * 6e307, SPHERE.faces, process=False)
    with pytest.raises(ValueError, match=r"noise=0.0 or outliers=1 leave float64's range"):
        sample_point_cloud(huge, 100, outliers=1, random_state=0)
    assert np.isfinite(sample_point_cloud(huge, 100, random_state=0)).all()
    with pytest.raises(ValueError, match=r"and 9999999 outliers\) is more than"):
        sample_point_cloud(SPHERE, 2, outliers=9_999_999)
    # The densest side's weights no longer overflow: nearly every point is on it.
    points = sample_point_cloud(SPHERE, 200, density=1e308, random_state=0)
    assert np.isfinite(points).all()
