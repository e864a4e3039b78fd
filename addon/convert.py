"""Convert to Mesh: the active fractal's surface as a closed, manifold mesh object (the core's
extract_mesh, native/src/mesh.c), in the Object menu and the fractal's Convert panel.

The mesh is in the fractal's object space and gets its world matrix. Per vertex it carries the
orbit trap (`unbound_trap`) and the escape count (`unbound_iterations`) as point attributes; the
material made with it reads the trap through an Attribute node, so Cycles and EEVEE colour it.

A keyframed fractal: with "Frame Range" on, one mesh per frame from the scene's start to end frame,
each shown (viewport and render) only on its own frame: a mesh sequence that plays back and renders
as the animation. By hand, the same: step the frames and convert at each.

Convert to Volume: the same mesh, made into an OpenVDB grid by Blender's own OpenVDB (the "Mesh to
SDF Grid" or "Mesh to Density Grid" geometry node, evaluated once on a temporary object), written
to a .vdb file and loaded by a new Volume object, which Cycles and EEVEE render. Why this way: the
OpenVDB Python module (`openvdb`) is bundled with Blender only from 4.4 on and is not on bpy's
path, and PyPI has no maintained openvdb wheel, while these nodes exist in every Blender from 4.2
(in 4.2 behind the "New Volume Nodes" experimental option for the Add menu, yet they evaluate) to
5.2. The voxel is the mesh's lattice cell, so the grid resolves what the mesh does."""
import os
import threading
import time

import bpy
from bpy.props import BoolProperty, EnumProperty, IntProperty, StringProperty

from . import engine, export, utils

TRAP_ATTRIBUTE = "unbound_trap"
ITERATIONS_ATTRIBUTE = "unbound_iterations"


def build_mesh(name, mesh, bare=False):
    """A Blender mesh datablock from a core mesh (unbound_core.mesh.Mesh). Bare: positions and
    triangles alone, unchecked (the temporary mesh Convert to Volume voxelizes: the core's
    triangles index its vertices by construction, and validate() took longer than all the rest)."""
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
    if bare:
        return me
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
    mat = utils.new_node_material(name)
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


def extraction_arguments(ob, depsgraph, resolution, min_faces):
    """(parameters, keywords) of the core's mesh of fractal `ob` (its surface: surface_epsilon),
    read from Blender: on the main thread."""
    params = export.object_parameters(ob, depsgraph, with_ramp=False)
    return params, dict(resolution=resolution, epsilon=surface_epsilon(ob), min_faces=min_faces)


def extract(ob, depsgraph, resolution, min_faces, progress=None, cancel=None, threads=0):
    """The core's mesh of fractal `ob` (its surface: surface_epsilon)."""
    params, keywords = extraction_arguments(ob, depsgraph, resolution, min_faces)
    return utils.native().mesh.extract(params, threads=threads, progress=progress, cancel=cancel, **keywords)


def extract_with_progress(context, ob, resolution, min_faces):
    """extract() at the current frame, with Blender's progress counter on the cursor."""
    wm = context.window_manager
    wm.progress_begin(0, 1000)
    try:
        return extract(ob, context.evaluated_depsgraph_get(), resolution, min_faces,
                       progress=lambda f: wm.progress_update(int(1000 * f)) and False)
    finally:
        wm.progress_end()


class ExtractionThread(threading.Thread):
    """extract() of fractal `ob` at the current frame on a worker thread, so that Blender's UI stays
    live: the parameters are read from Blender here, on the main thread; the thread runs the core
    alone (which releases the GIL) and never touches bpy. Its progress is `fraction`; setting
    `cancel` stops the core within its poll interval. Afterwards: `mesh`, or `error`."""

    def __init__(self, ob, depsgraph, resolution, min_faces):
        super().__init__(name="Unbound Convert", daemon=True)
        self.core = utils.native()
        self.params, self.keywords = extraction_arguments(ob, depsgraph, resolution, min_faces)
        self.cancel = threading.Event()
        self.fraction, self.mesh, self.error = 0.0, None, None

    def _progress(self, fraction):
        self.fraction = fraction
        return False

    def run(self):
        try:
            self.mesh = self.core.mesh.extract(self.params, progress=self._progress, cancel=self.cancel,
                                               **self.keywords)
        except Exception as exc:  # raised again on the main thread, which reports it
            self.error = exc


