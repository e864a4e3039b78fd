"""The community formulas of issue 22: kinds "mandelbulb" and "mandelbox".

References: reference/formulas64.py, float64 numpy iterations written from the published
definitions (numpy's arctan2/arccos/sin/cos/power where the core has its own float32 polynomials);
dense float64 sampling along the core's own rays for the no-pass-through checks, as for the kinds
of section 5 (test_mandelbrot.py)."""
import functools

import numpy as np
import pytest
import unbound_core as uc

from conftest import KERNELS, HEAVY_SHADING, check_no_passthrough, dense_sampling, estimate, make_camera, render
from reference import formulas64 as ref

BULB = dict(kind="mandelbulb", max_iterations=12)
BULB_JULIA = dict(kind="mandelbulb", max_iterations=12, julia_mode=True, julia_c=(0.35, -0.45, 0.25), power=6.0)
BOX = dict(kind="mandelbox", max_iterations=14)
BOX_NEG = dict(kind="mandelbox", max_iterations=14, box_scale=-1.5)
BOX_JULIA = dict(kind="mandelbox", max_iterations=14, box_scale=2.5, julia_mode=True, julia_c=(0.8, -0.3, 0.5))
FORMULA_OBJECTS = {"mandelbulb": BULB, "mandelbulb_julia": BULB_JULIA, "mandelbox": BOX,
                   "mandelbox_negative": BOX_NEG, "mandelbox_julia": BOX_JULIA}


def bulb_ref(obj, pts):
    d = uc.describe(obj)
    c = obj.get("julia_c") if obj.get("julia_mode") else None
    return ref.mandelbulb_estimate(pts, obj.get("power", 8.0), obj["max_iterations"], d["bailout"], c)


def box_ref(obj, pts):
    d = uc.describe(obj)
    c = obj.get("julia_c") if obj.get("julia_mode") else None
    return ref.mandelbox_estimate(pts, obj.get("box_scale", 2.0), obj.get("box_fold", 1.0), obj.get("min_radius", 0.5),
                                  obj.get("fixed_radius", 1.0), obj["max_iterations"], d["bailout"], c)


def reference_estimate(obj, pts):
    return (bulb_ref if obj["kind"] == "mandelbulb" else box_ref)(obj, pts)


# -- bounds -----------------------------------------------------------------------------------------

def test_empirical_with_the_bounds_of_the_theorems():
    bulb = uc.describe(BULB)
    assert not bulb["exact"] and bulb["bound_radius"] == pytest.approx(2 ** (1 / 7))
    assert bulb["step_factor"] == 0.5  # guarded as the other empirical kinds
    julia = uc.describe(BULB_JULIA)
    assert julia["bound_radius"] == pytest.approx(ref.mandelbulb_radius(6.0, BULB_JULIA["julia_c"]))
    box = uc.describe(BOX)
    assert not box["exact"] and box["bound_radius"] == pytest.approx(6 * np.sqrt(3))  # Lowe's cube for s = 2
    assert uc.describe(dict(BOX, box_scale=3.0))["bound_radius"] == pytest.approx(
        np.sqrt(3) * ref.mandelbox_halfwidth(3.0, 1.0))
    assert uc.describe(BOX_JULIA)["bound_radius"] == pytest.approx(
        np.sqrt(3) * ref.mandelbox_halfwidth(2.5, 1.0, BOX_JULIA["julia_c"]))


@pytest.mark.parametrize("obj", [dict(kind="mandelbox", box_scale=s) for s in (1.5, -1.5, 0.9)]
                         + [dict(kind="mandelbox", min_radius=1.2)])
def test_mandelbox_settings_outside_the_theorems(obj):
    if abs(obj.get("box_scale", 2.0)) <= 1 or obj.get("min_radius", 0) > 1:
        with pytest.raises(ValueError):
            uc.describe(obj)
    else:
        assert uc.describe(obj)["bound_radius"] > 0


