"""Shared first steps (issue 21, native/src/cone.h): the camera rays of each 8 x 8 block of pixels
start where one cone marched for the block is certified empty by unbounding spheres, instead of
at the clip plane. The rays start later, so they take fewer steps; what they hit stays: the same
pixels hit, at the same depth up to the hit threshold's slack (the bisection refines both renders
alike), and the sea, which the cone must not pass, is hit where it was, to the bit."""
import numpy as np
import pytest

from conftest import KIND_OBJECTS, make_camera, render

JULIA = KIND_OBJECTS["quaternion_julia"]
SKEWED = [[0.8, 0.3, 0.0, 0.1], [0.0, 1.2, 0.2, -0.1], [0.1, 0.0, 0.6, 0.05], [0.0, 0.0, 0.0, 1.0]]
SEA = dict(use_sea=True, sea_height=-0.9, sea_wavelength=0.3, sea_amplitude=0.02)
PASSES = ["alpha", "depth", "position"]

# name -> camera, objects, shading, the most steps the rays may take with the cone, as a fraction
# of the steps without (measured 0.68, 0.82, 0.82)
SCENES = {
    "perspective": (make_camera(160, 120), [JULIA], None, 0.75),
    "orthographic": (make_camera(120, 90, ortho_height=3.0), [JULIA], None, 0.9),
    "two-objects-sea": (make_camera(120, 90), [dict(JULIA, matrix=SKEWED, max_step=0.5),
                                               dict(KIND_OBJECTS["ifs"], matrix=[[0.5, 0, 0, 1.0], [0, 0.5, 0, 0.5],
                                                                                 [0, 0, 0.5, 0.2], [0, 0, 0, 1]])],
                        SEA, 0.9),
}


@pytest.mark.parametrize("name", sorted(SCENES))
def test_rays_start_later_and_hit_what_they_hit(name):
    camera, objects, shading, most_steps = SCENES[name]
    kw = dict(shading=shading) if shading else {}
    off, off_stats = render(camera, objects, PASSES, shared_steps=0, **kw)
    on, on_stats = render(camera, objects, PASSES, shared_steps=1, **kw)
    assert on_stats["steps"] <= most_steps * off_stats["steps"]
    hit_off, hit_on = off["alpha"][..., 0] > 0, on["alpha"][..., 0] > 0
    changed = (hit_off != hit_on).sum()
    both = hit_off & hit_on
    rel = np.abs(on["depth"][..., 0] - off["depth"][..., 0])[both] / off["depth"][..., 0][both]
    # Silhouette pixels may turn (measured 5, 0 and 0 of 19200, 10800, 10800); hits move within
    # the threshold's slack (a pixel's footprint is 6e-3 of the depth here; measured p99 5.9e-4,
    # 3.5e-4, 1.3e-4 of the depth).
    assert changed <= 5e-4 * hit_off.size
    assert np.percentile(rel, 99) < 1e-3
    if shading:  # the sea's hits: the same bits (a ray's sea hit is analytic from its t_min)
        sea_off, sea_on = (np.abs(p["position"][..., 2] - SEA["sea_height"]) < 1e-5 for p in (off, on))
        assert sea_off.sum() > 5000 and (sea_off != sea_on).sum() <= 5  # measured 5451 and 1 (a silhouette)
        sea = sea_off & sea_on
        assert np.array_equal(on["depth"][sea], off["depth"][sea])


WORLDS = {"colour": None, "constant": np.full((1, 1, 3), 0.4, np.float32),
          "map": np.arange(2 * 4 * 3, dtype=np.float32).reshape(2, 4, 3) / 24.0}


@pytest.mark.parametrize("world", sorted(WORLDS))
def test_empty_blocks_show_what_the_traced_rays_show(world):
    """A block whose cone gets past every object's bounding ball is empty: its camera rays are
    not traced, and a packet of only such rays gets the background's paths without rays
    (kernel.h, empty_packet) where the background is the same along every ray (a colour or a
    constant World). Where the rays traced from the clip plane (shared_steps 0) take no step,
    the rays missed every ball: there every pass must be the same to the bit, over two
    samples, with glow (from the steps), AO and a background colour on."""
    # The set off the frame's centre: most of the frame is background.
    camera = make_camera(160, 120, eye=(0.4, -3.0, 0.9), target=(1.6, 0.0, 0.9))
    shading = dict(samples=2, ao_strength=0.5, ao_samples=2, glow_strength=0.5, ambient=(0.2, 0.2, 0.2))
    kw = dict(shading=shading, background=(0.1, 0.2, 0.3, 0.5), world=WORLDS[world])
    off, off_stats = render(camera, [JULIA], shared_steps=0, **kw)
    on, on_stats = render(camera, [JULIA], shared_steps=1, **kw)
    missed = off["steps"][..., 0] == 0
    assert 0.5 < missed.mean() < 0.95 and (off["alpha"][..., 0] > 0).mean() > 0.02
    for name in off:
        assert np.array_equal(on[name][missed], off[name][missed]), name
    assert on_stats["rays"] == off_stats["rays"]
