"""Composite with Cycles: the scene's meshes (and curves, text, volumes, ...) rendered by Cycles in a
linked copy of the scene, combined with Unbound's fractal by depth in the Unbound scene's compositor.

Unbound traces only fractals. The copy, "<scene> Cycles", holds the same collections, camera and
world, so what is added to a collection shows up in both; its engine is Cycles, its film
transparent, its Depth pass on. The Unbound scene's compositor gets a Render Layers node for each
scene and a Z Combine node (Use Alpha, Anti-Alias) between them and the output (with an Alpha
Convert before each input: see build_nodes): F12 in the Unbound
scene renders the Cycles scene too (Blender renders every scene a Render Layers node names) and
writes the composed image. The background is the Unbound scene's (its world colour, or nothing with
Transparent film): the Cycles scene's film is transparent, so the background is composed once.

Not done: shadows and reflections of one on the other (Cycles does not see the fractal, Unbound
does not see the meshes); README: Composite with Cycles gives the Convert to Mesh way to get them."""
import bpy

from . import utils

# Names of the compositor nodes this set-up makes. Not operators.NODE_PREFIX ("Unbound "): Set Up
# Compositing replaces only its own nodes and must leave these alone, and the other way round.
NODE_PREFIX = "Unbound+Cycles "
SCENE_SUFFIX = " Cycles"
# Object types Cycles renders and Unbound does not (fractals are empties; lights light the fractal).
GEOMETRY_TYPES = frozenset({'MESH', 'CURVE', 'SURFACE', 'META', 'FONT', 'CURVES', 'POINTCLOUD', 'VOLUME'})
# Render settings the copy takes from the Unbound scene on every run: the same image, frame and camera.
SHARED_RENDER_SETTINGS = ("resolution_x", "resolution_y", "resolution_percentage", "pixel_aspect_x",
                          "pixel_aspect_y", "use_border", "border_min_x", "border_max_x", "border_min_y",
                          "border_max_y", "use_crop_to_border", "fps", "fps_base", "use_multiview",
                          "views_format")
SHARED_SCENE_SETTINGS = ("frame_start", "frame_end", "frame_step", "frame_current", "camera", "world")


def _pointers(items):
    return {item.as_pointer() for item in items}


def _link_same_contents(scene, copy):
    """copy's Scene Collection holds exactly the collections and objects that scene's holds directly
    (linked, not duplicated: both scenes show the same data)."""
    source, target = scene.collection, copy.collection
    wanted = _pointers(source.children)
    for child in [c for c in target.children if c.as_pointer() not in wanted]:
        target.children.unlink(child)
    present = _pointers(target.children)
    for child in source.children:
        if child.as_pointer() not in present:
            target.children.link(child)
    wanted = _pointers(source.objects)
    for ob in [o for o in target.objects if o.as_pointer() not in wanted]:
        target.objects.unlink(ob)
    present = _pointers(target.objects)
    for ob in source.objects:
        if ob.as_pointer() not in present:
            target.objects.link(ob)


def _copy_layer_collections(source, target):
    """The view layer's per-collection switches (Exclude, Holdout, Indirect Only), so the copy
    renders what the Unbound scene's view layer shows."""
    by_collection = {lc.collection.as_pointer(): lc for lc in target.children}
    for lc in source.children:
        other = by_collection.get(lc.collection.as_pointer())
        if other is None:
            continue
        for attr in ("exclude", "holdout", "indirect_only"):
            if getattr(other, attr) != getattr(lc, attr):
                setattr(other, attr, getattr(lc, attr))
        _copy_layer_collections(lc, other)


def copy_name(scene):
    """"<scene> Cycles", the scene name shortened to fit Blender's 63 bytes (a longer name would
    be cut by Blender, and the next run would not find the copy)."""
    base = scene.name.encode()[:63 - len(SCENE_SUFFIX)].decode(errors="ignore")
    return base + SCENE_SUFFIX


