"""Scripts of test_camera_exactness.py (run inside bpy by conftest.run_bpy: see bpy_scripts/__init__.py)."""
import bpy
import numpy as np


def unbound_matches_cycles(S, mod, case, band):
    camera_location, camera_data, camera_scale, render_settings = case
    scene = S.empty_scene(96, 72, "CYCLES")
    cam = S.add_camera(scene, location=camera_location, **camera_data)
    if camera_scale:
        cam.scale = camera_scale  # Blender's engines ignore the camera object's scale
    for key, value in render_settings.items():
        setattr(scene.render, key, value)
    scene.render.film_transparent = True
    view_layer = scene.view_layers[0]

    # Cycles: CPU, a few samples, no denoising, a 0.01-pixel filter (crisp edges), the Depth pass.
    scene.cycles.device = 'CPU'
    scene.cycles.samples = 4
    scene.cycles.use_denoising = False
    scene.cycles.filter_width = 0.01
    view_layer.use_pass_z = True
    bpy.ops.mesh.primitive_uv_sphere_add(segments=256, ring_count=128, radius=1.0)
    sphere = bpy.context.object
    bpy.ops.object.shade_smooth()
    out = {}
    for label, scale in (("cycles", 1.0), ("inner", 1.0 - band), ("outer", 1.0 + band)):
        sphere.scale = (scale, scale, scale)
        px = S.render_to_exr(scene, label + ".exr")
        out[label + "_alpha"], out[label + "_depth"] = px["ViewLayer.Combined.A"], px["ViewLayer.Depth.Z"]

    # Unbound: the unit ball, a fixed hit threshold well below the mesh's error.
    sphere.hide_render = True
    scene.render.engine = 'UNBOUND'
    S.add_fractal(mu=(0.0, 0.0, 0.0, 0.0), max_iterations=32, threshold_mode='FIXED', epsilon=1e-4)
    view_layer.unbound.use_pass_depth = True
    px = S.render_to_exr(scene, "unbound.exr")
    out["unbound_alpha"], out["unbound_depth"] = px["ViewLayer.Combined.A"], px["ViewLayer.Depth.Z"]
    np.savez(S.pathlib.Path(S.os.environ["UNBOUND_TEST_TMP"]) / "renders.npz", **out)
    S.report(done=True)
