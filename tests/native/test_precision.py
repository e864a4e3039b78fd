"""Numerical honesty: where single precision runs out, measured on the exact unit ball (μ = 0).

The core marches in float32 (24-bit significands: a position is resolved to about 6e-8 of its
size). Zooming in until one pixel covers a fraction r of the bounding radius, the rendered
depths stay exact to float32 rounding, and they stop being distinct from pixel to pixel once r
falls below about 1e-6: the image shows steps. The core measures that ratio at the nearest hit
(render()'s stats["footprint_ratio"]) and the add-on warns below uc.PRECISION_LIMIT; README
"Precision" states it. These tests pin both sides of the statement."""
import math

import numpy as np
import pytest
import unbound_core as uc

from conftest import make_camera, render, rays_float64, sphere_hits

TARGET = np.array([0.0, -0.6, 0.8])  # a point of the unit sphere
EYE = np.array([0.4, -3.0, 0.9])
SIZE = 64


PRECISION_LIMIT = uc.PRECISION_LIMIT  # a fraction of the bounding radius per pixel


def zoomed(ratio):
    """Depth pass and float64 depths with one pixel covering `ratio` of the unit radius."""
    distance = np.linalg.norm(EYE - TARGET)
    cam = make_camera(SIZE, SIZE, eye=tuple(EYE), target=tuple(TARGET), fov_y=ratio * SIZE / distance)
    passes, stats = render(cam, [dict(mu=(0.0, 0.0, 0.0, 0.0), max_iterations=30)], ["depth"])
    origin, direction, forward = rays_float64(cam)
    t, _ = sphere_hits(origin, direction)
    depth = t * np.sum(direction * forward, -1)
    # The core's ratio: a pixel's footprint at the nearest hit over the bounding radius (1 here).
    assert stats["footprint_ratio"] == pytest.approx(ratio * np.nanmin(depth) / distance, rel=2e-4)
    return passes["depth"][..., 0], depth


def equal_neighbours(depth):
    return float(np.mean(depth[:, 1:] == depth[:, :-1]))


@pytest.mark.parametrize("ratio", [1e-3, 1e-4, 1e-5, 4e-6, 2e-6])
def test_above_the_limit_depths_are_exact_and_distinct(ratio):
    assert ratio >= PRECISION_LIMIT  # the add-on stays quiet here (ratio at the nearest hit ~ ratio)
    depth, reference = zoomed(ratio)
    assert np.all(depth < 1e9)  # every pixel on the sphere
    # Within float32 rounding of the ~2.3 depth (ulp 2.4e-7) plus the marching epsilon.
    assert np.max(np.abs(depth - reference)) < 3e-7 + 0.5 * ratio
    assert equal_neighbours(depth) < 0.02


@pytest.mark.parametrize("ratio", [5e-7, 2.5e-7, 1e-7])
def test_below_the_limit_depths_show_steps(ratio):
    depth, reference = zoomed(ratio)
    # Still the right place, to float32 rounding...
    assert np.max(np.abs(depth - reference)) < 3e-7
    # ...but quantised: neighbouring pixels share their depth, in steps.
    assert equal_neighbours(depth) > 0.3, equal_neighbours(depth)
    assert ratio < PRECISION_LIMIT  # the add-on warns here


def test_footprint_of_a_non_square_frame_is_the_smaller_pixel_side():
    """Regression (issue 14): the add-on once took the pixel's width alone while the core's
    threshold used the smaller side. Now the core alone measures it: in a frame 4 times wider
    than tall with the vertical field fitted, a pixel is 2/(height * P[1][1]) tall and
    2/(width * P[0][0]) wide; the ratio takes the smaller."""
    cam = make_camera(256, 64, eye=(0.0, -3.0, 0.0), fov_y=0.6)
    proj = cam["projection"]
    # Squash pixels: halve P[1][1] so a pixel is twice as tall as wide... then the width rules;
    # double it so the height rules: the ratio must follow whichever side is smaller.
    for scale in (0.5, 2.0):
        p = [list(row) for row in proj]
        p[1][1] *= scale
        camera = dict(cam, projection=p)
        passes, stats = render(camera, [dict(mu=(0.0, 0.0, 0.0, 0.0), max_iterations=30)], ["depth"])
        nearest = float(passes["depth"][passes["depth"] < 1e9].min())
        fx, fy = 2.0 / (256 * abs(p[0][0])), 2.0 / (64 * abs(p[1][1]))
        assert stats["footprint_ratio"] == pytest.approx(min(fx, fy) * nearest, rel=1e-6), scale


def test_footprint_ratio_uses_the_world_bounding_radius():
    """A fractal scaled by 3 in the world: the same pixel covers a third of the ratio; none
    without a hit or a depth pass."""
    cam = make_camera(64, 64, eye=(0.0, -9.0, 0.0), fov_y=0.5)
    unit = dict(mu=(0.0, 0.0, 0.0, 0.0), max_iterations=30)
    big = dict(unit, matrix=[[3, 0, 0, 0], [0, 3, 0, 0], [0, 0, 3, 0], [0, 0, 0, 1]])
    _, small_stats = render(cam, [unit], ["depth"])
    passes, big_stats = render(cam, [big], ["depth"])
    nearest = float(passes["depth"][passes["depth"] < 1e9].min())
    pixel = 2.0 / (64 * cam["projection"][1][1])
    assert big_stats["footprint_ratio"] == pytest.approx(pixel * nearest / 3.0, rel=1e-6)
    assert small_stats["footprint_ratio"] > big_stats["footprint_ratio"]
    _, no_depth = render(cam, [big], ["combined"])
    assert no_depth["footprint_ratio"] is None
    away = make_camera(32, 32, eye=(0.0, -9.0, 0.0), target=(0.0, -20.0, 0.0))
    assert render(away, [big], ["depth"])[1]["footprint_ratio"] is None
    assert math.isclose(uc.PRECISION_LIMIT, 1e-6)


def test_footprint_ratio_of_every_sample_of_a_render():
    """The nearest hit is taken while the kernels write the depth pass (sample 0 alone writes it).
    A render of several samples, one core call per sample into the same buffers (as the add-on
    renders them), gets the same ratio from each call: the later ones read the depth that sample
    0 left in the buffer. It equals the ratio at the depth pass's nearest hit (the unit ball:
    bounding radius 1)."""
    cam = make_camera(48, 40, eye=(0.0, -3.0, 0.5), fov_y=0.7)
    ball = dict(mu=(0.0, 0.0, 0.0, 0.0), max_iterations=30)
    passes = {n: np.zeros((40, 48, uc.PASS_CHANNELS[n]), np.float32) for n in ("combined", "depth")}
    ratios = [uc.render(cam, [ball], passes, shading=dict(samples=3), sample_range=(s, 1))["footprint_ratio"]
              for s in range(3)]
    depth = passes["depth"][..., 0]
    nearest = float(depth[depth < 1e9].min())
    pixel = 2.0 / (40 * cam["projection"][1][1])
    assert ratios[0] == pytest.approx(pixel * nearest, rel=1e-6)
    assert ratios[1] == ratios[0] and ratios[2] == ratios[0]