def frames_to_convert(scene, use_frame_range):
    """[None] (the current frame), or with use_frame_range each frame of the scene's range."""
    return list(range(scene.frame_start, scene.frame_end + 1)) if use_frame_range else [None]


def for_frames(scene, use_frame_range, convert_frame):
    """[convert_frame(None)] at the current frame; with use_frame_range, [convert_frame(f)] for each
    frame f of the scene's range, set in turn, and the current frame set again afterwards."""
    current = scene.frame_current
    try:
        results = []
        for frame in frames_to_convert(scene, use_frame_range):
            if frame is not None:
                scene.frame_set(frame)
            results.append(convert_frame(frame))
        return results
    finally:
        if use_frame_range:
            scene.frame_set(current)


def link_beside(context, fractal, new):
    """`new` gets the fractal's world matrix and joins its first collection."""
    new.matrix_world = fractal.matrix_world
    collections = fractal.users_collection or (context.collection,)
    collections[0].objects.link(new)


def make_active(context, objects):
    """Only `objects` selected; the last is the active object."""
    for o in context.view_layer.objects:
        # None: an object removed since the view layer last synced (Blender 5.x syncs lazily)
        if o is not None and o.select_get():
            o.select_set(False)
    for o in objects:
        o.select_set(True)
    context.view_layer.objects.active = objects[-1]


# What a conversion reports as a clear error (nothing made) rather than a traceback: the core's
# ImportError, its parameter checks, memory, Blender's refusals (RuntimeError) and files (OSError).
CONVERT_ERRORS = (ImportError, ValueError, TypeError, MemoryError, RuntimeError, OSError, export.RenderError)
# The interactive conversion: how often it looks at the worker thread (and redraws the progress),
# what cancels it, how long a cancel waits for the core at once (it stops within its 50 ms poll
# interval; a longer wait goes on at the next tick, the UI live), and the events it lets through:
# viewport navigation, which changes no data (anything else could delete or change the fractal).
POLL_SECONDS = 0.05
CANCEL_EVENTS = {'ESC', 'RIGHTMOUSE'}
CANCEL_WAIT_SECONDS = 0.2
NAVIGATION_EVENTS = {'MIDDLEMOUSE', 'WHEELUPMOUSE', 'WHEELDOWNMOUSE', 'MOUSEMOVE', 'INBETWEEN_MOUSEMOVE',
                     'TRACKPADPAN', 'TRACKPADZOOM', 'MOUSEROTATE', 'MOUSESMARTZOOM', 'NDOF_MOTION'}


