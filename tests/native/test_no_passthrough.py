"""No ray passes through the set. Along the same rays a dense float64 sampling finds where the
rays meet {d < eps}, the object the marcher renders (eq. 11, section 3.3). Every ray that meets it
must hit. A refined hit (bisection, the default) must lie at the first sample inside it. An
unrefined hit may land anywhere in the eps-shell, but not beyond the first piece of the object
that is solidly inside it (d < eps/2 somewhere in the piece): the unbounding-sphere argument
protects the set, not grazing slivers of its eps-shell, which float32 and float64 also see
differently. Solid, dendritic, disconnected and 4-component mu; two of them also through a thin
lens (depth of field: rays that start off the eye, across the lens)."""
import functools

import numpy as np
import pytest
import unbound_core as uc

from conftest import make_camera, render, skip_the_reference_when_sanitized
from reference import qjulia64 as ref

CASES = {
    "solid basilica": (-1.0, 0.0, 0.0, 0.0),
    "dendrite": (0.0, 1.0, 0.0, 0.0),
    "paper-like": (-0.2, 0.8, 0.0, 0.0),
    "disconnected": (0.3, 0.55, 0.0, 0.0),
    "general 4-D": (-0.3, 0.5, 0.25, -0.15),
}
EPS = 2e-3          # fixed threshold, object units
SAMPLE = 2.5e-4     # dense sampling step along each ray
SLACK = 1e-3        # float32 marching vs float64 sampling


