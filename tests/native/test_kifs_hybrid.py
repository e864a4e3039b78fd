"""Issue 22: kinds "kifs" (kaleidoscopic IFS, exact) and "hybrid" (empirical).

References: reference/kifs64.py, float64 numpy written from Knighty's formulation (and, for the
three classic shapes, from his own code with swaps and translations instead of plane folds);
dense float64 sampling along the core's own rays for the no-pass-through checks."""
import functools

import numpy as np
import pytest
import unbound_core as uc

from conftest import KERNELS, HEAVY_SHADING, check_no_passthrough, dense_sampling, estimate, make_camera, render
from reference import kifs64 as ref

MENGER_PLANES = [(1, 0, 0, 0), (0, 1, 0, 0), (0, 0, 1, 0), (1, -1, 0, 0), (1, 0, -1, 0), (0, 1, -1, 0),
                 (0, 0, 1, 1 / 3)]
SIERPINSKI_PLANES = [(1, 1, 0, 0), (1, 0, 1, 0), (0, 1, 1, 0)]
OCTAHEDRAL_PLANES = [(1, 1, 0, 0), (1, 0, 1, 0), (1, -1, 0, 0), (1, 0, -1, 0)]
MENGER = dict(kind="kifs", kifs_planes=MENGER_PLANES, kifs_scale=3.0, kifs_offset=(1, 1, 1), kifs_shape="box",
              max_iterations=5)
SIERPINSKI = dict(kind="kifs", kifs_planes=SIERPINSKI_PLANES, kifs_scale=2.0, kifs_offset=(1, 1, 1),
                  kifs_shape="tetrahedron", max_iterations=8)
OCTAHEDRAL = dict(kind="kifs", kifs_planes=OCTAHEDRAL_PLANES, kifs_scale=2.0, kifs_offset=(1, 0, 0),
                  kifs_shape="octahedron", max_iterations=8)
# User-defined: offset planes (one with d < 0, which widens the ball), a rotation, a sphere.
TWISTED = dict(kind="kifs", kifs_planes=[(1, 0, 0, 0), (0, 1, 0, 0), (1, -1, 0.3, 0), (0, 0, 1, -0.1)],
               kifs_scale=2.2, kifs_offset=(1.0, 0.6, 0.4), kifs_rotation=(0.3, -0.2, 0.5), kifs_shape="sphere",
               kifs_size=0.8, max_iterations=7)
KIFS_OBJECTS = {"menger": MENGER, "sierpinski": SIERPINSKI, "octahedral": OCTAHEDRAL, "twisted": TWISTED}
KNIGHTY = {"menger": ref.menger_knighty, "sierpinski": ref.sierpinski_knighty, "octahedral": ref.octahedral_knighty}

HYBRID = dict(kind="hybrid", hybrid_steps=[(0, 1), (1, 1)], box_fold=1 / 6, min_radius=1 / 12, fixed_radius=1 / 6,
              max_iterations=10)
HYBRID_KIFS = dict(kind="hybrid", hybrid_steps=[(2, 2), (1, 1)], box_scale=2.0, box_fold=0.5, min_radius=0.25,
                   fixed_radius=0.5, max_iterations=12)
HYBRID_OBJECTS = {"bulb_box": HYBRID, "kifs_box": HYBRID_KIFS}


def kifs_args(obj):
    return (obj.get("kifs_planes", SIERPINSKI_PLANES), obj.get("kifs_scale", 2.0), obj.get("kifs_offset", (1, 1, 1)),
            obj.get("kifs_rotation"), obj.get("kifs_shape", "tetrahedron"), obj.get("kifs_size", 1.0))


def kifs_ref(obj, pts):
    return ref.kifs(pts, *kifs_args(obj), obj["max_iterations"], uc.describe(obj)["bailout"])