class ConvertOptions:
    """What Convert to Mesh and Convert to Volume share (a mixin: Blender registers the properties
    its subclasses inherit, as with bpy_extras' ExportHelper): the options, and the frame loop.

    From a script (EXEC_DEFAULT) or in background mode, execute() converts frame by frame and
    returns with the result made. From the UI (the dialog's OK after invoke()), it runs modal: each
    frame's extraction on a worker thread (ExtractionThread), the progress in the status bar, Esc or
    right-click cancels, and each finished frame built on the main thread between frames. Both
    ways, a subclass's hooks do the building: _begin(context) before the first frame,
    _convert_frame(context, frame, mesh) per frame, _finish(context) -> {'FINISHED'} at the end;
    what they make goes in self._made, removed again on an error or a cancel (_discard)."""
    resolution: IntProperty(name="Resolution", description="Lattice cells across the bounding ball's diameter; "
                            "time and memory grow with its square (the surface), not its cube",
                            default=256, min=8, max=8192, soft_max=2048)
    crumbs: EnumProperty(name="Crumbs", description="What to do with disconnected pieces",
                         items=[('KEEP', "Keep", "Keep every piece"),
                                ('REMOVE', "Remove", "Remove pieces with fewer faces than Crumb Size")],
                         default='KEEP')
    crumb_faces: IntProperty(name="Crumb Size", description="Pieces with fewer faces are removed",
                             default=1000, min=1)

    PROGRESS_LABEL = "Converting"  # the status bar's "Converting to mesh: 42 % ..."

    @classmethod
    def poll(cls, context):
        return utils.is_fractal(context.active_object)

    def min_faces(self):
        return self.crumb_faces if self.crumbs == 'REMOVE' else 0

    def invoke(self, context, event):
        # The dialog's OK calls execute(); this flag (on the same operator instance) makes that run
        # modal. execute() clears it, so a redo (Adjust Last Operation) converts blocking again.
        self._interactive = not bpy.app.background
        return context.window_manager.invoke_props_dialog(self)

    def execute(self, context):
        interactive, self._interactive = getattr(self, "_interactive", False), False
        self._fractal, self._made, self._started = context.active_object, [], time.perf_counter()
        try:
            self._begin(context)
            if interactive and context.window is not None:
                return self._start_modal(context)
            for_frames(context.scene, self.use_frame_range, lambda frame: self._convert_frame(
                context, frame, extract_with_progress(context, self._fractal, self.resolution, self.min_faces())))
            return self._finish(context)
        except CONVERT_ERRORS as exc:
            return self._fail(exc)

    def _fail(self, exc):
        self._discard()
        self.report({'ERROR'}, "Unbound: %s" % exc)
        return {'CANCELLED'}

    def _discard(self):
        """Removes what this conversion made so far (last made first: objects before their data)."""
        for collection, datablock in reversed(self._made):
            try:
                collection.remove(datablock)
            except ReferenceError:  # already gone with its file (a cancel by loading another .blend)
                pass
        self._made = []

    def _keep_new(self, collection, find_or_make):
        """find_or_make()'s datablock of `collection`, in self._made when it made a new one."""
        count = len(collection)
        datablock = find_or_make()
        if len(collection) > count:
            self._made.append((collection, datablock))
        return datablock

    def _seconds(self):
        return time.perf_counter() - self._started

    # ---- the interactive (modal) conversion

    def _start_modal(self, context):
        scene = context.scene
        self._frames, self._frame_before = frames_to_convert(scene, self.use_frame_range), scene.frame_current
        self._done, self._status, self._workspace = 0, None, context.workspace
        self._next_frame(context)
        wm = context.window_manager
        self._timer = wm.event_timer_add(POLL_SECONDS, window=context.window)
        wm.modal_handler_add(self)
        self._show_progress()
        return {'RUNNING_MODAL'}

    def _next_frame(self, context):
        frame = self._frames[self._done]
        if frame is not None:
            context.scene.frame_set(frame)
        self._job = ExtractionThread(self._fractal, context.evaluated_depsgraph_get(), self.resolution,
                                     self.min_faces())
        self._job.start()

    def _show_progress(self):
        frame, count = self._frames[self._done], len(self._frames)
        text = "%s: %d %%%s \u2014 Esc to cancel" % (
            self.PROGRESS_LABEL, int(100 * (self._done + self._job.fraction) / count),
            "" if frame is None else " (frame %d, %d of %d)" % (frame, self._done + 1, count))
        if text != self._status:  # a new text redraws the status bar
            self._status = text
            self._workspace.status_text_set(text)

    def _end_modal(self, context):
        """The timer gone, the status bar's own text back, the scene at its frame again."""
        if self._timer is not None:
            context.window_manager.event_timer_remove(self._timer)
            self._timer = None
            self._workspace.status_text_set(None)
            if self.use_frame_range:
                context.scene.frame_set(self._frame_before)

    def modal(self, context, event):
        job = self._job
        if event.type in CANCEL_EVENTS and event.value == 'PRESS':
            job.cancel.set()
            job.join(CANCEL_WAIT_SECONDS)
        elif event.type != 'TIMER':
            return {'PASS_THROUGH'} if event.type in NAVIGATION_EVENTS else {'RUNNING_MODAL'}
        if job.is_alive():
            self._show_progress()
            return {'RUNNING_MODAL'}
        try:
            if job.cancel.is_set():
                self._end_modal(context)
                self._discard()
                self.report({'INFO'}, "%s cancelled" % self.bl_label)
                return {'CANCELLED'}
            if job.error is not None:
                raise job.error
            self._convert_frame(context, self._frames[self._done], job.mesh)
            self._done += 1
            if self._done < len(self._frames):
                self._next_frame(context)
                self._show_progress()
                return {'RUNNING_MODAL'}
            self._end_modal(context)
            return self._finish(context)
        except CONVERT_ERRORS as exc:
            self._end_modal(context)
            return self._fail(exc)
        except Exception:  # a bug: Blender prints the traceback; nothing stays behind
            self._end_modal(context)
            self._discard()
            raise

    def cancel(self, context):
        """Blender ends the modal conversion (its window closed, another .blend loaded)."""
        self._job.cancel.set()
        self._job.join()
        self._end_modal(context)
        self._discard()


