"""Scripts of test_shading_blender.py (run inside bpy by conftest.run_bpy: see bpy_scripts/__init__.py)."""
import glob
import os
import re

import bpy
import numpy as np
from mathutils import Vector


def light_units_match_cycles(S, mod, case):
    kind, location, target, light_props = case
    scene = S.empty_scene(80, 60, "CYCLES")
    S.add_camera(scene, location=(1.0, -6.0, 2.0))
    scene.render.film_transparent = True           # black background, alpha = coverage
    scene.view_settings.view_transform = 'Standard'
    scene.view_settings.look = 'None'
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0
    c = scene.cycles
    c.device = 'CPU'
    c.samples = 64
    c.use_adaptive_sampling = False
    c.use_denoising = False
    c.seed = 7
    c.filter_width = 0.01
    c.max_bounces = 0

    bpy.ops.mesh.primitive_uv_sphere_add(segments=256, ring_count=128, radius=1.0)
    sphere = bpy.context.object
    bpy.ops.object.shade_smooth()
    mat = bpy.data.materials.new("White")
    mat.use_nodes = True
    nodes = mat.node_tree.nodes
    nodes.clear()
    bsdf = nodes.new("ShaderNodeBsdfDiffuse")
    bsdf.inputs["Color"].default_value = (0.8, 0.8, 0.8, 1.0)
    bsdf.inputs["Roughness"].default_value = 0.0
    out = nodes.new("ShaderNodeOutputMaterial")
    mat.node_tree.links.new(bsdf.outputs["BSDF"], out.inputs["Surface"])
    sphere.data.materials.append(mat)

    data = bpy.data.lights.new("Light", kind)
    for key, value in light_props.items():
        setattr(data, key, value)
    light = bpy.data.objects.new("Light", data)
    scene.collection.objects.link(light)
    light.location = location
    light.rotation_euler = (Vector(target) - Vector(location)).to_track_quat('-Z', 'Y').to_euler()

    cycles = S.render_to_exr(scene, "cycles.exr")

    sphere.hide_render = True
    scene.render.engine = 'UNBOUND'
    S.add_fractal(mu=(0.0, 0.0, 0.0, 0.0), max_iterations=32, threshold_mode='FIXED', epsilon=1e-4,
                  color=(0.8, 0.8, 0.8))
    u = scene.unbound
    u.axle_light = 0.0
    u.ambient = (0.0, 0.0, 0.0)
    u.shadows = 'HARD'
    u.samples = 1
    unbound = S.render_to_exr(scene, "unbound.exr")
    out = {}
    for label, px in (("cycles", cycles), ("unbound", unbound)):
        out[label] = np.stack([px["ViewLayer.Combined." + ch] for ch in "RGBA"], -1)
    np.savez(S.pathlib.Path(S.os.environ["UNBOUND_TEST_TMP"]) / "renders.npz", **out)
    S.report(done=True)


def shading_passes_reach_compositor_and_exr_and_sum_to_combined(S, mod):
    scene = S.empty_scene(64, 48)
    scene.render.film_transparent = True
    S.add_camera(scene, location=(0.8, -3.6, 1.0), target=(0.0, 0.0, -0.3))
    S.add_fractal(reflectivity=0.3)
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", 'SUN'))
    sun.data.energy = 3.0
    scene.collection.objects.link(sun)
    sun.rotation_euler = (Vector((0, 0, 0)) - Vector((2.0, 1.0, 3.0))).to_track_quat('-Z', 'Y').to_euler()
    u = scene.unbound
    u.samples = 2
    u.axle_light = 0.3
    u.ambient = (0.1, 0.12, 0.15)
    u.ao_strength = 0.8
    u.ao_distance = 0.3
    u.use_sea = True
    u.sea_height = -0.8
    u.reflection_depth = 2
    u.glow_strength = 0.5
    u.fog_density = 0.0
    vl = scene.view_layers[0]
    tree = mod.utils.compositor_tree(scene, create=True)
    before = tree.nodes.new("CompositorNodeRLayers")
    sockets_off = [s.name for s in before.outputs if s.enabled]
    tree.nodes.remove(before)
    for p in mod.passes.PASSES:
        if p.toggle:
            setattr(vl.unbound, p.toggle, True)
    rl = tree.nodes.new("CompositorNodeRLayers")
    sockets_on = [s.name for s in rl.outputs if s.enabled]
    exr = S.render_to_exr(scene)
    np.savez(S.pathlib.Path(S.os.environ["UNBOUND_TEST_TMP"]) / "passes.npz", **exr)
    S.report(sockets_off=sockets_off, sockets_on=sockets_on, channels=sorted(exr))


