"""Issue 18: the float32 march at its two limits, against the float64 reference march
(reference/qjulia64.py: the same method in numpy float64, with the same threshold and max_steps).

1. A fixed epsilon below float32's resolution of the ray (the UI allows 1e-7). Where the estimate
   drops below half an ulp of the marching parameter s, s + d rounds back to s: the ray used to
   stall there until it ran out of steps and showed the background where the set is (14 holes in
   the scene below). It now hits there, the closest point float32 represents.
2. Rays that run out of max_steps: counted in stats["out_of_steps"] and marked in the "max_steps"
   pass, both equal to the rays whose float64 march runs out of the same number of steps."""
import functools

import numpy as np
import pytest
import unbound_core as uc

from conftest import make_camera, render
from reference import qjulia64 as ref

# The scene: the dendrite mu = i, 24 iterations, fixed epsilon 1e-7 (the field's minimum).
TINY_CAMERA = make_camera(200, 150, eye=(0.7, -2.7, 1.5), fov_y=0.8)
TINY_EPS = dict(mu=(0.0, 1.0, 0.0, 0.0), max_iterations=24, threshold_mode="fixed", epsilon=1e-7)


@functools.cache
def float64_march(camera, obj):
    """The float64 reference render (hashable arguments: tuples of items), computed once."""
    camera, obj = dict(camera), dict(obj)
    return ref.render(camera, obj, camera["width"], camera["height"])


def frozen(d):
    return tuple((k, tuple(map(tuple, v)) if k in ("matrix", "projection") else v) for k, v in d.items())


def test_tiny_fixed_epsilon_leaves_no_holes():
    """Every pixel whose float64 march hits hits (before the fix: 14 did not, each after 2000
    steps), at the same depth: within 1e-6 for 99 % of the hits (measured 9.2e-7; a float32 depth
    of ~3 has an ulp of 2.4e-7) and within 1e-4 for all (measured 2.5e-5, a grazing ray), the
    filled holes among them within 2e-6 (measured 8.2e-7). No pixel hits that the float64 march
    misses. The only ray that runs out of steps is the one whose float64 march runs out too (it
    needs 2099 steps in float32): a slow approach, not a stall."""
    r = float64_march(frozen(TINY_CAMERA), frozen(TINY_EPS))
    p, stats = render(TINY_CAMERA, [TINY_EPS], ["alpha", "depth", "steps", "max_steps"])
    hit = p["alpha"][..., 0] > 0
    holes = np.argwhere(r["alpha"] & ~hit)
    assert holes.size == 0, "%d holes where the float64 march hits: %s" % (len(holes), holes[:10].tolist())
    assert not (hit & ~r["alpha"]).any()
    both = r["alpha"] & hit
    diff = np.abs(p["depth"][..., 0] - r["depth"])[both]
    assert np.percentile(diff, 99) < 1e-6 and diff.max() < 1e-4, (np.percentile(diff, 99), diff.max())
    # Those that stalled before the fix: hits after far fewer steps now (a stall never recovers).
    assert np.array_equal(p["max_steps"][..., 0] > 0, r["exhausted"])
    assert stats["out_of_steps"] == 1 == r["exhausted"].sum()
    assert np.all(p["steps"][..., 0][r["exhausted"]] == 2000)


def test_tiny_epsilon_hits_do_not_depend_on_the_kernel_or_threads():
    """The resolution test is float32 arithmetic (an add and a compare): same bits everywhere."""
    first, _ = render(TINY_CAMERA, [TINY_EPS], ["depth", "max_steps"], threads=1, simd="portable")
    for threads in (2, 3):
        other, _ = render(TINY_CAMERA, [TINY_EPS], ["depth", "max_steps"], threads=threads, tile_size=16)
        for name in first:
            assert first[name].tobytes() == other[name].tobytes(), (threads, name)


