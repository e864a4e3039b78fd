"""Deep zoom of the formula kinds (issue 22): the Mandelbulb (whole and fractional power), the
Mandelbox, the KIFS and the hybrid at p = anchor + 10^-zoom u, in double (native/src/zoom_formulas.c),
to zoom 10 (ZOOM_FORMULA_MAX).

References: reference/formulas64.py and reference/kifs64.py, float64 numpy written from the published
definitions (not the core's code). For each kind and zoom an anchor on the surface is found there by
bisection (the boundary of the set of points whose orbit stays bounded for the zoomed iteration count),
the camera looks at it from 3 local units, and along the core's own rays (uc.camera_ray) a float64
march of the reference estimate finds the first point within the threshold, and a dense float64
sampling between the eye and the hit finds no point of the set. Zoom 0 with anchor "0 0 0" is today's
float32 path, byte for byte: the golden hashes (test_golden_pixels.py) cover it."""
import functools

import numpy as np
import pytest

import unbound_core as uc
from conftest import KERNELS, make_camera, render, skip_the_reference_when_sanitized
from reference import formulas64 as f64
from reference import kifs64 as k64

SIERPINSKI_PLANES = [(1.0, 1.0, 0.0, 0.0), (1.0, 0.0, 1.0, 0.0), (0.0, 1.0, 1.0, 0.0)]
CASES = {
    "mandelbulb": dict(kind="mandelbulb", max_iterations=10),
    # A fractional power: the general path (atan2, sin, cos, pow), not de Moivre's.
    "mandelbulb_7.5": dict(kind="mandelbulb", power=7.5, max_iterations=10),
    "mandelbox": dict(kind="mandelbox", max_iterations=12),
    "kifs": dict(kind="kifs", kifs_planes=SIERPINSKI_PLANES, kifs_scale=2.0, kifs_offset=(1.0, 1.0, 1.0),
                 kifs_shape="tetrahedron", max_iterations=10),
    "hybrid": dict(kind="hybrid", hybrid_steps=[(0, 1), (1, 1)], max_iterations=10),
}
EPSILON = 1e-3      # fixed hit threshold, local units
EYE = np.array([0.4, -3.0, 0.9])
# The anchor's ray: from -EYE toward the origin; for the Sierpinski tetrahedron, whose level sets are
# dust-like, along the x axis, the one direction in which every level set's shadow is the full square
# [-1, 1]^2 (the axis through the midpoints of two opposite edges), so that the view is mostly surface.
AIM = {"kifs": np.array([0.0, 0.3, 0.2])}
DIRECTION = {"kifs": np.array([-1.0, 0.0, 0.0])}
SIDE = np.array([0.6, 0.8, 0.0])  # the camera looks 0.3 local units beside the anchor, this way


def zoomed(name, zoom, anchor_text="0 0 0", **extra):
    return dict(CASES[name], zoom=float(zoom), zoom_anchor=anchor_text, threshold_mode="fixed", epsilon=EPSILON,
                **extra)


def kifs_planes_as_read(planes):
    """The planes as the kernels read them: normalised in double, rounded to float32 (the reference
    takes them as given: normalize=False)."""
    out = []
    for plane in planes:
        plane = np.asarray(plane, np.float64)
        out.append(np.float32(plane / np.linalg.norm(plane[:3])).astype(np.float64))
    return out


def reference(name, iterations, bailout, points):
    """(estimate in fractal units, member: the orbit stays bounded / inside the level-n set)."""
    obj = CASES[name]
    if obj["kind"] == "mandelbulb":
        r, dr, escaped, _ = f64.mandelbulb(points, obj.get("power", 8.0), iterations, bailout)
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            est = np.where(escaped, 0.5 * np.log(np.maximum(r, 1.0)) * r / dr, 0.0)
        return est, ~escaped
    if obj["kind"] == "mandelbox":
        r, dr, escaped, _ = f64.mandelbox(points, 2.0, 1.0, 0.5, 1.0, iterations, bailout)
        return np.where(escaped, r / dr, 0.0), ~escaped
    if obj["kind"] == "kifs":
        est, inside, _ = k64.kifs(points, kifs_planes_as_read(obj["kifs_planes"]), obj["kifs_scale"],
                                  obj["kifs_offset"], None, obj["kifs_shape"], 1.0, iterations, bailout,
                                  normalize=False)
        return est, inside
    est, escaped = k64.hybrid(points, obj["hybrid_steps"], iterations, bailout)
    return est, ~escaped


