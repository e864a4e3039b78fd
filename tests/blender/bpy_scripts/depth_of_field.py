"""Scripts of test_depth_of_field_blender.py (run inside bpy by conftest.run_bpy: see bpy_scripts/__init__.py)."""
import time

import bpy
import numpy as np


def blurred_ball(S, mod, size, camera, dof, focus_object, cycles_samples, unbound_samples):
    """One scene rendered twice through Blender's pipeline with the same camera and depth of field:
    Cycles (a fine UV sphere mesh, the unit sphere) and Unbound (mu = 0: the unit ball). Saves both
    alpha passes and reports the render times."""
    scene = S.empty_scene(size[0], size[1], "CYCLES")
    cam = S.add_camera(scene, location=camera["location"], lens=camera["lens"])
    cam.data.dof.use_dof = True
    for key, value in dof.items():
        setattr(cam.data.dof, key, value)
    if focus_object:
        target = bpy.data.objects.new("Focus", None)
        scene.collection.objects.link(target)
        target.location = focus_object
        cam.data.dof.focus_object = target
    scene.render.film_transparent = True

    # Cycles: CPU, no denoising, no adaptive sampling, a one-pixel box filter (Unbound's jitter
    # is uniform over the pixel); no bounces: only the camera rays' coverage matters.
    scene.cycles.device = 'CPU'
    scene.cycles.samples = cycles_samples
    scene.cycles.use_adaptive_sampling = False
    scene.cycles.use_denoising = False
    scene.cycles.pixel_filter_type = 'BOX'
    scene.cycles.filter_width = 1.0
    scene.cycles.max_bounces = 0
    bpy.ops.mesh.primitive_uv_sphere_add(segments=256, ring_count=128, radius=1.0)
    sphere = bpy.context.object
    bpy.ops.object.shade_smooth()
    out, seconds = {}, {}
    start = time.perf_counter()
    out["cycles"] = S.render_to_exr(scene, "cycles.exr")["ViewLayer.Combined.A"]
    seconds["cycles"] = time.perf_counter() - start

    sphere.hide_render = True
    scene.render.engine = 'UNBOUND'
    scene.unbound.samples = unbound_samples
    S.add_fractal(mu=(0.0, 0.0, 0.0, 0.0), max_iterations=32, threshold_mode='FIXED', epsilon=1e-4)
    start = time.perf_counter()
    out["unbound"] = S.render_to_exr(scene, "unbound.exr")["ViewLayer.Combined.A"]
    seconds["unbound"] = time.perf_counter() - start
    np.savez(S.pathlib.Path(S.os.environ["UNBOUND_TEST_TMP"]) / "alpha.npz", **out)
    from bl_ext.user_default.unbound import export
    dg = bpy.context.evaluated_depsgraph_get()
    keys = export.camera_dict(dg, cam.evaluated_get(dg), cam.matrix_world, size[0], size[1])
    S.report(seconds=seconds, camera={k: v for k, v in keys.items() if k.startswith(("aperture", "focus"))})
