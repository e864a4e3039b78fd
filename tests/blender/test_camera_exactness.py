"""Unbound's geometry is Cycles' geometry.

For each camera case one bpy process renders the same scene through Blender's pipeline with
Cycles (a finely subdivided unit sphere mesh, also scaled by 1 -/+ BAND, see 3.) and with Unbound
(mu = 0: K_0 is the unit ball).
If Unbound uses Blender's camera exactly (matrix, projection, shift, sensor fit, orthographic
scale, pixel aspect, resolution percentage, render border with and without crop), the two
silhouettes and Depth passes agree up to the mesh's polygonal error.

What the mesh can and cannot tell apart, at the 96 x 72 pixels used here:

* A UV sphere with 256 segments and 128 rings has its vertices on the sphere and its faces inside
  it, by at most 2 (1 - cos(pi/256)) ~ 1.5e-4 (the sagitta of both edge directions).
* The sphere spans about 45 pixels per world unit, so 1e-3 world units are about 0.05 pixel.
  Cycles' pixel filter is made 0.01 pixel wide: its samples land within 0.005 pixel of the pixel
  centre, where Unbound shoots its single ray.

Checks (tolerances stated where they are asserted):

1. Output size: both engines write images of the same size (the cropped border, or full frame);
   placement inside an uncropped border is checked by 2-5 on the full frame.
2. Silhouette IoU (alpha > 0.5) against the unit mesh >= IOU_MIN. Measured: 1.0 in every case but
   the pixel-aspect-2 one (0.9989: a handful of pixels whose centre lies within the mesh's 1.5e-4
   sagitta of the true silhouette, which the mesh misses and the true ball does not). A border
   one pixel off, as with the double-precision border fixed in export.image_window, gave 0.94.
3. Sandwich, a sharper test of the camera: the unit ball lies between the mesh scaled by
   1 - BAND (inside the ball) and by 1 + BAND (containing it), so Unbound's silhouette must
   contain the inner mesh's and lie inside the outer mesh's, and its Depth must lie between the
   two meshes' Depth wherever the inner mesh covers the pixel. With BAND = 1e-3 (about 0.05
   pixel) a camera off by a tenth of a pixel fails by hundreds of pixels (checked by moving the
   projection 0.1 pixel sideways; its IoU was still 0.998, so IoU alone would not see it).
4. Depth against the unit mesh, on pixels inside both silhouettes eroded by 2 pixels (near the
   silhouette the depth is steep and the mesh error is divided by a grazing cosine):
   max |difference| <= DEPTH_TOL = 1e-3 world units. Measured: at most 5.1e-4, median 1.2e-4,
   Cycles always the deeper (the mesh is inside the ball).
5. Background: where neither engine hits, Unbound's Depth equals Cycles' exactly: 1e10 inside
   the rendered window (both engines write it), and Blender's own fill (1e11) outside an uncropped
   render border.
"""
import math

import numpy as np
import pytest

IOU_MIN = 0.995
BAND = 1e-3
DEPTH_TOL = 1e-3
BACKGROUND_DEPTH = 1e10

FAR = (0.4, -3.0, 0.9)        # camera location used by most cases (the unit ball fills the frame)
BORDER = dict(use_border=True, border_min_x=0.1, border_max_x=0.55, border_min_y=0.15, border_max_y=0.62)
BORDER_F32 = dict(use_border=True, border_min_x=0.05, border_max_x=0.7, border_min_y=0.1, border_max_y=0.58,
                  resolution_x=100, resolution_y=50)

