"""Same pixels across refactors: SHA-256 over every pass (and the ray, step and iteration
counters) of a suite of scenes, recorded before the parameter table replaced the hand-written
parsing (issue 14) and asserted ever since. Every kind, every effect, several cameras, a render
border, samples, the viewport's strides and sample ranges, transforms, several objects.

A hash changes only when pixels change: a change meant to alter pixels re-records the file
(UNBOUND_RECORD_GOLDEN=1 pytest tests/native/test_golden_pixels.py) and says why in its commit."""
import hashlib
import json
import os
import pathlib

import numpy as np
import pytest
import unbound_core as uc

from conftest import HEAVY_SHADING, KIND_OBJECTS, make_camera, render

GOLDEN = pathlib.Path(__file__).with_name("golden_pixels.json")
RECORD = bool(os.environ.get("UNBOUND_RECORD_GOLDEN"))
# The passes the hashes were recorded over. A pass added later (max_steps, issue 18: 0 in every
# scene here, since none runs out of steps; the denoising passes, issue 19) is checked by its own
# tests; rendered but left out, the hashes still say that adding it changed no pixel of these.
RECORDED_PASSES = ("combined", "alpha", "depth", "normal", "position", "iterations", "steps", "distance", "ao",
                   "shadow", "diffuse", "ambient", "reflection", "orbit_trap", "glow")

RAMP = [(0.1, 0.2, 0.6), (0.9, 0.5, 0.1), (1.0, 1.0, 0.9)]
SOFT_SUN = dict(samples=4, shadows="soft", ambient=(0.05, 0.05, 0.08), ao_strength=0.4, ao_distance=0.3,
                lights=[dict(type="sun", direction=(1.0, 0.5, -1.0), color=(2.0, 2.0, 2.0), radius=0.05),
                        dict(type="point", position=(1.5, -2.0, 1.0), color=(4.0, 3.0, 2.0), radius=0.2,
                             soft_falloff=True)])
FOG_GLOW = dict(fog_density=0.3, fog_color=(0.4, 0.5, 0.6), glow_strength=0.8, glow_color=(0.3, 0.6, 1.0))
SKEWED = [[0.8, 0.3, 0.0, 0.1], [0.0, 1.2, 0.2, -0.1], [0.1, 0.0, 0.6, 0.05], [0.0, 0.0, 0.0, 1.0]]


