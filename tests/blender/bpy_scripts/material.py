"""Scripts of test_material_blender.py (run inside bpy by conftest.run_bpy: see bpy_scripts/__init__.py)."""
import bpy
import numpy as np
from mathutils import Vector

SPACING = 2.5


def _principled(name, base=(0.8, 0.35, 0.1), metallic=0.0, roughness=0.5, **inputs):
    """A material whose output is a Principled BSDF with these inputs (IOR 1.5, Specular IOR Level
    0.5 unless given)."""
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    values = {"Base Color": tuple(base) + (1.0,), "Metallic": metallic, "Roughness": roughness, "IOR": 1.5,
              "Specular IOR Level": 0.5}
    values.update(inputs)
    for socket, value in values.items():
        bsdf.inputs[socket].default_value = value
    return mat, bsdf


def _sun(scene, toward=(-0.5, -0.7, 0.6), energy=3.0):
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", 'SUN'))
    sun.data.energy = energy
    sun.data.angle = 0.0  # a point on the sky: both engines light with one direction
    scene.collection.objects.link(sun)
    sun.rotation_euler = (-Vector(toward)).to_track_quat('-Z', 'Y').to_euler()
    return sun


def _unbound_lighting(scene):
    u = scene.unbound
    u.axle_light = 0.0
    u.ambient = (0.0, 0.0, 0.0)
    u.shadows = 'HARD'
    u.samples = 1


def _rgba(px):
    return np.stack([px["ViewLayer.Combined." + ch] for ch in "RGBA"], -1)


def _save(**arrays):
    np.savez(S_tmp() / "renders.npz", **arrays)


def S_tmp():
    import os
    import pathlib
    return pathlib.Path(os.environ["UNBOUND_TEST_TMP"])


def _uniform_world(scene, radiance):
    """A World of one colour: the background and, in both engines, a light."""
    world = bpy.data.worlds.new("Uniform")
    world.use_nodes = True
    background = world.node_tree.nodes["Background"]
    background.inputs["Color"].default_value = tuple(radiance) + (1.0,)
    background.inputs["Strength"].default_value = 1.0
    scene.world = world


def principled_grid_matches_cycles(S, mod, grid, size, samples, segments, unbound_samples=1, world=None,
                                   world_samples=0):
    """A 3 x 3 grid of unit balls, metallic by row and roughness by column, under one sun and a
    black world (world None) or a uniform one of radiance `world`: Cycles (smooth UV spheres,
    direct light only, `samples` per pixel; a box filter with a world) and Unbound (mu = 0 fractals
    with analytic normals; `unbound_samples` x `world_samples` world-light pairs) with the same materials,
    orthographic, one image each."""
    scene = S.empty_scene(size, size, "CYCLES")
    cam = S.add_camera(scene, location=(0.0, -10.0, 0.0), type='ORTHO', ortho_scale=3 * SPACING + 0.1)
    del cam
    scene.render.film_transparent = True  # black background, alpha = coverage (the world still lights)
    scene.view_settings.view_transform = 'Standard'
    scene.view_settings.look = 'None'
    if world is not None:
        _uniform_world(scene, world)
    c = scene.cycles
    c.device = 'CPU'
    c.samples = samples
    c.use_adaptive_sampling = False
    c.use_denoising = False
    c.seed = 7
    if world is None:
        c.filter_width = 0.01  # every sample at the pixel centre, where Unbound's one sample is
    else:
        c.pixel_filter_type = 'BOX'  # Unbound's samples: Halton points over the pixel square
        c.filter_width = 1.0
    c.max_bounces = 0        # direct light only: the lights' own contribution through the BSDF
    c.blur_glossy = 0.0
    _sun(scene)
    spheres, materials = [], {}
    for i, metallic in enumerate(grid["metallic"]):
        for j, roughness in enumerate(grid["roughness"]):
            mat, _ = _principled("M%d R%d" % (i, j), metallic=metallic, roughness=roughness)
            materials[(i, j)] = mat
            bpy.ops.mesh.primitive_uv_sphere_add(segments=segments, ring_count=segments // 2, radius=1.0,
                                                 location=((j - 1) * SPACING, 0.0, (1 - i) * SPACING))
            sphere = bpy.context.object
            bpy.ops.object.shade_smooth()
            sphere.data.materials.append(mat)
            spheres.append(sphere)
    cycles = _rgba(S.render_to_exr(scene, "cycles.exr"))
    for sphere in spheres:
        sphere.hide_render = True
    scene.render.engine = 'UNBOUND'
    _unbound_lighting(scene)
    scene.unbound.samples = unbound_samples
    scene.unbound.world_samples = world_samples
    for (i, j), mat in materials.items():
        # Analytic normals (the Jacobian's): eq. 15's central differences, with the default step
        # 1e-3 t, tilt the ball's normals by 0.2 degrees, which moves a one-pixel highlight.
        ob = S.add_fractal(mu=(0.0, 0.0, 0.0, 0.0), max_iterations=32, threshold_mode='FIXED', epsilon=1e-4,
                           normal_method='ANALYTIC')
        ob.location = ((j - 1) * SPACING, 0.0, (1 - i) * SPACING)
        ob.unbound.material = mat
    unbound = _rgba(S.render_to_exr(scene, "unbound.exr"))
    _save(cycles=cycles, unbound=unbound)
    S.report(done=True)


