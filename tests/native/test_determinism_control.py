"""Same parameters, same bytes: whatever the thread count, tile size or SIMD path. Progress,
cancellation and counters."""
import sys
import threading
import time

import numpy as np
import pytest
import unbound_core as uc

from conftest import (KERNELS, HEAVY_SHADING, KIND_OBJECTS, TIMING_UNRELIABLE, CancelClock, assert_cancel_latencies, make_camera,
                      render)

OBJ = dict(mu=(-0.2, 0.8, 0.1, 0.0), max_iterations=14)


def test_identical_bytes_for_any_threads_tiles_and_simd():
    cam = make_camera(97, 61)
    ref, ref_stats = render(cam, [OBJ], threads=1, tile_size=32)
    for threads, tile, simd in [(2, 32, "auto"), (7, 13, "auto"), (3, 1, "portable"), (1, 5, KERNELS[0])] + \
            [(2, 64, kernel) for kernel in KERNELS[1:]]:
        out, stats = render(cam, [OBJ], threads=threads, tile_size=tile, simd=simd)
        for k in ref:
            assert ref[k].tobytes() == out[k].tobytes(), (k, threads, tile, simd)
        for k in ("rays", "steps", "iterations", "normal_iterations"):
            assert stats[k] == ref_stats[k]


@pytest.mark.parametrize("shape", [(61, 97, 4), (37, 61, 1), (1, 1, 3), (0, 5, 4)])
def test_pass_array_starts_on_a_line_and_renders_the_same_bytes(shape):
    """unbound_core.pass_array: float32, C-contiguous, the data on a 64-byte line (whatever numpy's
    allocator gives; an empty array has no data), zeros when asked; the core renders the same bytes
    into it as into numpy's."""
    for zero in (False, True):
        a = uc.pass_array(*shape, zero=zero)
        assert a.shape == shape and a.dtype == np.float32 and a.flags["C_CONTIGUOUS"] and a.flags["WRITEABLE"]
        assert a.size == 0 or a.ctypes.data % 64 == 0
        if zero:
            assert not a.any()
    h, w, _ = shape
    if not h * w:
        return
    cam = make_camera(w, h)
    ref, _ = render(cam, [OBJ], threads=2, tile_size=8)
    mine = {n: uc.pass_array(h, w, uc.PASS_CHANNELS[n]) for n in ref}
    uc.render(cam, [OBJ], mine, threads=2, tile_size=8)
    for n in ref:
        assert ref[n].tobytes() == mine[n].tobytes(), n


def test_window_equals_crop_of_full_image():
    """Render borders and tiles: a window renders exactly the matching pixels of the full image."""
    cam = make_camera(80, 60)
    full, _ = render(cam, [OBJ])
    win = (13, 7, 41, 29)
    part, stats = render(cam, [OBJ], window=win)
    # Camera rays cover the window alone: no normal method here reads the neighbours' hits.
    assert stats["rays"] == 41 * 29
    for k in full:
        assert np.array_equal(part[k], full[k][7:36, 13:54], equal_nan=True), k
    # With Z-buffer normals (eq. 12-14) the window's camera rays take a one-pixel apron, so that
    # its edge pixels' normals equal the full image's.
    zbuffer = dict(OBJ, normal_method="zbuffer")
    full, _ = render(cam, [zbuffer])
    part, stats = render(cam, [zbuffer], window=win)
    assert stats["rays"] == (41 + 2) * (29 + 2)
    for k in full:
        assert np.array_equal(part[k], full[k][7:36, 13:54], equal_nan=True), k


def test_counters_and_stats():
    cam = make_camera(64, 48)
    passes, stats = render(cam, [OBJ])
    assert stats["rays"] == 64 * 48
    assert stats["steps"] == int(passes["steps"].sum())
    assert stats["iterations"] >= stats["steps"]
    assert stats["seconds"] > 0 and stats["threads"] >= 1 and stats["simd"] == KERNELS[-1]
    assert stats["cancelled"] is False


def test_the_normals_iterations_are_counted_apart():
    """stats["normal_iterations"]: the iterations of f in the six estimates of each hit's central
    differences (eq. 15), between one and max_iterations each; none with analytic normals (the
    Jacobian), none where nothing is hit. The march's count does not change with the method."""
    cam = make_camera(64, 48)
    passes, stats = render(cam, [OBJ])
    hits = int((passes["alpha"] > 0).sum())
    assert hits > 100
    assert 6 * hits <= stats["normal_iterations"] <= 6 * hits * OBJ["max_iterations"], (hits, stats)
    _, analytic = render(cam, [dict(OBJ, normal_method="analytic")])
    assert analytic["normal_iterations"] == 0 and analytic["iterations"] == stats["iterations"]
    empty = make_camera(16, 12, eye=(0.0, -5.0, 0.0), target=(0.0, -10.0, 0.0))  # looking away
    _, missed = render(empty, [OBJ])
    assert missed["normal_iterations"] == 0 and missed["iterations"] == 0


def test_progress_reaches_completion_and_is_monotonic():
    cam = make_camera(320, 240)
    seen = []
    render(cam, [dict(OBJ, max_iterations=60)], ["alpha"], progress=seen.append, poll_interval=0.001, threads=2)
    assert seen == sorted(seen) and all(0.0 <= f <= 1.0 for f in seen)


