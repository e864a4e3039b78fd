"""Operators: add a fractal object; build a compositor node tree from Unbound's passes."""
import bpy

from . import passes, utils
from .properties import bounding_radius


class UNBOUND_OT_fractal_add(bpy.types.Operator):
    """Add an Unbound fractal object: an empty whose sphere shows the set's bounding sphere"""
    bl_idname = "object.unbound_fractal_add"
    bl_label = "Quaternion Julia Fractal"
    bl_options = {'REGISTER', 'UNDO'}

    mu: bpy.props.FloatVectorProperty(name="Mu", description="Constant mu of z^2 + mu (1, i, j, k)", size=4,
                                      default=(-0.2, 0.8, 0.0, 0.0), soft_min=-2.0, soft_max=2.0)
    location: bpy.props.FloatVectorProperty(name="Location", description="Where to place the fractal",
                                            subtype='TRANSLATION', size=3)
    use_cursor: bpy.props.BoolProperty(name="At 3D Cursor", description="Place the fractal at the 3D cursor",
                                       default=True, options={'SKIP_SAVE'})

    def execute(self, context):
        ob = bpy.data.objects.new("Quaternion Julia", None)
        ob.empty_display_type = 'SPHERE'
        ob.unbound.is_fractal = True
        ob.unbound.mu = self.mu
        ob.empty_display_size = bounding_radius(self.mu)
        ob.location = context.scene.cursor.location if self.use_cursor else self.location
        collection = context.collection or context.scene.collection
        collection.objects.link(ob)
        for other in context.view_layer.objects:
            other.select_set(False)
        ob.select_set(True)
        context.view_layer.objects.active = ob
        return {'FINISHED'}


def _output_socket(rl_node, name):
    sock = rl_node.outputs.get(name)
    return sock if sock is not None and sock.enabled else None


class UNBOUND_OT_setup_compositing(bpy.types.Operator):
    """Build a compositor node tree from Unbound's passes: the image to the output, every enabled pass
    into a multilayer OpenEXR file, and a normalised depth preview in the Viewer"""
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
        tree.nodes.clear()
        new_api = bpy.app.version >= (5, 0, 0)
        rl = tree.nodes.new("CompositorNodeRLayers")
        rl.scene = scene
        rl.layer = context.view_layer.name
        rl.location = (-400, 0)
        if new_api:
            final = tree.nodes.new("NodeGroupOutput")
            final_in = final.inputs[0]
        else:
            final = tree.nodes.new("CompositorNodeComposite")
            final_in = final.inputs["Image"]
        final.location = (300, 200)
        tree.links.new(rl.outputs["Image"], final_in)

        viewer = tree.nodes.new("CompositorNodeViewer")
        viewer.location = (300, -100)
        depth = _output_socket(rl, "Depth")
        if depth is not None:
            norm = tree.nodes.new("CompositorNodeNormalize")
            norm.location = (50, -100)
            tree.links.new(depth, norm.inputs[0])
            tree.links.new(norm.outputs[0], viewer.inputs[0])
        else:
            tree.links.new(rl.outputs["Image"], viewer.inputs[0])

        fo = tree.nodes.new("CompositorNodeOutputFile")
        fo.location = (300, -350)
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
    self.layout.operator(UNBOUND_OT_fractal_add.bl_idname, text="Unbound Fractal", icon='MESH_UVSPHERE')


classes = (UNBOUND_OT_fractal_add, UNBOUND_OT_setup_compositing)


def register():
    for cls in classes:
        bpy.utils.register_class(cls)
    bpy.types.VIEW3D_MT_add.append(menu_add)


def unregister():
    bpy.types.VIEW3D_MT_add.remove(menu_add)
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
