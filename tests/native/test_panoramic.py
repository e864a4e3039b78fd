"""Panoramic cameras (Cycles' equirectangular, fisheye equidistant / equisolid and mirror ball).

The references here are written independently of the core, from Cycles' own formulas
(intern/cycles/kernel/camera/projection.h: panorama_to_direction, and the turn
blender_camera_matrix gives panoramic cameras), in float64 numpy.

The analytic check of issue 17: mu = 0 is the closed unit ball exactly, so an equirectangular
render from distance d covers exactly the pixels whose direction lies within asin(1 / d) of the
direction to the centre. Pixel centres within RIM_EPS = 1e-6 radians of that rim may go either way
(float64 rays, float32 marching); every other pixel must be right. Measured at 1024 x 512 pixels,
d = 1.01, 1.5, 3, 8, 40, fixed and pixel thresholds: not one pixel on the wrong side, the pixel
centre nearest the rim 1.75e-6 rad from it (so the rule held with no tolerance at all there)."""
import math

import numpy as np
import pytest

from conftest import KERNELS, HEAVY_SHADING, KIND_OBJECTS, alloc_passes, render

import unbound_core as uc

BALL = dict(mu=(0.0, 0.0, 0.0, 0.0), max_iterations=32)
# Cycles' panorama space (x forward) -> Blender's camera space (x right, y up, looking down -z).
TURN = np.array([[0.0, -1.0, 0.0], [0.0, 0.0, 1.0], [-1.0, 0.0, 0.0]])
TURN_MIRRORBALL = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]])


def pano_camera(kind, width=96, height=48, eye=(0.4, -3.0, 0.9), target=(0.0, 0.0, 0.0), clip=(0.1, 100.0),
                **keys):
    matrix = uc.look_at(eye, target, (0.0, 0.0, 1.0))
    proj = uc.perspective(0.7, width / height, *clip)
    return dict(matrix=matrix, projection=proj, width=width, height=height, panorama_type=kind, **keys)


def reference_directions(cam, offset=0.5):
    """Cycles' panorama_to_direction at every pixel centre, turned and placed: world directions
    (H, W, 3), NaN outside the lens."""
    w, h = cam["width"], cam["height"]
    vp = cam.get("viewplane", (0.0, 1.0, 0.0, 1.0))
    ys, xs = np.mgrid[0:h, 0:w].astype(np.float64)
    u = vp[0] + (xs + offset) / w * (vp[1] - vp[0])
    v = vp[2] + (ys + offset) / h * (vp[3] - vp[2])
    kind = cam["panorama_type"]
    fov = cam.get("fisheye_fov", math.pi)
    turn = TURN
    if kind == "equirectangular":
        lon0, lon1 = cam.get("longitude_min", -math.pi), cam.get("longitude_max", math.pi)
        lat0, lat1 = cam.get("latitude_min", -math.pi / 2), cam.get("latitude_max", math.pi / 2)
        phi = (lon0 - lon1) * u - lon0
        theta = (lat0 - lat1) * v - lat0 + math.pi / 2
        d = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], -1)
    elif kind in ("fisheye_equidistant", "fisheye_equisolid"):
        if kind == "fisheye_equidistant":
            a, b = (u - 0.5) * 2.0, (v - 0.5) * 2.0
            r = np.hypot(a, b)
            outside = r > 1.0
            theta = r * fov * 0.5
        else:
            lens = cam.get("fisheye_lens", 10.5)
            a, b = (u - 0.5) * cam.get("sensor_width", 36.0), (v - 0.5) * cam.get("sensor_height", 24.0)
            r = np.hypot(a, b)
            outside = r > 2.0 * lens * math.sin(fov * 0.25)
            theta = 2.0 * np.arcsin(np.minimum(r / (2.0 * lens), 1.0))
        phi = np.arccos(np.clip(np.divide(a, r, out=np.zeros_like(a), where=r > 0), -1, 1))
        phi = np.where(b < 0.0, -phi, phi)
        d = np.stack([np.cos(theta), -np.cos(phi) * np.sin(theta), np.sin(phi) * np.sin(theta)], -1)
        d[outside] = np.nan
    elif kind == "mirrorball":
        a, b = 2.0 * u - 1.0, 2.0 * v - 1.0
        outside = a * a + b * b > 1.0
        p = np.stack([a, -np.sqrt(np.maximum(1.0 - a * a - b * b, 0.0)), b], -1)
        incoming = np.array([0.0, -1.0, 0.0])
        d = 2.0 * (p @ incoming)[..., None] * p - incoming
        d[outside] = np.nan
        turn = TURN_MIRRORBALL
    m = np.array(cam["matrix"], np.float64)
    rot = m[:3, :3] / np.linalg.norm(m[:3, :3], axis=0)
    d = d @ (rot @ turn).T
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