def derived(name, zoom):
    """The core's iteration count at this zoom and its escape radius."""
    d = uc.describe(zoomed(name, zoom, "0 0 1"))
    return d["max_iterations"], d["bailout"]


@functools.cache
def surface_anchor(name, zoom):
    """A point within 10^-(zoom + 5) of the set (by the reference estimate: 10^-5 local units) on the
    ray from far outside toward the origin along -EYE, found by a float64 march of the reference
    estimate at half steps; as text and float64, and the ray's direction."""
    iterations, bailout = derived(name, zoom)
    direction = DIRECTION.get(name, -EYE / np.linalg.norm(EYE))
    radius = uc.describe(CASES[name])["bound_radius"]
    point = AIM.get(name, 0.0) - direction * (radius + 0.1)
    for _ in range(100000):
        est = reference(name, iterations, bailout, point[None])[0][0]
        if est < 10.0 ** -(zoom + 5):
            break
        point = point + 0.5 * est * direction
    assert est < 10.0 ** -(zoom + 5) and np.linalg.norm(point) < radius + 0.2, "the ray misses the set"
    return "%.17g %.17g %.17g" % tuple(point), point, direction


def view(direction, width=20, height=15, eye_scale=1.0, center=(0.0, 0.0, 0.0), clip=(0.1, 100.0)):
    """The camera 3 local units back along the anchor's ray, looking a little beside the anchor;
    eye_scale and center place the same view in other units."""
    center = np.asarray(center)
    eye = center - 3.0 * eye_scale * direction
    target = center + 0.3 * eye_scale * SIDE
    return make_camera(width, height, eye=tuple(eye), target=tuple(target), clip=clip)


def core_rays(camera):
    h, w = camera["height"], camera["width"]
    origin, direction = np.empty((h, w, 3)), np.empty((h, w, 3))
    for y in range(h):
        for x in range(w):
            origin[y, x], direction[y, x] = uc.camera_ray(camera, x + 0.5, y + 0.5)[:2]
    return origin.reshape(-1, 3), direction.reshape(-1, 3)


def reference_march(name, zoom, anchor, origin, direction, t_max=20.0):
    """Float64 sphere tracing of the reference estimate (local units: fractal / 10^-zoom) at half
    steps (the empirical kinds' safety), the hit refined by bisection between the last two samples
    (as the core's): t of the first point within EPSILON, inf where none."""
    iterations, bailout = derived(name, zoom)
    scale = 10.0 ** -zoom

    def estimate(idx, t):
        local = origin[idx] + t[:, None] * direction[idx]
        return reference(name, iterations, bailout, anchor + scale * local)[0] / scale

    t, before = np.zeros(len(origin)), np.zeros(len(origin))
    hit = np.zeros(len(origin), bool)
    active = np.ones(len(origin), bool)
    for _ in range(20000):
        idx = np.flatnonzero(active)
        if not len(idx):
            break
        est = estimate(idx, t[idx])
        done = est < EPSILON
        hit[idx[done]] = True
        active[idx[done]] = False
        step = idx[~done]
        before[step] = t[step]
        t[step] += 0.5 * est[~done]
        active &= t < t_max
    idx = np.flatnonzero(hit)
    lo, hi = before[idx], t[idx]
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        inside = estimate(idx, mid) < EPSILON
        lo, hi = np.where(inside, lo, mid), np.where(inside, mid, hi)
    out = np.full(len(origin), np.inf)
    out[idx] = hi
    return out


