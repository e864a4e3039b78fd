"""Coverage-guided fuzzing of the native core's whole Python API (atheris + libFuzzer).

Each input becomes one random call sequence: a camera (any size, degenerate and non-finite
matrices), 0-4 objects of every kind with every key at ordinary, extreme, non-finite and wrong-typed
values, a random pass selection (sometimes with wrong shapes, dtypes, strides or read-only
buffers), a window, threads, tile size, SIMD path, shading with lights, and cancellation at a random
poll (by the progress callback, an Event, or an exception raised in the callback); then
estimate(), normals(), describe() and camera_ray() on the same object.

What counts as a finding (atheris reports it and saves the input):
- a crash, an ASan or UBSan report (the build of tools/sanitize.sh aborts on both);
- an exception other than ValueError / TypeError naming the problem (or the callback's own);
- a finished, uncancelled render that leaves a pixel of a requested pass NaN or infinite
  (the passes start out NaN, so every pixel must have been written, and written finite);
- an estimate that is NaN for a finite point.

Run through tools/sanitize.sh (fuzz: a campaign; replay FILE: one saved input). Without atheris's
instrumentation (plain `python fuzz_native.py FILE`) it replays inputs against any build.
"""
import math
import os
import sys
import threading
import time

import warnings

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.environ.get("UNBOUND_CORE_PATH") or os.path.join(ROOT, "build", "wheel"))

import atheris  # noqa: E402
import unbound_core as uc  # noqa: E402

KINDS = ["quaternion_julia", "quaternion_mandelbrot", "julia_stack", "cubic_locus", "ifs"]
SPECIAL = [0.0, -0.0, 1.0, -1.0, 0.5, 2.0, 4.0, 1e-7, 1e-30, 1e30, -1e30, 1e300, 3.4e38, 5e-324,
           math.nan, math.inf, -math.inf]
BAD_TYPES = [None, "x", [1.0], {"a": 1}, object()]
# Per-input work is bounded by a time budget: the progress callback cancels after it (which
# exercises cancellation on every slow input, too).
BUDGET_S = 0.05


class CallbackError(Exception):
    """Raised from the progress callback: must come back out of render() unchanged."""


class Gen:
    """Values drawn from the fuzzer's bytes."""

    def __init__(self, data):
        self.f = atheris.FuzzedDataProvider(data)

    def pick(self, items):
        return items[self.f.ConsumeIntInRange(0, len(items) - 1)]

    # Exhausted bytes read as 0: every draw is arranged so that 0 means the ordinary case.
    def chance(self, n):
        """True with probability about 1/n."""
        return self.f.ConsumeIntInRange(0, n - 1) == n - 1

    def real(self, lo=-2.0, hi=2.0):
        c = self.f.ConsumeIntInRange(0, 15)
        if c == 12:
            return self.pick(SPECIAL)
        if c == 13:
            return self.f.ConsumeRegularFloat()
        if c == 14 and self.chance(4):
            return self.pick(BAD_TYPES)
        if c == 15:
            return self.f.ConsumeIntInRange(-3, 3)
        return lo + (hi - lo) * self.f.ConsumeProbability()

    def count(self, lo, hi, extreme=(0, -1, 10 ** 6, 2 ** 31, 2 ** 63, 10 ** 40)):
        c = self.f.ConsumeIntInRange(0, 19)
        if c == 18:
            return self.pick(list(extreme))
        if c == 19:
            return self.pick([3.5, "7", None, True])
        return self.f.ConsumeIntInRange(lo, hi)

    def length(self, lo, hi, extreme=()):
        """A list length: usually in [lo, hi], sometimes one of the extremes."""
        if extreme and self.chance(20):
            return self.pick(list(extreme))
        return self.f.ConsumeIntInRange(lo, hi)

    def vector(self, n, lo=-2.0, hi=2.0):
        if self.chance(40):
            n = self.f.ConsumeIntInRange(0, 5)
        return [self.real(lo, hi) for _ in range(n)]

    def matrix(self, rows, cols, lo=-2.0, hi=2.0):
        return [self.vector(cols, lo, hi) for _ in range(rows)]


