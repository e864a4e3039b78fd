"""Runs inside a bpy process (a subprocess of the tests): installs the built extension the way
Blender does and offers scene helpers. Each test gets a fresh process and a fresh
BLENDER_USER_RESOURCES directory (set by the caller before bpy is imported)."""
import atexit
import os
import pathlib
import sys

import bpy
import numpy as np

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


class EyeCamera:
    """What export.camera_description asks of a RenderEngine, for a mono camera outside a render."""
    camera_override = None

    def camera_model_matrix(self, ob, use_spherical_stereo=False):
        return ob.matrix_world

    def camera_shift_x(self, ob, use_spherical_stereo=False):
        return ob.data.shift_x


def add_fractal(mu=(-0.2, 0.8, 0.0, 0.0), **props):
    bpy.ops.object.unbound_fractal_add(mu=mu, use_cursor=False)
    ob = bpy.context.object
    for key, value in props.items():
        setattr(ob.unbound, key, value)
    return ob


def fcurve(ob, data_path, index=0):
    """The F-curve animating ob's data_path[index]: action.fcurves in 4.x, the slot's channel bag
    of a layered action in 5.x."""
    action = ob.animation_data.action
    if bpy.app.version < (5, 0, 0):
        return action.fcurves.find(data_path, index=index)
    from bpy_extras import anim_utils
    bag = anim_utils.action_get_channelbag_for_slot(action, ob.animation_data.action_slot)
    return bag.fcurves.find(data_path, index=index)


def exr_output(scene):
    """Render output as a 32-bit multilayer EXR of every pass (4.x and 5.x spell it differently)."""
    ims = scene.render.image_settings
    if bpy.app.version >= (5, 0, 0):
        ims.media_type = 'MULTI_LAYER_IMAGE'
    else:
        ims.file_format = 'OPEN_EXR_MULTILAYER'
    ims.color_depth = '32'


def render_to_exr(scene, name="result.exr"):
    """F12 through Blender's pipeline, written as a 32-bit multilayer EXR of every pass."""
    exr_output(scene)
    path = tmp_dir() / name
    scene.render.filepath = str(path)
    bpy.ops.render.render(write_still=True)
    return read_exr(path)


def tmp_dir():
    """The test's tmp_path (UNBOUND_TEST_TMP): where a script leaves files for the test to read."""
    return pathlib.Path(os.environ["UNBOUND_TEST_TMP"])


def combined(exr):
    """The Combined pass of read_exr's channels: float32 (H, W, 4), RGBA."""
    return np.stack([exr["ViewLayer.Combined." + c] for c in "RGBA"], axis=-1)


# ---------------------------------------------------------------- scenes compared with Cycles

def unit_ball(**props):
    """The unit ball (mu = 0) as Unbound's fractal, marched to a fixed threshold of 1e-4: the subject
    of the comparisons with Cycles, which renders uv_sphere() in its place."""
    return add_fractal(mu=(0.0, 0.0, 0.0, 0.0), max_iterations=32, threshold_mode='FIXED', epsilon=1e-4, **props)


def uv_sphere(segments=256, ring_count=128, location=(0.0, 0.0, 0.0)):
    """Cycles' unit ball: a fine smooth UV sphere of radius 1 (the active object afterwards)."""
    bpy.ops.mesh.primitive_uv_sphere_add(segments=segments, ring_count=ring_count, radius=1.0, location=location)
    bpy.ops.object.shade_smooth()
    return bpy.context.object


def cycles_cpu(scene, samples, **settings):
    """Cycles on the CPU with exactly `samples` samples per pixel (no adaptive sampling, no
    denoising), then `settings` (attributes of scene.cycles)."""
    c = scene.cycles
    c.device = 'CPU'
    c.samples = samples
    c.use_adaptive_sampling = False
    c.use_denoising = False
    for key, value in settings.items():
        setattr(c, key, value)
    return c