def scenes():
    """name -> (camera, objects, render keywords)."""
    cam = make_camera(64, 48)
    out = {}
    for kind, obj in KIND_OBJECTS.items():
        out["plain-" + kind] = (cam, [obj], {})
        out["heavy-" + kind] = (make_camera(48, 36), [obj], dict(shading=HEAVY_SHADING))
    julia = KIND_OBJECTS["quaternion_julia"]
    for method in ("gradient_distance", "gradient_potential", "zbuffer", "analytic"):
        out["normals-" + method] = (cam, [dict(julia, normal_method=method, normal_alpha=2e-3,
                                               normal_delta=0.5)], {})
    out["ramp-orbit-trap"] = (cam, [dict(julia, color_mode="orbit_trap", color_ramp=RAMP, ramp_scale=1.5,
                                         ramp_offset=-0.2)], {})
    out["ramp-iterations"] = (cam, [dict(KIND_OBJECTS["ifs"], color_mode="iterations", color_ramp=RAMP)], {})
    out["orthographic"] = (make_camera(56, 40, ortho_height=3.0), [julia], {})
    out["border-zbuffer"] = (make_camera(80, 60), [dict(julia, normal_method="zbuffer")],
                             dict(window=(13, 7, 41, 29)))
    out["soft-sun-4-samples"] = (cam, [julia], dict(shading=SOFT_SUN))
    out["fog-glow"] = (cam, [julia], dict(shading=FOG_GLOW, background=(0.2, 0.3, 0.4, 1.0)))
    out["fixed-threshold-slice"] = (cam, [dict(mu=(-0.08, 0.0, -0.83, -0.025), threshold_mode="fixed",
                                               epsilon=2e-3, theta=1.9, max_iterations=12,
                                               slice_basis=[[1, 0, 0], [0, 0.8, 0.6], [0, -0.6, 0.8], [0, 0, 0]],
                                               slice_origin=[0.0, 0.0, 0.0, 0.1], step_factor=0.8,
                                               bisection_steps=4, bailout=8.0, color=(0.9, 0.4, 0.2))], {})
    out["two-objects-skewed"] = (cam, [dict(julia, matrix=SKEWED, max_step=0.5),
                                       dict(KIND_OBJECTS["cubic_locus"],
                                            matrix=[[0.5, 0, 0, 1.0], [0, 0.5, 0, 0.5], [0, 0, 0.5, 0.2],
                                                    [0, 0, 0, 1]], detail=2.0)],
                                 dict(shading=dict(shadows="hard", lights=[dict(type="spot", position=(0, -3, 3),
                                                                                 direction=(0, 1, -1),
                                                                                 spot_size=1.0, spot_blend=0.3)])))
    out["sea-reflections"] = (cam, [dict(julia, reflectivity=0.5)],
                              dict(shading=dict(reflection_depth=3, use_sea=True, sea_height=-0.9, sea_wavelength=0.3, sea_amplitude=0.02, sea_color=(0.1, 0.3, 0.5), sea_reflectivity=0.6)))
    # Depth of field (issue 19): lens samples per pixel and sample, a turned anamorphic polygon,
    # the Z-buffer normals' neighbours through their own lens points; an orthographic thin lens.
    lens = dict(aperture_size=0.12, focus_distance=2.6, aperture_blades=6, aperture_rotation=0.3, aperture_ratio=1.4)
    out["depth-of-field"] = (dict(cam, **lens), [dict(julia, normal_method="zbuffer")], dict(shading=SOFT_SUN))
    out["depth-of-field-orthographic"] = (dict(make_camera(56, 40, ortho_height=3.0), aperture_size=0.2,
                                               focus_distance=3.0), [julia], dict(shading=dict(samples=3)))
    return out


def stride_pieces(camera, objects, shading, stride):
    """The viewport's interleaved sub-grids and sample ranges, as bytes in a fixed order."""
    parts = []
    for oy in range(stride):
        for ox in range(stride):
            w = (camera["width"] - ox + stride - 1) // stride
            h = (camera["height"] - oy + stride - 1) // stride
            passes = {n: np.zeros((h, w, uc.PASS_CHANNELS[n]), np.float32) for n in RECORDED_PASSES}
            for first in range(shading["samples"]):
                uc.render(camera, objects, passes, window=(ox, oy, w, h), stride=stride, shading=shading,
                          sample_range=(first, 1))
            parts += [passes[n].tobytes() for n in RECORDED_PASSES]
    return parts


def digest(parts, stats=None):
    h = hashlib.sha256()
    for part in parts:
        h.update(part)
    if stats is not None:
        h.update(("%d %d %d" % (stats["rays"], stats["steps"], stats["iterations"])).encode())
    return h.hexdigest()


def current_hashes():
    hashes = {}
    for name, (camera, objects, kw) in scenes().items():
        passes, stats = render(camera, objects, list(uc.PASSES), **kw)
        assert not passes["max_steps"].any() and stats["out_of_steps"] == 0, name
        hashes[name] = digest([passes[n].tobytes() for n in RECORDED_PASSES], stats)
    shading = dict(HEAVY_SHADING, samples=2)
    hashes["viewport-stride-2"] = digest(stride_pieces(make_camera(30, 22), [KIND_OBJECTS["quaternion_julia"]],
                                                       shading, 2))
    return hashes


def assert_recorded(hashes, path, record):
    """The hashes equal those recorded in `path`, scene by scene; with `record`, written there."""
    if record:
        path.write_text(json.dumps(hashes, indent=1, sort_keys=True) + "\n")
        pytest.skip("recorded %d hashes" % len(hashes))
    recorded = json.loads(path.read_text())
    assert set(hashes) == set(recorded), "the scenes changed: re-record them on the commit before the change"
    changed = sorted(name for name in hashes if hashes[name] != recorded[name])
    assert not changed, "bits changed in %d of %d scenes: %s" % (len(changed), len(hashes), changed)


def test_same_pixels_as_recorded():
    assert_recorded(current_hashes(), GOLDEN, RECORD)
