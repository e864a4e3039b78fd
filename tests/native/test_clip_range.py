"""The camera rays' range between the clip planes, against float64 numpy.

Since issue 21 a perspective camera whose clip planes are planes of constant view depth (Blender's,
lens shift included) takes each ray's t_max as t_min times the ratio of the planes' depths, not from
the clip-end plane's own root and divide; any other projection still meets its clip-end plane. The
references: the inverse projection's points of the pixel on NDC z = -1 and z = 1 (the ray's t_min
and t_max are their distances from the eye), and for the render the unit ball (mu = 0), whose hits
are known in closed form, cut by the far clip plane."""
import numpy as np
import pytest

import unbound_core as uc
from conftest import make_camera, rays_float64, render, sphere_hits

WIDTH, HEIGHT = 64, 48


def projection(kind):
    p = np.array(uc.perspective(0.7, WIDTH / HEIGHT, 0.25, 40.0), np.float64)
    if kind == "shifted":  # lens shift: an off-axis frustum, clip planes still of constant depth
        p[0][2], p[1][2] = 0.3, -0.2
    elif kind == "oblique":  # w depends on x: the planes are not of constant depth (no ratio)
        p[3][0] = 0.05
    return p


def reference_range(proj, x, y):
    """t_min, t_max of the ray through image point (x, y): the eye-to-plane distances, float64."""
    inv = np.linalg.inv(proj)
    ndc = (2.0 * x / WIDTH - 1.0, 2.0 * y / HEIGHT - 1.0)
    ts = []
    for z in (-1.0, 1.0):
        h = inv @ np.array([ndc[0], ndc[1], z, 1.0])
        ts.append(np.linalg.norm(h[:3] / h[3]))
    return ts


@pytest.mark.parametrize("kind", ["blender", "shifted", "oblique"])
def test_t_range_is_the_clip_planes_distances(kind):
    proj = projection(kind)
    cam = dict(matrix=uc.look_at((0.4, -3.0, 0.9), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0)), projection=proj.tolist(),
               width=WIDTH, height=HEIGHT)
    rng = np.random.default_rng(7)
    worst = 0.0
    for x, y in rng.random((200, 2)) * (WIDTH, HEIGHT):
        _o, _d, t_min, t_max = uc.camera_ray(cam, x, y)
        ref_min, ref_max = reference_range(proj, x, y)
        worst = max(worst, abs(t_min - ref_min) / ref_min, abs(t_max - ref_max) / ref_max)
    # A few float64 roundings of the inverse, the maps and the ratio: far below 1e-12.
    assert worst < 1e-12, worst


def test_far_clip_cuts_the_unit_ball():
    """Clip end at depth 2.2 from an eye 3 from the ball's centre: the ball's front (at depth 2)
    shows, the ring towards its limb (at depth 3 - 1/3) is cut. A pixel shows the ball iff its analytic hit lies
    before the clip-end plane; within a pixel footprint (plus the threshold) of either edge both
    answers pass."""
    cam = make_camera(WIDTH, HEIGHT, eye=(0.0, -3.0, 0.0), fov_y=0.8, clip=(0.1, 2.2))
    passes, _stats = render(cam, [dict(mu=(0.0, 0.0, 0.0, 0.0), max_iterations=32, threshold_mode="fixed",
                                       epsilon=1e-4)], names=["alpha", "depth"])
    origin, direction, forward = rays_float64(cam)
    t, closest = sphere_hits(origin, direction)
    depth_hit = t * np.sum(direction * forward, -1)  # view depth of the analytic hit (nan: a miss)
    alpha = passes["alpha"][..., 0]
    margin = 0.8 / HEIGHT * 3.0  # about a pixel's footprint at distance 3
    shown = (closest < 1.0 - margin) & (depth_hit < 2.2 - margin)
    hidden = (closest > 1.0 + margin) | (depth_hit > 2.2 + margin)
    assert shown.sum() > 100 and (hidden & (closest < 1.0)).sum() > 100  # both cases are there
    assert np.all(alpha[shown] == 1.0)
    assert np.all(alpha[hidden] == 0.0)
    assert np.nanmax(passes["depth"][..., 0][alpha == 1.0]) <= 2.2 * (1.0 + 1e-6)