def random_camera(g):
    width = g.count(1, 16, extreme=(0, -1, 65536, 65537, 2 ** 31))
    height = g.count(1, 16, extreme=(0, -1, 65536, 65537, 2 ** 31))
    aspect = width / height if type(width) is int and type(height) is int and height else 1.0
    if g.chance(6):
        matrix = g.matrix(4, 4, -4.0, 4.0)
    else:
        eye = [g.real(-4, 4) for _ in range(3)]
        try:
            matrix = uc.look_at(eye, [0.0, 0.0, 0.0], [0.0, 0.0, 1.0])
        except (ValueError, TypeError, ZeroDivisionError, OverflowError):
            matrix = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 3], [0, 0, 0, 1]]
    c = g.f.ConsumeIntInRange(0, 5)
    try:
        if c == 5:
            projection = g.matrix(4, 4)
        elif c == 4:
            projection = uc.orthographic(g.real(0.01, 5), aspect, abs(g.real(0.01, 1)) + 1e-3, g.real(2, 100))
        else:
            projection = uc.perspective(g.real(0.1, 2.5), aspect, abs(g.real(0.01, 1)) + 1e-3, g.real(2, 100))
    except (ValueError, TypeError, ZeroDivisionError, OverflowError):
        projection = uc.perspective(0.7, 1.0, 0.1, 100.0)
    camera = dict(matrix=matrix, projection=projection, width=width, height=height)
    if g.chance(30):
        del camera[g.pick(list(camera))]
    return camera


def random_object(g):
    kind = g.pick(KINDS + ["mandelbox", 3])
    obj = {}
    if not g.chance(10):
        obj["kind"] = kind
    setters = {
        "mu": lambda: g.vector(4, -1.2, 1.2),
        "theta": lambda: g.real(-7, 7),
        "slice_basis": lambda: g.matrix(4, 3) if g.chance(3) else [[1, 0, 0], [0, 1, 0], [0, 0, 1], [0, 0, 0]],
        "slice_origin": lambda: g.vector(4),
        "matrix": lambda: g.matrix(4, 4) if g.chance(3) else
        [[1, 0, 0, g.real()], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]],
        "max_iterations": lambda: g.count(1, 40, extreme=(0, -1, 10000, 10001, 2 ** 63)),
        "bailout": lambda: g.real(1, 100),
        "threshold_mode": lambda: g.pick(["pixel", "fixed", "tiny"]),
        "epsilon": lambda: g.real(1e-5, 0.1),
        "detail": lambda: g.real(0.1, 8),
        "step_factor": lambda: g.real(0.05, 1),
        "max_step": lambda: g.real(0.01, 2),
        "max_steps": lambda: g.count(1, 400, extreme=(0, -1, 1000000, 1000001)),
        "bisection_steps": lambda: g.count(0, 10, extreme=(-1, 64, 65)),
        "color": lambda: g.vector(3, 0, 1),
        "normal_method": lambda: g.pick(["gradient_distance", "gradient_potential", "zbuffer", "analytic", "x"]),
        "normal_alpha": lambda: g.real(0, 1),
        "normal_delta": lambda: g.real(0, 0.1),
        "reflectivity": lambda: g.real(0, 1),
        "color_mode": lambda: g.pick(["base", "orbit_trap", "iterations", "x"]),
        "color_ramp": lambda: [[g.real(0, 1)] + g.vector(3, 0, 1) for _ in range(g.length(0, 6, (300,)))],
        "ramp_scale": lambda: g.real(0, 4),
        "ramp_offset": lambda: g.real(-1, 1),
        "path": lambda: [g.vector(2, -1.2, 1.2) for _ in range(g.length(1, 8, (0, 256, 257)))],
        "stack_height": lambda: g.real(0, 3),
        "cubic_component": lambda: g.pick(["plus", "minus", "union", "both", "x"]),
        "extent": lambda: g.real(0, 3),
        "maps": lambda: [g.matrix(3, 4, -0.7, 0.7) for _ in range(g.length(1, 6, (0, 32, 33)))],
        "ifs_depth": lambda: g.count(0, 6, extreme=(-1, 64, 65, 1000)),
    }
    for key in list(setters):
        if g.chance(3):
            obj[key] = setters[key]()
    if g.chance(50):
        obj["colour"] = 1
    return obj


def random_shading(g):
    shading = {}
    for key, make in {
        "samples": lambda: g.count(1, 3, extreme=(0, 4096, 4097)),
        "axle_light": lambda: g.pick([True, False, 2]),
        "ambient": lambda: g.real(0, 1),
        "shadows": lambda: g.pick(["none", "hard", "soft", "x"]),
        "ao_strength": lambda: g.real(0, 1),
        "ao_distance": lambda: g.real(0, 1),
        "ao_samples": lambda: g.count(1, 4, extreme=(0, 1000)),
        "reflection_depth": lambda: g.count(0, 3, extreme=(-1, 16, 17)),
        "fog_density": lambda: g.real(0, 2),
        "fog_color": lambda: g.vector(3, 0, 1),
        "glow_strength": lambda: g.real(0, 2),
        "glow_color": lambda: g.vector(3, 0, 1),
        "sea": lambda: {k: g.real(-1, 1) if k != "color" else g.vector(3, 0, 1)
                        for k in ("height", "wavelength", "amplitude", "color", "reflectivity") if not g.chance(4)},
        "lights": lambda: [random_light(g) for _ in range(g.length(0, 3, (64, 65)))],
    }.items():
        if g.chance(3):
            shading[key] = make()
    return shading


