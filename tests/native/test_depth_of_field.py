"""Depth of field: Cycles' thin lens (issue 19).

The reference rays here are written independently of the core, in float64 numpy, from Cycles'
own code (intern/cycles/kernel/camera/camera.h: camera_sample_aperture, camera_sample_perspective,
camera_sample_orthographic, camera_sample_panorama; kernel/sample/mapping.h: sample_uniform_disk,
regular_polygon_sample), in Cycles' camera space (x right, y up, z forward) and turned to
Blender's as blender_camera_matrix does. tests/blender/test_depth_of_field_blender.py compares
whole blurred renders with Cycles' own.

Without depth of field (aperture 0) nothing changes, bit for bit; a lens far smaller than a pixel
gives the pinhole's picture; the lens samples are the same on every thread, tile, SIMD path and
window, and stratified per pixel."""
import math

import numpy as np
import pytest
import unbound_core as uc

from conftest import HEAVY_SHADING, KIND_OBJECTS, UNIT_BALL as BALL, alloc_passes, make_camera, render
from test_panoramic import TURN, TURN_MIRRORBALL, pano_camera
LENS = dict(aperture_size=0.15, focus_distance=2.2, aperture_blades=0, aperture_rotation=0.0, aperture_ratio=1.0)
SHAPES = {
    "disk": {},
    "disk_anamorphic": dict(aperture_ratio=1.7),
    "pentagon_turned": dict(aperture_blades=5, aperture_rotation=0.4),
    "triangle_anamorphic": dict(aperture_blades=3, aperture_rotation=-1.1, aperture_ratio=0.6),
    "two_blades_are_a_disk": dict(aperture_blades=2, aperture_rotation=0.7),
}
# Lens points of the unit square: corners, edges, the centre and a scatter.
UV = [(0.0, 0.0), (0.999, 0.0), (0.0, 0.999), (0.999, 0.999), (0.5, 0.5), (0.5, 0.1), (0.25, 0.75)] + [
    tuple(p) for p in np.random.default_rng(19).random((40, 2))]


def cycles_aperture(uv, blades, rotation, ratio, size):
    """Cycles' camera_sample_aperture times the aperture size: a lens point (x, y)."""
    u, v = uv
    if blades < 3:  # sample_uniform_disk: the concentric map
        a, b = 2.0 * u - 1.0, 2.0 * v - 1.0
        if a == 0.0 and b == 0.0:
            x = y = 0.0
        elif a * a > b * b:
            x, y = a * math.cos(math.pi / 4 * (b / a)), a * math.sin(math.pi / 4 * (b / a))
        else:
            phi = math.pi / 2 - math.pi / 4 * (a / b)
            x, y = b * math.cos(phi), b * math.sin(phi)
    else:  # regular_polygon_sample
        corner = math.floor(u * blades)
        u = math.sqrt(u * blades - corner)
        v, u = v * u, 1.0 - u
        angle = math.pi / blades
        px, py = (u + v) * math.cos(angle), (u - v) * math.sin(angle)
        turn = rotation + corner * 2.0 * math.pi / blades
        x, y = math.cos(turn) * px - math.sin(turn) * py, math.sin(turn) * px + math.cos(turn) * py
    return np.array([x / ratio * size, y * size])


def camera_rotation(cam):
    m = np.array(cam["matrix"], np.float64)
    return m[:3, :3] / np.linalg.norm(m[:3, :3], axis=0), m[:3, 3]


def to_cycles(v):
    """Blender's camera space (looking down -z) -> Cycles' (looking down +z), and back."""
    return np.array([v[0], v[1], -v[2]])


