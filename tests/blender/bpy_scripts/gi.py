"""Scripts of test_gi_blender.py (run inside bpy by conftest.run_bpy: see bpy_scripts/__init__.py)."""
import bpy
import numpy as np


def ball_over_floor(S, mod, size, ball_color, floor_color, world_color, sun_toward, sun_energy, bounces,
                    samples, world_samples, cycles_samples, principled=None):
    """The red unit ball (mu = 0) touching a white diffuse floor at z = -1 (Unbound: the flat sea,
    no mirror; Cycles: a large plane), a sun and a uniform world. Renders Unbound with GI, Unbound
    without GI, Unbound's ball alone (its coverage, for the masks) and Cycles with the same bounce
    limits on a fine smooth UV sphere."""
    scene = S.empty_scene(size[0], size[1])
    S.add_camera(scene, location=(0.0, -5.0, 0.8), target=(0.0, 0.0, -0.5))
    S.standard_view(scene)
    S.uniform_world(scene, world_color)
    S.add_sun(scene, sun_toward, sun_energy)
    ob = S.unit_ball(color=tuple(ball_color))
    # A Principled BSDF (metallic, roughness) of the ball's colour instead of Lambert, in both engines.
    ball_material = (S.principled_material("Ball", ball_color, *principled)[0] if principled
                     else S.diffuse_material("Ball", ball_color))
    if principled:
        ob.unbound.material = ball_material
    u = scene.unbound
    u.axle_light = 0.0
    u.ambient = (0.0, 0.0, 0.0)
    u.shadows = 'HARD'
    u.samples = samples
    u.world_samples = world_samples
    u.use_sea = True
    u.sea_height = -1.0
    u.sea_amplitude = 0.0
    u.sea_color = tuple(floor_color)
    u.sea_reflectivity = 0.0
    u.use_gi = True
    u.max_bounces, u.diffuse_bounces, u.glossy_bounces = bounces
    renders = {"gi": S.combined(S.render_to_exr(scene, "gi.exr"))}
    u.use_gi = False
    renders["direct"] = S.combined(S.render_to_exr(scene, "direct.exr"))
    u.use_sea = False
    u.samples = 1
    scene.render.film_transparent = True
    renders["ball"] = S.combined(S.render_to_exr(scene, "ball.exr"))
    scene.render.film_transparent = False

    for ob in list(scene.objects):
        if ob.type not in {'CAMERA', 'LIGHT'}:
            ob.hide_render = True
    S.uv_sphere().data.materials.append(ball_material)
    bpy.ops.mesh.primitive_plane_add(size=2000.0, location=(0.0, 0.0, -1.0))
    bpy.context.object.data.materials.append(S.diffuse_material("Floor", floor_color))
    scene.render.engine = 'CYCLES'
    c = S.cycles_cpu(scene, cycles_samples, seed=5)
    c.max_bounces, c.diffuse_bounces, c.glossy_bounces = bounces
    c.transmission_bounces = c.volume_bounces = 0
    c.sample_clamp_direct = c.sample_clamp_indirect = 0.0  # no clamping: unbiased, as Unbound
    c.blur_glossy = 0.0  # Filter Glossy would roughen glossy lobes after a diffuse bounce
    c.filter_width = 0.01  # every sample at the pixel centre
    renders["cycles"] = S.combined(S.render_to_exr(scene, "cycles.exr"))
    np.savez(S.tmp_dir() / "gi.npz", **renders)
    S.report(done=True)


def light_paths_panel_and_export(S, mod):
    """The Light Paths panel in the Render tab (under Unbound's, closed by default as Cycles' is)
    and the settings in the shading dict that F12 and the viewport both send."""
    scene = S.empty_scene()
    S.add_fractal()
    cls = mod.ui.UNBOUND_PT_render_light_paths
    panel = dict(label=cls.bl_label, parent=cls.bl_parent_id, context=cls.bl_context,
                 closed='DEFAULT_CLOSED' in cls.bl_options, registered=hasattr(bpy.types, cls.__name__))
    u = scene.unbound
    defaults = dict(use_gi=u.use_gi, max_bounces=u.max_bounces, diffuse_bounces=u.diffuse_bounces,
                    glossy_bounces=u.glossy_bounces)
    u.use_gi, u.max_bounces, u.diffuse_bounces, u.glossy_bounces = True, 7, 3, 2
    shading = mod.export.shading_description(bpy.context.evaluated_depsgraph_get())
    S.report(panel=panel, defaults=defaults,
             exported={k: shading[k] for k in ("use_gi", "max_bounces", "diffuse_bounces", "glossy_bounces")})