def cycles_scene(scene, view_layer):
    """Creates or refreshes "<scene> Cycles", the linked copy Cycles renders; returns it and its
    view layer. Cycles' own settings (samples, denoising, light paths) are the copy's, set there."""
    name = copy_name(scene)
    copy = bpy.data.scenes.get(name)
    if copy is None:
        copy = bpy.data.scenes.new(name)
    elif copy.library is not None:
        raise RuntimeError("scene '%s' is linked from a library and cannot be changed" % name)
    copy.render.engine = 'CYCLES'
    for attr in SHARED_SCENE_SETTINGS:
        setattr(copy, attr, getattr(scene, attr))
    for attr in SHARED_RENDER_SETTINGS:
        setattr(copy.render, attr, getattr(scene.render, attr))
    # The background is the Unbound scene's: Cycles' meshes over nothing, composed over it once.
    copy.render.film_transparent = True
    _link_same_contents(scene, copy)
    layer = copy.view_layers[0]
    layer.use_pass_z = True
    if layer.layer_collection is None:  # 5.x builds a new scene's layer tree on its first update
        layer.update()
    _copy_layer_collections(view_layer.layer_collection, layer.layer_collection)
    return copy, layer


def build_nodes(scene, view_layer, copy, copy_layer):
    """Render Layers of both scenes -> Z Combine -> the output, in scene's compositor; replaces only
    the nodes an earlier run made (NODE_PREFIX). Returns the Z Combine node."""
    tree = utils.compositor_tree(scene, create=True)
    scene.render.use_compositing = True
    for node in [n for n in tree.nodes if n.name.startswith(NODE_PREFIX)]:
        tree.nodes.remove(node)
    theirs = list(tree.nodes)
    top = max((n.location.y for n in theirs), default=-300.0) + 500.0  # ours above the user's
    new_api = bpy.app.version >= (5, 0, 0)

    def add(kind, name, x, y):
        node = tree.nodes.new(kind)
        node.name = node.label = NODE_PREFIX + name
        node.location = (x, top + y)
        return node

    fractal = add("CompositorNodeRLayers", "Unbound", -450, 150)
    fractal.scene, fractal.layer = scene, view_layer.name
    meshes = add("CompositorNodeRLayers", "Cycles", -450, -250)
    meshes.scene, meshes.layer = copy, copy_layer.name
    zc = add("CompositorNodeZcombine", "Z Combine", 200, 0)
    if new_api:  # 5.x: the options are input sockets
        zc.inputs["Use Alpha"].default_value = True
        zc.inputs["Anti-Alias"].default_value = True
    else:
        zc.use_alpha = True
        zc.use_antialias_z = True
    # Z Combine's Use Alpha mixes front and back by the front's alpha (4.2 and 5.2 alike): right for
    # straight colour, so both renders (premultiplied, as Blender's) are converted first; the result,
    # front + (1 - alpha) * back, is then premultiplied and exact wherever the back pixel is empty or
    # opaque. Where both show the background (Depth 1e10, Cycles' too on an edge pixel whose first
    # sample missed) Cycles' edge must go over Unbound's background, but Z Combine breaks such ties
    # differently in 4.2 (first input) and 5.2 (second): Unbound's background is moved behind
    # Cycles' (see _behind_background), which leaves the combined Depth as it was.
    # Inputs by position: 4.x names them Image, Z, Image, Z and 5.x A, Depth A, B, Depth B.
    for index, rl, y in ((0, meshes, -250), (2, fractal, 150)):
        depth = rl.outputs.get("Depth")
        if depth is None or not depth.enabled:
            raise RuntimeError("the Render Layers node of scene '%s' has no Depth output" % rl.scene.name)
        straight = add("CompositorNodePremulKey", "Straight " + rl.name[len(NODE_PREFIX):], -100, y)
        if new_api:
            straight.inputs["Type"].default_value = 'To Straight'
        else:
            straight.mapping = 'PREMUL_TO_STRAIGHT'
        tree.links.new(rl.outputs["Image"], straight.inputs[0])
        tree.links.new(straight.outputs[0], zc.inputs[index])
        if rl is fractal:
            depth = _behind_background(tree, add, depth, new_api)
        tree.links.new(depth, zc.inputs[index + 1])
    output_type = "NodeGroupOutput" if new_api else "CompositorNodeComposite"
    output = next((n for n in theirs if n.bl_idname == output_type), None)
    if output is None:
        output = add(output_type, "Output", 450, 0)
    tree.links.new(zc.outputs[0], output.inputs[0])
    viewer = add("CompositorNodeViewer", "Viewer", 450, -200)
    tree.links.new(zc.outputs[0], viewer.inputs[0])
    return zc


