"""Cancel latency over a grid of heavy but valid settings (issue 16, defect 2): every kind at the UI's
limits (10000 iterations, 64 bisection steps, 32 AO samples, 16 reflection bounces, 1024 GI bounces, a 32-map IFS at
depth 16, the Menger sponge's folded path at depth 16, soft shadows from six lights, the sea, several objects), cancelled while the camera rays
march and while the hits are shaded (normals, lights, shadows, AO, sea waves, reflections), with one
render thread. Without Z-buffer normals (every case here) a render is one phase that marches and
shades each packet in turn (render.c), so shading starts with the first packet: the "shade" moments
count from the start; with them the shading phase is the second half of the progress.

Asserted (conftest.assert_cancel_latencies): the work after the cancel, as process CPU time, is at
most 100 ms (the latency on a quiet core; measured: a few ms, since the kernel polls between pieces
of work of a few ms at most), and the wall time at most 1 s (the margin for a loaded CI machine,
where a thread runs only part of the time). Before the fix the IFS case took 1.3 s of CPU.
Skipped under the sanitizers (several-fold slower, by design)."""
import random
import time

import pytest
import unbound_core as uc

from conftest import TIMING_UNRELIABLE, CancelClock, alloc_passes, assert_cancel_latencies, make_camera

pytestmark = pytest.mark.skipif(TIMING_UNRELIABLE, reason="timing: the sanitizers or an emulated CPU slow the core several-fold")


def instances(n, spacing=0.35):
    return [[[1.0, 0, 0, (i - (n - 1) / 2) * spacing], [0, 1.0, 0, 0], [0, 0, 1.0, 0], [0, 0, 0, 1.0]]
            for i in range(n)]


def overlapping_maps(count=32, scale=0.8, spread=0.1, seed=1):
    """Nearly coincident contractions: the IFS estimate's worst case (branch-and-bound cannot prune)."""
    rng = random.Random(seed)
    return [[[scale, 0, 0, rng.uniform(-spread, spread)], [0, scale, 0, rng.uniform(-spread, spread)],
             [0, 0, scale, rng.uniform(-spread, spread)]] for _ in range(count)]


AO = dict(ao_strength=1.0, ao_samples=32, ao_distance=1e-4, ambient=(0.5, 0.5, 0.5))
LIGHTS = [dict(type="area", position=(2.0 * ((i % 3) - 1), -2.0, 3.0), radius=0.5, color=(2.0, 2.0, 2.0))
          for i in range(6)]
EVERYTHING = dict(AO, shadows="soft", lights=LIGHTS, reflection_depth=16)
HEAVY = dict(max_iterations=10000, bisection_steps=64, reflectivity=0.9)

# Sizes: each render lasts well past the last cancel moment (shade + 150 ms) on a fast machine;
# the AVX-512 kernel rendered the Julia stack at 96 pixels in 0.16 s, before the cancel came, and
# the GI case at 96 pixels in 0.17 s on an Emerald Rapids Xeon (2026-12-06), 20 ms after it.
CASES = {
    "ifs_32_maps_depth_16_ao_8_instances": (
        [dict(kind="ifs", maps=overlapping_maps(), ifs_depth=16, matrix=m) for m in instances(8, 0.3)], AO, 8),
    # The Menger sponge's folded one-path estimate (ifs.c detect_folded_pieces) at the deepest depth.
    "ifs_menger_depth_16_everything": (
        [dict(kind="ifs", maps=[[[1 / 3, 0, 0, 2 * x / 3], [0, 1 / 3, 0, 2 * y / 3], [0, 0, 1 / 3, 2 * z / 3]]
                                for x in (-1, 0, 1) for y in (-1, 0, 1) for z in (-1, 0, 1) if abs(x) + abs(y) + abs(z) > 1],
              ifs_depth=16, reflectivity=0.9, matrix=m)
         for m in instances(4)], EVERYTHING, 320),
    "julia_potential_normals_everything": (
        [dict(HEAVY, mu=(-0.2, 0.8, 0.1, 0.0), normal_method="gradient_potential", matrix=m) for m in instances(4)],
        EVERYTHING, 256),
    "mandelbrot_analytic_normals_everything": (
        [dict(HEAVY, kind="quaternion_mandelbrot", normal_method="analytic", matrix=m) for m in instances(2, 1.0)],
        EVERYTHING, 128),
    "julia_stack_everything": (
        [dict(HEAVY, kind="julia_stack", path=[(-0.12 - 0.003 * i, 0.75 - 0.002 * i) for i in range(256)])],
        EVERYTHING, 192),
    "cubic_locus_everything": ([dict(HEAVY, kind="cubic_locus", cubic_component="both", extent=1.2)], EVERYTHING, 96),
    "sea_waves_8_objects_reflections": (
        [dict(HEAVY, mu=(-0.2, 0.8, 0.1, 0.0), matrix=m) for m in instances(8, 0.25)],
        dict(AO, use_sea=True, sea_height=-0.6, sea_reflectivity=1.0, sea_wavelength=0.05, reflection_depth=16), 96),
    # Global illumination at its limits: 1024 bounces of every kind, paths that bounce between
    # the objects and the sea, each bounce with soft shadows from six lights.
    "gi_1024_bounces_sea_everything": (
        [dict(HEAVY, mu=(-0.2, 0.8, 0.1, 0.0), color=(1.0, 1.0, 1.0), matrix=m) for m in instances(4)],
        dict(EVERYTHING, use_gi=True, max_bounces=1024, diffuse_bounces=1024, glossy_bounces=1024, use_sea=True,
             sea_height=-0.6, sea_reflectivity=0.5, sea_color=(1.0, 1.0, 1.0)), 160),
}
# When to cancel: seconds after the render starts (the camera rays march), and after the shading
# starts.
MOMENTS = (("march", 0.03), ("shade", 0.01), ("shade", 0.15))


def cancel_latency(objects, shading, size, phase, delay):
    cam = make_camera(size, size * 3 // 4, eye=(0.3, -2.6, 0.8))
    passes = alloc_passes(cam["width"], cam["height"], ["combined", "normal", "ao", "shadow", "reflection"])
    state, clock = {"start": time.perf_counter()}, CancelClock()
    if not any(o.get("normal_method") == "zbuffer" for o in objects):
        state["shade"] = state["start"]  # one phase: shading starts with the first packet

    def progress(fraction):
        now = time.perf_counter()
        if "shade" not in state and fraction >= 0.5:
            state["shade"] = now
        origin = state["start"] if phase == "march" else state.get("shade")
        if origin is not None and now - origin >= delay:
            clock.mark()
        return clock.marked

    stats = uc.render(cam, objects, passes, shading=shading, threads=1, progress=progress, poll_interval=0.002)
    assert stats["cancelled"] and clock.marked, "the render ended before the cancel"
    return clock.latency()


@pytest.mark.parametrize("case", sorted(CASES))
def test_cancel_latency_grid(case):
    objects, shading, size = CASES[case]
    assert_cancel_latencies([cancel_latency(objects, shading, size, phase, delay) for phase, delay in MOMENTS],
                            "%s (march+30ms, shade+10ms, shade+150ms)" % case)
