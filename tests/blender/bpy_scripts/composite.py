"""Scripts of test_composite_blender.py (run inside bpy by conftest.run_bpy: see bpy_scripts/__init__.py)."""
import time

import bpy
import numpy as np

# Object indices of the reference render (Cycles' IndexOB pass): which surface a pixel shows.
BALL_INDEX, FRONT_INDEX, BACK_INDEX = 1, 2, 3
CYCLES_SAMPLES = 16


def _cube(name, location, size, index):
    bpy.ops.mesh.primitive_cube_add(size=size, location=location)
    cube = bpy.context.object
    cube.name = name
    cube.pass_index = index
    return cube


def _scene(S, width, height):
    """The unit ball (mu = 0) between a cube in front of it and one behind it, both partly
    overlapping it in the image; Cycles' settings shared by both renders."""
    scene = S.empty_scene(width, height, "UNBOUND")
    S.add_camera(scene, location=(0.0, -4.0, 0.6), target=(0.0, 0.0, 0.0), lens=35.0)
    scene.render.film_transparent = True
    S.cycles_cpu(scene, CYCLES_SAMPLES)
    S.unit_ball()
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", 'SUN'))
    sun.data.energy = 3.0
    sun.rotation_euler = (0.6, 0.2, 0.4)
    scene.collection.objects.link(sun)
    _cube("Front", (0.6, -1.3, -0.35), 0.8, FRONT_INDEX)
    _cube("Back", (-1.1, 1.4, 0.4), 1.4, BACK_INDEX)
    return scene


def _file_output(tree, directory, sockets):
    """A File Output node writing `sockets` ({name: (output socket, 'RGBA' or 'FLOAT')}) as a 32-bit
    multilayer EXR (4.x and 5.x spell it differently)."""
    fo = tree.nodes.new("CompositorNodeOutputFile")
    if bpy.app.version >= (5, 0, 0):
        fo.format.media_type = 'MULTI_LAYER_IMAGE'
        fo.directory = directory
        fo.file_name = "combined_"
        fo.file_output_items.clear()
        for name, (_, kind) in sockets.items():
            fo.file_output_items.new(kind, name)
    else:
        fo.format.file_format = 'OPEN_EXR_MULTILAYER'
        fo.base_path = directory + "/combined_"
        fo.layer_slots.clear()
        for name in sockets:
            fo.layer_slots.new(name)
    fo.format.color_depth = '32'
    for name, (socket, _) in sockets.items():
        tree.links.new(socket, fo.inputs[name])


def composite_matches_cycles(S, mod, width=160, height=120):
    """F12 of the Unbound scene after Composite with Cycles (the Z Combine's image and depth, read
    from a File Output node), then Cycles alone with a 256 x 128 UV sphere in place of the fractal:
    both saved for the test to compare."""
    scene = _scene(S, width, height)
    assert bpy.ops.scene.unbound_composite_with_cycles() == {'FINISHED'}
    copy = bpy.data.scenes[scene.name + " Cycles"]
    S.cycles_cpu(copy, CYCLES_SAMPLES)
    tree = mod.utils.compositor_tree(scene)
    zc = tree.nodes["Unbound+Cycles Z Combine"]
    meshes = tree.nodes["Unbound+Cycles Cycles"]
    fractal = tree.nodes["Unbound+Cycles Unbound"]
    tmp = S.tmp_dir()
    # The Z Combine's result and each scene's own render (to see which surface is in front).
    _file_output(tree, str(tmp / "combined"), {
        "Composite": (zc.outputs[0], 'RGBA'), "CompositeDepth": (zc.outputs[1], 'FLOAT'),
        "Cycles": (meshes.outputs["Image"], 'RGBA'), "CyclesDepth": (meshes.outputs["Depth"], 'FLOAT'),
        "Unbound": (fractal.outputs["Image"], 'RGBA'), "UnboundDepth": (fractal.outputs["Depth"], 'FLOAT')})
    started = time.perf_counter()
    S.render_to_exr(scene, "composite.exr")
    composite_seconds = time.perf_counter() - started
    exr = sorted((tmp / "combined").glob("*.exr"))
    assert len(exr) == 1, exr
    px = S.read_exr(exr[0])
    keys = sorted(px)

    def channel(layer, suffix):
        found = [k for k in keys if (k.rsplit(".", 1)[0] if suffix else k.split(".")[0]) == layer
                 and k.endswith(suffix)]
        assert len(found) == 1, (layer, suffix, keys)
        return px[found[0]]

    out = {}
    for layer in ("Composite", "Cycles", "Unbound"):
        out[layer.lower() + "_rgba"] = np.stack([channel(layer, "." + c) for c in "RGBA"], axis=-1)
        out[layer.lower() + "_depth"] = channel(layer + "Depth", "")

    # The reference: Cycles alone, the ball a fine smooth UV sphere of radius 1.
    S.uv_sphere().pass_index = BALL_INDEX
    scene.render.engine = 'CYCLES'
    scene.render.use_compositing = False
    S.cycles_cpu(scene, CYCLES_SAMPLES)
    layer = scene.view_layers[0]
    layer.use_pass_z = True
    layer.use_pass_object_index = True
    started = time.perf_counter()
    px = S.render_to_exr(scene, "reference.exr")
    reference_seconds = time.perf_counter() - started
    out.update(reference_rgba=S.combined(px),
               reference_depth=px["ViewLayer.Depth.Z"],
               reference_index=px.get("ViewLayer.IndexOB.X", px.get("ViewLayer.Object Index.X")))  # 4.x, 5.x
    np.savez(tmp / "renders.npz", **out)
    S.report(done=True, keys=keys, composite_seconds=composite_seconds, reference_seconds=reference_seconds)