class UNBOUND_OT_convert_to_mesh(ConvertOptions, bpy.types.Operator):
    """The fractal's surface as a closed, manifold mesh (watertight, for 3-D printing and any
    render engine), with the orbit trap and escape count as attributes"""
    bl_idname = "object.unbound_convert_to_mesh"
    bl_label = "Convert to Mesh"
    bl_options = {'REGISTER', 'UNDO'}
    PROGRESS_LABEL = "Converting to mesh"

    use_frame_range: BoolProperty(name="Frame Range", description="One mesh per frame of the scene's frame "
                                  "range, each shown only on its frame (a mesh sequence)", default=False)
    use_material: BoolProperty(name="Trap Material", description="Give the mesh a material coloured by the "
                               "orbit trap attribute", default=True)

    def _begin(self, context):
        self._meshes = []  # (object, core mesh stats) per frame

    def _convert_frame(self, context, frame, mesh):
        ob = self._fractal
        name = ob.name + (" Mesh" if frame is None else " Mesh %04d" % frame)
        me = build_mesh(name, mesh)
        self._made.append((bpy.data.meshes, me))
        if self.use_material:
            me.materials.append(self._keep_new(bpy.data.materials, trap_material))
        new = bpy.data.objects.new(name, me)
        self._made.append((bpy.data.objects, new))
        link_beside(context, ob, new)
        if frame is not None:  # shown on its own frame only
            for f, hidden in ((frame - 1, True), (frame, False), (frame + 1, True)):
                new.hide_viewport = new.hide_render = hidden
                new.keyframe_insert("hide_viewport", frame=f)
                new.keyframe_insert("hide_render", frame=f)
        self._meshes.append((new, mesh.stats))

    def _finish(self, context):
        made = self._meshes
        make_active(context, [new for new, _ in made])
        last, stats = made[-1]
        self.report({'INFO'}, "Unbound: %d mesh(es), last %d vertices, %d faces, %d piece(s) in %.1f s"
                    % (len(made), len(last.data.vertices), len(last.data.polygons),
                       stats["pieces"] - stats["pieces_removed"], self._seconds()))
        return {'FINISHED'}


# ------------------------------------------------------------------------------- Convert to Volume

# The grid kinds: (geometry node that makes it from a mesh, grid name). A signed distance field is
# OpenVDB's narrow-band level set (class "level set": negative inside, zero on the surface, kept
# within Band Width voxels of it); a density grid is its fog volume (0 outside, rising to 1 over
# Band Width voxels inside, 1 deeper).
GRID_KINDS = {'SDF': ("GeometryNodeMeshToSDFGrid", "sdf"),
              'DENSITY': ("GeometryNodeMeshToDensityGrid", "density")}
# Peak bytes per band voxel (band_voxels' estimate) while write_grid runs: the temporary mesh and
# Blender's evaluated copy of it, OpenVDB's intermediate grids (meshToVolume's closest-triangle
# indices and masks), the grid itself in partly filled 8^3 leaves, the file's buffers. Measured by
# bench/bench_volume.py as the growth of peak resident memory (bpy 4.2, default Julia set): 125,
# 124 and 133 at resolutions 128, 256 and 512 (the estimate is 1.3-1.6 times the active voxels
# OpenVDB keeps); a margin above that.
VOXEL_BYTES = 200


def band_voxels(mesh, voxel_size, band_width):
    """Voxels of a band `band_width` voxels deep on either side of the mesh: its area per voxel
    face, times the band's depth."""
    import numpy as np

    tri = mesh.vertices[mesh.faces].astype(np.float64)
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1).sum()
    return 2 * band_width * area / (voxel_size * voxel_size)


