"""Scripts of test_deep_zoom_blender.py (issue 18): the zoom properties, their keyframes, and Pick
Anchor: the anchor moves to the surface point at the centre of the camera's view and the object
with it, so that the view does not jump, at zoom 0 and again (refining) at depth."""
import math

import bpy
import numpy as np


def depth_image(scene):
    """The depth pass of the scene's camera view, rendered by the core from what export.py sends."""
    import unbound_core as uc
    from bl_ext.user_default.unbound import export
    dg = bpy.context.evaluated_depsgraph_get()
    w, h = scene.render.resolution_x, scene.render.resolution_y
    cam = export.camera_dict(dg, scene.camera.evaluated_get(dg), scene.camera.matrix_world, w, h)
    objects = export.fractal_objects(dg, original=True)
    out = {"depth": np.zeros((h, w, 1), np.float32), "alpha": np.zeros((h, w, 1), np.float32)}
    uc.render(cam, objects, out, threads=2)
    return out["depth"][..., 0].astype(float), out["alpha"][..., 0].astype(float)


def properties_and_keyframes(S, mod):
    scene = S.empty_scene(32, 24)
    ob = S.add_fractal()
    rows = {name: ob.unbound.bl_rna.properties[name] for name in ("zoom", "zoom_anchor")}
    ob.unbound.zoom = 0.0
    ob.unbound.keyframe_insert("zoom", frame=1)
    ob.unbound.zoom = 30.0
    ob.unbound.keyframe_insert("zoom", frame=49)
    scene.frame_set(25)
    mid = ob.unbound.zoom
    from bl_ext.user_default.unbound import export
    params = export.object_parameters(ob)
    S.report(zoom_default=rows["zoom"].default, anchor_default=rows["zoom_anchor"].default,
             animatable=rows["zoom"].is_animatable, mid=mid, exported=[params.get("zoom"), params.get("zoom_anchor")])


def pick_keeps_the_view(S, mod):
    """The unit ball (mu = 0) seen from 4 units: Pick Anchor at the view's centre, at zoom 0 and then
    at zoom 10; after each pick the anchor is the sphere point (0, -1, 0) and the depth image is
    the one before the pick."""
    scene = S.empty_scene(32, 24)
    S.add_camera(scene, location=(0.3, -4.0, 0.2), target=(0.0, 0.0, 0.0))
    ob = S.add_fractal(mu=(0.0, 0.0, 0.0, 0.0), max_iterations=24, threshold_mode='FIXED', epsilon=1e-5)
    bpy.context.view_layer.objects.active = ob
    results = []
    for zoom in (0.0, 10.0):
        ob.unbound.zoom = zoom
        before, alpha_before = depth_image(scene)
        r = bpy.ops.object.unbound_pick_zoom_anchor()
        after, alpha_after = depth_image(scene)
        both = (alpha_before == 1.0) & (alpha_after == 1.0)
        anchor = [float(v) for v in ob.unbound.zoom_anchor.split()]
        results.append(dict(zoom=zoom, result=list(r), anchor_text=ob.unbound.zoom_anchor, anchor=anchor,
                            location=list(ob.matrix_world.translation), hits=int(both.sum()),
                            same_coverage=bool(np.all(alpha_before == alpha_after)),
                            depth_change=float(np.abs(after - before)[both].max()) if both.any() else None))
    S.report(results=results)


def viewport_at_depth(S, mod):
    """The Rendered viewport's last frame of the default Julia set at zoom 20 (anchor picked at the
    camera's centre at zoom 0, refined at 6 and 12: each pick is within 10^-6 of the surface) against
    F12's Combined pass of the same view."""
    from bl_ext.user_default.unbound import viewport
    from bpy_scripts.viewport import combined, current_request
    scene = S.empty_scene(48, 36)
    S.add_camera(scene)
    ob = S.add_fractal()
    bpy.context.view_layer.objects.active = ob
    picks = []
    for zoom in (0.0, 6.0, 12.0):
        ob.unbound.zoom = zoom
        picks.append(list(bpy.ops.object.unbound_pick_zoom_anchor()))
    ob.unbound.zoom = 20.0
    session = viewport.Session()
    session.update(current_request(scene))
    frame = session.wait(300)
    session.stop()
    ref = combined(S.render_to_exr(scene, "deep.exr"))
    S.report(picks=picks, final=frame.final, identical=bool(np.array_equal(frame.pixels, ref)),
             coverage=float((ref[..., 3] > 0).mean()), anchor=ob.unbound.zoom_anchor)


def formula_zoom_f12(S, mod):
    """A Mandelbulb picked at the camera's centre at zoom 0 and 4, rendered through F12 at zoom 8 (the
    double path), then at zoom 10.5, past the formula kinds' limit: F12 stops with the core's message."""
    scene = S.empty_scene(32, 24)
    S.add_camera(scene, location=(0.3, -4.0, 0.2), target=(0.0, 0.0, 0.0))
    ob = S.add_fractal(kind='MANDELBULB', max_iterations=10)
    bpy.context.view_layer.objects.active = ob
    picks = []
    for zoom in (0.0, 4.0):
        ob.unbound.zoom = zoom
        picks.append(list(bpy.ops.object.unbound_pick_zoom_anchor()))
    ob.unbound.zoom = 8.0
    passes = S.render_to_exr(scene)
    alpha = [v for k, v in passes.items() if k.endswith("Combined.A")]
    coverage = float(np.mean(alpha[0] > 0.5)) if alpha else None
    ob.unbound.zoom = 10.5
    outcome, written = S.attempt(scene)
    S.report(picks=picks, coverage=coverage, passes=sorted(passes),
             past_limit=outcome, past_limit_written=written, anchor=ob.unbound.zoom_anchor)
