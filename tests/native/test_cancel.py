"""Cancellation of a heavy frame: 1920x1080 with soft shadows from an area light and reflections
(two bounces, off the fractal and a sea), cancelled at moments spread over the render (primary
rays, shading), by an event set from another thread and by the progress callback.
The budget is 100 ms of work after the cancel (conftest.assert_cancel_latencies: CPU time, and a
wall-clock margin that holds on a loaded machine). The moments are fractions of the render's
progress, not of a wall time measured earlier, so a busy machine cannot move them past the end."""
import threading
import time

import numpy as np
import pytest
import unbound_core as uc

from conftest import TIMING_UNRELIABLE, CancelClock, alloc_passes, assert_cancel_latencies, make_camera

pytestmark = pytest.mark.skipif(TIMING_UNRELIABLE, reason="timing: the sanitizers or an emulated CPU slow the core "
                                                            "several-fold")

HEAVY_OBJECT = dict(mu=(-0.2, 0.8, 0.1, 0.0), max_iterations=60, detail=2.0, reflectivity=0.5)
HEAVY_SHADING = dict(shadows="soft", reflection_depth=2, use_sea=True, sea_height=-1.1, sea_reflectivity=0.4,
                     lights=[dict(type="area", position=(2.0, -2.0, 3.0), radius=0.5, color=(3.0, 3.0, 3.0))])
# When to cancel, as fractions of the render's progress (below 0.5: camera rays; above: shading).
MOMENTS = (0.03, 0.2, 0.4, 0.55, 0.7)


def render_heavy(width=1920, height=1080, **kw):
    cam = make_camera(width, height)
    passes = alloc_passes(width, height, ["combined", "depth", "shadow", "reflection"])
    stats = uc.render(cam, [HEAVY_OBJECT], passes, shading=HEAVY_SHADING, **kw)
    return stats, passes


def test_cancel_by_event_within_budget_at_any_moment():
    """Another thread sets the event once the render has reached the moment."""
    latencies = []
    for moment in MOMENTS:
        event, clock, seen, done = threading.Event(), CancelClock(), [0.0], threading.Event()

        def watcher():
            while not done.is_set():
                if seen[0] >= moment:
                    clock.mark()
                    event.set()
                    return
                time.sleep(0.001)

        th = threading.Thread(target=watcher)
        th.start()
        stats, _ = render_heavy(cancel=event, progress=lambda f: seen.__setitem__(0, f), poll_interval=0.005)
        latency = clock.latency() if clock.marked else None
        done.set()
        th.join()
        assert stats["cancelled"] is True and latency, moment
        latencies.append(latency)
    assert_cancel_latencies(latencies, "event")


def test_cancel_by_progress_callback_within_budget():
    """The render engine's way: progress() returns test_break()."""
    latencies = []
    for moment in MOMENTS[::2]:
        clock = CancelClock()

        def progress(fraction):
            if fraction >= moment:
                clock.mark()
            return clock.marked

        stats, _ = render_heavy(progress=progress, poll_interval=0.02)
        assert stats["cancelled"] is True and clock.marked, moment
        latencies.append(clock.latency())
    assert_cancel_latencies(latencies, "progress")


def test_cancelled_render_then_full_render_is_unchanged():
    """A cancelled render leaves nothing behind: the next full render has the same bytes."""
    _, ref = render_heavy(480, 270)
    stats, _ = render_heavy(480, 270, progress=lambda f: f >= 0.3, poll_interval=0.002)
    assert stats["cancelled"]
    _, again = render_heavy(480, 270)
    for k in ref:
        assert np.array_equal(ref[k], again[k]), k