def random_light(g):
    light = {"type": g.pick(["point", "sun", "spot", "area", "x"])}
    for key, make in {"position": lambda: g.vector(3, -4, 4), "direction": lambda: g.vector(3),
                      "color": lambda: g.vector(3, 0, 2), "radius": lambda: g.real(0, 1),
                      "spot_size": lambda: g.real(0, 3.2), "spot_blend": lambda: g.real(0, 1),
                      "cast_shadow": lambda: g.pick([True, False]), "soft_falloff": lambda: g.pick([True, False])}.items():
        if g.chance(2):
            light[key] = make()
    return light


def random_passes(g, w, h):
    """Pass buffers for a w x h film, NaN-filled; sometimes deliberately wrong."""
    names = [n for n in uc.PASSES if g.chance(3)] or ["combined"]
    passes = {}
    for n in names:
        shape = (h, w, uc.PASS_CHANNELS[n])
        c = g.f.ConsumeIntInRange(0, 39)
        if c == 39:
            passes[n] = np.full(shape, np.nan, np.float64)
        elif c == 38:
            passes[n] = np.full((h + 1, w, shape[2]), np.nan, np.float32)
        elif c == 37:
            passes[n] = np.full((h, 2 * w, shape[2]), np.nan, np.float32)[:, ::2]
        elif c == 36:
            a = np.full(shape, np.nan, np.float32)
            a.flags.writeable = False
            passes[n] = a
        elif c == 35:
            passes[n] = g.pick(BAD_TYPES)
        else:
            passes[n] = np.full(shape, np.nan, np.float32)
    if g.chance(40):
        passes["beauty"] = np.zeros((h, w, 4), np.float32)
    return passes


def expected_error(exc):
    """ValueError/TypeError with a message: the documented answer to bad input."""
    return isinstance(exc, (ValueError, TypeError)) and str(exc).strip() != ""


