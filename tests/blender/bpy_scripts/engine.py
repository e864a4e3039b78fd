"""Scripts of test_engine.py (run inside bpy by conftest.run_bpy: see bpy_scripts/__init__.py)."""
import os

import bpy
import numpy as np


def passes_reach_compositor_and_exr(S, mod):
    scene = S.empty_scene(80, 60)
    scene.render.film_transparent = True  # Combined alpha is then the coverage
    S.add_camera(scene)
    S.add_fractal()
    vl = scene.view_layers[0]
    for p in mod.passes.PASSES:
        if p.toggle:
            setattr(vl.unbound, p.toggle, True)
    tree = mod.utils.compositor_tree(scene, create=True)
    rl = tree.nodes.new("CompositorNodeRLayers")
    sockets = [s.name for s in rl.outputs if s.enabled]
    exr = S.render_to_exr(scene)
    # The writer's data equals a direct native render of the same camera (rows: EXR top-down).
    import unbound_core
    from bl_ext.user_default.unbound import export
    dg = bpy.context.evaluated_depsgraph_get()
    cam = export.camera_description(S.EyeCamera(), dg, 80, 60)
    bufs = {n: np.empty((60, 80, c), np.float32) for n, c in unbound_core.PASS_CHANNELS.items()}
    unbound_core.render(cam, export.fractal_objects(dg), bufs)
    diffs = {}
    for name, chans, native in [("Depth", "Z", "depth"), ("Iterations", "X", "iterations"),
                                ("Steps", "X", "steps"), ("Distance", "X", "distance"),
                                ("Normal", "XYZ", "normal"), ("Position", "XYZ", "position")]:
        got = np.stack([exr["ViewLayer.%s.%s" % (name, c)] for c in chans], -1)[::-1]
        diffs[name] = float(np.max(np.abs(got - bufs[native])))
    alpha = exr["ViewLayer.Combined.A"][::-1]
    diffs["alpha"] = float(np.max(np.abs(alpha - bufs["alpha"][..., 0])))
    S.report(sockets=sockets, channels=sorted(exr), diffs=diffs, coverage=float(alpha.mean()),
             stats=mod.engine.LAST_STATS)


def disabled_passes_are_not_registered(S, mod):
    scene = S.empty_scene(32, 24)
    S.add_camera(scene)
    S.add_fractal()
    scene.view_layers[0].unbound.use_pass_iterations = True
    exr = S.render_to_exr(scene)
    S.report(channels=sorted(exr))


def keyframes_and_drivers_reach_the_render(S, mod):
    scene = S.empty_scene(48, 36)
    S.add_camera(scene)
    ob = S.add_fractal(mu=(-1.0, 0.0, 0.0, 0.0))
    ob.keyframe_insert("unbound.mu", frame=1)
    ob.unbound.mu = (0.0, 0.0, 0.0, 0.0)
    ob.keyframe_insert("unbound.mu", frame=3)
    fc = ob.driver_add("unbound.theta")
    fc.driver.expression = "frame * 0.5"
    scene.view_layers[0].unbound.use_pass_depth = True
    seen = []
    for f in (1, 2, 3):
        scene.frame_set(f)
        dg = bpy.context.evaluated_depsgraph_get()
        seen.append(mod.export.fractal_objects(dg)[0]["mu"][0])
        seen.append(mod.export.fractal_objects(dg)[0]["theta"])
    scene.frame_set(3)
    ball = S.render_to_exr(scene, "ball.exr")
    scene.frame_set(1)
    basilica = S.render_to_exr(scene, "basilica.exr")
    S.report(seen=seen, same=bool(np.array_equal(ball["ViewLayer.Depth.Z"], basilica["ViewLayer.Depth.Z"])))


def union_of_objects_instances_and_hidden(S, mod):
    scene = S.empty_scene(64, 48)
    S.add_camera(scene, location=(0, -5, 0))
    a = S.add_fractal(mu=(0, 0, 0, 0))
    a.location = (-1.2, 0, 0)
    a.scale = (0.7,) * 3
    b = S.add_fractal(mu=(0, 0, 0, 0))
    b.location = (1.2, 0, 0)
    b.scale = (0.7,) * 3
    scene.render.film_transparent = True
    both = S.render_to_exr(scene, "both.exr")["ViewLayer.Combined.A"]
    b.hide_render = True
    one = S.render_to_exr(scene, "one.exr")["ViewLayer.Combined.A"]
    S.report(both_left=float(both[:, :32].mean()), both_right=float(both[:, 32:].mean()),
             one_left=float(one[:, :32].mean()), one_right=float(one[:, 32:].mean()))


