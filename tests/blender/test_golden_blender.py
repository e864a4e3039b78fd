"""Same pixels through Blender's real pipeline: SHA-256 over every channel of the multilayer EXR that
F12 writes (every Unbound pass enabled) for a suite of small scenes built with the add-on, recorded
before the add-on's refactor and asserted ever since. Every fractal kind made by its operator, the
scene's shading settings and lights, the object's settings (fixed threshold, slice, analytic
normals, orbit-trap colour ramp, steps, a non-uniform scale and rotation), a render border with and
without crop, an orthographic camera.

A hash changes only when pixels change: a change meant to alter pixels re-records the file
(UNBOUND_RECORD_GOLDEN=1 pytest tests/blender/test_golden_blender.py) and says why in its commit.
(tests/native/test_golden_pixels.py does the same for the native core alone.)"""
import json
import os
import pathlib

import pytest

GOLDEN = pathlib.Path(__file__).with_name("golden_blender.json")
RECORD = bool(os.environ.get("UNBOUND_RECORD_GOLDEN"))
KINDS = ["QUATERNION_JULIA", "QUATERNION_MANDELBROT", "JULIA_STACK", "CUBIC_LOCUS", "IFS"]

SCRIPT = """
import hashlib
import math
import numpy as np

def all_passes(scene):
    vl = scene.view_layers[0]
    for p in mod.passes.PASSES:
        if p.toggle:
            setattr(vl.unbound, p.toggle, True)

def light(scene, kind, name, location=(0.0, 0.0, 0.0), rotation=(0.0, 0.0, 0.0), **data):
    ob = bpy.data.objects.new(name, bpy.data.lights.new(name, kind))
    for key, value in data.items():
        setattr(ob.data, key, value)
    ob.location, ob.rotation_euler = location, rotation
    scene.collection.objects.link(ob)
    return ob

def fractal(kind='QUATERNION_JULIA'):
    assert bpy.ops.object.unbound_fractal_add(kind=kind, use_cursor=False) == {'FINISHED'}
    return bpy.context.object

def digest(exr):
    h = hashlib.sha256()
    for name in sorted(exr):
        data = np.ascontiguousarray(exr[name], dtype=np.float32)
        h.update((name + " " + str(data.shape) + "\\n").encode())
        h.update(data.tobytes())
    return h.hexdigest()

def kind_scene(kind):
    scene = S.empty_scene(48, 36)
    S.add_camera(scene, location=(-2.6, -4.4, 2.4))
    fractal(kind)
    return scene

def shading_scene():
    scene = S.empty_scene(48, 36)
    S.add_camera(scene, location=(0.8, -3.6, 1.0), target=(0.0, 0.0, -0.3))
    ob = fractal()
    ob.unbound.reflectivity = 0.35
    world = bpy.data.worlds.new("World")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.15, 0.2, 0.3, 1.0)
    scene.world = world
    light(scene, 'SUN', "Sun", rotation=(0.6, 0.2, 0.3), energy=2.5, angle=math.radians(8.0),
          color=(1.0, 0.95, 0.85))
    light(scene, 'POINT', "Point", location=(1.5, -2.0, 1.2), energy=250.0, shadow_soft_size=0.3,
          color=(0.6, 0.8, 1.0))
    u = scene.unbound
    u.samples = 2
    u.shadows = 'SOFT'
    u.axle_light = 0.2
    u.ambient = (0.06, 0.07, 0.09)
    u.ao_strength = 0.7
    u.ao_distance = 0.35
    u.reflection_depth = 2
    u.fog_density = 0.12
    u.fog_use_world = False
    u.fog_color = (0.55, 0.5, 0.45)
    u.glow_strength = 0.4
    u.glow_color = (0.3, 0.6, 1.0)
    u.use_sea = True
    u.sea_height = -0.9
    u.sea_wavelength = 0.35
    u.sea_amplitude = 0.02
    u.sea_color = (0.05, 0.2, 0.35)
    u.sea_reflectivity = 0.55
    return scene

def object_scene():
    scene = S.empty_scene(48, 36)
    S.add_camera(scene)
    ob = fractal()
    p = ob.unbound
    p.mu = (-0.3, 0.65, 0.1, -0.05)
    p.threshold_mode = 'FIXED'
    p.epsilon = 2e-3
    p.theta = 0.6
    p.slice_offset = 0.12
    p.slice_rotation = (0.2, -0.1, 0.15)
    p.normal_method = 'ANALYTIC'
    assert bpy.ops.object.unbound_color_ramp_add() == {'FINISHED'}
    p.color_mode = 'ORBIT_TRAP'
    p.ramp_scale = 1.5
    p.ramp_offset = -0.2
    p.max_step = 0.5
    p.step_factor = 0.8
    p.bisection_steps = 4
    p.max_iterations = 14
    p.color = (0.9, 0.5, 0.3)
    ob.scale = (1.2, 0.8, 1.0)
    ob.rotation_euler = (0.3, 0.1, 0.5)
    ob.location = (0.05, 0.0, -0.05)
    return scene

def border_scene(crop):
    scene = S.empty_scene(48, 36)
    S.add_camera(scene, lens=35.0)
    fractal()
    r = scene.render
    r.use_border, r.use_crop_to_border = True, crop
    r.border_min_x, r.border_max_x, r.border_min_y, r.border_max_y = 0.13, 0.71, 0.2, 0.83
    r.film_transparent = True
    return scene

def ortho_scene():
    scene = S.empty_scene(48, 36)
    S.add_camera(scene, type='ORTHO', ortho_scale=3.0, shift_x=0.05)
    fractal()
    return scene

builders = {"kind-" + kind: (lambda kind=kind: kind_scene(kind)) for kind in %r}
builders.update({"shading": shading_scene, "object": object_scene,
                 "border-crop": lambda: border_scene(True), "border-no-crop": lambda: border_scene(False),
                 "orthographic": ortho_scene})
hashes, hits, channels = {}, {}, {}
for name, build in builders.items():
    scene = build()
    all_passes(scene)
    exr = S.render_to_exr(scene, name + ".exr")
    hashes[name] = digest(exr)
    hits[name] = float((exr["ViewLayer.Depth.Z"] < 1e9).mean())
    channels[name] = len(exr)
S.report(hashes=hashes, hits=hits, channels=channels, blender=bpy.app.version_string,
         pass_channels=sum(p.channels for p in mod.passes.PASSES))
""" % KINDS


def test_same_pixels_as_recorded(run_bpy):
    """Every scene shows the fractal (the Depth pass hits on more than 2% of its pixels), every pass
    reaches the EXR, and the SHA-256 of each scene's channels equals the recorded one."""
    r = run_bpy(SCRIPT, timeout=600)
    hashes = r["hashes"]
    for name in hashes:
        assert r["hits"][name] > 0.02, (name, r["hits"])
        assert r["channels"][name] >= r["pass_channels"], (name, r["channels"])
    if RECORD:
        GOLDEN.write_text(json.dumps(dict(blender=r["blender"], scenes=hashes), indent=1, sort_keys=True) + "\n")
        pytest.skip("recorded %d hashes" % len(hashes))
    recorded = json.loads(GOLDEN.read_text())
    if recorded["blender"].split(".")[:2] != r["blender"].split(".")[:2]:
        pytest.skip("recorded with Blender %s, running %s" % (recorded["blender"], r["blender"]))
    scenes = recorded["scenes"]
    assert set(hashes) == set(scenes), "the suite changed: re-record it on the commit before the change"
    changed = sorted(name for name in hashes if hashes[name] != scenes[name])
    assert not changed, "pixels changed in %d of %d scenes: %s" % (len(changed), len(hashes), changed)