def every_bundled_preset_applies_and_renders(S, mod):
    results = {}
    files = sorted(glob.glob(os.path.join(mod.operators.BUNDLED_PRESETS, "*.py")))
    for path in files:
        scene = S.empty_scene(48, 36)
        scene.render.film_transparent = True
        S.add_camera(scene, location=(0.8, -5.0, 1.6))
        sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", 'SUN'))
        scene.collection.objects.link(sun)
        sun.rotation_euler = (-0.6, 0.4, 0.0)
        ob = S.add_fractal(mu=(0.3, 0.3, 0.3, 0.3))
        assert bpy.context.object == ob
        status = bpy.ops.script.execute_preset(filepath=path, menu_idname="UNBOUND_MT_fractal_presets")
        text = open(path).read()
        mu = re.search(r"ob\.unbound\.mu = \(([^)]*)\)", text)
        wanted = [float(v) for v in mu.group(1).split(",")] if mu else None  # a preset without mu
        kind = re.search(r"ob\.unbound\.kind = '(\w+)'", text).group(1)
        exr = S.render_to_exr(scene, os.path.basename(path) + ".exr")
        rgba = np.stack([exr["ViewLayer.Combined." + c] for c in "RGBA"], -1)
        hit = rgba[..., 3] > 0.5
        results[os.path.basename(path)] = dict(
            status=sorted(status), mu=list(ob.unbound.mu), wanted=wanted, kind=ob.unbound.kind, wanted_kind=kind,
            finite=bool(all(np.isfinite(v).all() for v in exr.values())),
            coverage=float(hit.mean()),
            spread=float(np.ptp(rgba[..., :3][hit])) if hit.any() else 0.0)
    S.report(results=results)


def add_preset_writes_user_preset_that_restores_settings(S, mod):
    scene = S.empty_scene(32, 24)
    a = S.add_fractal(mu=(0.1, -0.6, 0.2, 0.05), theta=0.7)
    scene.unbound.glow_strength = 0.3
    status = bpy.ops.unbound.fractal_preset_add(name="My Preset")
    folders = bpy.utils.preset_paths("unbound/fractal")
    written = [os.path.join(f, n) for f in folders for n in os.listdir(f) if n.endswith(".py")]
    b = S.add_fractal(mu=(-1.0, 0.0, 0.0, 0.0), theta=0.0)
    scene.unbound.glow_strength = 0.0
    before = dict(mu=list(b.unbound.mu), theta=b.unbound.theta)
    path = next(p for p in written if os.path.basename(p).lower() == "my_preset.py")
    run = bpy.ops.script.execute_preset(filepath=path, menu_idname="UNBOUND_MT_fractal_presets")
    S.report(status=sorted(status), run=sorted(run), written=written, path=path, folders=folders,
             before=before, after=dict(mu=list(b.unbound.mu), theta=b.unbound.theta),
             first=dict(mu=list(a.unbound.mu), theta=a.unbound.theta), glow=scene.unbound.glow_strength)