def standard_view(scene):
    """The Standard view transform, no look, exposure 0, gamma 1: the image is the scene's radiance."""
    for name, value in (("view_transform", 'Standard'), ("look", 'None'), ("exposure", 0.0), ("gamma", 1.0)):
        setattr(scene.view_settings, name, value)


def add_sun(scene, toward, energy):
    """A sun of angle 0 (a point on the sky: both engines light with one direction) shining from
    `toward` (the direction to the sun)."""
    from mathutils import Vector
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", 'SUN'))
    sun.data.energy = energy
    sun.data.angle = 0.0
    scene.collection.objects.link(sun)
    sun.rotation_euler = (-Vector(toward)).to_track_quat('-Z', 'Y').to_euler()
    return sun


def uniform_world(scene, radiance, name="Uniform"):
    """A World of one colour (strength 1): the background and, in both engines, a light."""
    world = bpy.data.worlds.new(name)
    world.use_nodes = True
    background = world.node_tree.nodes["Background"]
    background.inputs["Color"].default_value = tuple(radiance) + (1.0,)
    background.inputs["Strength"].default_value = 1.0
    scene.world = world
    return world


def diffuse_material(name, color=None):
    """A Diffuse BSDF alone, roughness 0 (Lambert, as Unbound's colour), of `color` (Blender's
    default grey if None): the same in every direction (5.x's default surface is not: it has a
    specular layer)."""
    material = bpy.data.materials.new(name)
    if material.node_tree is None:  # 4.x; 5.x makes it with the material (use_nodes is deprecated)
        material.use_nodes = True
    nodes = material.node_tree.nodes
    for node in [n for n in nodes if n.bl_idname != "ShaderNodeOutputMaterial"]:
        nodes.remove(node)
    output = next(n for n in nodes if n.bl_idname == "ShaderNodeOutputMaterial")
    diffuse = nodes.new("ShaderNodeBsdfDiffuse")
    if color is not None:
        diffuse.inputs["Color"].default_value = tuple(color) + (1.0,)
    diffuse.inputs["Roughness"].default_value = 0.0
    material.node_tree.links.new(diffuse.outputs["BSDF"], output.inputs["Surface"])
    return material


def principled_material(name, base=(0.8, 0.35, 0.1), metallic=0.0, roughness=0.5, **inputs):
    """(material, its Principled BSDF) with these inputs (IOR 1.5, Specular IOR Level 0.5 unless
    given)."""
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    values = {"Base Color": tuple(base) + (1.0,), "Metallic": metallic, "Roughness": roughness, "IOR": 1.5,
              "Specular IOR Level": 0.5}
    values.update(inputs)
    for socket, value in values.items():
        bsdf.inputs[socket].default_value = value
    return mat, bsdf


def exit_without_finalizing():
    """Ends the process at once, skipping bpy's exit. bpy 4.2 from PyPI segfaults at exit once
    any Python-evaluated driver has run, or after bpy.ops.script.reload() (both reproduced with
    no add-on at all: an empty's location driven by `float(1)`; an empty file and a reload); a
    script that does either reports first, then leaves this way."""
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(0)


def attempt(scene, name="attempt.png"):
    """F12 with write_still, as a script does it: ("ok" or Blender's error message, whether the
    PNG exists afterwards). Blender writes the still only when the render succeeded, so a failed
    render must leave no file behind (an older one is removed first)."""
    path = tmp_dir() / name
    scene.render.filepath = str(path)
    scene.render.image_settings.file_format = 'PNG'
    path.unlink(missing_ok=True)
    try:
        bpy.ops.render.render(write_still=True)
        outcome = "ok"
    except RuntimeError as exc:
        # The report appears twice (report() and error_set()): the first line is the message.
        outcome = str(exc).strip().splitlines()[0]
    return outcome, path.exists()


def report(**values):
    """Hands results back to the pytest process (JSON on the last stdout line)."""
    import json
    print("UNBOUND_RESULT " + json.dumps(values))