def unrendered_warning(S, mod, set_up, add_to_scene_collection=False):
    """F12 of the fractal with two cubes: the render's reports (bpy.ops.render.render raises none for
    a warning; the engine's report goes to stdout, which the test reads)."""
    scene = _scene(S, 40, 30)
    if set_up:
        assert bpy.ops.scene.unbound_composite_with_cycles() == {'FINISHED'}
        S.cycles_cpu(bpy.data.scenes[scene.name + " Cycles"], 1)
    if add_to_scene_collection:
        _cube("Late", (0.0, 2.5, 0.0), 0.5, 4)  # added after the set-up: not in the Cycles copy
    outcome, written = S.attempt(scene)
    S.report(outcome=outcome, written=written)


def refresh(S, mod):
    """Composite with Cycles run twice, with Set Up Compositing and a user's node in between: what
    each run leaves behind."""
    scene = _scene(S, 40, 30)
    scene.render.film_transparent = False
    assert bpy.ops.scene.unbound_composite_with_cycles() == {'FINISHED'}
    tree = mod.utils.compositor_tree(scene)
    ours = sorted(n.name for n in tree.nodes if n.name.startswith("Unbound+Cycles "))
    user = tree.nodes.new("CompositorNodeViewer")
    user.name = "Mine"
    assert bpy.ops.scene.unbound_setup_compositing() == {'FINISHED'}
    _cube("Late", (0.0, 2.5, 0.0), 0.5, 4)
    collection = bpy.data.collections.new("Props")
    scene.collection.children.link(collection)
    scene.view_layers[0].layer_collection.children["Props"].exclude = True
    assert bpy.ops.scene.unbound_composite_with_cycles() == {'FINISHED'}
    copy = bpy.data.scenes[scene.name + " Cycles"]
    output = [n for n in tree.nodes if n.bl_idname in ("CompositorNodeComposite", "NodeGroupOutput")]
    S.report(first=ours, second=sorted(n.name for n in tree.nodes if n.name.startswith("Unbound+Cycles ")),
             all_nodes=sorted(n.name for n in tree.nodes), scenes=sorted(s.name for s in bpy.data.scenes),
             engine=copy.render.engine, transparent=copy.render.film_transparent,
             unbound_transparent=scene.render.film_transparent, camera=copy.camera.name,
             objects=sorted(o.name for o in copy.objects), props_excluded=copy.view_layers[0].layer_collection
             .children["Props"].exclude, z_pass=copy.view_layers[0].use_pass_z,
             depth_pass=scene.view_layers[0].unbound.use_pass_depth,
             output_fed_by=[l.from_node.name for n in output for l in tree.links if l.to_node == n])


def _render_scene(S, scene, name):
    """F12 of `scene` (not necessarily the context's), every pass in a 32-bit multilayer EXR."""
    S.exr_output(scene)
    path = S.tmp_dir() / name
    scene.render.filepath = str(path)
    bpy.ops.render.render(write_still=True, scene=scene.name)
    px = S.read_exr(path)
    return (S.combined(px),
            np.stack([px["ViewLayer.Position." + c] for c in "XYZ"], axis=-1))


def _shadow_proxy_facts(scene, copy):
    """What the copy's stand-ins are: names, ray visibility, where they live, their vertices' radii."""
    import mathutils
    proxies = [o for c in copy.collection.children if c.get("unbound_fractal_shadows") for o in c.objects]
    facts = []
    for proxy in proxies:
        radii = np.linalg.norm(np.array([v.co[:] for v in proxy.data.vertices]), axis=1)
        facts.append(dict(name=proxy.name, camera=proxy.visible_camera, shadow=proxy.visible_shadow,
                          diffuse=proxy.visible_diffuse, glossy=proxy.visible_glossy,
                          in_unbound_scene=proxy.name in scene.objects, in_copy=proxy.name in copy.objects,
                          follows=[c.target.name for c in proxy.constraints if c.type == 'COPY_TRANSFORMS'],
                          radius_min=float(radii.min()), radius_max=float(radii.max()),
                          faces=len(proxy.data.polygons), world_is_fractal=proxy.matrix_world ==
                          mathutils.Matrix(scene.objects["Quaternion Julia"].matrix_world)))
    return facts