def grid_memory_preflight(voxels, resolution):
    """A MemoryError before OpenVDB allocates anything (it would end Blender) when the grid cannot fit."""
    needed, available = voxels * VOXEL_BYTES, engine.memory_available()
    if available is not None and needed > available:
        raise MemoryError("this volume needs about %.1f GB of memory (about %.3g voxels at resolution %d) but "
                          "about %.1f GB is available: lower the resolution"
                          % (needed / 1e9, voxels, resolution, available / 1e9))


def grid_node_tree(kind, mesh_object, voxel_size, band_width):
    """A geometry node tree: the mesh of `mesh_object` as a grid of `kind`, stored by its name."""
    node_type, grid_name = GRID_KINDS[kind]
    tree = bpy.data.node_groups.new("Unbound Mesh to Grid", "GeometryNodeTree")
    tree.interface.new_socket("Geometry", in_out='INPUT', socket_type='NodeSocketGeometry')
    tree.interface.new_socket("Geometry", in_out='OUTPUT', socket_type='NodeSocketGeometry')
    nodes, links = tree.nodes, tree.links
    mesh_in = nodes.new("GeometryNodeObjectInfo")
    mesh_in.inputs["Object"].default_value = mesh_object
    to_grid = nodes.new(node_type)
    to_grid.inputs["Voxel Size"].default_value = voxel_size
    if kind == 'SDF':
        to_grid.inputs["Band Width"].default_value = band_width
    else:
        to_grid.inputs["Gradient Width"].default_value = band_width * voxel_size
        to_grid.inputs["Density"].default_value = 1.0
    store = nodes.new("GeometryNodeStoreNamedGrid")
    store.inputs["Name"].default_value = grid_name
    links.new(mesh_in.outputs["Geometry"], to_grid.inputs["Mesh"])
    links.new(to_grid.outputs[0], store.inputs["Grid"])
    links.new(nodes.new("NodeGroupInput").outputs[0], store.inputs["Volume"])
    links.new(store.outputs[0], nodes.new("NodeGroupOutput").inputs[0])
    return tree


def write_grid(context, mesh, kind, voxel_size, band_width, path):
    """Writes the grid of `kind` made from `mesh` (a core mesh, object space) to the .vdb file
    `path`, through a temporary mesh object, volume object and node tree, all removed again."""
    made = []  # (collection of bpy.data, datablock), removed in reverse order
    try:
        me = build_mesh("Unbound Temporary Mesh", mesh, bare=True)
        made.append((bpy.data.meshes, me))
        mesh_object = bpy.data.objects.new(me.name, me)  # read by the tree; in no scene
        made.append((bpy.data.objects, mesh_object))
        tree = grid_node_tree(kind, mesh_object, voxel_size, band_width)
        made.append((bpy.data.node_groups, tree))
        volume = bpy.data.volumes.new("Unbound Temporary Volume")
        made.append((bpy.data.volumes, volume))
        holder = bpy.data.objects.new(volume.name, volume)
        made.append((bpy.data.objects, holder))
        context.scene.collection.objects.link(holder)  # evaluated only in the view layer
        holder.modifiers.new("Mesh to Grid", 'NODES').node_group = tree
        grids = holder.evaluated_get(context.evaluated_depsgraph_get()).data.grids
        if not len(grids):
            raise RuntimeError("Blender made no grid from the mesh%s" % (
                ": " + grids.error_message if grids.error_message else ""))
        grids.save(path)
    finally:
        for collection, datablock in reversed(made):
            collection.remove(datablock)


# The volume material's density per Blender unit inside the surface: an optical depth of 1 within a
# hundredth of a unit, so a fractal of about unit size looks solid and its finest branches like
# smoke. The material's "Density" node holds it for editing.
VOLUME_DENSITY = 100.0