@pytest.mark.parametrize("name", list(FORMULA_OBJECTS))
def test_everything_outside_the_ball_escapes(name):
    """The set lies in the bounding ball: float64 orbits of points just outside it escape (this is
    the check of the Mandelbox cube for 1 < |s| <= 2, where scene.c has no proof), with 200
    iterations, and the float64 reference of points well inside finds members."""
    obj = FORMULA_OBJECTS[name]
    d = uc.describe(obj)
    rng = np.random.default_rng(3)
    u = rng.normal(size=(20000, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    outside = u * d["bound_radius"] * rng.uniform(1.0001, 1.05, (len(u), 1))
    fn = ref.mandelbulb if obj["kind"] == "mandelbulb" else ref.mandelbox
    args = ((obj.get("power", 8.0),) if obj["kind"] == "mandelbulb" else
            (obj.get("box_scale", 2.0), 1.0, 0.5, 1.0))
    c = obj.get("julia_c") if obj.get("julia_mode") else None
    _, _, escaped, _ = fn(outside, *args, 200, d["bailout"], c)
    assert escaped.all()
    # The escape radius is one: once past it, a float64 orbit never comes back (checked 30 steps on).
    inside = u * d["bound_radius"] * rng.uniform(0, 1, (len(u), 1))
    _, _, escaped, _ = fn(inside, *args, obj["max_iterations"], d["bailout"], c)
    assert (~escaped).sum() > 50


# -- the estimate against float64 ------------------------------------------------------------------

@pytest.mark.parametrize("name", list(FORMULA_OBJECTS))
def test_estimate_matches_float64(name):
    """The kernel's estimate (own float32 atan2, sincos, exp2, log) equals the float64 one within
    float32 rounding where it is not tiny; membership agrees but for boundary points."""
    obj = FORMULA_OBJECTS[name]
    d = uc.describe(obj)
    rng = np.random.default_rng(7)
    span = {"mandelbox": 7.0, "mandelbox_negative": 4.0}.get(name, d["bound_radius"])
    pts = (rng.uniform(-1, 1, (6000, 3)) * span).astype(np.float32)
    est, _, p64 = estimate(obj, pts)
    want = reference_estimate(obj, p64)
    big = want > 1e-3 * d["bound_radius"]
    assert big.sum() > 500 and (want == 0).sum() > 50
    np.testing.assert_allclose(est[big], want[big], rtol=2e-3)
    assert np.mean((est == 0) != (want == 0)) < 0.01


@pytest.mark.parametrize("power", [2.0, 3.0, 4.5, 8.0, 13.0])
def test_mandelbulb_powers(power):
    """Integer and fractional powers, larger angles for the sincos reduction."""
    obj = dict(kind="mandelbulb", power=power, max_iterations=8)
    d = uc.describe(obj)
    rng = np.random.default_rng(int(power * 10))
    pts = (rng.uniform(-1, 1, (4000, 3)) * d["bound_radius"]).astype(np.float32)
    est, _, p64 = estimate(obj, pts)
    want = bulb_ref(obj, p64)
    big = want > 1e-3
    assert big.sum() > 500
    np.testing.assert_allclose(est[big], want[big], rtol=3e-3)
    assert np.mean((est == 0) != (want == 0)) < 0.01


def test_power_8_julia_turned_by_an_eighth():
    """Turning a point by 2 pi / 8 about z turns its azimuth p by 2 pi / 8 and 8 p by 2 pi: the
    first iterate, and with c on the z axis the whole Julia-mode orbit, is unchanged."""
    obj = dict(kind="mandelbulb", julia_mode=True, julia_c=(0.0, 0.0, 0.3), max_iterations=10)
    rng = np.random.default_rng(1)
    pts = rng.uniform(-1, 1, (3000, 3))
    a = 2 * np.pi / 8
    turned = pts @ np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]]).T
    e0, _, _ = estimate(obj, pts)
    e1, _, _ = estimate(obj, turned)
    big = e0 > 1e-3
    np.testing.assert_allclose(e1[big], e0[big], rtol=3e-3)