def hybrid_ref(obj, pts):
    d = uc.describe(obj)
    return ref.hybrid(pts, obj["hybrid_steps"], obj["max_iterations"], d["bailout"],
                      obj.get("julia_c") if obj.get("julia_mode") else None, obj.get("power", 8.0),
                      (obj.get("box_scale", 2.0), obj.get("box_fold", 1.0), obj.get("min_radius", 0.5),
                       obj.get("fixed_radius", 1.0)),
                      (obj.get("kifs_planes", SIERPINSKI_PLANES), obj.get("kifs_scale", 2.0),
                       obj.get("kifs_offset", (1, 1, 1)), obj.get("kifs_rotation")))


# -- bounds and exactness ---------------------------------------------------------------------------

def test_kifs_exact_with_the_proven_ball():
    for name, obj in KIFS_OBJECTS.items():
        d = uc.describe(obj)
        assert d["exact"] and d["step_factor"] == 1.0, name
        assert d["bound_radius"] == pytest.approx(ref.kifs_rho(*[kifs_args(obj)[i] for i in (0, 1, 2, 4, 5)])), name
    # d >= 0 planes never shorten z: the Menger sponge's ball is its box's, sqrt 3.
    assert uc.describe(MENGER)["bound_radius"] == pytest.approx(np.sqrt(3))
    # The twisted set's d = -0.1 plane widens it: (2.2 * 0.2 + |o| 1.2) / 1.2.
    assert uc.describe(TWISTED)["bound_radius"] == pytest.approx((2.2 * 0.2 + np.linalg.norm((1, .6, .4)) * 1.2) / 1.2)


def test_hybrid_empirical():
    d = uc.describe(HYBRID)
    assert not d["exact"] and d["step_factor"] == 0.5


@pytest.mark.parametrize("bad", [dict(kind="kifs", kifs_scale=1.0), dict(kind="kifs", kifs_planes=[(0, 0, 0, 1)]),
                                 dict(kind="hybrid", hybrid_steps=[(3, 1)]), dict(kind="hybrid", hybrid_steps=[(0, 0)]),
                                 dict(kind="hybrid", hybrid_steps=[(0.5, 1)]),
                                 dict(kind="hybrid", hybrid_steps=[(1, 1)], box_scale=0.5)])
def test_settings_outside_the_theorems_are_refused(bad):
    with pytest.raises(ValueError):
        uc.describe(bad)