# id: (camera location, camera data attributes, camera object scale, scene.render attributes)
CASES = {
    "perspective_shift_vertical_fit": (FAR, dict(lens=50.0, shift_x=0.1, shift_y=-0.05, sensor_fit='VERTICAL'),
                                       None, {}),
    "perspective_horizontal_fit_portrait": (FAR, dict(lens=35.0, shift_y=0.08, sensor_fit='HORIZONTAL'), None,
                                            dict(resolution_x=60, resolution_y=90)),
    "orthographic": (FAR, dict(type='ORTHO', ortho_scale=3.0, shift_x=-0.07), None, {}),
    "pixel_aspect_x_2": (FAR, dict(lens=50.0), None, dict(pixel_aspect_x=2.0)),
    "pixel_aspect_y_1.5_shift": (FAR, dict(lens=50.0, shift_x=0.1), None, dict(pixel_aspect_y=1.5)),
    "ortho_pixel_aspect_y_1.5": (FAR, dict(type='ORTHO', ortho_scale=2.6), None, dict(pixel_aspect_y=1.5)),
    "border_crop": (FAR, dict(lens=35.0), None, dict(BORDER, use_crop_to_border=True)),
    "border_no_crop": (FAR, dict(lens=35.0), None, dict(BORDER, use_crop_to_border=False)),
    "border_odd_fractions_percentage_50_aspect": (
        FAR, dict(lens=35.0, shift_x=0.05), None,
        dict(use_border=True, use_crop_to_border=True, border_min_x=0.123, border_max_x=0.6789,
             border_min_y=0.3333, border_max_y=0.951, resolution_percentage=50, pixel_aspect_x=1.3)),
    # Blender computes the border in float32 (border.xmin * winx in C): 0.7f * 100 = 70, not 69.
    "border_float32_rounding_crop": (FAR, dict(lens=35.0), None, dict(BORDER_F32, use_crop_to_border=True)),
    "border_float32_rounding_no_crop": (FAR, dict(lens=35.0), None, dict(BORDER_F32, use_crop_to_border=False)),
    "percentage_50": (FAR, dict(lens=35.0), None, dict(resolution_percentage=50)),
    "scaled_camera_object": ((0.3, -2.6, 1.1), dict(lens=40.0), (2.0, 0.5, 1.5), {}),
}


def erode(mask, pixels):
    for _ in range(pixels):
        p = np.pad(mask, 1, constant_values=False)
        mask = p[1:-1, 1:-1] & p[:-2, 1:-1] & p[2:, 1:-1] & p[1:-1, :-2] & p[1:-1, 2:]
    return mask


def pixels(mask, limit=8):
    return [tuple(int(v) for v in rc) for rc in np.argwhere(mask)[:limit]]


@pytest.mark.parametrize("case", CASES, ids=list(CASES))
def test_unbound_matches_cycles(run_bpy, tmp_path, case):
    assert run_bpy("camera_exactness.unbound_matches_cycles", args=dict(case=CASES[case], band=BAND),
                   timeout=240).get("done")
    px = dict(np.load(tmp_path / "renders.npz"))

    # 1. Same output size (the cropped border, or the full frame) for every render.
    shapes = {k: v.shape for k, v in px.items()}
    assert len(set(shapes.values())) == 1, shapes

    silhouette = {k[:-6]: v > 0.5 for k, v in px.items() if k.endswith("_alpha")}
    unbound, cycles = silhouette["unbound"], silhouette["cycles"]
    assert cycles.any() and (~cycles).any(), "the case must show part of the ball's silhouette"
    assert set(np.unique(px["unbound_alpha"])) <= {0.0, 1.0}

    # 2. Silhouette IoU against the unit mesh.
    iou = (unbound & cycles).sum() / (unbound | cycles).sum()
    assert iou >= IOU_MIN, (iou, pixels(unbound & ~cycles), pixels(cycles & ~unbound))

    # 3. Sandwich: inner mesh <= Unbound's ball <= outer mesh, silhouettes and Depth.
    inner, outer = silhouette["inner"], silhouette["outer"]
    assert not (inner & ~unbound).any(), ("Unbound misses pixels the inner mesh covers", pixels(inner & ~unbound))
    assert not (unbound & ~outer).any(), ("Unbound covers pixels the outer mesh misses", pixels(unbound & ~outer))
    full = px["inner_alpha"] == 1.0  # every Cycles sample of the pixel hit the inner mesh
    z = px["unbound_depth"]
    too_near = full & (z < px["outer_depth"])
    too_far = full & (z > px["inner_depth"])
    assert not too_near.any(), ("Depth nearer than the outer mesh", pixels(too_near))
    assert not too_far.any(), ("Depth farther than the inner mesh", pixels(too_far))

    # 4. Depth against the unit mesh, 2 pixels inside both silhouettes.
    core = erode(unbound & cycles, 2)
    assert core.sum() >= 20
    error = np.abs(z - px["cycles_depth"])[core]
    assert error.max() <= DEPTH_TOL, (error.max(), np.median(error))

    # 5. Background Depth: identical to Cycles' (1e10 inside the rendered window).
    background = ~unbound & ~cycles
    assert background.any()
    assert np.array_equal(z[background], px["cycles_depth"][background])
    assert (z[background] >= BACKGROUND_DEPTH).all()
    assert (z[background] == BACKGROUND_DEPTH).any()


