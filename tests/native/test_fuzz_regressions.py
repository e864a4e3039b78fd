"""What the fuzzer (tests/fuzz/fuzz_native.py) found, each kept as a test that fails if it comes back.

Earlier finds live beside the code they concern: the Julia stack's path index from a NaN point
(test_julia_stack.py), the IFS walk's bounded work and NaN points (test_ifs.py)."""
import math

import numpy as np
import pytest
import unbound_core as uc

from conftest import alloc_passes, estimate, make_camera


@pytest.mark.parametrize("kind", ["quaternion_julia", "quaternion_mandelbrot", "cubic_locus", "julia_stack", "ifs"])
def test_far_points_get_a_finite_lower_bound(kind):
    """Found: estimate() returned NaN at y = -1e30 for a Mandelbrot slice (float32 orbit overflow,
    inf/inf). The set lies inside the bounding ball, so the distance to the ball bounds it."""
    obj = dict(kind=kind, max_iterations=14)
    if kind == "ifs":
        obj["maps"] = [[[0.5, 0, 0, x], [0, 0.5, 0, 0], [0, 0, 0.5, 0]] for x in (-0.5, 0.5)]
    info = uc.describe(obj)
    centre, radius = np.array(info["bound_center"]), info["bound_radius"]
    est, _, pts = estimate(obj, [[0.365, -1e30, 2.09], [3e38, 0, 0], [0, 0, -3e38], [1e20, 1e20, 1e20],
                                 [3.4e38, 3.4e38, 0.0]])  # the last one's distance exceeds float32
    assert not np.isnan(est).any(), est
    # Never more than the true distance to the set (which is at least the distance to the ball
    # minus nothing, at most the distance to the ball's far side).
    far_side = np.linalg.norm(pts - centre, axis=1) + radius
    assert np.all(est <= far_side * (1 + 1e-6)), (est, far_side)
    assert np.all(est > 0) and np.all(np.isfinite(est)), est


def test_background_beyond_float32_is_refused():
    """Found: background=(1.65e308, ...) is finite in Python but an infinite float32 in every
    missed pixel of the combined pass."""
    passes = alloc_passes(8, 6, ["combined"])
    with pytest.raises(ValueError, match=r"background\[0\] must be in \[0, 1e\+06\], got 1.65e\+308"):
        uc.render(make_camera(8, 6), [], passes, background=(1.65e308, 0.5, 0.5, 1.0))
    with pytest.raises(ValueError, match=r"alpha within \[0, 1\]"):
        uc.render(make_camera(8, 6), [], passes, background=(0.5, 0.5, 0.5, 2.0))
    uc.render(make_camera(8, 6), [], passes, background=(1e6, 0.0, 0.0, 1.0))
    assert np.array_equal(passes["combined"][0, 0], [1e6, 0, 0, 1])
    assert math.isfinite(float(passes["combined"].max()))


def test_infinite_far_plane_is_refused():
    """Found: a perspective projection with its clip end at infinity (row 2 = (0, 0, -1, -2n))
    rendered the sea with NaN depths and infinite positions. Every clip plane must be finite."""
    cam = make_camera(13, 14)
    near = 0.1
    cam["projection"] = [[1.0, 0, 0, 0], [0, 1.0, 0, 0], [0, 0, -1.0, -2 * near], [0, 0, -1.0, 0]]
    passes = alloc_passes(13, 14, ["depth", "position"])
    with pytest.raises(ValueError, match=r"camera.projection must have finite clip planes"):
        uc.render(cam, [], passes, shading=dict(use_sea=True, sea_height=-1.0))
    # The same camera with a far plane: every pixel finite, sea or sky.
    cam["projection"] = uc.perspective(1.57, 13 / 14, near, 1e6)
    uc.render(cam, [], passes, shading=dict(use_sea=True, sea_height=-1.0))
    assert np.isfinite(passes["depth"]).all() and np.isfinite(passes["position"]).all()
