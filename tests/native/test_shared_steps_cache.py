"""Shared first steps kept from one render call to the next (issue 21, render.c ub_kept_cones):
an F12 render of several samples renders a sample a call (sample_range), and each call marched
every 8 x 8 block's cone again. With shared_steps_cache() the first call marches them and the
next ones reuse them where the camera, the objects, the sea and the blocks are the same bytes.
The pixels must not change in any case: equal, to the bit, to one call of every sample and to the
calls without the cache; the iterations are counted where the cones are marched, so a render of a
sample a call counts what one call counts. Where what the cones read changes between calls, the
cones are marched again: the same bytes and the same count as a render without the cache."""
import threading

import numpy as np
import pytest

import unbound_core as uc
from conftest import KIND_OBJECTS, alloc_passes, make_camera

JULIA = KIND_OBJECTS["quaternion_julia"]
IFS = dict(KIND_OBJECTS["ifs"], matrix=[[0.5, 0, 0, 1.0], [0, 0.5, 0, 0.5], [0, 0, 0.5, 0.2], [0, 0, 0, 1]])
SEA = dict(use_sea=True, sea_height=-0.9, sea_wavelength=0.3, sea_amplitude=0.02)
SHADING = dict(SEA, samples=4, ao_strength=0.5, ao_samples=2, glow_strength=0.3)
PASSES = ["combined", "alpha", "depth", "normal", "position", "steps", "iterations"]


def render_calls(camera, objects, shading, calls, cache=None, **kw):
    """`calls`: None for one call of every sample, else that many calls of a sample each."""
    passes = alloc_passes(camera["width"], camera["height"], PASSES)
    for p in passes.values():
        p.fill(0.0)  # the running sum starts at zero (sample_range)
    if calls is None:
        return passes, [uc.render(camera, objects, passes, shading=shading, **kw)]
    stats = [uc.render(camera, objects, passes, shading=shading, sample_range=(s, 1), shared_steps_cache=cache, **kw)
             for s in range(calls)]
    return passes, stats


def same_bytes(a, b):
    return {n: np.array_equal(a[n], b[n]) for n in a}


def test_a_sample_a_call_with_the_cache_is_one_call_to_the_bit():
    camera = make_camera(160, 120)
    objects = [JULIA, IFS]
    one, one_stats = render_calls(camera, objects, SHADING, None)
    kept, kept_stats = render_calls(camera, objects, SHADING, 4, uc.shared_steps_cache())
    each, each_stats = render_calls(camera, objects, SHADING, 4)
    assert all(same_bytes(one, kept).values()) and all(same_bytes(one, each).values())
    assert (one["alpha"][..., 0] > 0).mean() > 0.3
    # The cones' iterations once, as in one call; without the cache once a call.
    total = one_stats[0]["iterations"]
    assert sum(s["iterations"] for s in kept_stats) == total
    assert sum(s["iterations"] for s in each_stats) > total
    assert kept_stats[1]["iterations"] < each_stats[1]["iterations"]
    assert sum(s["steps"] for s in kept_stats) == one_stats[0]["steps"]


def moved_camera():
    return make_camera(160, 120, eye=(0.5, -2.9, 1.0))


# What the cones read, changed between two calls that share a cache.
CHANGES = {
    "camera": lambda cam, objs, sh: (moved_camera(), objs, sh, {}),
    "mu": lambda cam, objs, sh: (cam, [dict(objs[0], mu=[-0.2, 0.75, 0.05, 0.0])] + objs[1:], sh, {}),
    "matrix": lambda cam, objs, sh: (cam, objs[:1] + [dict(objs[1], matrix=[[0.5, 0, 0, 0.9], [0, 0.5, 0, 0.5],
                                                                            [0, 0, 0.5, 0.2], [0, 0, 0, 1]])], sh, {}),
    "one object fewer": lambda cam, objs, sh: (cam, objs[:1], sh, {}),
    "sea height": lambda cam, objs, sh: (cam, objs, dict(sh, sea_height=-0.6), {}),
    "no sea": lambda cam, objs, sh: (cam, objs, dict(sh, use_sea=False), {}),
    "window": lambda cam, objs, sh: (cam, objs, sh, dict(window=(8, 16, 120, 90))),
}


