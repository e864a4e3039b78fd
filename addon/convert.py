"""Convert to Mesh: the active fractal's surface as a closed, manifold mesh object (the core's
extract_mesh, native/src/mesh.c), in the Object menu and the fractal's Convert panel.

The mesh is in the fractal's object space and gets its world matrix. Per vertex it carries the
orbit trap (`unbound_trap`) and the escape count (`unbound_iterations`) as point attributes; the
material made with it reads the trap through an Attribute node, so Cycles and EEVEE colour it.

A keyframed fractal: with "Frame Range" on, one mesh per frame from the scene's start to end frame,
each shown (viewport and render) only on its own frame: a mesh sequence that plays back and renders
as the animation. By hand, the same: step the frames and convert at each."""
import time

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty

from . import export, utils

TRAP_ATTRIBUTE = "unbound_trap"
ITERATIONS_ATTRIBUTE = "unbound_iterations"


def build_mesh(name, mesh):
    """A Blender mesh datablock from a core mesh (unbound_core.mesh.Mesh)."""
    import numpy as np

    me = bpy.data.meshes.new(name)
    nv, nf = len(mesh.vertices), len(mesh.faces)
    me.vertices.add(nv)
    me.vertices.foreach_set("co", mesh.vertices.ravel())
    me.loops.add(3 * nf)
    me.loops.foreach_set("vertex_index", mesh.faces.ravel())
    me.polygons.add(nf)
    me.polygons.foreach_set("loop_start", np.arange(0, 3 * nf, 3, dtype=np.int32))
    if hasattr(me.polygons, "foreach_set") and "loop_total" in me.polygons.bl_rna.properties.keys() \
            and not me.polygons.bl_rna.properties["loop_total"].is_readonly:
        me.polygons.foreach_set("loop_total", np.full(nf, 3, np.int32))
    me.update(calc_edges=True)
    for attr_name, values in ((TRAP_ATTRIBUTE, mesh.trap), (ITERATIONS_ATTRIBUTE, mesh.iterations)):
        attr = me.attributes.new(attr_name, 'FLOAT', 'POINT')
        attr.data.foreach_set("value", values)
    me.validate(verbose=False, clean_customdata=False)
    return me


def trap_material(name="Unbound Trap"):
    """A material colouring by the orbit trap attribute (Attribute -> Color Ramp -> Principled)."""
    mat = bpy.data.materials.get(name)
    if mat is not None:
        return mat
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    bsdf = nodes.get("Principled BSDF")
    attr = nodes.new("ShaderNodeAttribute")
    attr.attribute_name = TRAP_ATTRIBUTE
    attr.location = (-600, 300)
    ramp = nodes.new("ShaderNodeValToRGB")
    ramp.location = (-350, 300)
    links.new(attr.outputs["Fac"], ramp.inputs["Fac"])
    if bsdf is not None:
        links.new(ramp.outputs["Color"], bsdf.inputs["Base Color"])
    return mat


def surface_epsilon(ob):
    """The mesh's surface is {estimate = epsilon}: the fractal's own epsilon in the Fixed threshold
    mode (the surface its render shows), else 0, which the core takes as a 64th of a cell."""
    return ob.unbound.epsilon if ob.unbound.threshold_mode == 'FIXED' else 0.0


def extract(ob, depsgraph, resolution, min_faces, progress=None, cancel=None, threads=0):
    """The core's mesh of fractal `ob` (its surface: surface_epsilon)."""
    core = utils.native()
    params = export.object_parameters(ob, depsgraph, with_ramp=False)
    return core.mesh.extract(params, resolution=resolution, epsilon=surface_epsilon(ob), min_faces=min_faces,
                             threads=threads, progress=progress, cancel=cancel)


