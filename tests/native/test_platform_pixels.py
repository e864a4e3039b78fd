"""Same bits on every platform for what came after the golden pixels (test_golden_pixels.py, issue
14): the formula kinds, the KIFS and the hybrid, deep zoom (the double and the perturbation paths of
the Julia set, the formula kinds' double path), the World as a light, GI with a material, the
panoramic lenses, every pass (the denoising passes and max_steps too) and the extracted mesh.

SHA-256 over the bytes, recorded on x86-64 Linux (UNBOUND_RECORD_PLATFORM=1 pytest
tests/native/test_platform_pixels.py) and asserted wherever the suite runs: on x86-64 it guards the
pixels as the golden file does; under qemu (linux-arm64), wine (windows-x64) and Python 3.13 it is
what those runs check of these features, whose float64 and arbitrary-precision references
(conftest.REFERENCE_FILES) run on x86-64 only: a platform that gives x86-64's bits passes them too.
Every scene must show the set over part of its frame, so that no digest is of an empty image."""
import os
import pathlib

import numpy as np
import unbound_core as uc

from conftest import HEAVY_SHADING, KIND_OBJECTS, make_camera, render, uniform_world
from test_formulas import BOX, BOX_CAMERA, BOX_JULIA, BOX_NEG, BULB, BULB_CAMERA, BULB_JULIA
from test_kifs_hybrid import CAMERAS as KIFS_CAMERAS, HYBRID_OBJECTS, KIFS_OBJECTS
from test_panoramic import pano_camera
from test_deep_zoom import BASE_ITERATIONS, MU as ZOOM_MU
from test_deep_zoom_formulas import CASES as ZOOM_CASES, EPSILON as ZOOM_EPSILON, view as zoom_camera
from test_gi import FLOOR, RED, SUN
from test_golden_pixels import assert_recorded, digest

RECORDED = pathlib.Path(__file__).with_name("platform_pixels.json")
RECORD = bool(os.environ.get("UNBOUND_RECORD_PLATFORM"))

JULIA = KIND_OBJECTS["quaternion_julia"]
BALL = dict(mu=(0.0, 0.0, 0.0, 0.0), max_iterations=32, color=(0.8, 0.4, 0.2))
# Points on the surfaces found by the deep-zoom tests' referees (test_deep_zoom.surface,
# test_deep_zoom_formulas.surface_anchor at zoom 10), and the rays they were found along: the
# camera looks at the anchor from 3 local units back, a little beside it (test_deep_zoom_formulas.view).
TOWARD = (-0.12668127104390728, 0.9501095328293045, -0.2850328598487914)
JULIA_ANCHOR = ("0.134969271937106548198865103120613665424481 -1.012269539528299032059470560628253411465838 "
                "0.303680861858489662141152875893901244450800")
FORMULA_ANCHORS = {
    "mandelbulb": ("0.10035396779710364 -0.75265475847827712 0.22579642754348336", TOWARD),
    "mandelbox": ("0.7999999999999996 -6.0000000000000018 1.8000000000000009", TOWARD),
    "kifs": ("0.50000010309842369 0.29999999999999999 0.20000000000000001", (-1.0, 0.0, 0.0)),
    "hybrid": ("0.0082847522632319426 -0.062135641974239764 0.018640692592271853", TOWARD),
}


def world_map():
    """A World of random texels: numpy's PCG64 gives the same floats on every platform."""
    return np.random.default_rng(7).random((16, 32, 3), dtype=np.float32) * 3


