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

Fractal shadows (make_shadow_proxies): the fractal's shadows and reflections on the meshes come from
a stand-in Cycles does see, in the copy only: each rendered fractal converted to a mesh (the core's
extraction, as Convert to Mesh) at a modest resolution, invisible to camera rays (Unbound draws the
fractal itself) and held on the fractal by a Copy Transforms constraint, in a collection of the copy
alone. A run replaces the stand-ins; their shape is that of the frame the operator ran at.
Not available: the meshes' shadows and reflections on the fractal (Unbound does not trace meshes)."""
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
# The copy's collection of fractal shadow stand-ins, found again by this custom property (its name
# may have been taken: Blender appends ".001"). Only the copy's Scene Collection holds it.
SHADOW_COLLECTION = "Unbound Fractal Shadows"
SHADOW_MARK = "unbound_fractal_shadows"
SHADOW_SUFFIX = " Shadow"


def _pointers(items):
    return {item.as_pointer() for item in items}


def _link_same_contents(scene, copy):
    """copy's Scene Collection holds exactly the collections and objects that scene's holds directly
    (linked, not duplicated: both scenes show the same data)."""
    source, target = scene.collection, copy.collection
    wanted = _pointers(source.children)
    for child in [c for c in target.children if c.as_pointer() not in wanted and not c.get(SHADOW_MARK)]:
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


def rendered_fractals(view_layer):
    """The fractal objects F12 renders in view_layer, by name: not disabled for render themselves,
    in a collection neither excluded nor disabled for render (nor inside one that is). Instances
    (collection instances, geometry nodes) are not among them."""
    found = {}

    def walk(layer_collection):
        if layer_collection.exclude or layer_collection.collection.hide_render:
            return
        for ob in layer_collection.collection.objects:
            if utils.is_fractal(ob) and not ob.hide_render:
                found[ob.name_full] = ob
        for child in layer_collection.children:
            walk(child)

    walk(view_layer.layer_collection)
    return [found[name] for name in sorted(found)]


def shadow_collection(copy, create=False):
    """The copy's collection of fractal shadow stand-ins (SHADOW_MARK); None if there is none and
    create is False."""
    found = next((c for c in copy.collection.children if c.get(SHADOW_MARK)), None)
    if found is None and create:
        found = bpy.data.collections.new(SHADOW_COLLECTION)
        found[SHADOW_MARK] = True
        copy.collection.children.link(found)
    return found


def remove_shadow_proxies(copy):
    """Removes the copy's stand-ins, their meshes and materials, and their collection."""
    collection = shadow_collection(copy)
    if collection is None:
        return
    for ob in list(collection.objects):
        mesh = ob.data
        materials = [m for m in mesh.materials if m is not None]
        bpy.data.objects.remove(ob)
        if mesh.users == 0:
            bpy.data.meshes.remove(mesh)
        for material in materials:
            if material.users == 0:
                bpy.data.materials.remove(material)
    bpy.data.collections.remove(collection)


def _proxy_material(name, color):
    """The fractal's Color on a Principled BSDF: what its stand-in shows in reflections and bounces."""
    material = utils.new_node_material(name)
    material.diffuse_color = tuple(color) + (1.0,)
    bsdf = material.node_tree.nodes.get("Principled BSDF")
    if bsdf is not None:
        bsdf.inputs["Base Color"].default_value = tuple(color) + (1.0,)
    return material


def make_shadow_proxies(copy, fractals, depsgraph, resolution):
    """Replaces the copy's stand-ins by one per fractal: its surface as a mesh at `resolution`
    lattice cells (convert.extract, the render's surface), invisible to camera rays but casting
    shadows and seen in reflections and indirect light, on the fractal by a Copy Transforms
    constraint (it follows the fractal's moves; its shape is this frame's). Returns them.
    Nothing is left behind when an extraction fails."""
    from . import convert  # here: convert imports engine, which imports this module
    remove_shadow_proxies(copy)
    if not fractals:
        return []
    collection = shadow_collection(copy, create=True)
    try:
        for ob in fractals:
            surface = convert.extract(ob, depsgraph, resolution, min_faces=0)
            name = ob.name + SHADOW_SUFFIX
            mesh = convert.build_mesh(name, surface, bare=True)  # shadows need no trap attributes
            mesh.shade_smooth()
            mesh.materials.append(_proxy_material(name, ob.unbound.color))
            proxy = bpy.data.objects.new(name, mesh)
            collection.objects.link(proxy)
            proxy.visible_camera = False
            proxy.hide_select = True
            proxy.matrix_world = ob.matrix_world
            follow = proxy.constraints.new('COPY_TRANSFORMS')
            follow.target = ob
    except BaseException:
        remove_shadow_proxies(copy)
        raise
    return list(collection.objects)


def keyframed_shape(ob):
    """Whether an F-curve or driver animates one of fractal ob's settings (ob.unbound), which its
    stand-in's shape does not follow (its transform it does)."""
    animation = ob.animation_data
    if animation is None:
        return False
    curves = list(animation.drivers)
    action = animation.action
    if action is not None:
        if hasattr(action, "fcurves"):  # 4.x; 5.x has only the layered API
            curves += list(action.fcurves)
        else:
            from bpy_extras import anim_utils
            bag = anim_utils.action_get_channelbag_for_slot(action, animation.action_slot)
            curves += list(bag.fcurves) if bag is not None else []
    return any(curve.data_path.startswith("unbound.") for curve in curves)


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
