"""Scripts of test_composite_blender.py (run inside bpy by conftest.run_bpy: see bpy_scripts/__init__.py)."""
import time

import bpy
import numpy as np

# Object indices of the reference render (Cycles' IndexOB pass): which surface a pixel shows.
BALL_INDEX, FRONT_INDEX, BACK_INDEX = 1, 2, 3


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
    _cycles_settings(scene)
    S.add_fractal(mu=(0.0, 0.0, 0.0, 0.0), max_iterations=32, threshold_mode='FIXED', epsilon=1e-4)
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", 'SUN'))
    sun.data.energy = 3.0
    sun.rotation_euler = (0.6, 0.2, 0.4)
    scene.collection.objects.link(sun)
    _cube("Front", (0.6, -1.3, -0.35), 0.8, FRONT_INDEX)
    _cube("Back", (-1.1, 1.4, 0.4), 1.4, BACK_INDEX)
    return scene


def _cycles_settings(scene):
    scene.cycles.device = 'CPU'
    scene.cycles.samples = 16
    scene.cycles.use_denoising = False
    scene.cycles.use_adaptive_sampling = False


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
    _cycles_settings(copy)
    tree = mod.utils.compositor_tree(scene)
    zc = tree.nodes["Unbound+Cycles Z Combine"]
    meshes = tree.nodes["Unbound+Cycles Cycles"]
    fractal = tree.nodes["Unbound+Cycles Unbound"]
    tmp = S.pathlib.Path(S.os.environ["UNBOUND_TEST_TMP"])
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
    bpy.ops.mesh.primitive_uv_sphere_add(segments=256, ring_count=128, radius=1.0)
    sphere = bpy.context.object
    sphere.pass_index = BALL_INDEX
    bpy.ops.object.shade_smooth()
    scene.render.engine = 'CYCLES'
    scene.render.use_compositing = False
    _cycles_settings(scene)
    layer = scene.view_layers[0]
    layer.use_pass_z = True
    layer.use_pass_object_index = True
    started = time.perf_counter()
    px = S.render_to_exr(scene, "reference.exr")
    reference_seconds = time.perf_counter() - started
    out.update(reference_rgba=np.stack([px["ViewLayer.Combined." + c] for c in "RGBA"], axis=-1),
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
        _cycles_settings(bpy.data.scenes[scene.name + " Cycles"])
        bpy.data.scenes[scene.name + " Cycles"].cycles.samples = 1
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
