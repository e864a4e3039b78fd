"""Scripts of test_first_render_blender.py (issue 17, a beautiful first render): Blender's startup
scene (cube, camera, lamp), Add > Unbound Fractal as from the Add menu, F12: how much of the frame
the fractal fills, how coloured it is, how long it takes."""
import math
import os
import pathlib
import time

import mathutils

import bpy
import numpy as np


def startup_scene_add(mod, kind='QUATERNION_JULIA'):
    """Blender's factory startup file, then Add > Unbound Fractal as the Add menu runs it (invoke:
    the engine switched to Unbound)."""
    bpy.ops.wm.read_homefile(use_factory_startup=True)
    # bpy has no window, so the operator's invoke (which switches the engine, as the GUI test
    # shows) does not run: switch it as invoke does.
    bpy.context.scene.render.engine = 'UNBOUND'
    result = bpy.ops.object.unbound_fractal_add(kind=kind, **mod.operators.menu_options(bpy.context))
    assert result == {'FINISHED'}, result
    return bpy.context.scene, bpy.context.object


def measure(scene, name, percentage=100):
    """F12 at `percentage` % of the startup scene's 1920 x 1080, written as a 32-bit EXR: seconds,
    coverage (alpha > 0.5 over the frame, with a transparent film), and the mean HSV saturation
    of the object's pixels after the view transform (the PNG Blender writes)."""
    from exr import read_png
    tmp = pathlib.Path(os.environ["UNBOUND_TEST_TMP"])
    r = scene.render
    r.resolution_percentage = percentage
    r.film_transparent = True
    r.image_settings.file_format = 'PNG'
    r.image_settings.color_mode = 'RGBA'
    r.image_settings.color_depth = '8'
    r.filepath = str(tmp / (name + ".png"))
    started, cpu = time.perf_counter(), time.process_time()
    bpy.ops.render.render(write_still=True)
    seconds, cpu_seconds = time.perf_counter() - started, time.process_time() - cpu
    png = np.asarray(read_png(tmp / (name + ".png")), np.float64) / 255.0
    alpha = png[..., 3]
    obj = alpha > 0.5
    rgb = png[..., :3][obj]
    mx, mn = rgb.max(axis=1), rgb.min(axis=1)
    saturation = np.where(mx > 0, (mx - mn) / np.maximum(mx, 1e-9), 0.0)
    return dict(seconds=seconds, cpu_seconds=cpu_seconds, coverage=float(obj.mean()),
                saturation=float(saturation.mean()) if obj.any() else 0.0,
                value=float(mx.mean()) if obj.any() else 0.0, size=list(alpha.shape), png=str(tmp / (name + ".png")))


def first_render(S, mod, kind='QUATERNION_JULIA', percentage=100, keep=None, scene_settings=None,
                 object_settings=None):
    scene, ob = startup_scene_add(mod, kind)
    for key, value in (scene_settings or {}).items():
        setattr(scene.unbound, key, value)
    for key, value in (object_settings or {}).items():
        setattr(ob.unbound, key, value)
    out = measure(scene, "first_" + kind.lower(), percentage)
    out.update(scale=list(ob.scale), location=list(ob.location), engine=scene.render.engine,
               turned=any(abs(a) > 1e-6 for a in ob.rotation_euler),
               samples=scene.unbound.samples, stats=dict(mod.engine.LAST_STATS))
    if keep:
        import shutil
        shutil.copy(out["png"], keep)
    S.report(**out)



def frame_in_camera_centres(S, mod):
    """Frame in Camera on a fractal off to the side and far away: afterwards its silhouette sits in
    the middle of the camera's frame and fills it (a small render's box of hit pixels)."""
    scene, ob = startup_scene_add(mod)
    ob.location = (3.0, 4.0, -1.0)
    ob.scale = (0.3, 0.3, 0.3)
    bpy.context.view_layer.update()
    before = mod.operators.silhouette(scene, ob)
    result = bpy.ops.object.unbound_frame_camera()
    bpy.context.view_layer.update()
    after = mod.operators.silhouette(scene, ob)
    S.report(result=list(result), before=before, after=after, scale=list(ob.scale))


def turn_to_fit(S, mod):
    """Frame in Camera (centred, Turn to Fit) on the default Julia set added standing at the origin,
    in the startup camera's 16:9 frame and in a 9:16 one: the silhouette's box (frame heights) before
    and after, and the angle turned about the camera's view axis."""
    out = {}
    for name, (x, y) in (("wide", (1920, 1080)), ("tall", (1080, 1920))):
        bpy.ops.wm.read_homefile(use_factory_startup=True)
        scene = bpy.context.scene
        scene.render.engine = 'UNBOUND'
        scene.render.resolution_x, scene.render.resolution_y = x, y
        assert bpy.ops.object.unbound_fractal_add() == {'FINISHED'}
        ob = bpy.context.object
        bpy.ops.object.unbound_frame_camera(turn=False)
        aspect = x / y
        sizes = []
        before = ob.matrix_world.to_quaternion()
        for turn in (False, True):
            if turn:
                result = bpy.ops.object.unbound_frame_camera(turn=True)
            bpy.context.view_layer.update()
            x0, y0, x1, y1 = mod.operators.silhouette(scene, ob)
            sizes.append(((x1 - x0) * aspect, y1 - y0))
        forward = scene.camera.matrix_world.to_3x3() @ mathutils.Vector((0.0, 0.0, -1.0))
        turned = before.rotation_difference(ob.matrix_world.to_quaternion())
        axis_along_view = abs(abs(turned.axis.dot(forward.normalized())) - 1.0) < 1e-4 or turned.angle < 1e-6
        out[name] = dict(result=list(result), before_size=sizes[0], after_size=sizes[1],
                         before_area=sizes[0][0] * sizes[0][1], after_area=sizes[1][0] * sizes[1][1],
                         angle=math.degrees(turned.angle) if axis_along_view else -1.0)
    S.report(**out)