def background_world_colour_and_transparent_film(S, mod):
    scene = S.empty_scene(32, 24)
    S.add_camera(scene)
    S.add_fractal(mu=(0, 0, 0, 0))
    world = bpy.data.worlds.new("W")
    world.use_nodes = True
    bg = world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (0.2, 0.4, 0.6, 1.0)
    bg.inputs["Strength"].default_value = 0.5
    scene.world = world
    exr = S.render_to_exr(scene, "world.exr")
    corner = [float(exr["ViewLayer.Combined." + c][0, 0]) for c in "RGBA"]
    scene.render.film_transparent = True
    exr = S.render_to_exr(scene, "film.exr")
    clear = [float(exr["ViewLayer.Combined." + c][0, 0]) for c in "RGBA"]
    centre = float(exr["ViewLayer.Combined.A"][12, 16])
    S.report(corner=corner, clear=clear, centre=centre)


def threads_setting_honoured(S, mod):
    scene = S.empty_scene(64, 64)
    S.add_camera(scene)
    S.add_fractal()
    scene.render.threads_mode = 'FIXED'
    scene.render.threads = 1
    S.render_to_exr(scene, "t1.exr")
    one = dict(mod.engine.LAST_STATS)
    scene.render.threads_mode = 'AUTO'
    S.render_to_exr(scene, "ta.exr")
    S.report(one=one, auto=dict(mod.engine.LAST_STATS))


def errors_are_reported_not_raised_inside_the_engine(S, mod):
    scene = S.empty_scene(32, 24)
    S.add_camera(scene)
    S.add_fractal()
    scene.camera.data.type = 'PANO'
    scene.camera.data.panorama_type = 'EQUIANGULAR_CUBEMAP_FACE'
    try:
        bpy.ops.render.render()
        outcome = "finished"
    except RuntimeError as exc:
        outcome = str(exc)
    S.report(outcome=outcome)


def add_operator_and_empty_display(S, mod):
    S.empty_scene(32, 24)
    bpy.ops.object.unbound_fractal_add(mu=(0.0, 0.0, 0.0, 0.0))
    ob = bpy.context.object
    first = ob.empty_display_size
    ob.unbound.mu = (-0.2, 0.8, 0.0, 0.0)
    bpy.context.scene.frame_set(1)  # depsgraph update: the handler follows mu
    S.report(kind=ob.unbound.kind, fractal=ob.unbound.is_fractal, display=ob.empty_display_type,
             first=first, second=ob.empty_display_size)


def setup_compositing_writes_pass_file(S, mod):
    scene = S.empty_scene(32, 24)
    S.add_camera(scene)
    S.add_fractal()
    vl = scene.view_layers[0]
    vl.unbound.use_pass_depth = True
    vl.unbound.use_pass_normal = True
    out = os.path.join(os.environ["UNBOUND_TEST_TMP"], "comp") + "/"
    bpy.ops.scene.unbound_setup_compositing(directory=out)
    scene.render.filepath = os.path.join(os.environ["UNBOUND_TEST_TMP"], "still.png")
    bpy.ops.render.render(write_still=True)
    files = sorted(os.listdir(out))
    S.report(files=files, channels=sorted(S.read_exr(os.path.join(out, files[0]))))