@pytest.mark.parametrize("power", [2.0, 5.0, 8.0])
def test_whole_power_where_the_angles_degenerate(power):
    """Whole powers take de Moivre's path (bulb_step: no angles, the azimuth's cos and sin as x / rho
    and y / rho): on the z axis (rho = 0, azimuth 0), next to it down to rho = 1e-30 (rho^2 below
    float range), in the plane z = 0 and at the origin (r = 0) the estimate still matches float64's
    angles, and nothing is NaN."""
    obj = dict(kind="mandelbulb", power=power, max_iterations=10)
    d = uc.describe(obj)
    zs = np.linspace(-1.05, 1.05, 301) * d["bound_radius"]
    rng = np.random.default_rng(int(power))
    plane = rng.uniform(-1, 1, (2000, 2)) * d["bound_radius"]
    pts = np.concatenate([np.stack([0 * zs, 0 * zs, zs], 1), np.stack([0 * zs + 1e-30, 0 * zs - 1e-30, zs], 1),
                          np.stack([0 * zs + 1e-20, 0 * zs, zs], 1), np.stack([0 * zs, 0 * zs - 3e-7, zs], 1),
                          np.c_[plane, np.zeros(len(plane))], [[0.0, 0.0, 0.0]]])
    est, _, p64 = estimate(obj, pts)
    want = bulb_ref(obj, p64)
    assert np.isfinite(est).all() and est[-1] == 0.0 and want[-1] == 0.0
    big = want > 1e-3
    assert big.sum() > 400 and (want == 0).sum() > 100
    np.testing.assert_allclose(est[big], want[big], rtol=3e-3)
    assert np.mean((est == 0) != (want == 0)) < 0.01


# -- no ray passes through --------------------------------------------------------------------------

BULB_CAMERA = make_camera(32, 24, eye=(0.9, -2.4, 1.1), target=(0, 0, 0), fov_y=0.9)
BOX_CAMERA = make_camera(32, 24, eye=(5.0, -15.0, 7.0), target=(0, 0, 0), fov_y=0.9)


@functools.cache
def passthrough_reference(name, eps, sample):
    obj = FORMULA_OBJECTS[name]
    d = uc.describe(obj)
    cam = BULB_CAMERA if obj["kind"] == "mandelbulb" else BOX_CAMERA

    def classify(p):
        fn = ref.mandelbulb if obj["kind"] == "mandelbulb" else ref.mandelbox
        args = ((obj.get("power", 8.0),) if obj["kind"] == "mandelbulb" else
                (obj.get("box_scale", 2.0), 1.0, 0.5, 1.0))
        c = obj.get("julia_c") if obj.get("julia_mode") else None
        r, dr, escaped, _ = fn(p, *args, obj["max_iterations"], d["bailout"], c)
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            est = (0.5 * np.log(np.maximum(r, 1.0)) * r / dr) if obj["kind"] == "mandelbulb" else r / dr
        return ~escaped, ~escaped | (est < eps)

    return dense_sampling(cam, classify, (0, 0, 0), d["bound_radius"], sample)


PASSTHROUGH = {"mandelbulb": (2e-3, 5e-4), "mandelbulb_julia": (2e-3, 5e-4), "mandelbox": (1e-2, 2.5e-3),
               "mandelbox_negative": (1e-2, 2.5e-3)}


@pytest.mark.parametrize("bisection", [0, 10])
@pytest.mark.parametrize("name", list(PASSTHROUGH))
def test_no_ray_passes_through(name, bisection):
    """Dense float64 sampling along the core's own rays: every ray that meets a solid piece of the
    set (orbit bounded for max_iterations, 4 samples in a row) hits, never beyond it; the hits lie
    where the float64 estimate first drops below the fixed threshold for nearly every ray."""
    eps, sample = PASSTHROUGH[name]
    obj = dict(FORMULA_OBJECTS[name], threshold_mode="fixed", epsilon=eps, bisection_steps=bisection)
    cam = BULB_CAMERA if obj["kind"] == "mandelbulb" else BOX_CAMERA
    passes, _ = render(cam, [obj], ["alpha", "position"])
    t_solid, t_shell = passthrough_reference(name, eps, sample)
    check_no_passthrough(cam, passes, t_solid, t_shell, slack=eps, agree_tol=10 * eps, agree_fraction=0.95)