def reference_projection_ray(cam, x, y, lens):
    """Cycles' perspective / orthographic thin-lens ray at full-image point (x, y), world space:
    (origin at the ray's start, unit direction, t_min, t_max) with the core's convention that the
    ray starts at origin + t_min * direction."""
    keys = dict(LENS, **{k: v for k, v in cam.items() if k in LENS})
    w, h = cam["width"], cam["height"]
    inv = np.linalg.inv(np.array(cam["projection"], np.float64))
    ndc = np.array([2 * x / w - 1, 2 * y / h - 1, -1.0, 1.0])
    near_point = inv @ ndc
    near_point = near_point[:3] / near_point[3]
    far_ndc = ndc.copy()
    far_ndc[2] = 1.0
    far_point = inv @ far_ndc
    far_point = far_point[:3] / far_point[3]
    near, far = -near_point[2], -far_point[2]
    lx, ly = cycles_aperture(lens, keys["aperture_blades"], keys["aperture_rotation"], keys["aperture_ratio"],
                             keys["aperture_size"])
    focus = max(keys["focus_distance"], 1e-5)
    if cam["projection"][3][2] != 0.0:  # perspective: Pcamera is the pinhole's direction
        pc = to_cycles(near_point)
        p_focus = pc * (focus / pc[2])
        p = np.array([lx, ly, 0.0])
        d = (p_focus - p) / np.linalg.norm(p_focus - p)
        z_inv = 1.0 / (pc / np.linalg.norm(pc))[2]
        # Cycles starts the ray nearclip * z_inv along it and runs it cliplength * z_inv.
        origin, t_min, t_max = p, near * z_inv, far * z_inv
    else:  # orthographic: Pcamera on the camera plane
        pc = to_cycles(near_point)
        pc[2] = 0.0
        lens_point = np.array([lx, ly, 0.0])
        d = np.array([0.0, 0.0, focus]) - lens_point
        d /= np.linalg.norm(d)
        origin = pc + lens_point
        t_min = near / d[2]
        t_max = t_min + (far - near)
    rot, position = camera_rotation(cam)
    return rot @ to_cycles(origin) + position, rot @ to_cycles(d), t_min, t_max


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
def test_rays_are_cycles_thin_lens(projection, shape):
    cam = make_camera(64, 48, ortho_height=None if projection == "perspective" else 2.5, clip=(0.3, 40.0))
    cam.update(LENS, **SHAPES[shape])
    worst = 0.0
    for i, uv in enumerate(UV):
        x, y = 0.5 + (i * 13) % 64, 0.5 + (i * 7) % 48
        o, d, t0, t1 = (np.array(v) for v in uc.camera_ray(cam, x, y, uv))
        ro, rd, r0, r1 = reference_projection_ray(cam, x, y, uv)
        # The same segment: start, direction, end.
        worst = max(worst, np.abs(o + t0 * d - (ro + r0 * rd)).max(), np.abs(d - rd).max(),
                    np.abs(o + t1 * d - (ro + r1 * rd)).max() / 40.0)
    assert worst < 1e-12, worst


@pytest.mark.parametrize("kind, turn", [("equirectangular", TURN), ("fisheye_equidistant", TURN),
                                        ("fisheye_equisolid", TURN), ("mirrorball", TURN_MIRRORBALL)])
@pytest.mark.parametrize("shape", ["disk_anamorphic", "triangle_anamorphic"])
def test_panoramic_rays_are_cycles_thin_lens(kind, turn, shape):
    """camera_sample_panorama: the lens across the pinhole's ray D, its axes U = (x - D.x D)
    normalised and V = D x U in Cycles' panorama space (x forward), turned to Blender's."""
    keys = dict(LENS, **SHAPES[shape])
    cam = pano_camera(kind, 64, 32, clip=(0.2, 50.0), **keys)
    rot, position = camera_rotation(cam)
    checked = 0
    for i, uv in enumerate(UV):
        x, y = 0.5 + (i * 13) % 64, 0.5 + (i * 5) % 32
        pin_o, pin_d, _, _ = uc.camera_ray(cam, x, y)
        if not any(pin_d):
            continue  # outside the fisheye's or the mirror ball's circle
        o, d, t0, t1 = (np.array(v) for v in uc.camera_ray(cam, x, y, uv))
        D = turn.T @ (rot.T @ np.array(pin_d))  # the pinhole's direction in Cycles' panorama space
        U = np.array([1.0, 0.0, 0.0]) - D[0] * D
        U /= np.linalg.norm(U)
        V = np.cross(D, U)
        V /= np.linalg.norm(V)
        lx, ly = cycles_aperture(uv, keys["aperture_blades"], keys["aperture_rotation"], keys["aperture_ratio"],
                                 keys["aperture_size"])
        p = U * lx + V * ly
        rd = D * keys["focus_distance"] - p
        rd /= np.linalg.norm(rd)
        ro = rot @ (turn @ p) + position
        rd = rot @ (turn @ rd)
        assert np.abs(o - ro).max() < 1e-12 and np.abs(d - rd).max() < 1e-12, (x, y, uv)
        assert (t0, t1) == pytest.approx((0.2, 50.0), rel=1e-12)
        checked += 1
    assert checked > 20


CAMERAS = {
    "perspective": make_camera(40, 30, eye=(0.3, -3.2, 0.6)),
    "orthographic": make_camera(40, 30, eye=(0.3, -3.2, 0.6), ortho_height=2.6),
    "equirectangular": pano_camera("equirectangular", 40, 20, eye=(0.3, -1.8, 0.4)),
    "mirrorball": pano_camera("mirrorball", 30, 30, eye=(0.3, -2.2, 0.4)),
}


