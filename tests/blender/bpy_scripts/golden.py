"""Scripts of test_golden_blender.py (run inside bpy by conftest.run_bpy: see bpy_scripts/__init__.py)."""
import hashlib
import math

import bpy
import numpy as np

KINDS = ["QUATERNION_JULIA", "QUATERNION_MANDELBROT", "JULIA_STACK", "CUBIC_LOCUS", "IFS"]


def all_passes(mod, scene):
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


# The passes the hashes were recorded over. A pass added later (Max Steps, issue 18: 0 in every
# scene here; the denoising passes, issue 19) has its own tests and leaves these hashes alone: it
# is still enabled and written, so the hashes also say that adding it changed no pixel of these.
HASHED_PASSES = ("Combined", "Depth", "Normal", "Position", "Iterations", "Steps", "Distance", "AO", "Shadow",
                 "Diffuse", "Ambient", "Reflection", "Orbit Trap", "Glow")


def digest(exr):
    """SHA-256 over every channel of HASHED_PASSES: sorted names, each name and shape, then its
    float32 bytes."""
    h = hashlib.sha256()
    for name in sorted(n for n in exr if n.split(".")[-2] in HASHED_PASSES):
        data = np.ascontiguousarray(exr[name], dtype=np.float32)
        h.update((name + " " + str(data.shape) + "\n").encode())
        h.update(data.tobytes())
    return h.hexdigest()


def kind_scene(S, kind):
    scene = S.empty_scene(48, 36)
    S.add_camera(scene, location=(-2.6, -4.4, 2.4))
    fractal(kind)
    return scene


def shading_scene(S):
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


def object_scene(S):
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


def border_scene(S, crop):
    scene = S.empty_scene(48, 36)
    S.add_camera(scene, lens=35.0)
    fractal()
    r = scene.render
    r.use_border, r.use_crop_to_border = True, crop
    r.border_min_x, r.border_max_x, r.border_min_y, r.border_max_y = 0.13, 0.71, 0.2, 0.83
    r.film_transparent = True
    return scene


def ortho_scene(S):
    scene = S.empty_scene(48, 36)
    S.add_camera(scene, type='ORTHO', ortho_scale=3.0, shift_x=0.05)
    fractal()
    return scene


def same_pixels_as_recorded(S, mod):
    """Every scene rendered (F12, every pass) to a 32-bit multilayer EXR: its digest, the fraction
    of pixels the Depth pass hits and its channel count."""
    builders = {"kind-" + kind: (lambda kind=kind: kind_scene(S, kind)) for kind in KINDS}
    builders.update({"shading": lambda: shading_scene(S), "object": lambda: object_scene(S),
                     "border-crop": lambda: border_scene(S, True), "border-no-crop": lambda: border_scene(S, False),
                     "orthographic": lambda: ortho_scene(S)})
    hashes, hits, channels = {}, {}, {}
    for name, build in builders.items():
        scene = build()
        all_passes(mod, scene)
        exr = S.render_to_exr(scene, name + ".exr")
        hashes[name] = digest(exr)
        hits[name] = float((exr["ViewLayer.Depth.Z"] < 1e9).mean())
        channels[name] = len(exr)
    S.report(hashes=hashes, hits=hits, channels=channels, blender=bpy.app.version_string,
             pass_channels=sum(p.channels for p in mod.passes.PASSES))