def keyframed_shading_settings_reach_each_frame(S, mod):
    scene = S.empty_scene(48, 36)
    scene.render.film_transparent = True
    S.add_camera(scene)
    ob = S.add_fractal()
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", 'SUN'))
    scene.collection.objects.link(sun)
    sun.rotation_euler = (-0.5, 0.3, 0.0)
    # Linear keys (the halving check below), set the way a user would: Preferences > Animation.
    bpy.context.preferences.edit.keyframe_new_interpolation_type = 'LINEAR'
    u = scene.unbound
    u.axle_light = 0.5
    u.ao_distance = 0.8
    u.ao_strength = 0.0
    u.keyframe_insert("ao_strength", frame=1)
    u.ao_strength = 1.0
    u.keyframe_insert("ao_strength", frame=3)
    ob.unbound.normal_alpha = 1e-4
    ob.keyframe_insert("unbound.normal_alpha", frame=3)
    ob.unbound.normal_alpha = 0.2
    ob.keyframe_insert("unbound.normal_alpha", frame=5)
    bpy.ops.object.unbound_color_ramp_add()
    tex = ob.unbound.color_ramp_texture
    for frame, colour in ((1, (1.0, 0.0, 0.0, 1.0)), (5, (0.0, 0.0, 1.0, 1.0))):
        for el in tex.color_ramp.elements:
            el.color = colour
            el.keyframe_insert("color", frame=frame)
    vl = scene.view_layers[0]
    vl.unbound.use_pass_ao = True
    vl.unbound.use_pass_diffuse = True
    vl.unbound.use_pass_normal = True
    out, seen = {}, {}
    for f in (1, 2, 3, 5):
        scene.frame_set(f)
        seen[f] = dict(ao_strength=scene.unbound.ao_strength, normal_alpha=ob.unbound.normal_alpha,
                       color_mode=ob.unbound.color_mode)
        exr = S.render_to_exr(scene, "f%d.exr" % f)
        out["ao%d" % f] = exr["ViewLayer.AO.X"]
        out["alpha%d" % f] = exr["ViewLayer.Combined.A"]
        out["normal%d" % f] = np.stack([exr["ViewLayer.Normal." + c] for c in "XYZ"], -1)
        out["diffuse%d" % f] = np.stack([exr["ViewLayer.Diffuse." + c] for c in "RGB"], -1)
    np.savez(S.pathlib.Path(S.os.environ["UNBOUND_TEST_TMP"]) / "frames.npz", **out)
    S.report(seen=seen)


def light_power_colour_and_shadow_switch(S, mod):
    scene = S.empty_scene(64, 48)
    scene.render.film_transparent = True
    S.add_camera(scene)
    S.add_fractal(color=(0.7, 0.7, 0.7))
    u = scene.unbound
    u.axle_light = 0.0
    u.ambient = (0.0, 0.0, 0.0)
    u.shadows = 'HARD'
    vl = scene.view_layers[0]
    vl.unbound.use_pass_diffuse = True
    vl.unbound.use_pass_shadow = True
    specs = {'SUN': ((2.0, -1.5, 3.0), 2.0), 'POINT': ((2.0, -2.0, 2.0), 400.0),
             'SPOT': ((-1.5, -2.5, 2.0), 600.0), 'AREA': ((2.5, -3.0, 2.0), 800.0)}
    out = {}

    def shot(tag):
        exr = S.render_to_exr(scene, tag + ".exr")
        out[tag] = np.stack([exr["ViewLayer.Diffuse." + c] for c in "RGB"], -1)
        out[tag + "_shadow"] = exr["ViewLayer.Shadow.X"]
        out[tag + "_alpha"] = exr["ViewLayer.Combined.A"]

    for kind, (location, energy) in specs.items():
        data = bpy.data.lights.new(kind, kind)
        data.energy = energy
        if kind == 'SPOT':
            data.spot_size = 1.2
        light = bpy.data.objects.new(kind, data)
        scene.collection.objects.link(light)
        light.location = location
        light.rotation_euler = (-Vector(location)).to_track_quat('-Z', 'Y').to_euler()
        shot(kind)
        data.energy = 2.0 * energy
        shot(kind + "_x2")
        if kind == 'POINT':
            data.energy = energy
            data.color = (1.0, 0.0, 0.0)
            shot("red")
            data.color = (0.25, 0.5, 1.0)
            shot("tinted")
            data.color = (1.0, 1.0, 1.0)
            data.use_shadow = False
            shot("unshadowed")
            data.use_shadow = True
        bpy.data.objects.remove(light)
    np.savez(S.pathlib.Path(S.os.environ["UNBOUND_TEST_TMP"]) / "lights.npz", **out)
    S.report(done=True)


def more_than_64_lights_is_reported_not_raised(S, mod):
    scene = S.empty_scene(16, 12)
    S.add_camera(scene)
    S.add_fractal()
    lights = []

    def render():
        mod.engine.LAST_STATS.clear()
        try:
            return sorted(bpy.ops.render.render()), dict(mod.engine.LAST_STATS)
        except RuntimeError as exc:
            return str(exc), dict(mod.engine.LAST_STATS)

    for i in range(65):
        data = bpy.data.lights.new("L%d" % i, 'POINT')
        data.energy = 10.0
        ob = bpy.data.objects.new("L%d" % i, data)
        ob.location = (3.0 + 0.01 * i, -3.0, 2.0)
        scene.collection.objects.link(ob)
        lights.append(ob)
        if i == 63:
            ok64 = render()
    too_many = render()
    lights[0].hide_render = True
    hidden = render()
    S.report(ok64=ok64, too_many=too_many, hidden=hidden)