def denoise_lowers_the_error(S, mod, samples=1, reference_samples=256, gi=False):
    """Set Up Compositing (Denoise on) on a noisy render (soft shadows, ambient occlusion with
    few rays, `samples` samples; with `gi`, path-traced instead: Global Illumination in a uniform
    World, whose light and bounces are Monte-Carlo noise): the multilayer pass file holds the
    image and the Denoised one; both against a `reference_samples` render of the same scene
    (RMSE over the frame)."""
    import time
    scene = S.empty_scene(96, 72)
    S.add_camera(scene, location=(1.5, -6.0, 3.0), target=(0.0, 0.0, -0.6))
    S.add_fractal(mu=(0.0, 0.0, 0.0, 0.0))   # the unit ball on a calm sea: smooth surfaces, so
    # what differs from the reference is the noise of the soft shadow and the occlusion (or the paths)
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", 'SUN'))
    sun.data.angle, sun.data.energy = 1.2, 2.0
    sun.rotation_euler = (0.6, 0.3, 0.4)
    scene.collection.objects.link(sun)
    u = scene.unbound
    u.shadows = 'SOFT'
    u.use_sea, u.sea_height, u.sea_amplitude, u.sea_reflectivity = True, -1.0, 0.0, 0.0
    if gi:
        world = bpy.data.worlds.new("Uniform")
        world.use_nodes = True
        world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.3, 0.3, 0.3, 1.0)
        scene.world = world
        u.axle_light, u.use_gi = 0.0, True
    else:
        u.ao_strength, u.ao_samples, u.ao_distance = 1.0, 1, 0.5
        u.ambient = (0.3, 0.3, 0.3)
    out = os.path.join(os.environ["UNBOUND_TEST_TMP"], "denoise") + "/"
    assert bpy.ops.scene.unbound_setup_compositing(directory=out) == {'FINISHED'}
    tree = mod.utils.compositor_tree(scene)
    node = tree.nodes["Unbound Denoise"]
    fed = sorted(link.to_socket.name for link in tree.links if link.to_node == node)
    images = {}
    for name, count in (("noisy", samples), ("reference", reference_samples)):
        u.samples = count
        scene.render.filepath = os.path.join(os.environ["UNBOUND_TEST_TMP"], name + ".png")
        started = time.perf_counter()
        bpy.ops.render.render(write_still=True)
        seconds = time.perf_counter() - started
        files = sorted(os.listdir(out))
        layers = S.read_exr(os.path.join(out, files[-1]))
        os.remove(os.path.join(out, files[-1]))
        images[name] = dict(seconds=seconds, layers=sorted(layers),
                            image=np.stack([np.asarray(layers["Combined.%s" % c]) for c in "RGB"], -1),
                            denoised=np.stack([np.asarray(layers["Denoised.%s" % c]) for c in "RGB"], -1))
    ref = images["reference"]["image"]

    def rmse(a):
        return float(np.sqrt(np.mean((a - ref) ** 2)))
    S.report(fed=fed, layers=images["noisy"]["layers"], noisy=rmse(images["noisy"]["image"]),
             denoised=rmse(images["noisy"]["denoised"]), seconds=[v["seconds"] for v in images.values()],
             denoise_changed=bool(np.any(images["noisy"]["image"] != images["noisy"]["denoised"])))


def rays_out_of_max_steps(S, mod, max_steps, samples=1):
    """F12 of the default fractal with Max Steps `max_steps` and the Max Steps pass on: the engine's
    stats, the pass from the EXR (rows bottom-up, as the core's), the Render Layers node's sockets with
    the pass off and on, and the core's camera dict (for the float64 reference)."""
    scene = S.empty_scene(80, 60)
    S.add_camera(scene)
    ob = S.add_fractal(max_steps=max_steps)
    scene.unbound.samples = samples
    vl = scene.view_layers[0]
    tree = mod.utils.compositor_tree(scene, create=True)
    sockets = {}
    for on in (False, True):
        vl.unbound.use_pass_max_steps = on
        node = tree.nodes.new("CompositorNodeRLayers")
        sockets[on] = [s.name for s in node.outputs if s.enabled]
        tree.nodes.remove(node)
    # No compositing for the render: Blender 5.x writes nothing from a compositor tree without an
    # output node (4.x writes the render result).
    if bpy.app.version >= (5, 0, 0):
        scene.compositing_node_group = None
    else:
        scene.use_nodes = False
    exr = S.render_to_exr(scene)
    from bl_ext.user_default.unbound import export
    dg = bpy.context.evaluated_depsgraph_get()
    cam = export.camera_description(S.EyeCamera(), dg, 80, 60)
    S.report(stats=mod.engine.LAST_STATS, marked=exr["ViewLayer.Max Steps.X"][::-1].tolist(),
             sockets_off=sockets[False], sockets_on=sockets[True], toggle_name=vl.unbound.bl_rna.properties[
                 "use_pass_max_steps"].name,
             camera=dict(matrix=[list(r) for r in cam["matrix"]], projection=[list(r) for r in cam["projection"]]),
             mu=list(ob.unbound.mu), max_iterations=ob.unbound.max_iterations)