def first_member(name, zoom, anchor, origin, direction, t_end, sample):
    """Dense float64 sampling of each ray from the eye to t_end: t of the first point of the set
    (its orbit bounded), inf where none."""
    iterations, bailout = derived(name, zoom)
    scale = 10.0 ** -zoom
    found = np.full(len(origin), np.inf)
    for i in range(len(origin)):
        ts = np.arange(0.0, t_end[i], sample)
        member = reference(name, iterations, bailout, anchor + scale * (origin[i] + ts[:, None] * direction[i]))[1]
        if member.any():
            found[i] = ts[np.argmax(member)]
    return found


# The march tolerance: where both hit, within EPSILON of each other (the threshold the two stop at; the
# core refines its hit by bisection, the reference approaches by half steps). A few rays may differ
# more where the empirical estimates jump (the escape count changes along the ray) or where a ray grazes
# a thin piece, its estimate dipping below EPSILON over a stretch shorter than a step, which one march
# lands in and the other steps over (the KIFS's level sets are dust: up to 4 % of the rays at zoom 8;
# the dense sampling below shows that no such ray passes through the set itself): at most GRAZING of
# them, hit or coverage.
GRAZING = 0.05
# A hit may lie past the first point of the set by its bisection's last interval: where the level-n
# set's boundary is a jump of the empirical estimate (to 0 from a fraction of a unit), the march's last
# step there (half the estimate) over 2^10 bisections; the threshold bounds it (as SLACK in
# test_no_passthrough.py: a fraction of its EPS).
PASS_SLACK = EPSILON


@pytest.mark.parametrize("zoom", [4, 8])
@pytest.mark.parametrize("name", list(CASES))
def test_depth_agrees_with_the_reference_and_nothing_is_passed(name, zoom):
    text, anchor, direction = surface_anchor(name, zoom)
    camera = view(direction)
    passes, _ = render(camera, [zoomed(name, zoom, text)], names=["alpha", "position"])
    skip_the_reference_when_sanitized()
    origin, dirs = core_rays(camera)
    hit = passes["alpha"][..., 0].reshape(-1) == 1.0
    t_core = np.where(hit, np.linalg.norm(passes["position"].reshape(-1, 3) - origin, axis=-1), np.inf)
    t_ref = reference_march(name, zoom, anchor, origin, dirs)
    both = hit & np.isfinite(t_ref)
    assert both.sum() >= 0.3 * len(hit), both.sum()
    coverage = np.mean(hit != np.isfinite(t_ref))
    print("core only %d, reference only %d" % (np.sum(hit & ~np.isfinite(t_ref)), np.sum(~hit & np.isfinite(t_ref))))
    error = np.abs(t_core - t_ref)[both]
    far = np.mean(error > EPSILON)
    print("%s zoom %d: %d hits, coverage differs %.3f, |t - t_ref| median %.2g max %.2g, beyond eps %.3f"
          % (name, zoom, both.sum(), coverage, np.median(error), error.max(), far))
    assert coverage <= GRAZING and far <= GRAZING
    assert np.median(error) <= 0.1 * EPSILON
    # No ray passes through the set: between the eye and the hit (to 10 units for a miss) the dense
    # float64 sampling finds no point of it.
    sample = 0.5 * EPSILON
    t_end = np.where(hit, t_core - PASS_SLACK, 10.0)
    found = first_member(name, zoom, anchor, origin, dirs, t_end, sample)
    passed = np.isfinite(found)
    assert not passed.any(), "%s zoom %d: %d rays pass through the set, e.g. ray %d at t = %.5f (hit %.5f)" % (
        name, zoom, passed.sum(), np.argmax(passed), found[np.argmax(passed)], t_core[np.argmax(passed)])


