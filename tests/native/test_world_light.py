"""The World as a light (issue 19): render(world=map). mu = 0 is the unit ball; a convex body sees
the whole sky above each tangent plane, so its irradiance has closed forms to compare with."""
import numpy as np
import pytest

import unbound_core as uc
from conftest import KERNELS, UNIT_BALL as BALL, ball_pixels, make_camera, render, uniform_world

NO_PAPER_LIGHT = dict(axle_light=0.0)


def env_direction(u, v):
    """Cycles' Environment Texture mapping, inverse: u = atan2(-y, x) / 2 pi + 0.5, v = latitude / pi + 0.5."""
    phi, lat = 2 * np.pi * (u - 0.5), np.pi * (v - 0.5)
    return np.stack(np.broadcast_arrays(np.cos(phi) * np.cos(lat), -np.sin(phi) * np.cos(lat), np.sin(lat)), -1)


@pytest.mark.parametrize("texels", [(8, 16), (1, 1)], ids=["map", "constant"])
def test_uniform_world_lights_a_ball_to_albedo_times_radiance(texels):
    """A uniform world of radiance L on a diffuse ball of albedo rho: rho L at every pixel. A
    constant World is a 1x1 map (the add-on's), which skips the map's coordinates (world.h); it
    must light and show the same. Each
    world-sample pair adds L cos/pi / (p_map + p_surface) for two directions, each term <= L (as
    p_surface = cos/pi), so a pair's estimate lies in [0, 2 rho L]: by Hoeffding, a pixel's mean
    of K pairs is within rho L sqrt(2 ln(2 n / delta) / K) of rho L for all n pixels but with
    probability delta (1e-3 here); the mean over the pixels within 4 rho L / sqrt(K n)."""
    cam = make_camera(48, 36)
    rho, L = np.array([0.5, 0.8, 0.25]), np.array([2.0, 1.0, 4.0])
    world = np.broadcast_to(np.asarray(L, np.float32), texels + (3,)).copy()
    samples, world_samples = 16, 16
    passes, _ = render(cam, [dict(BALL, color=tuple(rho))], names=["combined", "diffuse"], world=world,
                       background=(0, 0, 0, 1), shading=dict(NO_PAPER_LIGHT, samples=samples,
                                                             world_samples=world_samples))
    inner, outer, _ = ball_pixels(cam)
    K, n = samples * world_samples, inner.sum()
    expected = rho * L
    got = passes["combined"][..., :3][inner]
    per_pixel = np.sqrt(2 * np.log(2 * n / 1e-3) / K)
    assert np.all(np.abs(got - expected) <= per_pixel * expected), np.abs(got / expected - 1).max()
    assert np.all(np.abs(got.mean(0) - expected) <= 4 * expected / np.sqrt(K * n))
    if texels == (1, 1):
        # A constant World is sampled from the surface alone (world.h): for Lambert each sample is
        # L cos/pi / (cos/pi) = L, times rho, so an unoccluded convex ball has no noise at all.
        assert np.allclose(got, expected, rtol=1e-5), np.abs(got / expected - 1).max()
    # The world's light is the surface's direct light: the Diffuse pass holds it.
    assert np.allclose(passes["diffuse"][inner], got, rtol=1e-6)
    # Missed camera rays see the world itself, exactly: the bilinear blend of equal texels is t + 0.
    assert np.array_equal(passes["combined"][outer][:, :3], np.broadcast_to(np.float32(L), (outer.sum(), 3)))
    assert np.all(passes["combined"][outer][:, 3] == 1.0)


def test_bright_spot_irradiance_matches_the_integral():
    """A dim floor L0 plus a bright patch of texels: each ball pixel's irradiance / pi is
    rho (L0 + 1/pi sum over the patch of L_extra * integral of max(n . w, 0) over the texel), n the
    shading normal (the Normal pass), the integral by a 32x32 midpoint rule per texel. The map
    distribution samples the patch, the surface's the floor; the mean error over the ball is held
    to 4 standard errors of the per-pixel differences, and below 1 % of the mean."""
    w, h = 64, 32
    L0, extra = 0.05, 40.0
    world = np.full((h, w, 3), L0, np.float32)
    spot = (slice(20, 23), slice(40, 43))  # rows (v) 20..22, columns (u) 40..42: above the horizon
    world[spot] += extra
    cam = make_camera(48, 36, eye=(0.0, -3.2, 0.4))
    rho = 0.7
    passes, _ = render(cam, [dict(BALL, color=(rho,) * 3)], names=["combined", "normal"], world=world,
                       background=(0, 0, 0, 1), shading=dict(NO_PAPER_LIGHT, samples=8, world_samples=8))
    inner, _, _ = ball_pixels(cam)
    normal = passes["normal"][inner].astype(np.float64)
    sub = 32
    rows, cols = np.arange(spot[0].start, spot[0].stop), np.arange(spot[1].start, spot[1].stop)
    fu = (np.arange(sub) + 0.5) / sub
    u = (cols[:, None] + fu[None, :]).ravel() / w
    v = (rows[:, None] + fu[None, :]).ravel() / h
    uu, vv = np.meshgrid(u, v)
    dirs = env_direction(uu, vv).reshape(-1, 3)
    solid = (2 * np.pi / w / sub) * (np.pi / h / sub) * np.cos(np.pi * (vv.ravel() - 0.5))
    cosines = np.clip(normal @ dirs.T, 0.0, None)
    reference = rho * (L0 + extra / np.pi * cosines @ solid)
    got = passes["combined"][inner][:, 0].astype(np.float64)
    diff = got - reference
    stderr = diff.std() / np.sqrt(diff.size)
    assert abs(diff.mean()) < 4 * stderr + 1e-6, (diff.mean(), stderr)
    assert abs(diff.mean()) < 0.01 * reference.mean()
    # The patch lights part of the ball and not the rest: the test is not of a uniform world.
    assert reference.max() > 5 * reference.min()


