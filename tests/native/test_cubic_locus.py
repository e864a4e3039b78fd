"""The cubic connectedness locus (kind "cubic_locus", section 5.2): parameters (a, b) of
f(z) = z^3 - 3a^2 z + b whose critical orbits from +a (C+) and -a (C-) stay bounded, seen in a
3-D slice of the 4-D (a, b) space.

References: the float64 iteration of reference/families64.py; exact relations between the
components: C- at (a, b) is C+ at (-a, b) (f depends on a^2 only), the union's estimate is the
smaller of the two and the intersection's the larger; on a = 0 both critical points are 0, so
the slice there is the cubic Multibrot set {b : 0 stays bounded under z^3 + b}."""
import numpy as np
import pytest
import unbound_core as uc

from conftest import check_no_passthrough, dense_sampling, estimate, make_camera, render
from reference import families64 as ref

ITERS = 24
EXTENT = 2.0
# Object x, y, z -> Re a, Im a, Re b; Im b = 0 (the default slice).
BASIS = np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [0, 0, 0]], np.float64)


def obj(component, **kw):
    return dict(dict(kind="cubic_locus", cubic_component=component, max_iterations=ITERS, extent=EXTENT), **kw)


def test_empirical_and_clipped_to_the_extent():
    d = uc.describe(obj("both"))
    assert not d["exact"] and d["bound_radius"] == pytest.approx(EXTENT)
    assert d["step_factor"] == pytest.approx(0.5)
    # Escape radius: 2 + (1 + sqrt 3) E guarantees escape inside the extent ball.
    assert d["bailout"] >= 2 + (1 + np.sqrt(3)) * EXTENT - 1e-9
    est, _, _ = estimate(obj("union"), [(2.5, 0, 0), (0, 0, 3.0)])
    assert np.all(est >= np.array([0.5, 1.0]) * (1 - 1e-6))


def test_component_relations():
    rng = np.random.default_rng(7)
    pts = rng.uniform(-1.5, 1.5, (4000, 3))
    plus, _, _ = estimate(obj("plus"), pts)
    minus, _, _ = estimate(obj("minus"), pts)
    mirrored, _, _ = estimate(obj("plus"), pts * [-1, -1, 1])
    union, _, _ = estimate(obj("union"), pts)
    both, _, _ = estimate(obj("both"), pts)
    np.testing.assert_array_equal(minus, mirrored)
    np.testing.assert_array_equal(union, np.minimum(plus, minus))
    np.testing.assert_array_equal(both, np.maximum(plus, minus))
    assert (plus == 0).mean() > 0.03 and (both == 0).mean() > 0.01 and (union > 0).mean() > 0.3


def test_estimate_matches_float64():
    """On a tilted slice: zero estimate (orbit bounded) where the float64 orbit stays bounded, and
    the empirical estimate equals its float64 form within float32 rounding elsewhere."""
    rng = np.random.default_rng(9)
    basis, _ = np.linalg.qr(rng.normal(size=(4, 3)))
    for component in ("plus", "minus", "union", "both"):
        o = obj(component, slice_basis=basis.tolist())
        pts = rng.uniform(-1.4, 1.4, (4000, 3)).astype(np.float32)
        est, _, _ = estimate(o, pts)
        inside = ref.cubic_inside(pts.astype(np.float64) @ basis.T, component, ITERS, 4.0, EXTENT)
        assert inside.mean() > 0.02
        assert np.mean((est == 0) != inside) < 0.01
        want = ref.cubic_estimate(pts.astype(np.float64) @ basis.T, basis, component, ITERS, 4.0, EXTENT)
        big = want > 1e-3
        assert big.mean() > 0.5
        np.testing.assert_allclose(est[big], want[big], rtol=5e-3)


def test_a_zero_is_the_cubic_multibrot_set():
    """Its real points are |b| <= 2 / (3 sqrt 3) = 0.385 (where z^3 + b = z has a real attracting
    fixed point): b = 0 and 0.3 are in it, 0.5, 1 and 0.8+0.8i not."""
    o = obj("both", max_iterations=64, slice_basis=[[0, 0, 1], [0, 0, 0], [1, 0, 0], [0, 1, 0]])
    est, _, _ = estimate(o, [(0, 0, 0), (0.3, 0, 0), (0.5, 0, 0), (1.0, 0, 0), (0.8, 0.8, 0)])
    assert list(est[:2]) == [0.0, 0.0]
    assert np.all(est[2:] > 0)


@pytest.mark.parametrize("component", ["plus", "both", "union"])
def test_no_ray_passes_through(component):
    """Dense float64 sampling along the native rays: every ray that meets a solid piece of the
    locus (critical orbits bounded for ITERS steps) hits, never beyond it; the hits lie where the
    float64 orbit first comes within the threshold shell (d < eps) for nearly every ray."""
    cam = make_camera(32, 24, eye=(-2.2, -3.4, 2.0), target=(0, 0, 0), fov_y=0.75)
    o = obj(component, threshold_mode="fixed", epsilon=2e-3)
    passes, _ = render(cam, [o], ["alpha", "position"])

    def classify(p):
        # The estimate is 0 exactly for the members (orbits bounded for ITERS steps): one pass
        # over the critical orbits answers both questions.
        est = ref.cubic_estimate(p @ BASIS.T, BASIS, component, ITERS, 4.0, EXTENT)
        return est == 0, est < 2e-3

    t_solid, t_shell = dense_sampling(cam, classify, (0, 0, 0), EXTENT, 1e-3)
    check_no_passthrough(cam, passes, t_solid, t_shell, slack=3e-3, agree_tol=0.02, agree_fraction=0.95)
