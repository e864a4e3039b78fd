"""Fixtures for the native core's tests: cameras, pass buffers, float64 rays.

The native module under test is the installed wheel (`unbound_core`); the float64 references
come from reference/ at the repository root."""
import os
import pathlib
import sys
import time

import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
# The wheel `make wheel` built, unpacked (the tests run the real compiled module), or the
# sanitizer build of tools/sanitize.sh, which names itself in UNBOUND_CORE_PATH.
sys.path.insert(0, os.environ.get("UNBOUND_CORE_PATH") or str(ROOT / "build" / "wheel"))
# Under ASan/UBSan the core runs several times slower: timing checks are skipped there.
SANITIZED = bool(os.environ.get("UNBOUND_SANITIZED"))
# Under qemu-user (tools/foreign.py linux-arm64) every instruction is emulated, ~10x slower and
# unevenly so: wall-clock latencies say nothing about the core there.
EMULATED = bool(os.environ.get("UNBOUND_EMULATED"))
TIMING_UNRELIABLE = SANITIZED or EMULATED
# Run on another platform's Python (tools/foreign.py: wine or qemu).
FOREIGN = bool(os.environ.get("UNBOUND_FOREIGN"))

# The files whose time goes into checking the geometry and the light against references (float64
# and arbitrary-precision: dense sampling along rays, certified distances, referees; converged Monte
# Carlo against the white furnace), not into what a platform changes. `pytest tests/native
# --platform-checks` leaves them out: the runs on another platform or Python (tools/foreign.py under
# qemu and wine, the Python 3.13 chroot), where they would check again what the x86-64 run checked,
# at 10-20x its cost under qemu. There the core's bits are held to x86-64's by test_golden_pixels.py
# and test_platform_pixels.py, which render what these files test (every kind and formula, deep
# zoom, GI): a platform that gives x86-64's bits passes them too. What stays is what a platform can
# change: the bits, the math library's vectors, the C API and its refusals, threads, cancel,
# progress, memory.
REFERENCE_FILES = ("test_mesh.py", "test_deep_zoom.py", "test_deep_zoom_formulas.py", "test_no_passthrough.py",
                   "test_ifs.py", "test_step_bound.py", "test_mandelbrot.py", "test_cubic_locus.py",
                   "test_formulas.py", "test_kifs_hybrid.py", "test_march_limits.py", "test_julia_stack.py",
                   "test_gi.py")


def pytest_addoption(parser):
    parser.addoption("--platform-checks", action="store_true",
                     help="leave out REFERENCE_FILES (another platform's or Python's run; see conftest.py)")


def pytest_ignore_collect(collection_path, config):
    if collection_path.name in REFERENCE_FILES and config.getoption("--platform-checks", default=False):
        return True
    return None

import unbound_core as uc  # noqa: E402  (the paths above first)

# The kernels this CPU runs, narrowest first: every one must give the same bits (the farm promise).
KERNELS = ["portable"] + (["avx2"] if uc.cpu_info()["avx2_fma"] else []) + \
    (["avx512"] if uc.cpu_info()["avx512"] else [])

# Cancel latency (issue 16, defects 2 and 8). The promise: a render stops within CANCEL_BUDGET_S of a
# cancel on a quiet core. What the tests measure is the work done after the cancel: this process's
# CPU time from the cancel to render() returning (every render thread's, summed: never less than
# the slowest thread's), which does not grow when other processes share the machine, and holds
# it to the budget. Wall time measures the same work plus the time the scheduler gave to others:
# on a loaded 2-core machine it is held only to CANCEL_WALL_S, which catches work that is not
# bounded at all (seconds) without failing because four agents share two cores. Latency tests
# skip under the sanitizers, which slow the core several-fold by design.
CANCEL_BUDGET_S = 0.1
CANCEL_WALL_S = 1.0


class CancelClock:
    """Marks the cancel (wall and process CPU time) and measures from it to render()'s return."""

    def __init__(self):
        self.wall = self.cpu = None

    def mark(self):
        if self.wall is None:
            self.wall, self.cpu = time.perf_counter(), time.process_time()

    @property
    def marked(self):
        return self.wall is not None

    def latency(self):
        return time.perf_counter() - self.wall, time.process_time() - self.cpu