@pytest.mark.parametrize("change", sorted(CHANGES))
def test_what_the_cones_read_changing_between_calls_marches_them_again(change):
    camera, objects, shading = make_camera(160, 120), [JULIA, IFS], dict(SEA, samples=1)
    camera2, objects2, shading2, kw = CHANGES[change](camera, objects, shading)
    cache = uc.shared_steps_cache()
    fresh = {}
    for name, (cam, objs, sh, extra) in {"first": (camera, objects, shading, {}),
                                         "second": (camera2, objects2, shading2, kw)}.items():
        w, h = (extra["window"][2:] if "window" in extra else (cam["width"], cam["height"]))
        passes = alloc_passes(w, h, PASSES)
        stats = uc.render(cam, objs, passes, shading=sh, **extra)
        fresh[name] = passes, stats
        kept = alloc_passes(w, h, PASSES)
        kept_stats = uc.render(cam, objs, kept, shading=sh, shared_steps_cache=cache, **extra)
        # Marched anew (the first call, and the second after the change): the same bytes and count.
        assert all(same_bytes(passes, kept).values()), (name, same_bytes(passes, kept))
        assert kept_stats["iterations"] == stats["iterations"], name
    # The same call again reuses them: the same bytes, fewer iterations.
    passes, stats = fresh["second"]
    again = alloc_passes(*passes["alpha"].shape[1::-1], PASSES)
    again_stats = uc.render(camera2, objects2, again, shading=shading2, shared_steps_cache=cache, **kw)
    assert all(same_bytes(passes, again).values())
    assert again_stats["iterations"] < stats["iterations"]
    assert again_stats["steps"] == stats["steps"]


def test_cones_kept_by_a_cancelled_call_are_whole():
    """A cancel stops the cones' marches too; the next call computes those that no call finished."""
    camera, objects, shading = make_camera(240, 180), [JULIA, IFS], dict(SEA, samples=1)
    reference = alloc_passes(240, 180, PASSES)
    ref_stats = uc.render(camera, objects, reference, shading=shading)
    cache = uc.shared_steps_cache()
    calls = [0]

    def cancel_soon(fraction):
        calls[0] += 1
        return fraction > 0.2

    partial = alloc_passes(240, 180, PASSES)
    stats = uc.render(camera, objects, partial, shading=shading, shared_steps_cache=cache, progress=cancel_soon,
                      poll_interval=0.0005, threads=1)
    assert stats["cancelled"]
    kept = alloc_passes(240, 180, PASSES)
    kept_stats = uc.render(camera, objects, kept, shading=shading, shared_steps_cache=cache)
    assert all(same_bytes(reference, kept).values())
    assert kept_stats["iterations"] < ref_stats["iterations"]


def test_renders_at_the_same_time_sharing_a_cache():
    """One render holds the cones at a time; one running beside it marches its own. Every render
    gives its scene's bytes."""
    cache = uc.shared_steps_cache()
    scenes = [(make_camera(160, 120), [JULIA, IFS]), (moved_camera(), [JULIA])]
    references = []
    for camera, objects in scenes:
        passes = alloc_passes(160, 120, PASSES)
        uc.render(camera, objects, passes, shading=dict(SEA, samples=1))
        references.append(passes)
    results, errors = {}, []

    def run(i, round_):
        try:
            camera, objects = scenes[i]
            passes = alloc_passes(160, 120, PASSES)
            uc.render(camera, objects, passes, shading=dict(SEA, samples=1), shared_steps_cache=cache, threads=1)
            results[(i, round_)] = all(same_bytes(references[i], passes).values())
        except Exception as exc:  # noqa: BLE001 - reported below
            errors.append(exc)

    threads = [threading.Thread(target=run, args=(i, r)) for r in range(3) for i in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors and len(results) == 6 and all(results.values()), (errors, results)


def test_not_a_cache_is_refused():
    passes = alloc_passes(16, 12, ["combined"])
    with pytest.raises(TypeError, match="shared_steps_cache"):
        uc.render(make_camera(16, 12), [JULIA], passes, shared_steps_cache=object())
