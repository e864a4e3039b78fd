"""Operators: add a fractal object, its colour ramp and presets; build a compositor node tree from
Unbound's passes."""
import math
import os

import bpy
from bl_operators.presets import AddPresetBase

from . import passes, utils
from .properties import FRACTAL_KINDS, UnboundObjectSettings, UnboundSceneSettings, display_radius

# Presets shipped with the extension; the user's own (Add Preset) go where Blender keeps presets,
# scripts/presets/unbound/fractal, and the menu lists both.
PRESET_SUBDIR = "unbound/fractal"
BUNDLED_PRESETS = os.path.join(os.path.dirname(__file__), "presets", "fractal")


class UNBOUND_MT_fractal_presets(bpy.types.Menu):
    bl_label = "Fractal Presets"
    preset_subdir = PRESET_SUBDIR
    preset_operator = "script.execute_preset"
    preset_add_operator = "unbound.fractal_preset_add"

    def draw(self, context):
        # Menu.draw_preset with the bundled folder searched too.
        self.path_menu([BUNDLED_PRESETS] + bpy.utils.preset_paths(self.preset_subdir), self.preset_operator,
                       filter_ext=lambda ext: ext.lower() == ".py", add_operator=self.preset_add_operator,
                       display_name=lambda name: bpy.path.display_name(name, title_case=False))


class UNBOUND_OT_fractal_preset_add(AddPresetBase, bpy.types.Operator):
    """Save the active fractal's parameters and the scene's Unbound shading as a preset, or remove one"""
    bl_idname = "unbound.fractal_preset_add"
    bl_label = "Add Fractal Preset"
    preset_menu = "UNBOUND_MT_fractal_presets"
    preset_subdir = PRESET_SUBDIR
    preset_defines = ["ob = bpy.context.object", "scene = bpy.context.scene"]
    # Every fractal and scene setting, read from the PropertyGroups so a new one is never left out;
    # not the ramp texture (a datablock) nor machine-specific render or viewport settings.
    preset_values = (["ob.unbound." + name for name in UnboundObjectSettings.__annotations__
                      if name not in {"is_fractal", "color_ramp_texture", "path_curve", "ifs_active_map"}]
                     + ["scene.unbound." + name for name in UnboundSceneSettings.__annotations__
                        if name not in {"tile_size", "simd"} and not name.startswith("viewport_")])

    @classmethod
    def poll(cls, context):
        return utils.is_fractal(context.object)


class UNBOUND_OT_color_ramp_add(bpy.types.Operator):
    """Give the active fractal a colour ramp (a texture's ramp) for orbit-trap or iteration colouring"""
    bl_idname = "object.unbound_color_ramp_add"
    bl_label = "New Color Ramp"
    bl_options = {'REGISTER', 'UNDO'}

    @classmethod
    def poll(cls, context):
        return utils.is_fractal(context.object)

    def execute(self, context):
        props = context.object.unbound
        tex = bpy.data.textures.new("%s Ramp" % context.object.name, 'BLEND')
        tex.use_color_ramp = True
        ramp = tex.color_ramp
        ramp.elements[0].color = (0.05, 0.1, 0.4, 1.0)
        ramp.elements[1].color = (1.0, 0.85, 0.4, 1.0)
        mid = ramp.elements.new(0.5)
        mid.color = (0.8, 0.2, 0.1, 1.0)
        props.color_ramp_texture = tex
        if props.color_mode == 'BASE':
            props.color_mode = 'ORBIT_TRAP'
        return {'FINISHED'}


def _menger_maps():
    third = 1.0 / 3.0
    return [((2 * third * x, 2 * third * y, 2 * third * z), (0.0, 0.0, 0.0), (third,) * 3)
            for x in (-1, 0, 1) for y in (-1, 0, 1) for z in (-1, 0, 1) if abs(x) + abs(y) + abs(z) > 1]


def _koch_maps():
    """The Koch curve's four maps of ratio 1/3 on [-1, 1] along X, the two rising ones also turned a
    quarter about X, so that every level's spikes stand in a plane across the last one's."""
    third, spike = 1.0 / 3.0, math.radians(60.0)
    rise = math.sqrt(3.0) / 6.0
    return [((-2 * third, 0.0, 0.0), (0.0, 0.0, 0.0), (third,) * 3),
            ((-1.0 / 6.0, 0.0, rise), (math.pi / 2, -spike, 0.0), (third,) * 3),
            ((1.0 / 6.0, 0.0, rise), (math.pi / 2, spike, 0.0), (third,) * 3),
            ((2 * third, 0.0, 0.0), (0.0, 0.0, 0.0), (third,) * 3)]


