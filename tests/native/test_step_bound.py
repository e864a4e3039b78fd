"""Unbounding spheres must not overshoot: the step the marcher takes at a point (the estimate in
world units times step_factor, at most max_step) never exceeds the true distance to the set,
at random points where that distance is known or rigorously bounded from below."""
import math

import numpy as np
import pytest
import unbound_core as uc

RNG = np.random.default_rng(7)


def world_step(obj, world_points):
    """The step the marcher would take at world points (object matrix applied by the caller)."""
    m = np.array(obj.get("matrix", np.eye(4)), np.float64)
    local = (world_points - m[:3, 3]) @ np.linalg.inv(m[:3, :3]).T
    e = np.empty(len(local), np.float32)
    it = np.empty(len(local), np.float32)
    uc.estimate(obj, np.ascontiguousarray(local, np.float32), e, it)
    info = uc.describe(obj)
    return np.minimum(e * info["sigma_min"] * obj.get("step_factor", 1.0), obj.get("max_step", np.inf))


def test_unit_ball_step_below_exact_distance():
    """mu = 0: true distance |p| - 1, for every point within the escape radius (the estimate
    0.5 r ln r stays below r - 1 up to r = 4)."""
    obj = dict(mu=(0, 0, 0, 0), max_iterations=40, bailout=4.0)
    dirs = RNG.normal(size=(20000, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    r = np.concatenate([1 + np.geomspace(1e-4, 3.0, 20000)])
    pts = dirs * r[:, None]
    step = world_step(obj, pts)
    assert np.all(step <= (r - 1.0) * (1 + 1e-5) + 1e-7)
    assert np.all(step[r > 1.01] > 0)


def _ellipsoid_distance(y, axes):
    """Exact distance from points y (outside) to the ellipsoid sum (x_i/a_i)^2 = 1, by bisection
    on the Lagrange multiplier (Eberly): x_i = a_i^2 y_i / (t + a_i^2)."""
    y = np.abs(y)
    a2 = np.asarray(axes) ** 2
    lo = np.full(len(y), -a2.min())
    hi = np.full(len(y), np.linalg.norm(y, axis=1) * np.max(axes))
    for _ in range(200):
        t = 0.5 * (lo + hi)
        f = np.sum((np.sqrt(a2) * y / (t[:, None] + a2)) ** 2, axis=1) - 1.0
        lo = np.where(f > 0, t, lo)
        hi = np.where(f > 0, hi, t)
    x = a2 * y / (t[:, None] + a2)
    return np.linalg.norm(y - x, axis=1)


@pytest.mark.parametrize("axes", [(2.0, 1.0, 0.5), (0.3, 1.5, 1.0)])
def test_non_uniform_scale_never_oversteps(axes):
    """The unit ball scaled by (a, b, c) is an ellipsoid; the marcher scales object-space
    estimates by the smallest singular value, so its steps stay below the exact distance."""
    m = [[axes[0], 0, 0, 0.2], [0, axes[1], 0, -0.1], [0, 0, axes[2], 0.3], [0, 0, 0, 1]]
    obj = dict(mu=(0, 0, 0, 0), max_iterations=40, matrix=m)
    local = RNG.normal(size=(20000, 3))
    local *= (1 + RNG.uniform(1e-3, 2.5, (20000, 1))) / np.linalg.norm(local, axis=1, keepdims=True)
    world = local * axes + np.array([0.2, -0.1, 0.3])
    exact = _ellipsoid_distance(world - np.array([0.2, -0.1, 0.3]), axes)
    step = world_step(obj, world)
    assert np.all(step <= exact * (1 + 1e-4) + 1e-6)
    assert np.all(step[exact > 0.05] > 0)


def _certified_outside_cells(mu, half, n, max_iterations=60):
    """Real mu: K_mu in the 1-i-j slice is the filled complex Julia set rotated about the real
    axis. Certify grid cells of the complex plane as outside K by ball arithmetic: for z in
    B(c, rho), z^2 + mu lies in B(c^2 + mu, 2|c| rho + rho^2); a ball wholly beyond the escape
    radius R escapes. Uncertified cells may hold points of K."""
    xs = (np.arange(n) + 0.5) / n * 2 * half - half
    c = xs[None, :] + 1j * xs[:, None]
    rho = np.full(c.shape, half / n * math.sqrt(2))
    radius = 0.5 * (1 + math.sqrt(1 + 4 * abs(mu)))
    outside = np.zeros(c.shape, bool)
    with np.errstate(all="ignore"):  # escaped cells overflow in the branch np.where discards
        return xs, _iterate_balls(c, rho, mu, radius, outside, max_iterations)


def _iterate_balls(c, rho, mu, radius, outside, max_iterations):
    for _ in range(max_iterations):
        outside |= np.abs(c) - rho > radius
        c, rho = np.where(outside, 0, c * c + mu), np.where(outside, 0, 2 * np.abs(c) * rho + rho * rho)
    return outside


@pytest.mark.parametrize("mu", [-1.0, -0.5, 0.25, -0.12])
def test_real_mu_step_below_certified_distance(mu):
    """Rigorous lower bound on the true distance: from the point (x, sqrt(y^2+z^2)) in the
    meridian half-plane to the nearest uncertified cell (a cell of side h counts as a square).
    Checked at points at least 20 cells away, where the bound is tight to a few per cent."""
    half, n = 2.0, 1024
    xs, outside = _certified_outside_cells(mu, half, n)
    h = 2 * half / n
    cand = np.argwhere(~outside)
    cells = np.stack([xs[cand[:, 1]], xs[cand[:, 0]]], 1)  # (re, im) centres
    cells = cells[cells[:, 1] >= -h]                          # symmetric: upper half-plane suffices
    pts = RNG.uniform(-1.9, 1.9, (1500, 3))
    meridian = np.stack([pts[:, 0], np.hypot(pts[:, 1], pts[:, 2])], 1)
    lower = np.empty(len(pts))
    for i in range(0, len(pts), 100):
        gap = np.maximum(np.abs(meridian[i:i + 100, None, :] - cells[None, :, :]) - h / 2, 0)
        lower[i:i + 100] = np.sqrt((gap ** 2).sum(-1)).min(1)
    keep = lower > 20 * h
    assert keep.sum() > 200
    obj = dict(mu=(mu, 0, 0, 0), max_iterations=60)
    step = world_step(obj, pts[keep])
    assert np.all(step <= lower[keep])
