"""Runs inside a bpy process (a subprocess of the tests): installs the built extension the way
Blender does and offers scene helpers. Each test gets a fresh process and a fresh
BLENDER_USER_RESOURCES directory (set by the caller before bpy is imported)."""
import atexit
import os
import pathlib
import sys

import bpy

from exr import read_exr  # noqa: F401  (re-exported for the test scripts)

MODULE = "bl_ext.user_default.unbound"


def install_extension(zip_path):
    result = bpy.ops.extensions.package_install_files(filepath=str(zip_path), repo='user_default',
                                                      enable_on_install=True)
    assert result == {'FINISHED'}, result
    assert MODULE in bpy.context.preferences.addons, "extension not enabled"
    # Disable before exit: 4.2/4.5 crash or hang at exit with a registered RenderEngine otherwise.
    atexit.register(disable)
    return sys.modules[MODULE]


def disable():
    import addon_utils
    if MODULE in bpy.context.preferences.addons:
        addon_utils.disable(MODULE, default_set=True)


def empty_scene(width=64, height=48, engine="UNBOUND"):
    bpy.ops.wm.read_homefile(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine = engine
    scene.render.resolution_x, scene.render.resolution_y = width, height
    scene.render.resolution_percentage = 100
    return scene


def add_camera(scene, location=(0.4, -3.0, 0.9), target=(0.0, 0.0, 0.0), lens=50.0, **data):
    from mathutils import Vector
    cam_data = bpy.data.cameras.new("Camera")
    cam_data.lens = lens
    for key, value in data.items():
        setattr(cam_data, key, value)
    cam = bpy.data.objects.new("Camera", cam_data)
    scene.collection.objects.link(cam)
    cam.location = location
    direction = Vector(target) - Vector(location)
    cam.rotation_euler = direction.to_track_quat('-Z', 'Y').to_euler()
    scene.camera = cam
    return cam


def add_fractal(mu=(-0.2, 0.8, 0.0, 0.0), **props):
    bpy.ops.object.unbound_fractal_add(mu=mu, use_cursor=False)
    ob = bpy.context.object
    for key, value in props.items():
        setattr(ob.unbound, key, value)
    return ob


def render_to_exr(scene, name="result.exr"):
    """F12 through Blender's pipeline, written as a 32-bit multilayer EXR of every pass."""
    ims = scene.render.image_settings
    if bpy.app.version >= (5, 0, 0):
        ims.media_type = 'MULTI_LAYER_IMAGE'
    else:
        ims.file_format = 'OPEN_EXR_MULTILAYER'
    ims.color_depth = '32'
    path = pathlib.Path(os.environ["UNBOUND_TEST_TMP"]) / name
    scene.render.filepath = str(path)
    bpy.ops.render.render(write_still=True)
    return read_exr(path)


def report(**values):
    """Hands results back to the pytest process (JSON on the last stdout line)."""
    import json
    print("UNBOUND_RESULT " + json.dumps(values))