@pytest.mark.parametrize("name", CAMERAS)
def test_aperture_zero_is_the_pinhole_bit_for_bit(name):
    """aperture_size 0 with every other lens key set: the same bytes in every pass as a camera
    without the keys (also with samples, and for camera_ray with a lens point)."""
    cam = CAMERAS[name]
    off = dict(cam, **dict(LENS, aperture_size=0.0, aperture_blades=6, aperture_ratio=3.0))
    shading = dict(HEAVY_SHADING, samples=3)
    objects = [dict(KIND_OBJECTS["quaternion_julia"], normal_method="zbuffer")]
    ref, _ = render(cam, objects, shading=shading)
    out, _ = render(off, objects, shading=shading)
    for k in ref:
        assert ref[k].tobytes() == out[k].tobytes(), k
    for uv in UV[:8]:
        assert uc.camera_ray(off, 11.3, 7.9, uv) == uc.camera_ray(cam, 11.3, 7.9)


@pytest.mark.parametrize("name", ["perspective", "orthographic"])
def test_tiny_aperture_in_focus_is_the_pinhole(name):
    """Focus on the ball, a lens a millionth of the ball: the pinhole's picture. Each ray moves by
    at most the lens' radius, far below a pixel, so coverage differs only where a sample lies
    within that of the silhouette (none here), and depth by rounding."""
    cam = CAMERAS[name]
    focus = float(np.linalg.norm(np.array(cam["matrix"])[:3, 3]))
    lens = dict(cam, aperture_size=1e-6, focus_distance=focus, aperture_blades=5)
    shading = dict(samples=4)
    ref, _ = render(cam, [BALL], ["alpha", "depth", "combined"], shading=shading)
    out, _ = render(lens, [BALL], ["alpha", "depth", "combined"], shading=shading)
    assert ref["alpha"].sum() > 100
    assert np.array_equal(ref["alpha"], out["alpha"])
    hit = ref["alpha"][..., 0] == 1
    assert np.abs(out["depth"][hit] - ref["depth"][hit]).max() < 1e-5
    assert np.abs(out["combined"] - ref["combined"]).max() < 1e-4


def test_out_of_focus_ball_is_blurred_by_the_circle_of_confusion():
    """A thin lens of radius A focused at distance f blurs a point at depth z into a disk of
    radius A |1 - f / z| on the plane in focus, i.e. A |1/f - 1/z| / tan per unit of the image's
    half height (tan = tan(fov_y / 2)). The unit ball at distance 4 from the camera (its
    silhouette at depth about 3.75): the 50 % alpha ring stays at the sharp silhouette's radius,
    and alpha falls from 1 to 0 over a band about twice the blur radius wide."""
    fov_y, size = 0.6, 96
    cam = make_camera(size, size, eye=(0.0, -4.0, 0.0), fov_y=fov_y)
    aperture, focus = 0.12, 2.0
    sharp, _ = render(cam, [BALL], ["alpha"], shading=dict(samples=16))
    blurred, _ = render(dict(cam, aperture_size=aperture, focus_distance=focus), [BALL], ["alpha"],
                        shading=dict(samples=256))
    z = math.sqrt(4.0 ** 2 - 1.0)  # depth of the silhouette circle along the view axis
    pixels_per_unit = size / 2 / math.tan(fov_y / 2)
    blur_radius = aperture * abs(1 / focus - 1 / z) * pixels_per_unit
    ys, xs = np.mgrid[0:size, 0:size]
    r = np.hypot(xs + 0.5 - size / 2, ys + 0.5 - size / 2)
    silhouette = math.tan(math.asin(1 / 4.0)) * pixels_per_unit
    a = blurred["alpha"][..., 0]
    assert np.all(a[r < silhouette - 1.05 * blur_radius - 1] == 1.0)
    assert np.all(a[r > silhouette + 1.05 * blur_radius + 1] == 0.0)
    ring = np.abs(r - silhouette) < 1.0
    assert 0.4 < a[ring].mean() < 0.6
    # Blurred for real: a band of partial coverage about 2 * blur_radius wide (the sharp one: ~1 px).
    partial = (a > 0.02) & (a < 0.98)
    band = partial.sum() / (2 * math.pi * silhouette)
    sharp_band = ((sharp["alpha"][..., 0] > 0.02) & (sharp["alpha"][..., 0] < 0.98)).sum() / (2 * math.pi * silhouette)
    assert blur_radius > 4 and 1.4 * blur_radius < band < 2.1 * blur_radius and sharp_band < 1.5, \
        (blur_radius, band, sharp_band)


