"""The viewport's progressive refinement in the core: strided sub-grids of the image and samples
rendered a few at a time must add up to exactly the bytes of one whole render."""
import numpy as np
import pytest
import unbound_core as uc

from conftest import HEAVY_SHADING, KIND_OBJECTS, alloc_passes, make_camera, render

SHADING_1 = dict(HEAVY_SHADING, samples=1)


def interleaved(camera, objects, start_stride, window=None, **kw):
    """The image assembled as the viewport builds it: the grid of `start_stride`, then at each
    halving of the stride the three sub-grids between the pixels already rendered."""
    x0, y0, w, h = window or (0, 0, camera["width"], camera["height"])
    out = alloc_passes(w, h)
    rays = 0

    def piece(ox, oy, stride):
        nonlocal rays
        if ox >= w or oy >= h:
            return
        cols, rows = -(-(w - ox) // stride), -(-(h - oy) // stride)
        part = alloc_passes(cols, rows)
        stats = uc.render(camera, objects, part, window=(x0 + ox, y0 + oy, cols, rows), stride=stride, **kw)
        rays += stats["rays"]
        for k in out:
            out[k][oy::stride, ox::stride] = part[k]

    piece(0, 0, start_stride)
    d = start_stride // 2
    while d >= 1:
        for ox, oy in ((d, 0), (0, d), (d, d)):
            piece(ox, oy, 2 * d)
        d //= 2
    return out, rays


@pytest.mark.parametrize("kind", sorted(KIND_OBJECTS))
def test_interleaved_sub_grids_equal_the_whole_render(kind):
    """Every pass, every kind, with shadows, reflections, AO, fog, glow and the sea: bit for bit."""
    cam = make_camera(61, 37)
    obj = KIND_OBJECTS[kind]
    ref, _ = render(cam, [obj], shading=SHADING_1)
    out, _ = interleaved(cam, [obj], 8, shading=SHADING_1)
    for k in ref:
        assert ref[k].tobytes() == out[k].tobytes(), (kind, k)


def test_interleaved_window_equals_the_crop_and_costs_one_ray_per_pixel_plus_aprons():
    cam = make_camera(80, 60)
    obj = KIND_OBJECTS["quaternion_julia"]
    full, _ = render(cam, [obj])
    window = (13, 7, 41, 29)
    out, rays = interleaved(cam, [obj], 4, window=window)
    for k in full:
        assert np.array_equal(out[k], full[k][7:36, 13:54], equal_nan=True), k
    # Each sub-grid marches its pixels and a one-pixel apron on its own grid (the Z-buffer
    # normals read neighbours): at most 2 (cols + rows) + 4 extra rays per piece of 7.
    assert 41 * 29 <= rays <= 41 * 29 + 7 * (2 * (41 + 29) + 4)


def test_stride_renders_the_grid_pixels_of_the_full_image():
    cam = make_camera(50, 30)
    obj = KIND_OBJECTS["quaternion_julia"]
    full, _ = render(cam, [obj])
    part, _ = render(cam, [obj], window=(3, 1, 12, 8), stride=4)
    for k in full:
        assert np.array_equal(part[k], full[k][1::4, 3::4][:8, :12], equal_nan=True), k
    grid = alloc_passes(7, 4)
    stats = uc.render(cam, [obj], grid, stride=8)  # no window: the whole image's grid, ceil(50/8) x ceil(30/8)
    for k in full:
        assert np.array_equal(grid[k], full[k][::8, ::8], equal_nan=True), k
    assert stats["rays"] == 7 * 4  # the grid covers the whole image: no apron beyond it


def test_zbuffer_normals_on_a_grid_use_the_grids_neighbours():
    """Coarse Z-buffer normals come from the coarse grid (a preview); they stay unit vectors."""
    cam = make_camera(64, 48)
    obj = dict(KIND_OBJECTS["quaternion_julia"], normal_method="zbuffer")
    grid = alloc_passes(16, 12)
    uc.render(cam, [obj], grid, stride=4)
    hit = grid["alpha"][..., 0] > 0
    lengths = np.linalg.norm(grid["normal"][hit], axis=-1)
    assert hit.sum() > 20 and np.allclose(lengths, 1.0, atol=1e-5)


@pytest.mark.parametrize("split", [(1, 1, 1, 1), (2, 2), (1, 3)])
def test_samples_in_ranges_accumulate_to_the_whole_render(split):
    """Samples rendered a range at a time into the same buffers (their running sum) give, after
    the last, the bytes of one render of all samples; before it, the undivided sum."""
    cam = make_camera(45, 33)
    obj = KIND_OBJECTS["quaternion_julia"]
    shading = dict(HEAVY_SHADING, samples=4)
    ref, _ = render(cam, [obj], shading=shading)
    acc = alloc_passes(45, 33)
    first = 0
    for count in split:
        stats = uc.render(cam, [obj], acc, shading=shading, sample_range=(first, count))
        assert stats["rays"] == 45 * 33 * count and not stats["cancelled"]
        first += count
        if first == 1:
            one, _ = render(cam, [obj], shading=dict(shading, samples=1))
            np.testing.assert_allclose(acc["combined"], one["combined"], rtol=0, atol=0)
    for k in ref:
        assert ref[k].tobytes() == acc[k].tobytes(), (split, k)


@pytest.mark.parametrize("kwargs, message", [
    (dict(stride=0), "stride"),
    (dict(stride=5000), "stride"),
    (dict(stride=float("nan")), "stride"),
    (dict(stride=4, window=(0, 0, 17, 12)), "window (x, y, width, height) must lie inside the 64x48 image"),
    (dict(sample_range=(0, 0)), "sample_range must be 2 integers (first, count)"),
    (dict(sample_range=(1, 2)), "first + count <= shading samples (2)"),
    (dict(sample_range=(-1, 1)), "sample_range"),
    (dict(sample_range=(0.5, 1)), "sample_range"),
    (dict(sample_range=(float("inf"), 1)), "sample_range"),
])
def test_bad_stride_and_sample_range_are_named(kwargs, message):
    cam = make_camera(64, 48)
    w, h = (17, 12) if "window" in kwargs else (64, 48)
    with pytest.raises((ValueError, TypeError)) as info:
        uc.render(cam, [KIND_OBJECTS["quaternion_julia"]], alloc_passes(w, h, ["combined"]),
                  shading=dict(samples=2), **kwargs)
    assert message in str(info.value)
