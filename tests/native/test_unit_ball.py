"""mu = 0: K is the closed unit ball exactly (|z|^(2^n) escapes iff |z| > 1). Depth, normals,
position and coverage are checked per pixel against the analytic sphere."""
import numpy as np
import pytest

from conftest import make_camera, rays_float64, render, sphere_hits

BALL = dict(mu=(0.0, 0.0, 0.0, 0.0), max_iterations=32)


@pytest.mark.parametrize("mode", ["pixel", "fixed"])
@pytest.mark.parametrize("ortho", [False, True])
def test_unit_ball_depth_normal_position(mode, ortho):
    cam = make_camera(96, 72, ortho_height=3.0 if ortho else None)
    obj = dict(BALL, threshold_mode=mode, epsilon=1e-4)
    passes, stats = render(cam, [obj])
    origin, direction, forward = rays_float64(cam)
    t, closest = sphere_hits(origin, direction)
    footprint = 3.0 / 72 if ortho else 0.7 / 72 * 4.0  # generous pixel size near the ball
    # Coverage: exact away from the silhouette (within one pixel footprint of the limb either
    # answer is acceptable: the threshold thickens the set by up to eps).
    inner = closest < 1.0 - footprint
    outer = closest > 1.0 + footprint
    alpha = passes["alpha"][..., 0]
    assert np.all(alpha[inner] == 1.0)
    assert np.all(alpha[outer] == 0.0)
    assert inner.sum() > 500
    # Depth along the view axis, against the analytic hit (tolerance 2e-4 world units at
    # distance ~3: float32 marching plus the hit threshold, which is below 1e-4 here).
    hit_point = origin + t[..., None] * direction
    depth_ref = np.sum((hit_point - np.array(cam["matrix"])[:3, 3]) * forward, -1)
    depth = passes["depth"][..., 0]
    assert np.max(np.abs(depth[inner] - depth_ref[inner])) < 2e-4
    # Position pass is the world-space hit point; on the unit sphere its norm is 1.
    pos = passes["position"]
    assert np.max(np.abs(np.linalg.norm(pos[inner], axis=-1) - 1.0)) < 2e-4
    # Normals: gradient of the estimate (eq. 15) vs the analytic normal (the position). The
    # central-difference offset is the hit threshold: 1e-4 in fixed mode (within 0.5 degree),
    # one pixel footprint in pixel mode (0.04 units on this 72-pixel-high view: within 2 degrees).
    normal = passes["normal"][inner].astype(np.float64)
    cosang = np.sum(normal * hit_point[inner], -1) / np.linalg.norm(normal, axis=-1)
    limit = 0.5 if mode == "fixed" else 2.0
    assert np.degrees(np.arccos(np.clip(cosang.min(), -1, 1))) < limit
    # Background pixels: documented values.
    assert np.all(depth[outer] == np.float32(1e10))
    assert np.all(passes["normal"][outer] == 0.0)
    assert np.all(passes["combined"][outer] == 0.0)
    assert np.all(passes["iterations"][outer] == 0.0)
    assert stats["rays"] == 96 * 72


def test_lambert_axle_light_on_ball():
    """Combined = colour * max(0, n . -ray): the light sits at the eye (section 4)."""
    cam = make_camera(64, 48)
    passes, _ = render(cam, [dict(BALL, color=(1.0, 0.5, 0.25))])
    origin, direction, _ = rays_float64(cam)
    t, closest = sphere_hits(origin, direction)
    inner = closest < 0.95
    n = (origin + t[..., None] * direction)[inner]
    lambert = np.clip(-np.sum(n * direction[inner], -1), 0, 1)
    rgba = passes["combined"][inner]
    np.testing.assert_allclose(rgba[:, 0], lambert, atol=0.02)
    np.testing.assert_allclose(rgba[:, 1], 0.5 * lambert, atol=0.01)
    np.testing.assert_allclose(rgba[:, 3], 1.0)


def test_ball_moved_and_scaled_by_object_matrix():
    """The object matrix places the fractal: a ball of radius 0.5 centred at (0.3, 0.2, -0.1)."""
    cam = make_camera(80, 60)
    m = [[0.5, 0, 0, 0.3], [0, 0.5, 0, 0.2], [0, 0, 0.5, -0.1], [0, 0, 0, 1]]
    passes, _ = render(cam, [dict(BALL, matrix=m, threshold_mode="fixed", epsilon=1e-4)])
    origin, direction, forward = rays_float64(cam)
    t, closest = sphere_hits(origin, direction, (0.3, 0.2, -0.1), 0.5)
    inner = closest < 0.48
    hit_point = origin + t[..., None] * direction
    depth_ref = np.sum((hit_point - np.array(cam["matrix"])[:3, 3]) * forward, -1)
    assert inner.sum() > 100
    assert np.max(np.abs(passes["depth"][..., 0][inner] - depth_ref[inner])) < 2e-4
    assert np.all(passes["alpha"][..., 0][closest > 0.52] == 0)
