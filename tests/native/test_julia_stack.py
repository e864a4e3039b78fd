"""Julia set stacks (kind "julia_stack", section 5.1): complex Julia sets of z^2 + c(u) stacked
along object z, u = z / height + 1/2 running along a piecewise linear c-path.

References: the float64 iteration of reference/families64.py; with a constant path the stack is a
straight extrusion of one Julia set, which has a closed form in every view: from above, the
filled Julia set itself under a flat top at z = height / 2."""
import numpy as np
import pytest
import unbound_core as uc

from conftest import check_no_passthrough, dense_sampling, estimate, make_camera, render
from reference import families64 as ref
from reference import qjulia64 as qj

ITERS = 32
HEIGHT = 2.0


def test_empirical():
    d = uc.describe(dict(kind="julia_stack"))
    assert not d["exact"]
    # Made safe: half steps, and no step longer than 5 % of the bounding radius.
    assert d["step_factor"] == pytest.approx(0.5)
    assert d["max_step"] == pytest.approx(0.05 * d["bound_radius"])


@pytest.mark.parametrize("path", [[(-0.123, 0.745)], [(-0.123, 0.745), (-0.123, 0.745)]])
def test_constant_path_is_an_extrusion(path):
    """Inside the slab the estimate does not depend on z (same bits at every height) and is the
    planar Julia estimate; outside the slab it is at least the distance to the slab."""
    rng = np.random.default_rng(3)
    obj = dict(kind="julia_stack", path=path, stack_height=HEIGHT, max_iterations=ITERS)
    xy = rng.uniform(-1.6, 1.6, (3000, 2))
    base, _, _ = estimate(obj, np.column_stack([xy, np.zeros(len(xy))]))
    for z in (-0.99, -0.3, 0.5, 0.999):
        moved, _, _ = estimate(obj, np.column_stack([xy, np.full(len(xy), z)]))
        np.testing.assert_array_equal(moved, base)
    # The planar Julia estimate: the quaternion one on the 1-i plane (z and mu with no j, k part).
    xy0 = np.column_stack([xy.astype(np.float32).astype(np.float64), np.zeros(len(xy))])
    want = qj.distance_estimate(qj.slice_points(xy0), (*path[0], 0.0, 0.0), ITERS, 4.0)[0]
    big = want > 1e-3
    assert big.sum() > 1000 and (want == 0).sum() > 200
    np.testing.assert_allclose(base[big], want[big], rtol=2e-3)
    above, _, _ = estimate(obj, np.column_stack([xy, np.full(len(xy), 1.7)]))
    assert np.all(above >= 0.7 - 1e-6)


def test_constant_path_from_above_is_the_filled_julia_set():
    """Orthographic view straight down: the alpha pass is the float64 escape map of the filled
    Julia set at the pixel centres (up to boundary pixels) and the depth is the flat top's."""
    c = complex(-0.123, 0.745)
    # Looking down -z with +y up (make_camera's up vector is z).
    cam = dict(matrix=uc.look_at((0.0, 0.0, 5.0), (0.0, 0.0, 0.0), (0.0, 1.0, 0.0)),
               projection=uc.orthographic(3.2, 1.0, 0.1, 100.0), width=96, height=96)
    obj = dict(kind="julia_stack", path=[(c.real, c.imag)], stack_height=HEIGHT, max_iterations=ITERS,
               threshold_mode="fixed", epsilon=1e-4)
    passes, _ = render(cam, [obj], ["alpha", "depth", "position"])
    xy = passes["position"][..., :2]
    # Pixel centres in the object's plane, from the native rays' own origins (orthographic).
    ys, xs = np.mgrid[0:96, 0:96]
    px = (xs + 0.5) / 96 * 3.2 - 1.6
    py = (ys + 0.5) / 96 * 3.2 - 1.6
    escaped, _, _, _, _ = ref.stack_escape(np.stack([px, py, np.zeros_like(px)], -1), [(c.real, c.imag)], HEIGHT,
                                           ITERS)
    inside = ~escaped
    hit = passes["alpha"][..., 0] == 1
    assert inside.mean() > 0.1
    # Hits where the set is; the pixel-mode-free fixed threshold adds at most a thin rim.
    assert np.mean(inside & ~hit) == 0.0
    assert np.mean(hit & ~inside) < 0.03
    np.testing.assert_allclose(passes["depth"][inside, 0], 5.0 - HEIGHT / 2, atol=1e-3)
    np.testing.assert_allclose(xy[inside], np.stack([px, py], -1)[inside], atol=1e-5)


PATHS = {
    "fig 4, real c": [(-1.75, 0.0), (0.25, 0.0)],
    "rabbit to dendrite": [(-0.123, 0.745), (0.0, 1.0)],
    "three segments": [(-0.8, 0.156), (-0.4, 0.6), (0.28, 0.0), (-1.0, 0.05)],
}


def stack_estimate64(p, path):
    escaped, in_slab, r, dz, dc = ref.stack_escape(p, path, HEIGHT, ITERS)
    _, speed = ref.path_c(path, p[..., 2] / HEIGHT + 0.5)
    est = np.where(escaped, r * np.log(np.maximum(r, 1.0)) / (2.0 * np.sqrt(dz ** 2 + (dc * speed / HEIGHT) ** 2)), 0.0)
    return np.maximum(est, np.abs(p[..., 2]) - HEIGHT / 2), escaped, in_slab


@pytest.mark.parametrize("name", list(PATHS))
def test_no_ray_passes_through(name):
    """Dense float64 sampling along the native rays: every ray that meets a solid piece of the
    stack (orbit bounded for ITERS steps, inside the slab) hits, and never beyond it; the hits lie
    where the float64 form of the empirical estimate first drops below the threshold."""
    path = PATHS[name]
    cam = make_camera(32, 24, eye=(-3.2, -5.2, 3.0), target=(0, 0, -0.1), fov_y=0.7)
    obj = dict(kind="julia_stack", path=path, stack_height=HEIGHT, max_iterations=ITERS, threshold_mode="fixed",
               epsilon=2e-3)
    passes, _ = render(cam, [obj], ["alpha", "position"])
    bound = uc.describe(obj)

    def classify(p):
        est, escaped, in_slab = stack_estimate64(p, path)
        return ~escaped & in_slab, est < 2e-3

    t_solid, t_shell = dense_sampling(cam, classify, bound["bound_center"], bound["bound_radius"], 1e-3)
    check_no_passthrough(cam, passes, t_solid, t_shell, slack=3e-3, agree_tol=0.02, agree_fraction=0.95)


def test_non_finite_points_are_safe():
    """Shading evaluates the estimate at every lane of a packet, missed rays included (their
    infinite t gives NaN and inf points): the path lookup must stay inside the path."""
    obj = dict(kind="julia_stack", path=[(-1.0, 0.0), (0.2, 0.3), (0.25, 0.0)])
    pts = [(np.nan, 0, np.nan), (0, 0, np.inf), (0, 0, -np.inf), (np.inf, np.nan, 1e30), (1.8, 1.8, 0.0)]
    est, it, _ = estimate(obj, pts)
    assert np.isfinite(est[-1]) and est[-1] > 0
    assert not np.any(est[:4] < 0)  # NaN or a non-negative bound, never a crash