@pytest.mark.parametrize("max_steps", [8, 20])
def test_out_of_steps_counted_and_marked_like_the_float64_march(max_steps):
    """A pixel-threshold render with max_steps 8 or 20 (10216 and 1636 of 160 x 120 rays run out):
    stats["out_of_steps"] equals the pixels the max_steps pass marks (1.0; 0.0 elsewhere) and the
    rays whose float64 march is still going after max_steps steps, pixel for pixel. Those pixels
    show the background (alpha 0) and took max_steps steps. The float64 march starts every ray at
    the clip plane, so the render does too (shared_steps=0); with the shared first steps (issue 21)
    the rays start further in, and the count, the pass and the pixels still agree with each other."""
    camera = make_camera(160, 120)
    obj = dict(mu=(-0.2, 0.8, 0.0, 0.0), max_iterations=16, max_steps=max_steps)
    r = float64_march(frozen(camera), frozen(obj))
    for shared in (0, 1):
        p, stats = render(camera, [obj], ["alpha", "steps", "max_steps"], shared_steps=shared)
        marked = p["max_steps"][..., 0]
        assert set(np.unique(marked)) <= {0.0, 1.0}
        out = marked == 1.0
        assert stats["out_of_steps"] == out.sum() > 100
        if not shared:
            assert out.sum() == r["exhausted"].sum()
            assert np.array_equal(out, r["exhausted"])
        assert not p["alpha"][..., 0][out].any()
        assert np.all(p["steps"][..., 0][out] == max_steps)


def test_out_of_steps_over_samples_windows_and_strides():
    """With 3 samples the pass is the fraction of each pixel's samples that ran out and the count
    sums the samples (count = 3 x the pass's sum); a render border counts its own pixels only (not
    the one-pixel apron the normals read) and marks them as the full render does; so does each of
    the viewport's stride-2 sub-grids, which together count what the full render counts."""
    camera = make_camera(64, 48)
    obj = dict(mu=(-0.2, 0.8, 0.0, 0.0), max_iterations=16, max_steps=10)
    full, full_stats = render(camera, [obj], ["max_steps"])
    mask = full["max_steps"][..., 0]
    assert full_stats["out_of_steps"] == mask.sum() > 50
    multi, stats = render(camera, [obj], ["max_steps"], shading=dict(samples=3))
    fraction = multi["max_steps"][..., 0]
    assert set(np.round(3 * np.unique(fraction)).astype(int)) <= {0, 1, 2, 3}
    assert stats["out_of_steps"] == round(3 * float(fraction.astype(np.float64).sum()))
    assert ((fraction > 0) & (fraction < 1)).any()  # the samples' rays differ: not one ray counted thrice
    x, y, w, h = 10, 7, 33, 21
    part, stats = render(camera, [obj], ["max_steps"], window=(x, y, w, h))
    assert np.array_equal(part["max_steps"], full["max_steps"][y:y + h, x:x + w])
    assert stats["out_of_steps"] == part["max_steps"].sum()
    total = 0
    for oy in range(2):
        for ox in range(2):
            sw, sh = (64 - ox + 1) // 2, (48 - oy + 1) // 2
            sub = {"max_steps": np.zeros((sh, sw, 1), np.float32)}
            total += uc.render(camera, [obj], sub, window=(ox, oy, sw, sh), stride=2)["out_of_steps"]
            assert np.array_equal(sub["max_steps"], full["max_steps"][oy::2, ox::2])
    assert total == full_stats["out_of_steps"]


def test_a_nearer_hit_is_not_out_of_steps():
    """Object A (max_steps 3) behind object B, whose every hit is nearer than A's bounding ball: a ray
    that hits B shows what it would have shown anyway and is not marked, whichever object is
    marched first; a ray that misses B and runs out on A is. Expected: A alone's marks where B
    alone misses."""
    camera = make_camera(96, 72, eye=(0.0, -4.0, 0.5), fov_y=0.9)
    back = dict(mu=(-0.2, 0.8, 0.0, 0.0), max_steps=3,
                matrix=[[1, 0, 0, 0.8], [0, 1, 0, 4.0], [0, 0, 1, 0], [0, 0, 0, 1]])
    front = dict(mu=(-1.0, 0.0, 0.0, 0.0), matrix=[[0.4, 0, 0, 0], [0, 0.4, 0, 0], [0, 0, 0.4, 0], [0, 0, 0, 1]])
    alone, _ = render(camera, [back], ["max_steps"])
    covered, _ = render(camera, [front], ["alpha", "depth"])
    # B's hits are nearer than any point of A's bounding ball (radius 1.54 at a depth of about 8).
    assert covered["depth"][covered["alpha"] > 0].max() < 8.0 - 1.6 - 0.5
    expected = (alone["max_steps"][..., 0] > 0) & ~(covered["alpha"][..., 0] > 0)
    overlap = (alone["max_steps"][..., 0] > 0) & (covered["alpha"][..., 0] > 0)
    assert expected.sum() > 50 and overlap.sum() > 50  # both cases occur
    for order in ([back, front], [front, back]):
        p, stats = render(camera, order, ["max_steps"])
        assert np.array_equal(p["max_steps"][..., 0] > 0, expected)
        assert stats["out_of_steps"] == expected.sum()
