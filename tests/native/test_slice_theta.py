"""The set and its slice: eq. 5-6's theta rotation, general mu, slice offset and 4-D rotation,
checked against the literal float64 iteration in reference/qjulia64.py."""
import math

import numpy as np
import pytest
import unbound_core as uc

from conftest import KERNELS, make_camera, render
from reference import qjulia64 as ref

RNG = np.random.default_rng(20261121)


def native_estimate(obj, points):
    e = np.empty(len(points), np.float32)
    it = np.empty(len(points), np.float32)
    uc.estimate(obj, np.ascontiguousarray(points, np.float32), e, it)
    return e, it


@pytest.mark.parametrize("mu", [(-0.2, 0.8, 0.0, 0.0), (-1.0, 0.0, 0.0, 0.0), (0.1, 0.6, 0.3, -0.2),
                                (-0.5, 0.1, -0.4, 0.35)])
@pytest.mark.parametrize("theta", [0.0, 0.7, math.radians(110.0), -2.5])
def test_estimate_matches_literal_eq5_6(mu, theta):
    """The kernels fold g_theta^-1 into the slice; the reference iterates g o f_mu o g^-1 as
    written. Tolerance: 1e-3 relative plus 1e-5 absolute (float32 kernel vs float64)."""
    pts = RNG.uniform(-1.6, 1.6, (4000, 3))
    obj = dict(mu=mu, theta=theta, max_iterations=24)
    e, it = native_estimate(obj, pts)
    d, n = ref.distance_estimate(ref.slice_points(pts), mu, 24, 4.0, theta)
    # Points whose escape count differs sit on an escape-radius boundary where float32 and
    # float64 may round differently; they must be rare.
    same = it == n
    assert same.mean() > 0.995
    np.testing.assert_allclose(e[same], d[same], rtol=1e-3, atol=1e-5)


@pytest.mark.parametrize("obj", [dict(mu=(-0.2, 0.8, 0.0, 0.0), max_iterations=16),
                                 dict(mu=(-0.5, 0.1, -0.4, 0.35), theta=0.7, max_iterations=40),
                                 dict(mu=(0.3, 0.5, 0.0, 0.0), max_iterations=9, bailout=16.0),
                                 dict(kind="quaternion_mandelbrot", max_iterations=12)])
def test_estimate_in_batches_has_the_bits_of_one_point_at_a_time(obj):
    """estimate() takes a Julia set's points two packets at a time (de_julia_pair, issue 21), a
    last packet or a point alone through de(); each point's estimate and escape count must have
    the bits of that point estimated alone, in every kernel, whatever the count (partial packets,
    an odd packet at the end), points far outside the ball (the fallback to the ball's distance)
    included, and the kernels must agree."""
    pts = np.concatenate([RNG.uniform(-1.6, 1.6, (97, 3)), RNG.uniform(-40.0, 40.0, (6, 3))]).astype(np.float32)
    for kernel in KERNELS:
        alone = [np.empty(1, np.float32) for _ in range(2)]
        one_by_one = np.empty((2, len(pts)), np.float32)
        for i in range(len(pts)):
            uc.estimate(obj, pts[i:i + 1], alone[0], alone[1], simd=kernel)
            one_by_one[:, i] = alone[0][0], alone[1][0]
        for count in (1, 15, 16, 17, 32, 33, 48, 49, len(pts)):
            e, it = np.full(count, np.nan, np.float32), np.full(count, np.nan, np.float32)
            uc.estimate(obj, pts[:count], e, it, simd=kernel)
            assert np.array_equal(e, one_by_one[0, :count]), (kernel, count)
            assert np.array_equal(it, one_by_one[1, :count]), (kernel, count)
        if kernel == "portable":
            portable = one_by_one
        else:
            assert np.array_equal(one_by_one, portable), kernel
    assert np.all(np.isfinite(portable)) and np.any(portable[0] > 0.0) and np.any(portable[0] == 0.0)


def test_theta_zero_and_two_pi_render_identically():
    cam = make_camera(48, 36)
    base = dict(mu=(-0.2, 0.8, 0.0, 0.0), max_iterations=12)
    plain, _ = render(cam, [base], ["combined", "depth"])
    zero, _ = render(cam, [dict(base, theta=0.0)], ["combined", "depth"])
    full, _ = render(cam, [dict(base, theta=2 * math.pi)], ["combined", "depth"])
    turned, _ = render(cam, [dict(base, theta=1.0)], ["combined", "depth"])
    for k in plain:
        assert plain[k].tobytes() == zero[k].tobytes()
        assert plain[k].tobytes() == full[k].tobytes()
    assert not np.array_equal(plain["depth"], turned["depth"])


def test_slice_offset_moves_along_fourth_axis():
    """k-offset w: the slice of K_0 (unit 4-ball) at k = w is a ball of radius sqrt(1 - w^2)."""
    for w in (0.0, 0.6, 0.8):
        info = uc.describe(dict(mu=(0, 0, 0, 0), slice_origin=(0, 0, 0, w)))
        assert info["bound_radius"] == pytest.approx(math.sqrt(1 - w * w), abs=1e-12)
    assert uc.describe(dict(mu=(0, 0, 0, 0), slice_origin=(0, 0, 0, 1.5)))["bound_radius"] < 0


def test_rotated_slice_equals_reference():
    """A 4-D rotation of the slicing hyperplane (here in the j-k plane by 0.4 rad): the native
    estimate at object point p equals the reference at origin + basis @ p."""
    c, s = math.cos(0.4), math.sin(0.4)
    basis = [[1, 0, 0], [0, 1, 0], [0, 0, c], [0, 0, s]]
    origin = (0.0, 0.0, -0.3 * s, 0.3 * c)
    mu = (-0.2, 0.6, 0.2, 0.1)
    obj = dict(mu=mu, slice_basis=basis, slice_origin=origin, max_iterations=20)
    pts = RNG.uniform(-1.5, 1.5, (3000, 3))
    e, it = native_estimate(obj, pts)
    d, n = ref.distance_estimate(ref.slice_points(pts, basis, origin), mu, 20, 4.0)
    same = it == n
    assert same.mean() > 0.995
    np.testing.assert_allclose(e[same], d[same], rtol=1e-3, atol=1e-5)


def test_bounding_ball_radius_follows_mu():
    for mu in [(0, 0, 0, 0), (-0.2, 0.8, 0, 0), (0.3, -0.4, 0.5, 0.6)]:
        r = 0.5 * (1 + math.sqrt(1 + 4 * math.sqrt(sum(x * x for x in mu))))
        info = uc.describe(dict(mu=mu, bailout=1.0))
        assert info["bound_radius"] == pytest.approx(r, rel=1e-12)
        assert info["bailout"] == pytest.approx(r, rel=1e-12)  # never below the bound