@pytest.mark.parametrize("name", list(KIFS_OBJECTS))
def test_kifs_set_lies_in_the_ball(name):
    """Float64 points just outside the ball are outside every level's set, with 40 levels, and
    their orbits escape; points inside find members."""
    obj = KIFS_OBJECTS[name]
    d = uc.describe(obj)
    rng = np.random.default_rng(3)
    u = rng.normal(size=(20000, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    outside = u * d["bound_radius"] * rng.uniform(1.0001, 1.05, (len(u), 1))
    est, member, _ = ref.kifs(outside, *kifs_args(obj), 40, d["bailout"])
    assert not member.any() and (est > 0).all()
    inside = u * d["bound_radius"] * rng.uniform(0, 1, (len(u), 1))
    assert ref.kifs(inside, *kifs_args(obj), obj["max_iterations"], d["bailout"])[1].sum() > 5  # the Sierpinski level 8 keeps 2^-8 of its volume


@pytest.mark.parametrize("name", list(HYBRID_OBJECTS))
def test_hybrid_escapes_outside_its_ball(name):
    """No proof for a mixture: float64 orbits of points just outside the ball all escape (200 steps)."""
    obj = HYBRID_OBJECTS[name]
    d = uc.describe(obj)
    rng = np.random.default_rng(4)
    u = rng.normal(size=(20000, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    _, escaped = hybrid_ref(dict(obj, max_iterations=200), u * d["bound_radius"] * rng.uniform(1.0001, 1.05, (len(u), 1)))
    assert escaped.all()


# -- the estimate: a true lower bound, and the core against float64 --------------------------------

@pytest.mark.parametrize("name", list(KNIGHTY))
def test_plane_lists_are_knightys_shapes(name):
    """The generic plane-fold reference equals Knighty's own code (swaps, translation) for the
    three classic shapes: the presets' plane lists are his folds."""
    obj = KIFS_OBJECTS[name]
    pts = np.random.default_rng(5).uniform(-2, 2, (20000, 3))
    np.testing.assert_allclose(kifs_ref(obj, pts)[0], KNIGHTY[name](pts, obj["max_iterations"]), atol=1e-12)


@pytest.mark.parametrize("name", list(KIFS_OBJECTS))
def test_kifs_estimate_is_a_lower_bound(name):
    """The exactness argument, checked: the float64 estimate at p never exceeds the distance to
    the nearest of many float64 members of the level-n set (p's estimate is a lower bound of
    the distance to every member). Where no orbit escapes, it is 1-Lipschitz as well (an escaped
    orbit's ball bound is a lower bound too, but a different function)."""
    obj = KIFS_OBJECTS[name]
    d = uc.describe(obj)
    rng = np.random.default_rng(6)
    cloud = rng.uniform(-1, 1, (400000, 3)) * d["bound_radius"]
    members = cloud[kifs_ref(obj, cloud)[1]]
    assert len(members) > 50
    probe = rng.uniform(-1, 1, (3000, 3)) * d["bound_radius"] * 1.2
    est = kifs_ref(obj, probe)[0]
    nearest = np.array([np.min(np.linalg.norm(members - q, axis=1)) for q in probe])
    assert np.all(est <= nearest + 1e-12)
    q = probe + rng.normal(size=probe.shape) * 0.05
    a = ref.kifs(probe, *kifs_args(obj), obj["max_iterations"], 1e300)[0]
    b = ref.kifs(q, *kifs_args(obj), obj["max_iterations"], 1e300)[0]
    assert np.all(np.abs(a - b) <= np.linalg.norm(q - probe, axis=1) + 1e-9)


@pytest.mark.parametrize("name", list(KIFS_OBJECTS))
def test_kifs_estimate_matches_float64(name):
    obj = KIFS_OBJECTS[name]
    d = uc.describe(obj)
    pts = (np.random.default_rng(7).uniform(-1, 1, (6000, 3)) * d["bound_radius"] * 1.1).astype(np.float32)
    est, _, p64 = estimate(obj, pts)
    want = kifs_ref(obj, p64)[0]
    big = np.abs(want) > 1e-3
    assert big.sum() > 3000
    np.testing.assert_allclose(est[big], want[big], rtol=1e-4, atol=2e-6)
    assert np.mean((est <= 0) != (want <= 0)) < 0.01


@pytest.mark.parametrize("name", list(HYBRID_OBJECTS))
def test_hybrid_estimate_matches_float64(name):
    obj = HYBRID_OBJECTS[name]
    d = uc.describe(obj)
    pts = (np.random.default_rng(8).uniform(-1, 1, (6000, 3)) * d["bound_radius"] * 0.6).astype(np.float32)
    est, _, p64 = estimate(obj, pts)
    want = hybrid_ref(obj, p64)[0]
    big = want > 1e-3 * d["bound_radius"]
    assert big.sum() > 500 and (want == 0).sum() > 10
    np.testing.assert_allclose(est[big], want[big], rtol=3e-3)
    assert np.mean((est == 0) != (want == 0)) < 0.02


# -- no ray passes through --------------------------------------------------------------------------

CAMERAS = {"kifs": make_camera(32, 24, eye=(2.0, -4.6, 2.4), target=(0, 0, 0), fov_y=0.9),
           "bulb_box": make_camera(32, 24, eye=(1.2, -3.0, 1.4), target=(0, 0, 0), fov_y=0.9),
           "kifs_box": make_camera(32, 24, eye=(2.5, -6.0, 3.0), target=(0, 0, 0), fov_y=0.9)}
ALL = dict(KIFS_OBJECTS, **HYBRID_OBJECTS)


def camera_of(name):
    return CAMERAS.get(name, CAMERAS["kifs"])


@functools.cache
def passthrough_reference(name, eps, sample):
    obj = ALL[name]
    d = uc.describe(obj)

    def classify(p):
        if obj["kind"] == "kifs":
            est, member, _ = kifs_ref(obj, p)
            return member, est < eps
        est, escaped = hybrid_ref(obj, p)
        return ~escaped, ~escaped | (est < eps)

    return dense_sampling(camera_of(name), classify, (0, 0, 0), d["bound_radius"], sample)


PASSTHROUGH = {"menger": (2e-3, 5e-4), "sierpinski": (2e-3, 5e-4), "octahedral": (2e-3, 5e-4),
               "twisted": (2e-3, 5e-4), "bulb_box": (2e-3, 5e-4), "kifs_box": (4e-3, 1e-3)}


@pytest.mark.parametrize("bisection", [0, 10])
@pytest.mark.parametrize("name", list(PASSTHROUGH))
def test_no_ray_passes_through(name, bisection):
    eps, sample = PASSTHROUGH[name]
    obj = dict(ALL[name], threshold_mode="fixed", epsilon=eps, bisection_steps=bisection)
    cam = camera_of(name)
    passes, _ = render(cam, [obj], ["alpha", "position"])
    t_solid, t_shell = passthrough_reference(name, eps, sample)
    check_no_passthrough(cam, passes, t_solid, t_shell, slack=eps, agree_tol=10 * eps, agree_fraction=0.95)


# -- every pass, both kernels, normals --------------------------------------------------------------

@pytest.mark.parametrize("name", ["menger", "twisted", "bulb_box", "kifs_box"])
def test_every_pass_both_kernels_bit_identical(name):
    obj = ALL[name]
    cam = make_camera(37, 29, eye=tuple(1.2 * np.asarray(camera_of(name)["matrix"])[:3, 3]))
    shading = dict(HEAVY_SHADING, use_sea=False)
    a, sa = render(cam, [dict(obj, reflectivity=0.3)], simd="portable", threads=1, shading=shading)
    for kernel in KERNELS[1:]:
        b, sb = render(cam, [dict(obj, reflectivity=0.3)], simd=kernel, threads=2, tile_size=7, shading=shading)
        for k in a:
            assert a[k].tobytes() == b[k].tobytes(), (k, kernel)
        assert sa["iterations"] == sb["iterations"], kernel
    for k in a:
        assert np.isfinite(a[k]).all(), k
    assert 0.05 < a["alpha"].mean() < 0.95
    hit = a["alpha"][..., 0] == 1
    assert (a["iterations"][hit] > 0).any()


@pytest.mark.parametrize("name", ["menger", "sierpinski", "bulb_box"])
@pytest.mark.parametrize("method", ["gradient_distance", "gradient_potential", "zbuffer", "analytic"])
def test_normals_are_unit_and_face_the_camera(name, method):
    obj = dict(ALL[name], normal_method=method)
    eye = tuple(np.asarray(camera_of(name)["matrix"])[:3, 3])
    cam = make_camera(40, 30, eye=eye)
    p, _ = render(cam, [obj], ["alpha", "normal", "position"])
    hit = p["alpha"][..., 0] == 1
    n = p["normal"][hit]
    assert hit.sum() > 100
    np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-4)
    view = p["position"][hit] - np.asarray(eye)
    assert np.all(np.sum(n * view, axis=1) <= 1e-6)
    facing = -view / np.linalg.norm(view, axis=1, keepdims=True)
    assert np.mean(np.sum(n * facing, axis=1) > 0.999) < 0.5


def test_parameters_change_the_set():
    pts = np.random.default_rng(2).uniform(-1.5, 1.5, (2000, 3)).astype(np.float32)
    base, _, _ = estimate(TWISTED, pts)
    for change in (dict(kifs_scale=2.3), dict(kifs_offset=(1.0, 0.5, 0.4)), dict(kifs_rotation=(0.3, -0.2, 0.6)),
                   dict(kifs_shape="box"), dict(kifs_size=0.7), dict(kifs_planes=MENGER_PLANES)):
        assert not np.array_equal(estimate(dict(TWISTED, **change), pts)[0], base), change
    base, _, _ = estimate(HYBRID, pts)
    for change in (dict(hybrid_steps=[(0, 2), (1, 1)]), dict(power=7.0), dict(box_scale=2.2),
                   dict(julia_mode=True, julia_c=(0.2, 0.1, 0.0))):
        assert not np.array_equal(estimate(dict(HYBRID, **change), pts)[0], base), change