class UNBOUND_OT_convert_to_mesh(bpy.types.Operator):
    """The fractal's surface as a closed, manifold mesh (watertight, for 3-D printing and any
    render engine), with the orbit trap and escape count as attributes"""
    bl_idname = "object.unbound_convert_to_mesh"
    bl_label = "Convert to Mesh"
    bl_options = {'REGISTER', 'UNDO'}

    resolution: IntProperty(name="Resolution", description="Lattice cells across the bounding ball's diameter; "
                            "time and memory grow with its square (the surface), not its cube",
                            default=256, min=8, max=8192, soft_max=2048)
    crumbs: EnumProperty(name="Crumbs", description="What to do with disconnected pieces",
                         items=[('KEEP', "Keep", "Keep every piece"),
                                ('REMOVE', "Remove", "Remove pieces with fewer faces than Crumb Size")],
                         default='KEEP')
    crumb_faces: IntProperty(name="Crumb Size", description="Pieces with fewer faces are removed",
                             default=1000, min=1)
    use_frame_range: BoolProperty(name="Frame Range", description="One mesh per frame of the scene's frame "
                                  "range, each shown only on its frame (a mesh sequence)", default=False)
    use_material: BoolProperty(name="Trap Material", description="Give the mesh a material coloured by the "
                               "orbit trap attribute", default=True)

    @classmethod
    def poll(cls, context):
        return utils.is_fractal(context.active_object)

    def _convert(self, context, ob, frame=None):
        depsgraph = context.evaluated_depsgraph_get()
        wm = context.window_manager
        wm.progress_begin(0, 1000)
        try:
            mesh = extract(ob, depsgraph, self.resolution, self.crumb_faces if self.crumbs == 'REMOVE' else 0,
                           progress=lambda f: wm.progress_update(int(1000 * f)) and False)
        finally:
            wm.progress_end()
        name = ob.name + (" Mesh" if frame is None else " Mesh %04d" % frame)
        me = build_mesh(name, mesh)
        if self.use_material:
            me.materials.append(trap_material())
        new = bpy.data.objects.new(name, me)
        new.matrix_world = ob.matrix_world
        collections = ob.users_collection or (context.collection,)
        collections[0].objects.link(new)
        return new, mesh.stats

    def execute(self, context):
        ob = context.active_object
        start = time.perf_counter()
        try:
            if not self.use_frame_range:
                new, stats = self._convert(context, ob)
                made = [new]
            else:
                scene = context.scene
                current = scene.frame_current
                made = []
                try:
                    for frame in range(scene.frame_start, scene.frame_end + 1):
                        scene.frame_set(frame)
                        new, stats = self._convert(context, ob, frame)
                        for f, hidden in ((frame - 1, True), (frame, False), (frame + 1, True)):
                            new.hide_viewport = new.hide_render = hidden
                            new.keyframe_insert("hide_viewport", frame=f)
                            new.keyframe_insert("hide_render", frame=f)
                        made.append(new)
                finally:
                    scene.frame_set(current)
        except (ImportError, ValueError, TypeError, MemoryError, export.RenderError) as exc:
            self.report({'ERROR'}, "Unbound: %s" % exc)
            return {'CANCELLED'}
        for o in context.view_layer.objects:
            if o.select_get():
                o.select_set(False)
        for o in made:
            o.select_set(True)
        context.view_layer.objects.active = made[-1]
        self.report({'INFO'}, "Unbound: %d mesh(es), last %d vertices, %d faces, %d piece(s) in %.1f s"
                    % (len(made), len(made[-1].data.vertices), len(made[-1].data.polygons),
                       stats["pieces"] - stats["pieces_removed"], time.perf_counter() - start))
        return {'FINISHED'}

    def invoke(self, context, event):
        return context.window_manager.invoke_props_dialog(self)


def menu_convert(self, context):
    if utils.is_fractal(context.active_object):
        self.layout.separator()
        self.layout.operator(UNBOUND_OT_convert_to_mesh.bl_idname, icon='MESH_DATA')
        if hasattr(bpy.types, "OBJECT_OT_unbound_convert_to_volume") or \
                "unbound_convert_to_volume" in dir(bpy.ops.object):
            self.layout.operator("object.unbound_convert_to_volume", icon='VOLUME_DATA')


class UNBOUND_PT_fractal_convert(bpy.types.Panel):
    bl_label = "Convert"
    bl_space_type = 'PROPERTIES'
    bl_region_type = 'WINDOW'
    bl_context = "data"
    bl_options = {'DEFAULT_CLOSED'}
    COMPAT_ENGINES = {utils.ENGINE_ID}

    @classmethod
    def poll(cls, context):
        return context.engine in cls.COMPAT_ENGINES and utils.is_fractal(context.object)

    def draw(self, context):
        col = self.layout.column(align=True)
        col.operator(UNBOUND_OT_convert_to_mesh.bl_idname, icon='MESH_DATA')
        if "unbound_convert_to_volume" in dir(bpy.ops.object):
            col.operator("object.unbound_convert_to_volume", icon='VOLUME_DATA')


classes = (UNBOUND_OT_convert_to_mesh, UNBOUND_PT_fractal_convert)


def register():
    for cls in classes:
        bpy.utils.register_class(cls)
    bpy.types.VIEW3D_MT_object.append(menu_convert)
    bpy.types.VIEW3D_MT_object_convert.append(menu_convert)


def unregister():
    bpy.types.VIEW3D_MT_object_convert.remove(menu_convert)
    bpy.types.VIEW3D_MT_object.remove(menu_convert)
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