@pytest.mark.parametrize("name", list(CASES))
def test_no_pop_from_float32_to_double(name):
    """Zoom 1 (the double path) against zoom 0 (float32) with the camera flown in by 10 toward the
    anchor and the threshold 10 times finer: the same view, the same iteration count. Coverage
    and depth agree."""
    text, anchor, direction = surface_anchor(name, 1)
    iterations, _ = derived(name, 1)
    camera = view(direction, 32, 24)
    passes, _ = render(camera, [zoomed(name, 1, text)], names=["alpha", "depth"])
    flown = view(direction, 32, 24, eye_scale=0.1, center=anchor, clip=(0.01, 10.0))
    flat = dict(CASES[name], max_iterations=iterations, threshold_mode="fixed", epsilon=0.1 * EPSILON)
    passes0, _ = render(flown, [flat], names=["alpha", "depth"])
    hit, hit0 = passes["alpha"][..., 0] == 1.0, passes0["alpha"][..., 0] == 1.0
    both = hit & hit0
    assert both.sum() >= 0.3 * hit.size
    depth, depth0 = passes["depth"][..., 0].astype(np.float64), 10.0 * passes0["depth"][..., 0].astype(np.float64)
    error = np.abs(depth - depth0)[both]
    print("%s: coverage differs %.4f, depth error median %.2g 99%% %.2g max %.2g (local units)"
          % (name, np.mean(hit != hit0), np.median(error), np.percentile(error, 99), error.max()))
    assert np.mean(hit != hit0) <= 0.01
    assert np.median(error) <= 0.01 * EPSILON and np.mean(error > EPSILON) <= 0.01


@pytest.mark.parametrize("name", list(CASES))
def test_every_kernel_and_thread_count_gives_the_same_bytes(name):
    text, _, direction = surface_anchor(name, 8)
    camera = view(direction, 24, 18)
    obj = dict(zoomed(name, 8, text), threshold_mode="pixel", reflectivity=0.3)
    shading = dict(shadows="hard", ao_strength=0.5, ao_samples=2,
                   lights=[dict(type="sun", direction=(0.3, 0.5, -1.0))])
    runs = [render(camera, [obj], names=["combined", "depth", "normal"], simd=simd, threads=threads,
                   shading=shading)[0]
            for simd in KERNELS for threads in (1, 3)]
    assert np.mean(runs[0]["depth"] < 1e9) > 0.3
    for other in runs[1:]:
        for key in ("combined", "depth", "normal"):
            assert runs[0][key].tobytes() == other[key].tobytes(), key


@pytest.mark.parametrize("name", list(CASES))
def test_zoom_past_the_double_limit_is_refused(name):
    camera = make_camera(8, 6)
    assert uc.ZOOM_FORMULA_MAX == 10.0
    render(camera, [dict(CASES[name], zoom=10.0, zoom_anchor="0 0 1")], names=["alpha"])  # the limit itself
    with pytest.raises(ValueError, match="zoom to 10 at most") as info:
        render(camera, [dict(CASES[name], zoom=10.5, zoom_anchor="0 0 1")], names=["alpha"])
    assert "double precision" in str(info.value) and "quaternion" in str(info.value)


@pytest.mark.parametrize("kind", ["julia_stack", "cubic_locus", "ifs"])
def test_kinds_without_zoom_say_which_zoom(kind):
    with pytest.raises(ValueError, match="Julia stacks, the cubic locus and IFS take no zoom"):
        render(make_camera(8, 6), [dict(kind=kind, zoom=2.0)], names=["alpha"])


def test_iterations_follow_each_formulas_growth():
    """max_iterations + ceil(zoom ln 10 / ln g): g = sqrt(power) for the Mandelbulb, the scale 2 for the
    Mandelbox and KIFS, the geometric mean sqrt(sqrt 8 * 2) per step for the hybrid's one-and-one cycle."""
    grow = {"mandelbulb": 0.5 * np.log(8.0), "mandelbulb_7.5": 0.5 * np.log(7.5), "mandelbox": np.log(2.0),
            "kifs": np.log(2.0), "hybrid": 0.5 * (0.5 * np.log(8.0) + np.log(2.0))}
    for name, log_g in grow.items():
        for zoom in (0.5, 4.0, 10.0):
            expected = CASES[name]["max_iterations"] + int(np.ceil(zoom * np.log(10.0) / log_g))
            assert uc.describe(zoomed(name, zoom, "0 0 1"))["max_iterations"] == expected, (name, zoom)