def scenes():
    """name -> (camera, objects, render keywords)."""
    out = {}
    formulas = {"mandelbulb": (BULB, BULB_CAMERA), "mandelbulb-julia": (BULB_JULIA, BULB_CAMERA),
                "mandelbox": (BOX, BOX_CAMERA), "mandelbox-negative": (BOX_NEG, BOX_CAMERA),
                "mandelbox-julia": (BOX_JULIA, BOX_CAMERA)}
    formulas.update({"kifs-" + name: (obj, KIFS_CAMERAS["kifs"]) for name, obj in KIFS_OBJECTS.items()})
    formulas.update({"hybrid-" + name: (obj, KIFS_CAMERAS[name]) for name, obj in HYBRID_OBJECTS.items()})
    for name, (obj, cam) in formulas.items():
        out[name] = (cam, [obj], {})
    out["heavy-mandelbulb"] = (BULB_CAMERA, [dict(BULB, reflectivity=0.3)], dict(shading=HEAVY_SHADING))
    out["heavy-kifs-menger"] = (KIFS_CAMERAS["kifs"], [KIFS_OBJECTS["menger"]], dict(shading=HEAVY_SHADING))
    julia_zoom = dict(mu=ZOOM_MU, max_iterations=BASE_ITERATIONS, threshold_mode="fixed", epsilon=ZOOM_EPSILON,
                      zoom_anchor=JULIA_ANCHOR)
    for zoom in (5, 20, 30):  # 5: double; 20, 30: perturbation from the anchor's orbit
        out["zoom-julia-%d" % zoom] = (zoom_camera(np.array(TOWARD), 24, 18), [dict(julia_zoom, zoom=float(zoom))],
                                       dict(shading=dict(shadows="hard")))
    for name, (anchor, toward) in FORMULA_ANCHORS.items():
        out["zoom-%s-10" % name] = (zoom_camera(np.array(toward), 24, 18),
                                    [dict(ZOOM_CASES[name], zoom=10.0, zoom_anchor=anchor, threshold_mode="fixed",
                                          epsilon=ZOOM_EPSILON)], {})
    out["world-map"] = (make_camera(32, 24), [dict(BALL, reflectivity=0.3), dict(JULIA, matrix=[
        [0.5, 0, 0, 1.2], [0, 0.5, 0, 0], [0, 0, 0.5, 0], [0, 0, 0, 1]])],
        dict(world=world_map(), background=(0, 0, 0, 1),
             shading=dict(samples=3, world_samples=2, reflection_depth=1)))
    out["gi-material"] = (make_camera(32, 24, eye=(0.0, -4.0, 1.5)),
                          [dict(BALL, use_material=True, material_base_color=RED, material_roughness=0.3,
                                material_metallic=0.2)],
                          dict(world=uniform_world((0.3, 0.4, 0.5)), background=(0, 0, 0, 1),
                               shading=dict(FLOOR, sea_amplitude=0.02, sea_reflectivity=0.3, axle_light=0.0,
                                            samples=3, world_samples=1, lights=[SUN], fog_density=0.05,
                                            use_gi=True, max_bounces=6)))
    for kind, keys in (("equirectangular", dict(latitude_min=-0.5, latitude_max=1.2, longitude_min=-2.0,
                                                longitude_max=0.7)),
                       ("fisheye_equidistant", dict(fisheye_fov=3.5)),
                       ("fisheye_equisolid", dict(fisheye_lens=8.0, fisheye_fov=3.0, sensor_width=36.0,
                                                  sensor_height=18.0)),
                       ("mirrorball", {})):
        out["panorama-" + kind] = (pano_camera(kind, 32, 16, **keys), [JULIA], {})
    return out


MESH_KEYS = ("vertices", "faces", "trap", "iterations", "estimate")


def current_hashes():
    hashes = {}
    for name, (camera, objects, kw) in scenes().items():
        passes, stats = render(camera, objects, list(uc.PASSES), **kw)
        covered = float(np.mean(passes["alpha"] > 0))
        assert 0.02 < covered, "%s: the set covers %.3f of the frame" % (name, covered)
        hashes[name] = digest([passes[n].tobytes() for n in uc.PASSES], stats)
    for name, obj, resolution in (("mesh-julia", JULIA, 40), ("mesh-mandelbulb", BULB, 32)):
        mesh = uc.extract_mesh(obj, resolution=resolution)
        assert len(mesh["faces"]) > 0, name
        hashes[name] = digest([mesh[k] for k in MESH_KEYS])
    return hashes


def test_same_bits_as_recorded_on_x86_64():
    assert_recorded(current_hashes(), RECORDED, RECORD)