@pytest.mark.parametrize("kernel", KERNELS)
def test_same_bits_for_any_threads_tiles_kernel_and_window(kernel):
    rng = np.random.default_rng(7)
    world = rng.random((16, 32, 3), dtype=np.float32) * 3
    cam = make_camera(40, 30)
    kw = dict(world=world, background=(0, 0, 0, 1), shading=dict(samples=3, world_samples=2, reflection_depth=1),
              names=["combined"])
    obj = dict(BALL, reflectivity=0.3)
    base, _ = render(cam, [obj], simd="portable", threads=1, tile_size=8, **kw)
    other, _ = render(cam, [obj], simd=kernel, threads=2, tile_size=32, **kw)
    assert np.array_equal(base["combined"].view(np.uint32), other["combined"].view(np.uint32))
    part, _ = render(cam, [obj], simd=kernel, window=(5, 7, 20, 11), **kw)
    assert np.array_equal(part["combined"].view(np.uint32), base["combined"][7:18, 5:25].view(np.uint32))


def test_missed_rays_see_the_map_bilinearly_and_a_transparent_film_hides_it():
    w, h = 16, 8
    rng = np.random.default_rng(3)
    world = rng.random((h, w, 3), dtype=np.float32)
    cam = make_camera(32, 24, eye=(0.0, -6.0, 0.0))
    passes, _ = render(cam, [BALL], names=["combined"], world=world, background=(0, 0, 0, 1))
    _, outer, direction = ball_pixels(cam)
    d = direction[outer]
    u = np.arctan2(-d[:, 1], d[:, 0]) / (2 * np.pi) + 0.5
    v = np.arctan2(d[:, 2], np.hypot(d[:, 0], d[:, 1])) / np.pi + 0.5
    x, y = u * w - 0.5, v * h - 0.5
    x0, y0 = np.floor(x).astype(int), np.floor(y).astype(int)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]
    i0, i1 = x0 % w, (x0 + 1) % w
    j0, j1 = np.clip(y0, 0, h - 1), np.clip(y0 + 1, 0, h - 1)
    expected = ((world[j0, i0] * (1 - fx) + world[j0, i1] * fx) * (1 - fy)
                + (world[j1, i0] * (1 - fx) + world[j1, i1] * fx) * fy)
    assert np.allclose(passes["combined"][outer][:, :3], expected, atol=2e-4)
    clear, _ = render(cam, [BALL], names=["combined"], world=world, background=(0, 0, 0, 0))
    assert np.all(clear["combined"][outer] == 0.0)


def test_shadows_are_marched_and_world_samples_zero_lights_nothing():
    """A second ball beside the first hides part of its sky: with shadows the facing side is
    darker than without; world_samples = 0 leaves only the (black) axle-free surface."""
    world = np.ones((8, 16, 3), np.float32)
    cam = make_camera(48, 36, eye=(0.0, -4.0, 0.0))
    objs = [BALL, dict(BALL, matrix=((1, 0, 0, 2.1), (0, 1, 0, 0), (0, 0, 1, 0), (0, 0, 0, 1)))]
    common = dict(names=["combined", "normal"], world=world, background=(0, 0, 0, 1))
    lit, _ = render(cam, objs, shading=dict(NO_PAPER_LIGHT, samples=4, world_samples=4, shadows="none"), **common)
    shadowed, _ = render(cam, objs, shading=dict(NO_PAPER_LIGHT, samples=4, world_samples=4), **common)
    inner, _, _ = ball_pixels(cam, margin=0.98)
    facing = inner & (lit["normal"][..., 0] > 0.5)  # the first ball's side toward the second
    ratio = shadowed["combined"][facing][:, 0].mean() / lit["combined"][facing][:, 0].mean()
    assert facing.sum() > 20 and ratio < 0.93, ratio
    dark, _ = render(cam, objs, shading=dict(NO_PAPER_LIGHT, world_samples=0), **common)
    assert np.all(dark["combined"][inner][:, :3] == 0.0)