@pytest.mark.skipif(TIMING_UNRELIABLE, reason="timing: the sanitizers or an emulated CPU slow the core several-fold")
def test_cancel_from_progress_callback_stops_within_100ms():
    cam = make_camera(1920, 1080)
    heavy = dict(OBJ, max_iterations=400, detail=4.0)
    clock = CancelClock()

    def progress(fraction):
        if fraction >= 0.05:
            clock.mark()
        return clock.marked

    _, stats = render(cam, [heavy], ["combined"], progress=progress, poll_interval=0.005)
    assert stats["cancelled"] is True
    assert_cancel_latencies([clock.latency()], "progress")


@pytest.mark.skipif(TIMING_UNRELIABLE, reason="timing: the sanitizers or an emulated CPU slow the core several-fold")
def test_cancel_from_another_thread_with_event():
    """The event is set from another thread once the render is under way (5 % of its progress)."""
    cam = make_camera(1920, 1080)
    event, clock, seen, done = threading.Event(), CancelClock(), [0.0], threading.Event()

    def watcher():
        while not done.is_set():
            if seen[0] >= 0.05:
                clock.mark()
                event.set()
                return
            time.sleep(0.001)

    th = threading.Thread(target=watcher)
    th.start()
    _, stats = render(cam, [dict(OBJ, max_iterations=400, detail=4.0)], ["alpha"], cancel=event,
                      progress=lambda f: seen.__setitem__(0, f), poll_interval=0.005)
    done.set()
    th.join()
    assert stats["cancelled"] is True and clock.marked
    assert_cancel_latencies([clock.latency()], "event")


def test_exception_in_progress_propagates_and_stops():
    cam = make_camera(640, 480)

    def boom(_):
        raise RuntimeError("user callback failed")

    # Polled every millisecond: at the default interval this render can end before the first poll
    # on a fast machine (it did, at 640x480, on a Zen 5 once the camera rays went two packets at a time).
    with pytest.raises(RuntimeError, match="user callback failed"):
        render(cam, [dict(OBJ, max_iterations=200)], ["alpha"], progress=boom, poll_interval=0.001)


def test_gil_released_during_render():
    """Another Python thread keeps running while a render is in progress: it ticks strictly inside
    the render's time, away from its ends by more than the interpreter's switch interval (with the
    GIL held for the render, no tick could land there). Counted by time, not by the number of
    ticks over a whole render: a faster core left too few (5 under wine, whose sleeps last a
    15.6 ms timer tick). One render thread, so that the ticker has a core of its own; renders
    repeat until three ticks landed inside, at most 50."""
    cam = make_camera(1600, 1200)  # tens of ms, far longer than the margins below
    ticks = []
    stop = threading.Event()

    def ticker():
        while not stop.is_set():
            ticks.append(time.perf_counter())
            time.sleep(0.001)

    margin = 2.0 * sys.getswitchinterval()
    inside = 0
    th = threading.Thread(target=ticker)
    th.start()
    try:
        for _ in range(50):
            t0 = time.perf_counter()
            render(cam, [dict(OBJ, max_iterations=100)], ["alpha"], threads=1)  # a core left for the ticker
            t1 = time.perf_counter()
            inside += sum(1 for t in list(ticks) if t0 + margin < t < t1 - margin)
            if inside >= 3:
                break
    finally:
        stop.set()
        th.join()
    assert inside >= 3, inside


def test_union_of_two_objects_takes_nearest():
    cam = make_camera(64, 48, eye=(0.0, -4.0, 0.0), target=(0, 0, 0))
    ball = dict(mu=(0, 0, 0, 0), max_iterations=30, threshold_mode="fixed", epsilon=1e-4)
    left = dict(ball, matrix=[[0.6, 0, 0, -0.5], [0, 0.6, 0, 0], [0, 0, 0.6, 0], [0, 0, 0, 1]])
    right = dict(ball, matrix=[[0.6, 0, 0, 0.5], [0, 0.6, 0, -0.8], [0, 0, 0.6, 0], [0, 0, 0, 1]])
    a, _ = render(cam, [left], ["depth", "alpha"])
    b, _ = render(cam, [right], ["depth", "alpha"])
    both, _ = render(cam, [left, right], ["depth", "alpha"])
    assert np.array_equal(both["alpha"], np.maximum(a["alpha"], b["alpha"]))
    assert np.array_equal(both["depth"], np.minimum(a["depth"], b["depth"]))
    swapped, _ = render(cam, [right, left], ["depth", "alpha"])
    assert np.array_equal(swapped["depth"], both["depth"])


@pytest.mark.parametrize("kind", sorted(KIND_OBJECTS))
def test_every_kind_with_every_effect_is_bit_identical_for_threads_tiles_and_runs(kind):
    """Shadows, reflections, AO, fog, glow, the sea and two samples: the passes' bytes do not
    depend on the thread count (1, 2, 7), the tile size (1, 13, 64) or the run."""
    cam = make_camera(61, 37)
    obj = KIND_OBJECTS[kind]
    ref, ref_stats = render(cam, [obj], threads=1, tile_size=32, shading=HEAVY_SHADING)
    for threads, tile in [(2, 13), (7, 1), (7, 64), (1, 32)]:
        out, stats = render(cam, [obj], threads=threads, tile_size=tile, shading=HEAVY_SHADING)
        for k in ref:
            assert ref[k].tobytes() == out[k].tobytes(), (kind, k, threads, tile)
        assert stats["iterations"] == ref_stats["iterations"]
    assert np.isfinite(ref["combined"]).all() and (ref["alpha"] > 0).any()