def fractal_shadow(S, mod, width=120, height=90, resolution=128, samples=4):
    """The unit ball (mu = 0) above a plane lit by a sun, Composite with Cycles with Fractal
    Shadows on (run twice), then off, then off with a 256 x 128 smooth UV sphere of radius 1
    invisible to the camera in the Cycles scene in place of the stand-in: the Cycles scene's image
    and Position pass each time, for the test to compare. Cycles: direct light only."""
    scene = S.empty_scene(width, height, "UNBOUND")
    S.add_camera(scene, location=(0.0, -3.5, 2.0), target=(-0.45, 0.65, -1.5), lens=35.0)
    ball = S.unit_ball()
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", 'SUN'))
    sun.data.energy, sun.data.angle = 3.0, 0.0  # a hard shadow: its outline is the ball's exactly
    sun.rotation_euler = (0.5, 0.0, 0.6)
    scene.collection.objects.link(sun)
    bpy.ops.mesh.primitive_plane_add(size=16.0, location=(0.0, 0.0, -1.5))
    bpy.context.object.data.materials.append(S.diffuse_material("Matte"))
    assert bpy.ops.scene.unbound_composite_with_cycles(shadow_resolution=resolution) == {'FINISHED'}
    copy = bpy.data.scenes[scene.name + " Cycles"]
    S.cycles_cpu(copy, samples, max_bounces=0)  # direct light: a lit diffuse plane is uniform, a shadowed one black
    copy.view_layers[0].use_pass_position = True
    first = _shadow_proxy_facts(scene, copy)
    meshes_after_one_run = len(bpy.data.meshes)
    started = time.perf_counter()
    assert bpy.ops.scene.unbound_composite_with_cycles(shadow_resolution=resolution) == {'FINISHED'}
    operator_seconds = time.perf_counter() - started
    second = _shadow_proxy_facts(scene, copy)
    meshes_after_two_runs = len(bpy.data.meshes)
    started = time.perf_counter()
    on = _render_scene(S, copy, "on.exr")
    render_seconds = time.perf_counter() - started

    # Moved, the fractal takes its stand-in along (the Copy Transforms constraint).
    ball.location = (0.3, -0.2, 0.1)
    depsgraph = copy.view_layers[0].depsgraph
    depsgraph.update()
    proxy = bpy.data.objects[second[0]["name"]]
    moved_with = list(proxy.evaluated_get(depsgraph).matrix_world.translation)
    ball.location = (0.0, 0.0, 0.0)

    assert bpy.ops.scene.unbound_composite_with_cycles(fractal_shadows=False) == {'FINISHED'}
    off_facts = _shadow_proxy_facts(scene, copy)
    collections_off = sorted(c.name for c in copy.collection.children)
    meshes_off = len(bpy.data.meshes)
    off = _render_scene(S, copy, "off.exr")

    sphere = S.uv_sphere()
    for collection in list(sphere.users_collection):
        collection.objects.unlink(sphere)
    copy.collection.objects.link(sphere)  # in the Cycles scene only, as the stand-in
    sphere.visible_camera = False
    reference = _render_scene(S, copy, "sphere.exr")

    out = {}
    for key, (rgba, position) in (("on", on), ("off", off), ("sphere", reference)):
        out[key + "_rgba"], out[key + "_position"] = rgba, position
    np.savez(S.tmp_dir() / "shadow.npz", **out)
    from mathutils import Vector
    light_travel = sun.matrix_world.to_3x3() @ Vector((0.0, 0.0, -1.0))
    S.report(first=first, second=second, meshes_after_one_run=meshes_after_one_run,
             meshes_after_two_runs=meshes_after_two_runs, meshes_off=meshes_off,
             off_facts=off_facts, collections_off=collections_off, moved_with=moved_with,
             light_travel=list(light_travel), operator_seconds=operator_seconds, render_seconds=render_seconds)


def shadow_reports(S, mod):
    """Composite with Cycles on a keyframed fractal (its info message, stdout), then on one the core
    refuses (an IFS without maps: the error, and no stand-in left in the Cycles scene)."""
    scene = _scene(S, 40, 30)
    ball = scene.objects["Quaternion Julia"]
    for frame, mu in ((1, (0.0, 0.0, 0.0, 0.0)), (10, (-0.2, 0.6, 0.0, 0.0))):
        ball.unbound.mu = mu
        ball.keyframe_insert("unbound.mu", frame=frame)
    scene.frame_set(4)
    assert bpy.ops.scene.unbound_composite_with_cycles(shadow_resolution=32) == {'FINISHED'}
    copy = bpy.data.scenes[scene.name + " Cycles"]
    keyframed = [o.name for c in copy.collection.children if c.get("unbound_fractal_shadows") for o in c.objects]
    ball.animation_data_clear()
    ball.unbound.kind = 'IFS'
    ball.unbound.ifs_maps.clear()
    try:
        bpy.ops.scene.unbound_composite_with_cycles()
        error = None
    except RuntimeError as exc:
        error = str(exc).strip().splitlines()[0]
    S.report(keyframed=keyframed, error=error, left=[c.name for c in copy.collection.children],
             meshes=sorted(m.name for m in bpy.data.meshes))