def assert_cancel_latencies(latencies, what=""):
    """latencies: (wall, cpu) seconds from the cancel to render()'s return."""
    text = "%s cancel latencies (ms, wall/cpu, load %.2f): %s" % (
        what, os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan"), ", ".join("%.1f/%.1f" % (w * 1e3, c * 1e3) for w, c in latencies))
    print(text)
    assert max(c for _, c in latencies) <= CANCEL_BUDGET_S, text
    assert max(w for w, _ in latencies) <= CANCEL_WALL_S, text


# Every effect at once (two samples, soft shadows from an area and a spot light, two bounces, AO,
# fog, glow, a reflective sea), and one object of each kind: shared by the tests that compare whole
# renders byte for byte (determinism, progressive refinement).
HEAVY_SHADING = dict(samples=2, shadows="soft", reflection_depth=2, ao_strength=0.5, ao_samples=3, glow_strength=0.5,
                     fog_density=0.1, fog_color=(0.0, 0.0, 0.0), glow_color=(0.0, 0.0, 0.0), use_sea=True, sea_height=-1.2, sea_reflectivity=0.3,
                     lights=[dict(type="area", position=(2.0, -2.0, 3.0), radius=0.4),
                             dict(type="spot", position=(-2.0, -2.0, 2.0), direction=(1.0, 1.0, -1.0))])
KIND_OBJECTS = {
    "quaternion_julia": dict(mu=(-0.2, 0.8, 0.1, 0.0), max_iterations=14, reflectivity=0.3),
    "quaternion_mandelbrot": dict(kind="quaternion_mandelbrot", max_iterations=12),
    "julia_stack": dict(kind="julia_stack", path=[(-0.12, 0.75), (-0.8, 0.15)]),
    "cubic_locus": dict(kind="cubic_locus", cubic_component="union", extent=1.2),
    "ifs": dict(kind="ifs", ifs_depth=4, maps=[[[0.5, 0, 0, x], [0, 0.5, 0, y], [0, 0, 0.5, z]]
                                               for x, y, z in ((-0.5, -0.3, -0.3), (0.5, -0.3, -0.3),
                                                               (0, 0.5, -0.3), (0, 0, 0.5))]),
}


# The unit ball (mu = 0) marched to a fixed threshold: the scenes with closed-form answers.
UNIT_BALL = dict(mu=(0.0, 0.0, 0.0, 0.0), max_iterations=32, threshold_mode="fixed", epsilon=1e-4)


def uniform_world(radiance):
    """A world map (8 x 16 texels) of one radiance."""
    return np.broadcast_to(np.asarray(radiance, np.float32), (8, 16, 3)).copy()


def make_camera(width=64, height=48, eye=(0.4, -3.0, 0.9), target=(0.0, 0.0, 0.0), fov_y=0.7,
                ortho_height=None, clip=(0.1, 100.0)):
    matrix = uc.look_at(eye, target, (0.0, 0.0, 1.0))
    if ortho_height is None:
        proj = uc.perspective(fov_y, width / height, *clip)
    else:
        proj = uc.orthographic(ortho_height, width / height, *clip)
    return dict(matrix=matrix, projection=proj, width=width, height=height)


def alloc_passes(width, height, names=None):
    names = uc.PASSES if names is None else names
    return {n: np.full((height, width, uc.PASS_CHANNELS[n]), np.nan, np.float32) for n in names}


def render(camera, objects, names=None, window=None, **kw):
    w = camera["width"] if window is None else window[2]
    h = camera["height"] if window is None else window[3]
    passes = alloc_passes(w, h, names)
    stats = uc.render(camera, objects, passes, window=window, **kw)
    return passes, stats


def rays_float64(camera):
    """Independent float64 camera rays (numpy), pixel centres, shape (H, W, 3)."""
    w, h = camera["width"], camera["height"]
    inv = np.linalg.inv(np.array(camera["projection"], np.float64))
    m = np.array(camera["matrix"], np.float64)
    rot = m[:3, :3] / np.linalg.norm(m[:3, :3], axis=0)
    ys, xs = np.mgrid[0:h, 0:w]
    ndc = np.stack([2 * (xs + 0.5) / w - 1, 2 * (ys + 0.5) / h - 1, -np.ones_like(xs, float),
                    np.ones_like(xs, float)], -1)
    near = ndc @ inv.T
    near = near[..., :3] / near[..., 3:]
    far_ndc = ndc.copy()
    far_ndc[..., 2] = 1.0
    far = far_ndc @ inv.T
    far = far[..., :3] / far[..., 3:]
    if camera["projection"][3][2] != 0.0:  # perspective
        d = near / np.linalg.norm(near, axis=-1, keepdims=True)
        o = np.zeros_like(d)
    else:
        d = (far - near) / np.linalg.norm(far - near, axis=-1, keepdims=True)
        o = near - d * (near[..., 2:] / d[..., 2:])
    origin = o @ rot.T + m[:3, 3]
    direction = d @ rot.T
    forward = -rot[:, 2]
    return origin, direction, forward


def sphere_hits(origin, direction, center=(0.0, 0.0, 0.0), radius=1.0):
    """Analytic first intersection t with a sphere (nan where missed) and closest approach."""
    rel = origin - np.asarray(center)
    b = np.sum(rel * direction, -1)
    c = np.sum(rel * rel, -1) - radius * radius
    disc = b * b - c
    t = np.where(disc >= 0, -b - np.sqrt(np.maximum(disc, 0)), np.nan)
    closest = np.sqrt(np.maximum(np.sum(rel * rel, -1) - b * b, 0))
    return t, closest


def ball_pixels(camera, margin=0.9):
    """(inner, outer, direction): the pixels whose float64 ray passes within `margin` of the unit
    ball's centre (inside its silhouette), those passing beyond 1.05 (outside it), and the rays'
    directions (H, W, 3)."""
    origin, direction, _ = rays_float64(camera)
    _, closest = sphere_hits(origin, direction)
    return closest < margin, closest > 1.05, direction


@pytest.fixture
def camera():
    return make_camera()


def estimate(obj, points):
    """uc.estimate at points (n, 3), rounded to float32 as the core reads them: (estimate,
    escape count, the points as float64)."""
    pts = np.ascontiguousarray(points, np.float32)
    # NaN-filled: a slot the core failed to write shows as NaN, never as stale memory.
    est, it = np.full(len(pts), np.nan, np.float32), np.full(len(pts), np.nan, np.float32)
    uc.estimate(obj, pts, est, it)
    return est, it, pts.astype(np.float64)


def pixel_rays(camera):
    """The native core's own pixel-centre rays (uc.camera_ray), as float64 arrays (H, W, 3)."""
    h, w = camera["height"], camera["width"]
    origin, direction = np.empty((h, w, 3)), np.empty((h, w, 3))
    for y in range(h):
        for x in range(w):
            o, d, _, _ = uc.camera_ray(camera, x + 0.5, y + 0.5)
            origin[y, x], direction[y, x] = o, d
    return origin, direction


def skip_the_reference_when_sanitized():
    """Under the sanitizers (tools/sanitize.sh) what they check of a no-pass-through test is its
    render, which ran before this, instrumented; the float64 dense sampling that follows is numpy's
    time (10-80 s a test there, half of the sanitized run), and its verdict is the plain run's."""
    if SANITIZED:
        pytest.skip("sanitized: the render ran; its float64 reference is left to the plain run")


def dense_sampling(camera, classify, center, radius, sample, solid=4):
    """Float64 dense sampling of each pixel's ray through the ball (center, radius).
    classify(points (n, 3)) -> (member, shell): booleans, in the set (its orbit stays bounded)
    and in the threshold shell {d < eps} of the float64 estimate. Returns (t_solid, t_shell) per
    pixel: the end of the first run of at least `solid` consecutive member samples (a piece of
    the set thicker than a grazing sliver), and the first shell sample; inf where there is none."""
    skip_the_reference_when_sanitized()
    origin, direction = pixel_rays(camera)
    h, w = origin.shape[:2]
    t_solid = np.full((h, w), np.inf)
    t_shell = np.full((h, w), np.inf)
    for y in range(h):
        for x in range(w):
            o, d = origin[y, x], direction[y, x]
            rel = o - np.asarray(center, np.float64)
            b = rel @ d
            disc = b * b - (rel @ rel - radius * radius)
            if disc < 0:
                continue
            ts = np.arange(max(-b - np.sqrt(disc), 0.0), -b + np.sqrt(disc), sample)
            member, shell = classify(o + ts[:, None] * d)
            if shell.any():
                t_shell[y, x] = ts[np.argmax(shell)]
            edges = np.flatnonzero(np.diff(np.concatenate([[0], member.astype(np.int8), [0]])))
            for start, stop in zip(edges[0::2], edges[1::2]):
                if stop - start >= solid:
                    t_solid[y, x] = ts[stop - 1]
                    break
    return t_solid, t_shell


def check_no_passthrough(camera, passes, t_solid, t_shell, slack, agree_tol, agree_fraction, min_hits=20):
    """Every ray whose float64 sampling finds a solid piece of the set hits, and not beyond that
    piece (no ray passes through); hits and the first samples in the float64 threshold shell
    agree for most rays. Returns the counts for messages."""
    origin, _ = pixel_rays(camera)
    hit = passes["alpha"][..., 0] == 1
    t_hit = np.linalg.norm(passes["position"] - origin, axis=-1)
    solid = np.isfinite(t_solid)
    assert solid.sum() >= min_hits, "too few reference hits for a meaningful test"
    missed = np.argwhere(solid & ~hit)
    assert len(missed) == 0, f"{len(missed)} rays passed through the set, e.g. pixel {missed[0][::-1]}"
    beyond = (t_hit - t_solid)[solid]
    assert beyond.max() < slack, f"a hit lies {beyond.max():.4f} beyond the first solid piece of the set"
    found = np.isfinite(t_shell) | hit
    close = (np.abs(t_hit - t_shell) < agree_tol) & hit
    assert close[found].mean() > agree_fraction, \
        f"only {close[found].mean():.3f} of hits agree with the float64 sampling of d < eps"
    return dict(solid=int(solid.sum()), agree=float(close[found].mean()))