@pytest.mark.parametrize("world, message", [
    (np.ones((4, 8, 3), np.float64), "dtype float32"),
    (np.ones((4, 8, 4), np.float32), "shape (height, width, 3)"),
    (np.ones((4, 8, 3), np.float32)[:, ::2], "C-contiguous"),
    (np.full((4, 8, 3), np.nan, np.float32), "finite"),
    (np.full((4, 8, 3), -1.0, np.float32), "within [0, 1e12]"),
    ([[1.0, 2.0, 3.0]], "float32 array"),
])
def test_bad_world_maps_are_refused_with_a_message(world, message):
    cam = make_camera(8, 6)
    with pytest.raises((TypeError, ValueError)) as err:
        render(cam, [BALL], names=["combined"], world=world)
    assert message in str(err.value)


def test_a_huge_world_map_is_refused():
    huge = np.zeros((4097, 2048, 3), np.float32)  # one row too many: 100 MB, refused before any work
    with pytest.raises(ValueError, match="larger than"):
        render(make_camera(8, 6), [BALL], names=["combined"], world=huge)


def test_world_samples_is_a_shading_parameter():
    row = uc.PARAMETERS["shading"]["world_samples"]
    assert (row["min"], row["max"], row["default"]) == (0, 64, 1)


def test_a_materials_alpha_shows_the_world_behind_it_not_the_background_colour():
    """A material's Alpha below 1 lets the world through, as Cycles' transparency does: where a World
    map is set, what shows through is the map along the ray, not the flat background colour (which a
    World replaces everywhere else too). A black, non-specular, non-emitting surface of alpha a over a
    uniform world of radiance L: every ball pixel is (1 - a) L; the background colour (red) is nowhere."""
    radiance, alpha = np.array([0.2, 0.4, 0.6], np.float32), 0.25
    cam = make_camera(32, 24, eye=(0.0, -6.0, 0.0))
    ball = dict(BALL, use_material=True, material_base_color=(0.0, 0.0, 0.0), material_specular_ior_level=0.0,
                material_alpha=alpha)
    passes, _ = render(cam, [ball], names=["combined"], world=uniform_world(radiance), background=(1, 0, 0, 1),
                       shading=dict(ambient=(0.0, 0.0, 0.0)))
    inner, _, _ = ball_pixels(cam)
    np.testing.assert_allclose(passes["combined"][inner][:, :3], np.broadcast_to((1 - alpha) * radiance, (inner.sum(), 3)),
                               rtol=1e-5, atol=1e-6)


@pytest.mark.parametrize("kernel", KERNELS)
def test_a_lights_and_the_worlds_shadow_rays_traced_together_keep_their_bits(kernel):
    """Issue 21: with a constant World of one sample a hit and hard shadows (the add-on's defaults),
    the AVX2 and AVX-512 kernels march the World's shadow rays together with the first light's
    (trace_pair); the portable kernel, and the same render with the light's shadows soft, march
    them one packet at a time. The same bits every way, with shadows in the picture: the light's
    and the World's shadow rays each blocked at some hits and not at others."""
    cam = make_camera(48, 36, eye=(0.4, -2.4, 1.2))
    julia = dict(mu=(-0.2, 0.8, 0.0, 0.0), max_iterations=12)
    point = dict(type="point", position=(1.2, -1.5, 1.8), color=(6.0, 6.0, 6.0))
    common = dict(world=uniform_world((0.6, 0.7, 0.8))[:1, :1].copy(), background=(0, 0, 0, 1),
                  names=["combined", "shadow", "diffuse"])
    shading = dict(axle_light=0.0, world_samples=1, reflection_depth=1, lights=[point])
    base, _ = render(cam, [julia], simd="portable", threads=1, shading=shading, **common)
    paired, _ = render(cam, [julia], simd=kernel, threads=2, tile_size=16, shading=shading, **common)
    for name in base:
        assert np.array_equal(base[name].view(np.uint32), paired[name].view(np.uint32)), name
    # A soft light's shadow rays are not paired: with radius 0 its shadows are the hard ones.
    soft, _ = render(cam, [julia], simd=kernel, shading=dict(shading, shadows="soft", lights=[dict(point, radius=0.0)]),
                     **common)
    assert np.array_equal(base["combined"].view(np.uint32), soft["combined"].view(np.uint32))
    # The light's shadows: the shadow pass (lit / unshadowed) is 0 at some hits and 1 at others.
    shadow = base["shadow"][..., 0]
    assert (shadow == 0.0).sum() > 20 and (shadow == 1.0).sum() > 20
    # The World's shadows: without them (shadows off) the diffuse light is larger at some hits.
    unshadowed, _ = render(cam, [julia], simd=kernel, shading=dict(shading, shadows="none", lights=[]), **common)
    lit_only_world, _ = render(cam, [julia], simd=kernel, shading=dict(shading, lights=[]), **common)
    more = unshadowed["diffuse"][..., 0] > lit_only_world["diffuse"][..., 0] * 1.01
    assert more.sum() > 20
