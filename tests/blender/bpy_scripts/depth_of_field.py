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
    S.cycles_cpu(scene, cycles_samples, pixel_filter_type='BOX', filter_width=1.0, max_bounces=0)
    sphere = S.uv_sphere()
    out, seconds = {}, {}
    start = time.perf_counter()
    out["cycles"] = S.render_to_exr(scene, "cycles.exr")["ViewLayer.Combined.A"]
    seconds["cycles"] = time.perf_counter() - start

    sphere.hide_render = True
    scene.render.engine = 'UNBOUND'
    scene.unbound.samples = unbound_samples
    S.unit_ball()
    start = time.perf_counter()
    out["unbound"] = S.render_to_exr(scene, "unbound.exr")["ViewLayer.Combined.A"]
    seconds["unbound"] = time.perf_counter() - start
    np.savez(S.tmp_dir() / "alpha.npz", **out)
    from bl_ext.user_default.unbound import export
    dg = bpy.context.evaluated_depsgraph_get()
    keys = export.camera_dict(dg, cam.evaluated_get(dg), cam.matrix_world, size[0], size[1])
    S.report(seconds=seconds, camera={k: v for k, v in keys.items() if k.startswith(("aperture", "focus"))})