@pytest.mark.parametrize("kind, keys", [
    ("equirectangular", {}),
    ("equirectangular", dict(latitude_min=-0.5, latitude_max=1.2, longitude_min=-2.0, longitude_max=0.7)),
    ("fisheye_equidistant", dict(fisheye_fov=3.5)),
    ("fisheye_equisolid", dict(fisheye_lens=8.0, fisheye_fov=3.0, sensor_width=36.0, sensor_height=18.0)),
    ("mirrorball", {}),
    ("equirectangular", dict(viewplane=(0.1, 1.1, -0.05, 0.95))),
])
def test_rays_are_cycles_mapping(kind, keys):
    cam = pano_camera(kind, 40, 20, **keys)
    ref = reference_directions(cam)
    for y in range(cam["height"]):
        for x in range(cam["width"]):
            o, d, t0, t1 = uc.camera_ray(cam, x + 0.5, y + 0.5)
            assert o == pytest.approx((0.4, -3.0, 0.9), abs=1e-12)
            if np.isnan(ref[y, x, 0]):
                assert d == (0.0, 0.0, 0.0) and t0 == t1 == 0.0, (x, y)
            else:
                assert np.abs(np.array(d) - ref[y, x]).max() < 1e-12, (x, y, d, ref[y, x])
                assert t0 == pytest.approx(0.1, rel=1e-12) and t1 == pytest.approx(100.0, rel=1e-12)


def test_equirectangular_centre_looks_forward():
    """Cycles: the image centre looks along the camera's -Z, the right edge's middle to its +X
    (looking straight back at the left and right edges), the top row up."""
    cam = pano_camera("equirectangular", 64, 32, eye=(0.0, 0.0, 0.0), target=(0.0, 1.0, 0.0))
    _, d, _, _ = uc.camera_ray(cam, 32.0, 16.0)
    assert d == pytest.approx((0.0, 1.0, 0.0), abs=1e-12)
    _, d, _, _ = uc.camera_ray(cam, 48.0, 16.0)
    assert d == pytest.approx((1.0, 0.0, 0.0), abs=1e-12)
    _, d, _, _ = uc.camera_ray(cam, 32.0, 32.0)
    assert d == pytest.approx((0.0, 0.0, 1.0), abs=1e-12)


RIM_EPS = 1e-6  # radians: pixel centres this close to the ball's rim may go either way


@pytest.mark.parametrize("distance", [1.5, 3.0, 8.0])
@pytest.mark.parametrize("mode", ["fixed", "pixel"])
@pytest.mark.parametrize("keys", [{}, dict(latitude_min=-0.4, latitude_max=0.9, longitude_min=-1.0,
                                           longitude_max=0.8)], ids=["full", "part"])
def test_equirectangular_unit_ball_covers_the_analytic_cone(distance, mode, keys):
    """Issue 17: the unit ball from distance d covers exactly the directions within asin(1/d)
    of the centre, pixel by pixel."""
    eye = np.array([0.3, -1.0, 0.45])
    eye = eye / np.linalg.norm(eye) * distance
    # Looking away from the ball's centre a little, so the ball is off the image centre.
    cam = pano_camera("equirectangular", 256, 128, eye=tuple(eye), target=tuple(eye + np.array([-0.6, 1.0, -0.2])),
                      **keys)
    obj = dict(BALL, threshold_mode=mode, epsilon=1e-5)
    passes, stats = render(cam, [obj], ["alpha", "depth", "combined"])
    d = reference_directions(cam)
    to_centre = -eye / distance
    angle = np.arccos(np.clip(d @ to_centre, -1.0, 1.0))
    rim = math.asin(1.0 / distance)
    alpha = passes["alpha"][..., 0]
    hit = alpha == 1.0
    assert set(np.unique(alpha)) <= {0.0, 1.0}
    inside, outside = angle < rim - RIM_EPS, angle > rim + RIM_EPS
    assert inside.sum() >= 30 and outside.sum() > 30
    assert (np.abs(angle - rim) < 2 * math.pi / 256).sum() >= 10  # pixels near the rim are tested
    wrong = (inside & ~hit) | (outside & hit)
    margin = np.abs(angle - rim)[hit != (angle < rim)]
    print("distance %g, %s threshold: %d pixels on the wrong side of the rim, the farthest %.2e rad from it"
          % (distance, mode, margin.size, margin.max() if margin.size else 0.0))
    assert not wrong.any(), np.argwhere(wrong)[:8]
    # Depth of a panoramic camera is the distance along the ray (Cycles' camera_z_depth).
    b = distance * np.cos(angle)
    t = b - np.sqrt(np.maximum(b * b - (distance * distance - 1.0), 0.0))
    depth = passes["depth"][..., 0]
    assert np.abs(depth[inside] - t[inside]).max() < 2e-4
    assert np.all(depth[~hit] == np.float32(1e10))