def fuzz_render(g):
    camera = random_camera(g)
    objects = [random_object(g) for _ in range(g.length(0, 3, (64, 65)))]
    width, height = camera.get("width"), camera.get("height")
    window = None
    if type(width) is int and type(height) is int and width > 0 and height > 0 and \
            (width * height > 16 * 16 or g.chance(4)):
        # Big images are rendered through a small window (the buffers stay small).
        x = g.f.ConsumeIntInRange(0, max(0, min(width, 2 ** 20) - 1))
        y = g.f.ConsumeIntInRange(0, max(0, min(height, 2 ** 20) - 1))
        window = (x, y, g.count(1, 16, extreme=(0, -1, 2 ** 31)), g.count(1, 16, extreme=(0, -1, 2 ** 31)))
        if g.chance(30):
            window = g.vector(4, -2, 30)
    # The viewport's interleaved sub-grids: every stride-th pixel of every stride-th row.
    stride = g.count(1, 9, extreme=(0, -1, 4096, 4097)) if g.chance(3) else None
    if window is not None and len(window) == 4 and all(type(v) is int for v in window):
        fw, fh = window[2], window[3]
    elif type(stride) is int and stride > 0 and type(width) is int and type(height) is int:
        fw, fh = -(-width // stride), -(-height // stride)
    else:
        fw, fh = width, height
    if not (type(fw) is int and type(fh) is int and 0 < fw <= 64 and 0 < fh <= 64):
        fw, fh = 4, 4  # nonsense size: the call must refuse the buffers (or the camera) anyway
    passes = random_passes(g, fw, fh)
    kw = {}
    if g.chance(2):
        kw["threads"] = g.count(1, 7, extreme=(0, -1, 1024, 1025))
    if g.chance(2):
        kw["tile_size"] = g.count(1, 33, extreme=(0, -1, 4096, 4097))
    if g.chance(3):
        kw["simd"] = g.pick(["auto", "portable", "avx2", "sse"])
    if g.chance(4):
        kw["background"] = g.vector(4, 0, 1)
    if g.chance(2):
        kw["shading"] = random_shading(g)
    if g.chance(4):
        kw["poll_interval"] = g.real(1e-4, 0.01)
    if stride is not None:
        kw["stride"] = stride
    if g.chance(4):  # samples a range at a time into running sums
        kw["sample_range"] = (g.count(0, 4, extreme=(-1, 2 ** 31)), g.count(1, 4, extreme=(0, -1, 2 ** 31)))
        if g.chance(20):
            kw["sample_range"] = g.vector(g.length(0, 3, (2,)), -2, 5)
    # Cancellation: by the callback's return value, an exception in it, or an Event set from a
    # thread; and always by the time budget.
    cancel_mode = g.pick(["none", "return", "raise", "event"])
    cancel_at = g.f.ConsumeIntInRange(0, 5)
    calls = [0]
    start = time.perf_counter()
    event = threading.Event()
    timer = None

    def progress(fraction):
        calls[0] += 1
        if cancel_mode == "raise" and calls[0] > cancel_at:
            raise CallbackError("stop")
        return (cancel_mode == "return" and calls[0] > cancel_at) or time.perf_counter() - start > BUDGET_S

    kw["progress"] = progress
    if cancel_mode == "event":
        kw["cancel"] = event
        timer = threading.Timer(cancel_at * 0.002, event.set)
        timer.start()
    try:
        stats = uc.render(camera, objects, passes, window=window, **kw)
    except CallbackError:
        return
    except Exception as exc:  # noqa: BLE001 - anything unexpected is the finding
        if not expected_error(exc):
            raise
        return
    finally:
        if timer is not None:
            timer.cancel()
    if stats["cancelled"]:
        return
    sample_range = kw.get("sample_range")
    if sample_range is not None and sample_range[0] != 0:
        return  # later samples add to the caller's running sums: the buffers' contents are theirs
    for name, buf in passes.items():
        if isinstance(buf, np.ndarray) and not np.all(np.isfinite(buf)):
            raise AssertionError(f"finished render left non-finite values in pass {name!r}: "
                                 f"camera={camera!r} objects={objects!r} kw={ {k: v for k, v in kw.items() if k != 'progress'} !r}")


def fuzz_point_queries(g):
    obj = random_object(g)
    n = g.count(0, 9, extreme=(0,))
    n = n if type(n) is int and 0 <= n <= 64 else 3
    pts = np.array([[g.real(-3, 3) for _ in range(3)] for _ in range(n)], dtype=object)
    try:
        pts = pts.astype(np.float32).reshape(n, 3)
    except (TypeError, ValueError):
        pts = np.zeros((n, 3), np.float32)
    est = np.full(n, np.nan, np.float32)
    its = np.full(n, np.nan, np.float32)
    simd = g.pick(["auto", "portable", "avx2"])
    try:
        info = uc.describe(obj)
        uc.estimate(obj, pts, est, its, simd=simd)
    except Exception as exc:  # noqa: BLE001
        if not expected_error(exc):
            raise
        return
    # A slice that misses the bounding ball is an empty object: radius -1 (a zero extent: 0).
    assert info["bound_radius"] == -1.0 or 0 <= info["bound_radius"] < math.inf, info
    finite = np.all(np.isfinite(pts), axis=1)
    if np.any(np.isnan(est[finite])):
        raise AssertionError(f"estimate is NaN at a finite point: object={obj!r} points={pts[finite]!r}")
    # Outside the bounding ball there is no set: the estimate is positive and finite there.
    if info["bound_radius"] >= 0:
        gap = np.linalg.norm(pts.astype(np.float64) - np.array(info["bound_center"]), axis=1) - info["bound_radius"]
        bad = finite & (gap > 1e-3 * (1 + info["bound_radius"])) & ~((est > 0) & (est < np.inf))
        if np.any(bad):
            raise AssertionError(f"estimate {est[bad]!r} outside the bounding ball: object={obj!r} "
                                 f"points={pts[bad]!r}")
    t = np.full(n, 0.5 * g.f.ConsumeProbability(), np.float32)
    normals = np.full((n, 3), np.nan, np.float32)
    try:
        uc.normals(obj, pts, t, normals, simd=simd)
    except Exception as exc:  # noqa: BLE001
        if not expected_error(exc):
            raise


def fuzz_camera_ray(g):
    camera = random_camera(g)
    try:
        uc.camera_ray(camera, g.real(-10, 30), g.real(-10, 30))
    except Exception as exc:  # noqa: BLE001
        if not expected_error(exc):
            raise


def test_one_input(data):
    g = Gen(data)
    which = g.f.ConsumeIntInRange(0, 7)
    if which <= 4:
        fuzz_render(g)
    elif which <= 6:
        fuzz_point_queries(g)
    else:
        fuzz_camera_ray(g)


def main():
    warnings.simplefilter("ignore")  # numpy's cast warnings on the deliberately odd values
    atheris.Setup(sys.argv, test_one_input)
    atheris.Fuzz()


if __name__ == "__main__":
    main()