# Panoramic cameras (issue 17) against Cycles' own panoramic render of the same mesh spheres, with
# the same bpy script. NEAR puts the ball large in a wide view.
NEAR = (0.35, -1.6, 0.5)
PANO_CASES = {
    "fisheye_equidistant_180": (NEAR, dict(type='PANO', panorama_type='FISHEYE_EQUIDISTANT', fisheye_fov=math.pi),
                                None, {}),
    "fisheye_equidistant_250_shift": (NEAR, dict(type='PANO', panorama_type='FISHEYE_EQUIDISTANT',
                                                 fisheye_fov=math.radians(250), shift_x=0.12, shift_y=-0.05),
                                      None, {}),
    "fisheye_equisolid": (NEAR, dict(type='PANO', panorama_type='FISHEYE_EQUISOLID', fisheye_lens=10.5,
                                     fisheye_fov=math.pi), None, {}),
    "fisheye_equisolid_vertical_fit_portrait": (
        NEAR, dict(type='PANO', panorama_type='FISHEYE_EQUISOLID', fisheye_lens=8.0, fisheye_fov=math.radians(200),
                   sensor_fit='VERTICAL', sensor_height=20.0), None,
        dict(resolution_x=64, resolution_y=90, pixel_aspect_x=1.2)),
    "mirrorball": (NEAR, dict(type='PANO', panorama_type='MIRRORBALL'), None, {}),
    "equirectangular_full": (NEAR, dict(type='PANO', panorama_type='EQUIRECTANGULAR'), None, {}),
    "equirectangular_ranges_border": (
        NEAR, dict(type='PANO', panorama_type='EQUIRECTANGULAR', latitude_min=-0.7, latitude_max=0.5,
                   longitude_min=-0.9, longitude_max=0.6, shift_y=0.03), None,
        dict(BORDER, use_crop_to_border=True)),
}
# Pixels whose centre lies this close to the lens circle (in the mapping's radius, 1 at the rim) may
# fall on either side: about 0.1 pixel at these sizes. Cycles' samples of a rim pixel land on both
# sides farther out than its 0.01-pixel filter suggests: measured, one pixel 0.064 pixel outside the
# equisolid circle (radius 1.0016) had one Cycles sample of 4 inside; every other pixel agrees.
LENS_RIM = 3e-3


def lens_radius(case):
    """The mapping's radius at each pixel centre, 1 at the lens circle (None: no lens circle), as
    Cycles computes it (projection.h), for the case's camera and image."""
    _, data, _, render = case
    kind = data["panorama_type"]
    if kind == 'EQUIRECTANGULAR':
        return None
    w, h = render.get("resolution_x", 96), render.get("resolution_y", 72)
    ys, xs = np.mgrid[0:h, 0:w]
    u = data.get("shift_x", 0.0) + (xs + 0.5) / w
    v = data.get("shift_y", 0.0) + (ys + 0.5) / h
    if kind == 'MIRRORBALL' or kind == 'FISHEYE_EQUIDISTANT':
        return np.hypot(2 * u - 1, 2 * v - 1)
    fx, fy = w * render.get("pixel_aspect_x", 1.0), h * render.get("pixel_aspect_y", 1.0)
    fit = data.get("sensor_fit", 'AUTO')
    if fit == 'VERTICAL':
        size = data.get("sensor_height", 24.0)
        sw, sh = size * fx / fy, size
    else:
        size = data.get("sensor_width", 36.0)
        sw, sh = (size, size * fy / fx) if fit == 'HORIZONTAL' or fx > fy else (size * fx / fy, size)
    rmax = 2 * data["fisheye_lens"] * math.sin(data["fisheye_fov"] / 4)
    return np.hypot((u - 0.5) * sw, (v - 0.5) * sh) / rmax