@pytest.mark.parametrize("kind, keys", [
    ("fisheye_equidistant", dict(fisheye_fov=2.5)),
    ("fisheye_equisolid", dict(fisheye_lens=10.5, fisheye_fov=2.8, sensor_width=36.0, sensor_height=18.0)),
    ("mirrorball", {}),
])
def test_outside_the_lens_is_opaque_black_as_in_cycles(kind, keys):
    """Cycles traces no ray outside the lens: the pixel is black with alpha 1 (transparent film or
    not; measured in Blender 4.2), its Depth 1e10. Inside, the background shows as usual."""
    cam = pano_camera(kind, 64, 32, eye=(0.0, -3.0, 0.0), **keys)
    lens = ~np.isnan(reference_directions(cam)[..., 0])
    assert lens.any() and (~lens).any()
    for background in [(0.2, 0.3, 0.4, 1.0), (0.0, 0.0, 0.0, 0.0)]:
        passes, _ = render(cam, [BALL], ["combined", "alpha", "depth", "normal"], background=background)
        combined = passes["combined"]
        assert np.all(combined[~lens] == np.array([0.0, 0.0, 0.0, 1.0], np.float32))
        assert np.all(passes["alpha"][~lens] == 0.0)
        assert np.all(passes["depth"][~lens] == np.float32(1e10))
        assert np.all(passes["normal"][~lens] == 0.0)
        missed = lens & (passes["alpha"][..., 0] == 0.0)
        assert missed.any() and np.all(combined[missed] == np.array(background, np.float32))
        assert (passes["alpha"][lens] == 1.0).any()


@pytest.mark.parametrize("kind, keys", [
    ("equirectangular", dict(latitude_min=-1.0, latitude_max=1.0)),
    ("fisheye_equidistant", dict(fisheye_fov=3.2)),
    ("fisheye_equisolid", dict(fisheye_lens=9.0, sensor_width=36.0, sensor_height=24.0)),
    ("mirrorball", {}),
])
def test_bit_identical_for_threads_tiles_simd_and_windows(kind, keys):
    """Same bits in the portable and AVX2 kernels, for every thread count and tile size, and a
    window equals the crop of the full image; every effect, every pass."""
    cam = pano_camera(kind, 48, 32, eye=(0.5, -2.2, 0.6), **keys)
    obj = KIND_OBJECTS["quaternion_julia"]
    shading = dict(HEAVY_SHADING, samples=2)
    ref, _ = render(cam, [obj], shading=shading, threads=1, tile_size=32, simd="portable")
    for threads, tile, simd in [(2, 13, KERNELS[-1]), (3, 1, "portable"), (1, 64, KERNELS[-2 if len(KERNELS) > 2 else -1])]:
        out, _ = render(cam, [obj], shading=shading, threads=threads, tile_size=tile, simd=simd)
        for k in ref:
            assert ref[k].tobytes() == out[k].tobytes(), (k, threads, tile, simd)
    window = (5, 3, 30, 20)
    out, _ = render(cam, [obj], shading=shading, window=window, threads=2)
    for k in ref:
        assert ref[k][3:23, 5:35].tobytes() == out[k].tobytes(), k


def test_pixel_footprint_and_precision_ratio():
    """The pixel threshold uses the angle a pixel spans (the footprint per unit distance)."""
    cam = pano_camera("equirectangular", 360, 180)
    _, stats = render(cam, [BALL], ["depth"])
    # 2 pi / 360 rad per pixel; nearest hit at distance |eye| - 1.
    nearest = math.sqrt(0.4 ** 2 + 3.0 ** 2 + 0.9 ** 2) - 1.0
    assert stats["footprint_ratio"] == pytest.approx(2 * math.pi / 360 * nearest, rel=1e-3)


@pytest.mark.parametrize("keys, message", [
    (dict(panorama_type="cylindrical"), "panorama_type"),
    (dict(panorama_type="equirectangular", latitude_min=0.3, latitude_max=0.3, longitude_min=1.0, longitude_max=1.0),
     "must not both be empty"),
    (dict(panorama_type="fisheye_equidistant", fisheye_fov=0.0), "fisheye_fov"),
    (dict(panorama_type="equirectangular", latitude_max=2.0), "latitude_max"),
    (dict(panorama_type="fisheye_equisolid", fisheye_lens=math.nan), "fisheye_lens"),
])
def test_bad_panoramic_keys_are_refused(keys, message):
    cam = dict(pano_camera("mirrorball", 16, 8), **keys)
    with pytest.raises(ValueError, match=message):
        uc.render(cam, [BALL], alloc_passes(16, 8, ["combined"]))


def test_perspective_camera_ignores_panoramic_keys():
    """Without a panorama_type the panoramic keys change nothing."""
    cam = pano_camera("none", 32, 24)
    ref, _ = render(cam, [BALL])
    out, _ = render(dict(cam, fisheye_fov=1.0, latitude_min=0.2, viewplane=(0.3, 0.4, 0.0, 2.0)), [BALL])
    for k in ref:
        assert ref[k].tobytes() == out[k].tobytes(), k
