"""Scripts of test_material_blender.py (run inside bpy by conftest.run_bpy: see bpy_scripts/__init__.py)."""
import bpy
import numpy as np

SPACING = 2.5
SUN = dict(toward=(-0.5, -0.7, 0.6), energy=3.0)


def _unbound_lighting(scene):
    u = scene.unbound
    u.axle_light = 0.0
    u.ambient = (0.0, 0.0, 0.0)
    u.shadows = 'HARD'
    u.samples = 1


def _save(S, **arrays):
    np.savez(S.tmp_dir() / "renders.npz", **arrays)


def principled_grid_matches_cycles(S, mod, grid, size, samples, segments, unbound_samples=1, world=None,
                                   world_samples=0):
    """A 3 x 3 grid of unit balls, metallic by row and roughness by column, under one sun and a
    black world (world None) or a uniform one of radiance `world`: Cycles (smooth UV spheres,
    direct light only, `samples` per pixel; a box filter with a world) and Unbound (mu = 0 fractals
    with analytic normals; `unbound_samples` x `world_samples` world-light pairs) with the same materials,
    orthographic, one image each."""
    scene = S.empty_scene(size, size, "CYCLES")
    S.add_camera(scene, location=(0.0, -10.0, 0.0), type='ORTHO', ortho_scale=3 * SPACING + 0.1)
    scene.render.film_transparent = True  # black background, alpha = coverage (the world still lights)
    S.standard_view(scene)
    if world is not None:
        S.uniform_world(scene, world)
    c = S.cycles_cpu(scene, samples, seed=7)
    if world is None:
        c.filter_width = 0.01  # every sample at the pixel centre, where Unbound's one sample is
    else:
        c.pixel_filter_type = 'BOX'  # Unbound's samples: Halton points over the pixel square
        c.filter_width = 1.0
    c.max_bounces = 0        # direct light only: the lights' own contribution through the BSDF
    c.blur_glossy = 0.0
    S.add_sun(scene, **SUN)
    spheres, materials = [], {}
    for i, metallic in enumerate(grid["metallic"]):
        for j, roughness in enumerate(grid["roughness"]):
            mat, _ = S.principled_material("M%d R%d" % (i, j), metallic=metallic, roughness=roughness)
            materials[(i, j)] = mat
            sphere = S.uv_sphere(segments, segments // 2, location=((j - 1) * SPACING, 0.0, (1 - i) * SPACING))
            sphere.data.materials.append(mat)
            spheres.append(sphere)
    cycles = S.combined(S.render_to_exr(scene, "cycles.exr"))
    for sphere in spheres:
        sphere.hide_render = True
    scene.render.engine = 'UNBOUND'
    _unbound_lighting(scene)
    scene.unbound.samples = unbound_samples
    scene.unbound.world_samples = world_samples
    for (i, j), mat in materials.items():
        # Analytic normals (the Jacobian's): eq. 15's central differences, with the default step
        # 1e-3 t, tilt the ball's normals by 0.2 degrees, which moves a one-pixel highlight.
        ob = S.unit_ball(normal_method='ANALYTIC')
        ob.location = ((j - 1) * SPACING, 0.0, (1 - i) * SPACING)
        ob.unbound.material = mat
    unbound = S.combined(S.render_to_exr(scene, "unbound.exr"))
    _save(S, cycles=cycles, unbound=unbound)
    S.report(done=True)


def _fractal_scene(S, size=(64, 48)):
    scene = S.empty_scene(*size)
    scene.render.film_transparent = True
    S.add_camera(scene)
    S.add_sun(scene, **SUN)
    _unbound_lighting(scene)
    return scene, S.add_fractal()


def attribute_ramp_drives_base_color(S, mod, stops):
    """Attribute unbound_orbit_trap -> Color Ramp -> Base Color of a purely diffuse Principled BSDF
    (Specular IOR Level 0: no specular layer), against the same ramp as the object's own orbit-trap
    colouring (a texture's ramp) without a material."""
    scene, ob = _fractal_scene(S)
    mat, bsdf = S.principled_material("Ramped", **{"Specular IOR Level": 0.0})
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
    material = S.combined(S.render_to_exr(scene, "material.exr"))
    ob.unbound.material = None
    ob.unbound.color_mode = 'ORBIT_TRAP'
    ob.unbound.color_ramp_texture = texture
    legacy = S.combined(S.render_to_exr(scene, "legacy.exr"))
    _save(S, material=material, legacy=legacy)
    S.report(done=True)


def unsupported_node_warns_and_falls_back(S, mod):
    """A Noise Texture drives Base Color: F12 warns, naming the node, and renders the input's own
    value; then the same material with the link removed."""
    scene, ob = _fractal_scene(S)
    mat, bsdf = S.principled_material("Noisy", base=(0.2, 0.6, 0.3))
    noise = mat.node_tree.nodes.new("ShaderNodeTexNoise")
    link = mat.node_tree.links.new(noise.outputs["Color"], bsdf.inputs["Base Color"])
    ob.unbound.material = mat
    outcome, written = S.attempt(scene, "noisy.png")
    linked = S.combined(S.render_to_exr(scene, "linked.exr"))
    mat.node_tree.links.remove(link)
    unlinked = S.combined(S.render_to_exr(scene, "unlinked.exr"))
    _save(S, linked=linked, unlinked=unlinked)
    S.report(outcome=outcome, written=written)


def emission_and_alpha(S, mod, emission, strength, alpha):
    """The same material three times: as is, with emission, and with alpha below 1."""
    scene, ob = _fractal_scene(S)
    mat, bsdf = S.principled_material("Glowing", metallic=0.3, roughness=0.4)
    ob.unbound.material = mat
    plain = S.combined(S.render_to_exr(scene, "plain.exr"))
    bsdf.inputs["Emission Color"].default_value = tuple(emission) + (1.0,)
    bsdf.inputs["Emission Strength"].default_value = strength
    emitting = S.combined(S.render_to_exr(scene, "emitting.exr"))
    bsdf.inputs["Emission Strength"].default_value = 0.0
    bsdf.inputs["Alpha"].default_value = alpha
    faded = S.combined(S.render_to_exr(scene, "faded.exr"))
    _save(S, plain=plain, emitting=emitting, faded=faded)
    S.report(done=True)