# IFS shapes: (location, rotation, scale) per map.
IFS_SHAPES = {
    'SIERPINSKI': [((0.5 * x, 0.5 * y, 0.5 * z), (0.0, 0.0, 0.0), (0.5, 0.5, 0.5))
                   for x, y, z in ((1, 1, 1), (1, -1, -1), (-1, 1, -1), (-1, -1, 1))],
    'MENGER': _menger_maps(),
    'KOCH': _koch_maps(),
}
IFS_SHAPE_ITEMS = [
    ('SIERPINSKI', "Sierpinski Tetrahedron", "Four maps of ratio 1/2 toward a tetrahedron's corners", 0),
    ('MENGER', "Menger Sponge", "Twenty maps of ratio 1/3: a cube without its face and body centres", 1),
    ('KOCH', "Koch Curve", "The Koch curve's four maps of ratio 1/3, the spikes turned a quarter at each level "
     "(a thin set: give it a fixed threshold)", 2),
]


# A depth that shows each shape's detail at 1080p without making it slow (the cost of an estimate
# grows with the depth near the surface; twenty maps branch fastest).
IFS_SHAPE_DEPTH = {'SIERPINSKI': 7, 'MENGER': 4, 'KOCH': 6}


def set_ifs_maps(props, shape):
    props.ifs_depth = IFS_SHAPE_DEPTH[shape]
    props.ifs_maps.clear()
    for location, rotation, scale in IFS_SHAPES[shape]:
        m = props.ifs_maps.add()
        m.location, m.rotation, m.scale = location, rotation, scale
    props.ifs_active_map = 0


class UNBOUND_OT_fractal_add(bpy.types.Operator):
    """Add an Unbound fractal object: an empty whose sphere shows the set's bounding sphere"""
    bl_idname = "object.unbound_fractal_add"
    bl_label = "Add Unbound Fractal"
    bl_options = {'REGISTER', 'UNDO'}

    kind: bpy.props.EnumProperty(name="Kind", description="Family of fractal", items=FRACTAL_KINDS,
                                 default='QUATERNION_JULIA')
    mu: bpy.props.FloatVectorProperty(name="Mu", description="Constant mu of z^2 + mu (1, i, j, k)", size=4,
                                      default=(-0.2, 0.8, 0.0, 0.0), soft_min=-2.0, soft_max=2.0)
    location: bpy.props.FloatVectorProperty(name="Location", description="Where to place the fractal",
                                            subtype='TRANSLATION', size=3)
    use_cursor: bpy.props.BoolProperty(name="At 3D Cursor", description="Place the fractal at the 3D cursor",
                                       default=True, options={'SKIP_SAVE'})

    def execute(self, context):
        if not all(abs(c) <= 1000.0 for c in self.mu):
            self.report({'ERROR'}, "Mu components must lie within [-1000, 1000]")
            return {'CANCELLED'}
        name = next(item[1] for item in FRACTAL_KINDS if item[0] == self.kind)
        ob = bpy.data.objects.new(name, None)
        ob.empty_display_type = 'SPHERE'
        props = ob.unbound
        props.is_fractal = True
        props.kind = self.kind
        props.mu = self.mu
        if self.kind == 'IFS':
            set_ifs_maps(props, 'SIERPINSKI')
        elif self.kind in {'QUATERNION_MANDELBROT', 'CUBIC_LOCUS'}:
            props.max_iterations = 24
        ob.empty_display_size = display_radius(ob) or 2.0
        ob.location = context.scene.cursor.location if self.use_cursor else self.location
        collection = context.collection or context.scene.collection
        collection.objects.link(ob)
        for other in context.view_layer.objects:
            other.select_set(False)
        ob.select_set(True)
        context.view_layer.objects.active = ob
        return {'FINISHED'}


class IFSOperator:
    bl_options = {'REGISTER', 'UNDO'}

    @classmethod
    def poll(cls, context):
        return utils.is_fractal(context.object) and context.object.unbound.kind == 'IFS'


class UNBOUND_OT_ifs_shape(IFSOperator, bpy.types.Operator):
    """Replace the IFS's maps with a classic shape's, at a depth that suits it"""
    bl_idname = "object.unbound_ifs_shape"
    bl_label = "Load IFS Shape"

    shape: bpy.props.EnumProperty(name="Shape", description="Set of maps to load", items=IFS_SHAPE_ITEMS)

    def execute(self, context):
        set_ifs_maps(context.object.unbound, self.shape)
        return {'FINISHED'}


class UNBOUND_OT_ifs_map_add(IFSOperator, bpy.types.Operator):
    """Add a map to the IFS (a copy of the active one, or a half-size map)"""
    bl_idname = "object.unbound_ifs_map_add"
    bl_label = "Add IFS Map"

    def execute(self, context):
        props = context.object.unbound
        if len(props.ifs_maps) >= 32:
            self.report({'ERROR'}, "An IFS has at most 32 maps")
            return {'CANCELLED'}
        source = props.ifs_maps[props.ifs_active_map] if props.ifs_active_map < len(props.ifs_maps) else None
        m = props.ifs_maps.add()
        if source is not None:
            m.location, m.rotation, m.scale = source.location, source.rotation, source.scale
        props.ifs_active_map = len(props.ifs_maps) - 1
        return {'FINISHED'}