def test_same_bytes_for_threads_tiles_simd_windows_and_sample_ranges():
    cam = dict(make_camera(53, 37), **dict(LENS, aperture_blades=6, aperture_rotation=0.3))
    objects = [dict(KIND_OBJECTS["quaternion_julia"], normal_method="zbuffer")]
    shading = dict(HEAVY_SHADING, samples=3)
    ref, _ = render(cam, objects, shading=shading, threads=1, tile_size=32)
    paths = ["portable"] + (["avx2"] if uc.cpu_info()["avx2_fma"] else [])
    for threads, tile, simd in [(3, 7, paths[-1]), (2, 64, paths[0])]:
        out, _ = render(cam, objects, shading=shading, threads=threads, tile_size=tile, simd=simd)
        for k in ref:
            assert ref[k].tobytes() == out[k].tobytes(), (k, threads, tile, simd)
    # A window renders the full image's pixels: a pixel's lens samples follow its place in the image.
    part, _ = render(cam, objects, shading=shading, window=(9, 5, 30, 22))
    for k in ref:
        assert np.array_equal(part[k], ref[k][5:27, 9:39], equal_nan=True), k
    acc = alloc_passes(53, 37)
    for first in range(3):
        uc.render(cam, objects, acc, shading=shading, sample_range=(first, 1))
    for k in ref:
        assert ref[k].tobytes() == acc[k].tobytes(), k


def test_lens_samples_are_stratified_per_pixel_and_differ_between_pixels():
    """Halton bases 5 and 7, turned per pixel: any 5 consecutive-from-0 samples put one u in each
    fifth of [0, 1), the first 7 one v in each seventh; neighbours start elsewhere."""
    starts = set()
    for x, y in [(0, 0), (1, 0), (0, 1), (17, 3), (1919, 1079), (-1, -1)]:
        uv = np.array([uc.lens_sample(s, x, y) for s in range(49)])
        assert ((0 <= uv) & (uv < 1)).all()
        assert sorted(np.floor(uv[:5, 0] * 5).astype(int)) == list(range(5))
        assert sorted(np.floor(uv[:25, 0] * 25).astype(int)) == list(range(25))
        assert sorted(np.floor(uv[:7, 1] * 7).astype(int)) == list(range(7))
        assert sorted(np.floor(uv[:49, 1] * 49).astype(int)) == list(range(49))
        starts.add(uc.lens_sample(0, x, y))
    assert len(starts) == 6


@pytest.mark.parametrize("name", CAMERAS)
def test_extreme_lens_values_give_finite_rays(name):
    """The table's extremes (a focus distance of 1.7e308, a lens of 1e6, ratios of 1e-3 and 1e300)
    still give unit directions and finite t ranges."""
    cam = CAMERAS[name]
    for focus in (0.0, 1e-5, 1.7e308):
        for size in (1e-300, 1e6):
            for ratio in (1e-3, 1e300):
                keys = dict(cam, aperture_size=size, focus_distance=focus, aperture_ratio=ratio, aperture_blades=7)
                for uv in UV[:7]:
                    o, d, t0, t1 = uc.camera_ray(keys, 10.5, 5.5, uv)
                    if name == "mirrorball" and not any(d):
                        continue
                    assert np.isfinite(o + (t0, t1)).all() and abs(np.linalg.norm(d) - 1) < 1e-12, (keys, uv)


@pytest.mark.parametrize("keys, message", [
    (dict(aperture_size=-0.1), r"camera\.aperture_size must be in \[0, "),
    (dict(aperture_size=math.nan), r"camera\.aperture_size must be finite"),
    (dict(focus_distance=-1.0), r"camera\.focus_distance must be in \[0, "),
    (dict(aperture_ratio=0.0), r"camera\.aperture_ratio must be in \[0\.001, "),
    (dict(aperture_blades=101), r"camera\.aperture_blades must be in \[0, 100\]"),
    (dict(aperture_rotation=math.inf), r"camera\.aperture_rotation must be finite"),
])
def test_bad_lens_keys_are_refused(keys, message):
    with pytest.raises(ValueError, match=message):
        render(dict(make_camera(8, 6), **keys), [BALL], ["alpha"])


def test_camera_ray_lens_argument_is_checked():
    cam = make_camera(8, 6)
    with pytest.raises(ValueError, match=r"lens\[1\] must be in \[0, 1\]"):
        uc.camera_ray(cam, 1.0, 1.0, (0.5, 1.5))
    with pytest.raises(TypeError, match="lens must be a pair"):
        uc.camera_ray(cam, 1.0, 1.0, (0.5,))