@pytest.mark.parametrize("case", PANO_CASES, ids=list(PANO_CASES))
def test_panoramic_unbound_matches_cycles(run_bpy, tmp_path, case):
    """Coverage masks, lens circle and Depth (the distance along the ray for panoramas, as Cycles'
    camera_z_depth) against Cycles' render of the 256 x 128 UV sphere and of its copies scaled by
    1 -/+ BAND. Outside the lens Cycles traces nothing: opaque black (alpha 1), Depth 1e10."""
    assert run_bpy("camera_exactness.unbound_matches_cycles", args=dict(case=PANO_CASES[case], band=BAND),
                   timeout=240).get("done")
    px = dict(np.load(tmp_path / "renders.npz"))
    shapes = {k: v.shape for k, v in px.items()}
    assert len(set(shapes.values())) == 1, shapes
    # The lens: where a render is opaque with the background's Depth (the film is transparent).
    unseen = {k[:-6]: (v == 1.0) & (px[k[:-6] + "_depth"] >= BACKGROUND_DEPTH) for k, v in px.items()
              if k.endswith("_alpha")}
    radius = lens_radius(PANO_CASES[case])
    if radius is None:
        assert not unseen["unbound"].any() and not unseen["cycles"].any()
    else:
        if PANO_CASES[case][3].get("use_border"):
            r = PANO_CASES[case][3]
            w, h = r.get("resolution_x", 96), r.get("resolution_y", 72)
            x0, x1 = int(np.float32(r["border_min_x"]) * w), int(np.float32(r["border_max_x"]) * w)
            y0, y1 = int(np.float32(r["border_min_y"]) * h), int(np.float32(r["border_max_y"]) * h)
            radius = radius[y0:y1, x0:x1]
        radius = radius[::-1]  # EXR rows run top to bottom
        assert unseen["cycles"].any() and (~unseen["cycles"]).any()
        differ = unseen["unbound"] != unseen["cycles"]
        assert not (differ & (np.abs(radius - 1.0) > LENS_RIM)).any(), pixels(differ)
        assert not (unseen["unbound"] != (radius > 1.0))[np.abs(radius - 1.0) > 1e-9].any()
    lens = ~unseen["unbound"] & ~unseen["cycles"]
    cover = {k[:-6]: (v > 0.5) & lens for k, v in px.items() if k.endswith("_alpha")}
    unbound, cycles = cover["unbound"], cover["cycles"]
    assert cycles.any() and (lens & ~cycles).any(), "the case must show part of the ball's silhouette"
    assert set(np.unique(px["unbound_alpha"])) <= {0.0, 1.0}
    iou = (unbound & cycles).sum() / (unbound | cycles).sum()
    print("%s: coverage IoU %.4f (%d pixels), Unbound-only %d, Cycles-only %d"
          % (case, iou, cycles.sum(), (unbound & ~cycles).sum(), (cycles & ~unbound).sum()))
    assert iou >= IOU_MIN, (iou, pixels(unbound & ~cycles), pixels(cycles & ~unbound))
    inner, outer = cover["inner"], cover["outer"]
    assert not (inner & ~unbound).any(), ("Unbound misses pixels the inner mesh covers", pixels(inner & ~unbound))
    assert not (unbound & ~outer).any(), ("Unbound covers pixels the outer mesh misses", pixels(unbound & ~outer))
    full = (px["inner_alpha"] == 1.0) & lens
    z = px["unbound_depth"]
    assert not (full & (z < px["outer_depth"])).any(), ("Depth nearer than the outer mesh", pixels(full & (z < px["outer_depth"])))
    assert not (full & (z > px["inner_depth"])).any(), ("Depth farther than the inner mesh", pixels(full & (z > px["inner_depth"])))
    core = erode(unbound & cycles, 2)
    assert core.sum() >= 20
    error = np.abs(z - px["cycles_depth"])[core]
    print("%s: Depth |Unbound - Cycles| max %.2e median %.2e" % (case, error.max(), np.median(error)))
    assert error.max() <= DEPTH_TOL, (error.max(), np.median(error))
    background = ~unbound & ~cycles
    assert np.array_equal(z[background], px["cycles_depth"][background])