def _end_of_first_solid_piece(ts, dist, inside):
    """t where the ray leaves the first run of {d < eps} samples that reaches d < eps/2."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], inside.astype(np.int8), [0]])))
    for start, stop in zip(edges[0::2], edges[1::2]):
        if dist[start:stop].min() < EPS / 2:
            return ts[stop] if stop < len(ts) else ts[-1]
    return np.inf


CAMERA = make_camera(28, 21, eye=(0.5, -2.6, 1.2), fov_y=1.0)
# Depth of field moves each ray's origin across the lens (up to 0.2 here, in a 2.9 distance):
# the bounding-ball clipping and the first step must hold for rays that do not start at the eye.
THIN_LENS = dict(CAMERA, aperture_size=0.2, focus_distance=2.3, aperture_blades=5, aperture_rotation=0.2)
ITERATIONS = 24


def pixel_ray(camera, x, y):
    """The ray render() traces for pixel (x, y) in its one sample (centre, and lens sample 0)."""
    lens = uc.lens_sample(0, x, y) if camera.get("aperture_size") else None
    return uc.camera_ray(camera, x + 0.5, y + 0.5, lens)


@functools.cache
def dense_reference(name, camera_name="pinhole"):
    """{(y, x): None (the ray misses the bounding ball) or (origin, t of the first dense sample in
    {d < eps}, t where its first solid piece ends)} for the rays that meet the ball and the set.
    The float64 sampling is the slow part: once per case, for both bisection settings."""
    skip_the_reference_when_sanitized()
    mu = CASES[name]
    radius = ref.bounding_radius(mu)
    camera = THIN_LENS if camera_name == "thin_lens" else CAMERA
    found = {}
    for y in range(CAMERA["height"]):
        origin, direction, t0, t1 = zip(*[pixel_ray(camera, x, y) for x in range(CAMERA["width"])])
        for x in range(CAMERA["width"]):
            o, d = np.array(origin[x]), np.array(direction[x])
            b = o @ d
            disc = b * b - (o @ o - radius * radius)
            if disc < 0:
                found[y, x] = None
                continue
            ts = np.arange(-b - np.sqrt(disc), -b + np.sqrt(disc), SAMPLE)
            dist, _ = ref.distance_estimate(ref.slice_points(o + ts[:, None] * d), mu, ITERATIONS, 4.0)
            inside = dist < EPS
            if inside.any():
                found[y, x] = (o, ts[int(np.argmax(inside))], _end_of_first_solid_piece(ts, dist, inside))
    return found


@pytest.mark.parametrize("name, bisection, camera_name",
                         [(name, bisection, "pinhole") for name in CASES for bisection in (0, 10)]
                         + [("dendrite", 0, "thin_lens"), ("general 4-D", 10, "thin_lens")])
def test_native_hit_not_beyond_first_dense_hit(name, bisection, camera_name):
    """With refinement off the marching alone is checked; with it on, the refined hit too."""
    obj = dict(mu=CASES[name], max_iterations=ITERATIONS, threshold_mode="fixed", epsilon=EPS,
               bisection_steps=bisection)
    passes, _ = render(THIN_LENS if camera_name == "thin_lens" else CAMERA, [obj], ["alpha", "position"])
    worst = []
    ref_hits = agree = solid_hits = 0
    for (y, x), hit in dense_reference(name, camera_name).items():
        if hit is None:
            assert passes["alpha"][y, x, 0] == 0
            continue
        o, t_ref, t_run_end = hit
        ref_hits += 1
        assert passes["alpha"][y, x, 0] == 1, f"ray ({x}, {y}) passed through the set at t={t_ref:.4f}"
        t_native = np.linalg.norm(passes["position"][y, x] - o)
        # Never in front of the object, never beyond the first piece of it.
        assert t_native > t_ref - SLACK - SAMPLE, f"ray ({x}, {y}) hit {t_ref - t_native:.5f} early"
        worst.append(t_native - (t_ref if bisection else t_run_end))
        solid_hits += np.isfinite(t_run_end)
        agree += abs(t_native - t_ref) < 0.01
    assert ref_hits > 20 and solid_hits > 20
    what = "first dense sample in {d < eps}" if bisection else "first piece of {d < eps}"
    assert max(worst) < SLACK + SAMPLE, f"native hit {max(worst):.5f} beyond the {what}"
    # And the hits are the same surface for nearly every ray (float32 vs float64 can disagree
    # where a ray grazes a thin feature).
    assert agree / ref_hits > 0.95


SUN_TOWARD = np.array([-0.8, 0.1, 0.3]) / np.linalg.norm([-0.8, 0.1, 0.3])


@pytest.mark.parametrize("name", ["dendrite", "paper-like", "general 4-D"])
def test_shadow_rays_do_not_pass_through_the_set(name):
    """Shadow rays march with over-relaxed steps (march.h, issue 21): the unbounding spheres of
    consecutive samples must overlap, so the set itself is never stepped over. From each hit,
    the float64 dense sampling follows the shadow ray (from the hit lifted 4 thresholds along the
    rendered normal, toward the sun, from 4 thresholds on: kernel.h's direct light): where it meets a solid piece of the set (d < eps/2) the pixel must be
    in shadow; where the ray stays 2 thresholds clear of the set it must be lit. Rays that only
    graze the eps-shell may go either way (as for camera rays, float32 and float64 see it
    differently, and a relaxed step may pass a sliver of the shell the plain one stopped on).
    It can fail: with steps of 6 times the plain one and the overlap check removed, a shadow ray
    of the paper-like set passed through it; with the check, none does."""
    mu = CASES[name]
    obj = dict(mu=mu, max_iterations=ITERATIONS, threshold_mode="fixed", epsilon=EPS)
    sun = dict(type="sun", direction=tuple(-SUN_TOWARD), color=(1.0, 1.0, 1.0))
    passes, _ = render(CAMERA, [obj], ["alpha", "position", "normal", "shadow"],
                       shading=dict(lights=[sun], shadows="hard", axle_light=0.0))
    skip_the_reference_when_sanitized()
    radius = ref.bounding_radius(mu)
    occluded = free = 0
    for y, x in zip(*np.nonzero(passes["alpha"][..., 0] == 1)):
        p = passes["position"][y, x].astype(np.float64)
        n = passes["normal"][y, x].astype(np.float64)
        if not n @ SUN_TOWARD > 0.05:  # facing away (or nearly): no shadow ray is marched
            continue
        o = p + 4 * EPS * n
        t_exit = -(o @ SUN_TOWARD) + np.sqrt(max((o @ SUN_TOWARD) ** 2 - (o @ o - radius * radius), 0.0))
        ts = np.arange(4 * EPS, t_exit, SAMPLE)  # as the core: t_min = the lift
        dist, _ = ref.distance_estimate(ref.slice_points(o + ts[:, None] * SUN_TOWARD), mu, ITERATIONS, 4.0)
        lit = passes["shadow"][y, x, 0]
        if (dist < EPS / 2).any():
            occluded += 1
            assert lit == 0.0, f"shadow ray of ({x}, {y}) passed through the set at t={ts[np.argmax(dist < EPS / 2)]:.4f}"
        elif dist.min() > 2 * EPS:
            free += 1
            assert lit == 1.0, f"shadow ray of ({x}, {y}) stopped though it stays {dist.min():.4f} clear of the set"
    assert occluded > 10 and free > 10, (occluded, free)
