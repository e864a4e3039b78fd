"""Numerical honesty: where single precision runs out, measured on the exact unit ball (μ = 0).

The core marches in float32 (24-bit significands: a position is resolved to about 6e-8 of its
size). Zooming in until one pixel covers a fraction r of the bounding radius, the rendered
depths stay exact to float32 rounding, and they stop being distinct from pixel to pixel once r
falls below about 1e-6: the image shows steps. The add-on warns below that (engine.PRECISION_LIMIT);
README "Precision" states it. These tests pin both sides of the statement."""
import ast

import numpy as np
import pytest

from conftest import ROOT, make_camera, render, rays_float64, sphere_hits

TARGET = np.array([0.0, -0.6, 0.8])  # a point of the unit sphere
EYE = np.array([0.4, -3.0, 0.9])
SIZE = 64


def addon_precision_limit():
    """engine.PRECISION_LIMIT, read from the add-on's source (the module needs Blender's
    mathutils to import)."""
    tree = ast.parse((ROOT / "addon" / "engine.py").read_text())
    (value,) = [node.value.value for node in tree.body if isinstance(node, ast.Assign)
                and [t.id for t in node.targets if isinstance(t, ast.Name)] == ["PRECISION_LIMIT"]]
    return value


PRECISION_LIMIT = addon_precision_limit()  # a fraction of the bounding radius per pixel


def zoomed(ratio):
    """Depth pass and float64 depths with one pixel covering `ratio` of the unit radius."""
    distance = np.linalg.norm(EYE - TARGET)
    cam = make_camera(SIZE, SIZE, eye=tuple(EYE), target=tuple(TARGET), fov_y=ratio * SIZE / distance)
    passes, _ = render(cam, [dict(mu=(0.0, 0.0, 0.0, 0.0), max_iterations=30)], ["depth"])
    origin, direction, forward = rays_float64(cam)
    t, _ = sphere_hits(origin, direction)
    return passes["depth"][..., 0], t * np.sum(direction * forward, -1)


def equal_neighbours(depth):
    return float(np.mean(depth[:, 1:] == depth[:, :-1]))


@pytest.mark.parametrize("ratio", [1e-3, 1e-4, 1e-5, 4e-6, 2e-6])
def test_above_the_limit_depths_are_exact_and_distinct(ratio):
    assert ratio >= PRECISION_LIMIT  # the add-on stays quiet here
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