def _fractal_scene(S, size=(64, 48)):
    scene = S.empty_scene(*size)
    scene.render.film_transparent = True
    S.add_camera(scene)
    _sun(scene)
    _unbound_lighting(scene)
    return scene, S.add_fractal()


def attribute_ramp_drives_base_color(S, mod, stops):
    """Attribute unbound_orbit_trap -> Color Ramp -> Base Color of a purely diffuse Principled BSDF
    (Specular IOR Level 0: no specular layer), against the same ramp as the object's own orbit-trap
    colouring (a texture's ramp) without a material."""
    scene, ob = _fractal_scene(S)
    mat, bsdf = _principled("Ramped", **{"Specular IOR Level": 0.0})
    tree = mat.node_tree
    attribute = tree.nodes.new("ShaderNodeAttribute")
    attribute.attribute_name = "unbound_orbit_trap"
    ramp = tree.nodes.new("ShaderNodeValToRGB")
    texture = bpy.data.textures.new("Ramp", 'BLEND')
    texture.use_color_ramp = True
    for color_ramp in (ramp.color_ramp, texture.color_ramp):
        for element, (position, color) in zip(color_ramp.elements, stops):
            element.position = position
            element.color = tuple(color) + (1.0,)
    tree.links.new(attribute.outputs["Fac"], ramp.inputs["Fac"])
    tree.links.new(ramp.outputs["Color"], bsdf.inputs["Base Color"])
    ob.unbound.material = mat
    material = _rgba(S.render_to_exr(scene, "material.exr"))
    ob.unbound.material = None
    ob.unbound.color_mode = 'ORBIT_TRAP'
    ob.unbound.color_ramp_texture = texture
    legacy = _rgba(S.render_to_exr(scene, "legacy.exr"))
    _save(material=material, legacy=legacy)
    S.report(done=True)


def unsupported_node_warns_and_falls_back(S, mod):
    """A Noise Texture drives Base Color: F12 warns, naming the node, and renders the input's own
    value; then the same material with the link removed."""
    scene, ob = _fractal_scene(S)
    mat, bsdf = _principled("Noisy", base=(0.2, 0.6, 0.3))
    noise = mat.node_tree.nodes.new("ShaderNodeTexNoise")
    link = mat.node_tree.links.new(noise.outputs["Color"], bsdf.inputs["Base Color"])
    ob.unbound.material = mat
    outcome, written = S.attempt(scene, "noisy.png")
    linked = _rgba(S.render_to_exr(scene, "linked.exr"))
    mat.node_tree.links.remove(link)
    unlinked = _rgba(S.render_to_exr(scene, "unlinked.exr"))
    _save(linked=linked, unlinked=unlinked)
    S.report(outcome=outcome, written=written)


def emission_and_alpha(S, mod, emission, strength, alpha):
    """The same material three times: as is, with emission, and with alpha below 1."""
    scene, ob = _fractal_scene(S)
    mat, bsdf = _principled("Glowing", metallic=0.3, roughness=0.4)
    ob.unbound.material = mat
    plain = _rgba(S.render_to_exr(scene, "plain.exr"))
    bsdf.inputs["Emission Color"].default_value = tuple(emission) + (1.0,)
    bsdf.inputs["Emission Strength"].default_value = strength
    emitting = _rgba(S.render_to_exr(scene, "emitting.exr"))
    bsdf.inputs["Emission Strength"].default_value = 0.0
    bsdf.inputs["Alpha"].default_value = alpha
    faded = _rgba(S.render_to_exr(scene, "faded.exr"))
    _save(plain=plain, emitting=emitting, faded=faded)
    S.report(done=True)
