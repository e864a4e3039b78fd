"""Scripts of test_world_light_blender.py (run inside bpy by conftest.run_bpy)."""
import importlib
import math

import bpy
import numpy as np


def world_light(mod):
    return importlib.import_module(mod.__name__ + ".world_light")


def ball_scene(S, width, height, rho):
    scene = S.empty_scene(width, height)
    S.add_camera(scene, location=(0.6, -3.4, 1.0))
    scene.render.film_transparent = True  # alpha = coverage; the world still lights
    S.standard_view(scene)
    S.unit_ball(color=(rho, rho, rho))
    u = scene.unbound
    u.axle_light = 0.0
    u.ambient = (0.0, 0.0, 0.0)
    return scene


def uniform_world(S, mod, radiance, rho, samples, world_samples):
    scene = ball_scene(S, 48, 36, rho)
    S.uniform_world(scene, radiance)
    scene.unbound.samples = samples
    scene.unbound.world_samples = world_samples
    px = S.combined(S.render_to_exr(scene, "uniform.exr"))
    np.save(S.tmp_dir() / "uniform.npy", px)
    S.report(constant_map=world_light(mod).world_map(scene).tolist())


def write_hdri(path, width=64, height=32):
    """A sky: a blue gradient up, a dark ground, a warm bright blob at u = 0.3, 30 degrees up."""
    import OpenImageIO as oiio
    u = (np.arange(width) + 0.5) / width
    v = (np.arange(height) + 0.5) / height
    uu, vv = np.meshgrid(u, v)
    lat = (vv - 0.5) * math.pi
    img = np.zeros((height, width, 3), np.float32)
    sky = np.clip(np.sin(lat), 0, None)
    img[..., 0] = 0.2 + 0.3 * sky
    img[..., 1] = 0.25 + 0.45 * sky
    img[..., 2] = 0.3 + 0.9 * sky
    img[lat < 0] = (0.08, 0.06, 0.04)
    blob = np.exp(-(((uu - 0.3) / 0.05) ** 2 + ((lat - math.radians(30)) / 0.12) ** 2))
    img += blob[..., None] * np.array([30.0, 24.0, 16.0], np.float32)
    out = oiio.ImageOutput.create(str(path))
    out.open(str(path), oiio.ImageSpec(width, height, 3, oiio.FLOAT))
    out.write_image(np.ascontiguousarray(img[::-1]))  # OpenEXR's first row is the top
    out.close()


def hdri_world(S, mod, samples, world_samples, cycles_samples, rotation_z_deg):
    rho = 0.7
    scene = ball_scene(S, 64, 48, rho)
    path = S.tmp_dir() / "sky.exr"
    write_hdri(path)
    world = bpy.data.worlds.new("HDRI")
    world.use_nodes = True
    nt = world.node_tree
    env = nt.nodes.new("ShaderNodeTexEnvironment")
    env.image = bpy.data.images.load(str(path))
    coords = nt.nodes.new("ShaderNodeTexCoord")
    mapping = nt.nodes.new("ShaderNodeMapping")
    mapping.inputs["Rotation"].default_value = (0.0, 0.0, math.radians(rotation_z_deg))
    nt.links.new(coords.outputs["Generated"], mapping.inputs["Vector"])
    nt.links.new(mapping.outputs["Vector"], env.inputs["Vector"])
    nt.links.new(env.outputs["Color"], nt.nodes["Background"].inputs["Color"])
    scene.world = world
    u = scene.unbound
    u.samples = samples
    u.world_samples = world_samples
    u.world_resolution = 256
    u.world_bake_samples = 16
    import time
    t0 = time.perf_counter()
    baked = world_light(mod).world_map(scene)
    bake_seconds = time.perf_counter() - t0
    t0 = time.perf_counter()
    again = world_light(mod).world_map(scene)
    cached_seconds = time.perf_counter() - t0
    np.save(S.tmp_dir() / "baked.npy", baked)
    unbound = S.combined(S.render_to_exr(scene, "unbound.exr"))
    # A changed node setting is a new map (the cache is keyed by the tree's settings).
    key = world_light(mod).fingerprint(world, 256, 16)
    mapping.inputs["Rotation"].default_value = (0.0, 0.0, math.radians(rotation_z_deg + 90.0))
    changed_key = world_light(mod).fingerprint(world, 256, 16) != key
    mapping.inputs["Rotation"].default_value = (0.0, 0.0, math.radians(rotation_z_deg))

    # Cycles: the same camera and world on a fine smooth UV sphere with a Diffuse BSDF.
    for ob in list(scene.objects):
        if ob.type != 'CAMERA':
            ob.hide_render = True
    S.uv_sphere().data.materials.append(S.diffuse_material("Diffuse", (rho, rho, rho)))
    scene.render.engine = 'CYCLES'
    # Direct light only (max bounces 0): the world seen by the surface, no interreflection.
    S.cycles_cpu(scene, cycles_samples, seed=3, max_bounces=0, filter_width=0.01)
    cycles = S.combined(S.render_to_exr(scene, "cycles.exr"))
    np.savez(S.tmp_dir() / "hdri.npz", unbound=unbound, cycles=cycles)
    S.report(bake_seconds=bake_seconds, cached_seconds=cached_seconds, changed_key=changed_key,
             shape=list(baked.shape))


def bake_failure_is_reported(S, mod):
    scene = ball_scene(S, 16, 12, 0.5)
    world = bpy.data.worlds.new("Broken")
    world.use_nodes = True
    nt = world.node_tree
    env = nt.nodes.new("ShaderNodeTexEnvironment")
    nt.links.new(env.outputs["Color"], nt.nodes["Background"].inputs["Color"])
    scene.world = world
    world_light(mod).BAKE_SCRIPT = S.tmp_dir() / "missing_script.py"
    outcome, written = S.attempt(scene, "broken.png")
    S.report(outcome=outcome, written=written)