def volume_material(kind):
    """A Principled Volume of uniform density inside the surface: where the SDF is negative, or as
    much as the density grid says; one material per kind, made once and shared."""
    grid_name = GRID_KINDS[kind][1]
    name = "Unbound Volume " + ("SDF" if kind == 'SDF' else "Density")
    mat = bpy.data.materials.get(name)
    if mat is not None:
        return mat
    mat = utils.new_node_material(name)
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    for node in [n for n in nodes if n.type != 'OUTPUT_MATERIAL']:
        nodes.remove(node)
    output = next(n for n in nodes if n.type == 'OUTPUT_MATERIAL')
    shader = nodes.new("ShaderNodeVolumePrincipled")
    shader.location = (0, 300)
    # the density comes through the link alone, not multiplied by a grid of Blender's choosing
    shader.inputs["Density Attribute"].default_value = ""
    links.new(shader.outputs["Volume"], output.inputs["Volume"])
    grid = nodes.new("ShaderNodeAttribute")
    grid.attribute_name = grid_name
    grid.location = (-700, 300)
    fill = grid.outputs["Fac"]
    if kind == 'SDF':
        inside = nodes.new("ShaderNodeMath")
        inside.operation = 'LESS_THAN'
        inside.inputs[1].default_value = 0.0
        inside.location = (-500, 300)
        links.new(fill, inside.inputs[0])
        fill = inside.outputs["Value"]
    density = nodes.new("ShaderNodeMath")
    density.operation = 'MULTIPLY'
    density.label = "Density"
    density.inputs[1].default_value = VOLUME_DENSITY
    density.location = (-300, 300)
    links.new(fill, density.inputs[0])
    links.new(density.outputs["Value"], shader.inputs["Density"])
    return mat


def referenced_vdb_paths():
    """The files Volume datablocks of this .blend read (absolute, normalised)."""
    return {os.path.normcase(os.path.normpath(bpy.path.abspath(v.filepath, library=v.library)))
            for v in bpy.data.volumes if v.filepath}