# Depth at or beyond this is background: 1e10 inside the rendered window, 1e11 outside an uncropped
# border (Blender's fill); hits are nearer (the camera's clip end).
BACKGROUND_DEPTH = 5e9


def _behind_background(tree, add, depth, new_api):
    """Depth + 1e10 where it is background, else Depth: two Math nodes (the compositor's own in
    4.x, the shader Math node in 5.x). Z Combine outputs the smaller Depth, so where Unbound shows
    the background the result is still Cycles' 1e10."""
    kind = "ShaderNodeMath" if new_api else "CompositorNodeMath"
    is_background = add(kind, "Unbound Background", -100, -20)
    is_background.operation = 'GREATER_THAN'
    tree.links.new(depth, is_background.inputs[0])
    is_background.inputs[1].default_value = BACKGROUND_DEPTH
    moved = add(kind, "Unbound Background Behind", 50, -20)
    moved.operation = 'MULTIPLY_ADD'
    tree.links.new(is_background.outputs[0], moved.inputs[0])
    moved.inputs[1].default_value = 1e10
    tree.links.new(depth, moved.inputs[2])
    return moved.outputs[0]


def composited_scenes(scene):
    """Other scenes whose render the compositor of `scene` reads (unmuted Render Layers nodes),
    when F12 composites (Post Processing > Compositing on)."""
    if not scene.render.use_compositing:
        return []
    tree = utils.compositor_tree(scene)
    if tree is None:
        return []
    found = {}
    for node in tree.nodes:
        if node.bl_idname == "CompositorNodeRLayers" and not node.mute and node.scene is not None \
                and node.scene != scene:
            found[node.scene.as_pointer()] = node.scene
    return list(found.values())


def unrendered_warning(depsgraph):
    """A message naming the visible objects Unbound does not render (meshes, curves, ...) that no
    composited scene renders either, and what to do; None when there are none."""
    scene = depsgraph.scene
    missing = {}
    for inst in depsgraph.object_instances:
        ob = inst.object
        if ob.type in GEOMETRY_TYPES:
            original = ob.original
            missing.setdefault(original.name_full, original)
    if not missing:
        return None
    others = composited_scenes(scene.original)
    if others:
        # A composited scene (Composite with Cycles) renders them: warn only about objects it lacks.
        inside = set()
        for other in others:
            inside |= _pointers(other.objects)
        missing = {k: ob for k, ob in missing.items() if ob.as_pointer() not in inside}
        if not missing:
            return None
        names = sorted(missing)
        return ("%d object%s (%s) %s in no composited scene and %s not rendered: run Render > Unbound > "
                "Composite with Cycles again" % (len(names), "" if len(names) == 1 else "s", _some(names),
                                                 "is" if len(names) == 1 else "are",
                                                 "is" if len(names) == 1 else "are"))
    names = sorted(missing)
    return ("%d object%s (%s) %s not rendered: Unbound renders only fractals. Render > Unbound > Composite "
            "with Cycles renders them with Cycles and combines them by depth" % (
                len(names), "" if len(names) == 1 else "s", _some(names), "is" if len(names) == 1 else "are"))


def _some(names, limit=3):
    shown = ", ".join(names[:limit])
    return shown + (", ..." if len(names) > limit else "")