class UNBOUND_OT_ifs_map_remove(IFSOperator, bpy.types.Operator):
    """Remove the active map from the IFS"""
    bl_idname = "object.unbound_ifs_map_remove"
    bl_label = "Remove IFS Map"

    def execute(self, context):
        props = context.object.unbound
        if not 0 <= props.ifs_active_map < len(props.ifs_maps):
            return {'CANCELLED'}
        props.ifs_maps.remove(props.ifs_active_map)
        props.ifs_active_map = max(0, min(props.ifs_active_map, len(props.ifs_maps) - 1))
        return {'FINISHED'}


def _output_socket(rl_node, name):
    sock = rl_node.outputs.get(name)
    return sock if sock is not None and sock.enabled else None


# Names of the compositor nodes Set Up Compositing makes: a second run replaces exactly these.
NODE_PREFIX = "Unbound "


class UNBOUND_OT_setup_compositing(bpy.types.Operator):
    """Add compositor nodes for Unbound's passes beside the user's own: the image to the output
    (unless the tree has one), every enabled pass into a multilayer OpenEXR file, and a normalised
    depth preview in a Viewer"""
    bl_idname = "scene.unbound_setup_compositing"
    bl_label = "Set Up Compositing"
    bl_options = {'REGISTER', 'UNDO'}

    directory: bpy.props.StringProperty(name="Directory", description="Where the pass files are written",
                                        default="//unbound_passes/", subtype='DIR_PATH')

    def execute(self, context):
        scene = context.scene
        if scene.render.engine != utils.ENGINE_ID:
            scene.render.engine = utils.ENGINE_ID
        tree = utils.compositor_tree(scene, create=True)
        # The user's nodes stay (issue 16): only the nodes an earlier run of this operator made
        # (named with NODE_PREFIX) are replaced, and ours go below the user's.
        for node in [n for n in tree.nodes if n.name.startswith(NODE_PREFIX)]:
            tree.nodes.remove(node)
        theirs = list(tree.nodes)
        base = min((n.location.y for n in theirs), default=0.0) - (700.0 if theirs else 0.0)
        new_api = bpy.app.version >= (5, 0, 0)
        output_type = "NodeGroupOutput" if new_api else "CompositorNodeComposite"

        def add(kind, name, x, y):
            node = tree.nodes.new(kind)
            node.name = node.label = NODE_PREFIX + name
            node.location = (x, base + y)
            return node

        rl = add("CompositorNodeRLayers", "Render Layers", -400, 0)
        rl.scene = scene
        rl.layer = context.view_layer.name
        if not any(n.bl_idname == output_type for n in theirs):
            final = add(output_type, "Output", 300, 200)
            tree.links.new(rl.outputs["Image"], final.inputs[0] if new_api else final.inputs["Image"])

        viewer = add("CompositorNodeViewer", "Viewer", 300, -100)
        depth = _output_socket(rl, "Depth")
        if depth is not None:
            norm = add("CompositorNodeNormalize", "Depth Preview", 50, -100)
            tree.links.new(depth, norm.inputs[0])
            tree.links.new(norm.outputs[0], viewer.inputs[0])
        else:
            tree.links.new(rl.outputs["Image"], viewer.inputs[0])

        fo = add("CompositorNodeOutputFile", "Pass Files", 300, -350)
        if new_api:
            fo.format.media_type = 'MULTI_LAYER_IMAGE'
            fo.directory = self.directory
            fo.file_name = "passes_"
            fo.file_output_items.clear()
        else:
            fo.format.file_format = 'OPEN_EXR_MULTILAYER'
            fo.base_path = self.directory + "passes_"
            fo.layer_slots.clear()
        fo.format.color_depth = '32'  # after the format: 8 and 16 bit formats have no '32'
        linked = 0
        for p in passes.enabled(context.view_layer):
            sock = _output_socket(rl, "Image" if p.name == "Combined" else p.name)
            if sock is None:
                continue
            if new_api:
                kind = {'COLOR': 'RGBA', 'VECTOR': 'VECTOR', 'VALUE': 'FLOAT'}[p.kind]
                fo.file_output_items.new(kind, p.name)
                target = fo.inputs[p.name]
            else:
                fo.layer_slots.new(p.name)
                target = fo.inputs[p.name]
            tree.links.new(sock, target)
            linked += 1
        self.report({'INFO'}, "Unbound: compositor writes %d passes to %s" % (linked, self.directory))
        return {'FINISHED'}


def menu_add(self, context):
    self.layout.operator_menu_enum(UNBOUND_OT_fractal_add.bl_idname, "kind", text="Unbound Fractal",
                                   icon='MESH_UVSPHERE')


classes = (UNBOUND_OT_fractal_add, UNBOUND_OT_setup_compositing, UNBOUND_MT_fractal_presets,
           UNBOUND_OT_fractal_preset_add, UNBOUND_OT_color_ramp_add, UNBOUND_OT_ifs_shape, UNBOUND_OT_ifs_map_add,
           UNBOUND_OT_ifs_map_remove)


def register():
    for cls in classes:
        bpy.utils.register_class(cls)
    bpy.types.VIEW3D_MT_add.append(menu_add)


def unregister():
    bpy.types.VIEW3D_MT_add.remove(menu_add)
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