class UNBOUND_OT_convert_to_volume(ConvertOptions, bpy.types.Operator):
    """The fractal as an OpenVDB volume (a narrow-band signed distance field or a density grid),
    written to a .vdb file and loaded as a Volume object that Cycles and EEVEE render"""
    bl_idname = "object.unbound_convert_to_volume"
    bl_label = "Convert to Volume"
    bl_options = {'REGISTER', 'UNDO'}
    PROGRESS_LABEL = "Converting to volume"

    grid: EnumProperty(name="Grid", description="What the voxels hold",
                       items=[('SDF', "Signed Distance", "A narrow-band level set named 'sdf': signed distance "
                               "to the surface (negative inside) within Band Width voxels of it"),
                              ('DENSITY', "Density", "A fog volume named 'density': 0 outside, rising to 1 over "
                               "Band Width voxels inside the surface, 1 deeper")],
                       default='SDF')
    band_width: IntProperty(name="Band Width", description="Voxels either side of the surface the signed "
                            "distance is kept for (OpenVDB's usual 3); the density's ramp inside", default=3,
                            min=1, max=100)
    directory: StringProperty(name="Directory", description="Folder of the .vdb file, named after the fractal "
                              "('//': beside the .blend; an unsaved .blend: the system's temporary folder)",
                              default="//", subtype='DIR_PATH')
    use_frame_range: BoolProperty(name="Frame Range", description="One .vdb file per frame of the scene's frame "
                                  "range, played by the Volume object as a sequence", default=False)
    use_material: BoolProperty(name="Volume Material", description="Give the volume a material of uniform "
                               "density inside the surface", default=True)

    def _folder(self):
        """(absolute folder for the files, whether the path goes in as relative to the .blend)."""
        relative = self.directory.startswith("//")
        if relative and not bpy.data.filepath:
            # Blender deletes its session folder (bpy.app.tempdir) when it quits, so the system's
            # temporary folder above it, where Blender puts an unsaved file's fluid caches.
            base = os.path.dirname(os.path.normpath(bpy.app.tempdir))
            return os.path.join(base, self.directory[2:]), False
        folder = bpy.path.abspath(self.directory)
        if not folder:
            raise ValueError("no directory for the .vdb file")
        return folder, relative

    def _stem(self, folder, fractal, frames):
        """The files' common name: the fractal's, with .001, .002... while another Volume of this
        .blend reads a file of that name (an unread file of that name is overwritten: redoing the
        operator rewrites its own file)."""
        taken = referenced_vdb_paths()
        base = bpy.path.clean_name(fractal.name)
        for number in range(10000):
            stem = base if number == 0 else "%s.%03d" % (base, number)
            if os.path.normcase(os.path.normpath(os.path.join(folder, vdb_name(stem, frames[0])))) not in taken:
                return stem
        raise ValueError("no free .vdb file name for %r in %s" % (base, folder))

    def _begin(self, context):
        self._written, self._grids = [], []  # the .vdb paths; (voxels, voxel size) per frame
        self._folder_path, self._relative = self._folder()
        try:
            os.makedirs(self._folder_path, exist_ok=True)
        except OSError as exc:
            raise OSError("cannot write the .vdb file into %s: %s" % (self._folder_path, exc.strerror)) from exc
        self._file_stem = self._stem(self._folder_path, self._fractal,
                                     frames_to_convert(context.scene, self.use_frame_range))

    def _convert_frame(self, context, frame, mesh):
        if not len(mesh.faces):
            raise ValueError("the fractal has no surface at resolution %d%s" % (
                self.resolution, "" if frame is None else " on frame %d" % frame))
        voxel_size = mesh.stats["cell_size"]
        voxels = band_voxels(mesh, voxel_size, self.band_width)
        grid_memory_preflight(voxels, self.resolution)
        path = os.path.join(self._folder_path, vdb_name(self._file_stem, frame))
        self._written.append(path)
        write_grid(context, mesh, self.grid, voxel_size, self.band_width, path)
        self._grids.append((voxels, voxel_size))

    def _discard(self):
        super()._discard()
        for path in self._written:  # nothing half-made stays, on disk either
            if os.path.exists(path):
                os.remove(path)
        self._written = []

    def _finish(self, context):
        written = self._written
        new = self._volume_object(context, self._fractal, written, self._relative)
        make_active(context, [new])
        voxels, voxel_size = self._grids[-1]
        size = sum(os.path.getsize(p) for p in written)
        self.report({'INFO'}, "Unbound: %s (%d file%s, %.1f MB), voxel size %.4g, about %.3g voxels%s, in %.1f s"
                    % (written[-1], len(written), "" if len(written) == 1 else "s", size / 1e6, voxel_size,
                       voxels, " per frame" if len(written) > 1 else "", self._seconds()))
        if not bpy.data.filepath and self.directory.startswith("//"):
            self.report({'WARNING'}, "Unbound: the .blend is unsaved, so the .vdb went to the system's temporary "
                        "folder: save the .blend and convert again, or pack it (File > External Data > Pack "
                        "Resources)")
        return {'FINISHED'}

    def _volume_object(self, context, fractal, written, relative):
        """The Volume object reading the written file(s), placed like the fractal."""
        name = fractal.name + " Volume"
        volume = bpy.data.volumes.new(name)
        self._made.append((bpy.data.volumes, volume))
        volume.filepath = bpy.path.relpath(written[0]) if relative else written[0]
        if self.use_frame_range:
            scene = context.scene
            volume.is_sequence = True
            volume.frame_start = scene.frame_start
            volume.frame_duration = len(written)
            # file numbers are scene frames: frame_start plays file number frame_start
            volume.frame_offset = scene.frame_start - 1
            volume.sequence_mode = 'CLIP'
        if self.use_material:
            volume.materials.append(self._keep_new(bpy.data.materials, lambda: volume_material(self.grid)))
        new = bpy.data.objects.new(name, volume)
        self._made.append((bpy.data.objects, new))
        link_beside(context, fractal, new)
        return new


def vdb_name(stem, frame):
    """The .vdb file's name: stem.vdb, or stem_0001.vdb for frame 1 of a sequence."""
    return stem + ".vdb" if frame is None else "%s_%04d.vdb" % (stem, frame)


def menu_convert(self, context):
    if utils.is_fractal(context.active_object):
        self.layout.separator()
        self.layout.operator(UNBOUND_OT_convert_to_mesh.bl_idname, icon='MESH_DATA')
        self.layout.operator(UNBOUND_OT_convert_to_volume.bl_idname, icon='VOLUME_DATA')


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
        col.operator(UNBOUND_OT_convert_to_volume.bl_idname, icon='VOLUME_DATA')


classes = (UNBOUND_OT_convert_to_mesh, UNBOUND_OT_convert_to_volume, UNBOUND_PT_fractal_convert)


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