# -- every pass, both kernels, normals --------------------------------------------------------------

# Whole powers, even (8; 6 in Julia mode) and odd (5), take de Moivre's path, 7.5 the angles'.
BOTH_KERNELS = dict(FORMULA_OBJECTS, mandelbulb_5=dict(BULB, power=5.0), mandelbulb_7_5=dict(BULB, power=7.5))


@pytest.mark.parametrize("name", ["mandelbulb", "mandelbulb_5", "mandelbulb_7_5", "mandelbulb_julia", "mandelbox",
                                  "mandelbox_julia"])
def test_every_pass_both_kernels_bit_identical(name):
    """Every effect (soft shadows, reflections, AO, fog, glow, the sea, two samples): the AVX2 and
    the portable kernels give the same bytes in every pass, and threads and tiles do not matter."""
    obj = BOTH_KERNELS[name]
    eye = (0.9, -2.6, 1.2) if obj["kind"] == "mandelbulb" else (7.0, -22.0, 10.0)
    cam = make_camera(37, 29, eye=eye)
    shading = dict(HEAVY_SHADING, use_sea=False)
    if obj["kind"] == "mandelbox":
        shading = dict(shading, lights=[dict(type="sun", direction=(1.0, 0.5, -1.0), radius=0.05)])
    a, sa = render(cam, [dict(obj, reflectivity=0.3)], simd="portable", threads=1, shading=shading)
    for kernel in KERNELS[1:]:
        b, sb = render(cam, [dict(obj, reflectivity=0.3)], simd=kernel, threads=2, tile_size=7, shading=shading)
        for k in a:
            assert a[k].tobytes() == b[k].tobytes(), (k, kernel)
        assert sa["iterations"] == sb["iterations"], kernel
    for k in a:
        assert np.isfinite(a[k]).all(), k
    assert 0.1 < a["alpha"].mean() < 0.95
    hit = a["alpha"][..., 0] == 1
    assert (a["iterations"][hit] > 0).any() and (a["orbit_trap"][hit] > 0).all()


@pytest.mark.parametrize("name", ["mandelbulb", "mandelbox"])
@pytest.mark.parametrize("method", ["gradient_distance", "gradient_potential", "zbuffer", "analytic"])
def test_normals_are_unit_and_face_the_camera(name, method):
    obj = dict(FORMULA_OBJECTS[name], normal_method=method)
    eye = (0.9, -2.6, 1.2) if obj["kind"] == "mandelbulb" else (5.0, -16.0, 7.0)
    cam = make_camera(40, 30, eye=eye)
    p, _ = render(cam, [obj], ["alpha", "normal", "position"])
    hit = p["alpha"][..., 0] == 1
    n = p["normal"][hit]
    assert hit.sum() > 100
    np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-4)
    view = p["position"][hit] - np.asarray(eye)
    assert np.all(np.sum(n * view, axis=1) <= 1e-6)
    # Not all facing the viewer (the flat fallback): the gradient did its work.
    facing = -view / np.linalg.norm(view, axis=1, keepdims=True)
    assert np.mean(np.sum(n * facing, axis=1) > 0.999) < 0.5


def test_parameters_change_the_set():
    """Every new key reaches the kernel."""
    rng = np.random.default_rng(2)
    pts = rng.uniform(-1, 1, (2000, 3)).astype(np.float32)
    base, _, _ = estimate(BULB, pts)
    for change in (dict(power=7.0), dict(julia_mode=True, julia_c=(0.2, 0.1, 0.0))):
        assert not np.array_equal(estimate(dict(BULB, **change), pts)[0], base), change
    pts = pts * 4
    base, _, _ = estimate(BOX, pts)
    for change in (dict(box_scale=2.2), dict(box_fold=0.9), dict(min_radius=0.4), dict(fixed_radius=1.1),
                   dict(julia_mode=True, julia_c=(0.5, 0.1, 0.0))):
        assert not np.array_equal(estimate(dict(BOX, **change), pts)[0], base), change
