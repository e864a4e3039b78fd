"""Quaternion Mandelbrot slices (kind "quaternion_mandelbrot"): z0 = 0, mu the slice point.

References: the float64 iteration of reference/families64.py; the rotational symmetry of the
1-i-j slice (the quaternion Mandelbrot set is a solid of revolution about the real axis, since
z^2 + c stays in the plane spanned by 1 and c); the classic complex Mandelbrot set on the 1-i
plane."""
import functools

import numpy as np
import pytest
import unbound_core as uc

from conftest import check_no_passthrough, dense_sampling, estimate, make_camera, render
from reference import families64 as ref

ITERS = 24
BASIS_1IJ = [[1, 0, 0], [0, 1, 0], [0, 0, 1], [0, 0, 0]]


def test_exact_and_bounded_by_radius_2():
    d = uc.describe(dict(kind="quaternion_mandelbrot"))
    assert d["exact"] and d["bound_radius"] == pytest.approx(2.0)
    # A slice at k = 1.5 cuts the 4-ball |c| <= 2 in a ball of radius sqrt(4 - 2.25).
    d = uc.describe(dict(kind="quaternion_mandelbrot", slice_origin=(0, 0, 0, 1.5)))
    assert d["bound_radius"] == pytest.approx(np.sqrt(4 - 2.25))


def test_estimate_matches_float64():
    """The kernel's estimate equals the float64 one within float32 rounding (relative 2e-3 where
    the estimate is not tiny) on random points of a tilted 4-D slice; membership agrees."""
    rng = np.random.default_rng(5)
    basis, _ = np.linalg.qr(rng.normal(size=(4, 3)))
    origin = (0.05, -0.1, 0.02, 0.1)
    obj = dict(kind="quaternion_mandelbrot", max_iterations=ITERS, slice_basis=basis.tolist(), slice_origin=origin)
    pts = rng.uniform(-1.6, 1.6, (4000, 3)).astype(np.float32)
    est, _, _ = estimate(obj, pts)
    q = np.asarray(origin) + pts.astype(np.float64) @ basis.T
    want = ref.mandelbrot_estimate(q, ITERS)
    big = want > 1e-3
    assert big.sum() > 1000 and (want == 0).sum() > 100
    np.testing.assert_allclose(est[big], want[big], rtol=2e-3)
    # Inside/outside disagree only right at the boundary (float32 vs float64 orbits).
    disagree = (est == 0) != (want == 0)
    assert disagree.mean() < 0.01


def test_complex_plane_is_the_mandelbrot_set():
    """On the 1-i plane: c = -1, -0.12+0.75i (inside) and 0.3, -2.1, 1i+0.5 (outside)."""
    obj = dict(kind="quaternion_mandelbrot", max_iterations=64, slice_basis=BASIS_1IJ)
    est, _, _ = estimate(obj, [(-1.0, 0, 0), (-0.12, 0.75, 0), (0.3, 0, 0), (-2.1, 0, 0), (0.5, 1.0, 0)])
    assert list(est[:2]) == [0.0, 0.0]
    assert np.all(est[2:] > 0.0)


def test_solid_of_revolution():
    """In the 1-i-j slice, d(x, y, z) depends on x and sqrt(y^2 + z^2) only."""
    rng = np.random.default_rng(11)
    obj = dict(kind="quaternion_mandelbrot", max_iterations=ITERS, slice_basis=BASIS_1IJ)
    x = rng.uniform(-2, 0.6, 2000)
    rho = rng.uniform(0, 1.3, 2000)
    phi = rng.uniform(0, 2 * np.pi, 2000)
    turned, _, _ = estimate(obj, np.stack([x, rho * np.cos(phi), rho * np.sin(phi)], 1))
    plane, _, _ = estimate(obj, np.stack([x, rho, np.zeros_like(x)], 1))
    big = plane > 1e-3
    np.testing.assert_allclose(turned[big], plane[big], rtol=2e-3)
    assert np.mean((turned == 0) != (plane == 0)) < 0.01


PASSTHROUGH_BASIS = np.linalg.qr(np.random.default_rng(2).normal(size=(4, 3)))[0]
PASSTHROUGH_CAMERA = make_camera(32, 24, eye=(1.2, -3.0, 1.5), target=(-0.4, 0, 0), fov_y=0.9)


@functools.cache
def passthrough_reference():
    """Dense float64 samples along the camera's rays: (first solid t, first shell t) per pixel;
    the same for both bisection settings, so computed once."""
    def classify(p):
        r, dz, escaped = ref.mandelbrot(p @ PASSTHROUGH_BASIS.T, ITERS)
        return ~escaped, ~escaped | (r * np.log(np.maximum(r, 1.0)) / (2.0 * dz) < 2e-3)

    return dense_sampling(PASSTHROUGH_CAMERA, classify, (0, 0, 0), 2.0, 5e-4)


@pytest.mark.parametrize("bisection", [0, 10])
def test_no_ray_passes_through(bisection):
    """Dense float64 sampling along the native core's own rays: every ray that meets a solid piece
    of the set (orbit bounded for ITERS steps) hits, never beyond it; the hits lie where the
    float64 estimate first drops below the fixed threshold 2e-3 for nearly every ray."""
    cam = PASSTHROUGH_CAMERA
    obj = dict(kind="quaternion_mandelbrot", max_iterations=ITERS, slice_basis=PASSTHROUGH_BASIS.tolist(),
               threshold_mode="fixed", epsilon=2e-3, bisection_steps=bisection)
    passes, _ = render(cam, [obj], ["alpha", "position"])
    t_solid, t_shell = passthrough_reference()
    check_no_passthrough(cam, passes, t_solid, t_shell, slack=2e-3, agree_tol=0.02, agree_fraction=0.95)
