"""Operators: add a fractal object, its colour ramp and presets; build a compositor node tree from
Unbound's passes."""
import math
import os

import bpy
import numpy as np
from mathutils import Euler, Matrix, Vector
from bl_operators.presets import AddPresetBase
from bl_ui.utils import PresetPanel

from . import composite, convert, export, passes, utils
from .properties import (FRACTAL_KINDS, MU_STEP, UnboundObjectSettings, UnboundSceneSettings, _sync_display_size,
                         display_radius)

# Presets shipped with the extension, read-only; the user's own (the + of a preset popover) go where
# Blender keeps presets, scripts/presets/unbound/<kind>, and the popover lists both. Two kinds:
# fractal presets hold the active object's parameters (Object.unbound), look presets the scene's
# shading (Scene.unbound): applying one never changes what the other holds.
PRESET_SUBDIR = "unbound/fractal"
LOOK_PRESET_SUBDIR = "unbound/look"
BUNDLED_PRESETS = os.path.join(os.path.dirname(__file__), "presets", "fractal")
BUNDLED_LOOK_PRESETS = os.path.join(os.path.dirname(__file__), "presets", "look")

# What a preset holds: every setting of the PropertyGroup, read from its annotations so that a new
# one is never left out, except a datablock (the ramp texture, the path curve, the material), the map
# shown for editing, and machine-specific render or viewport settings.
FRACTAL_PRESET_EXCLUDE = {"is_fractal", "color_ramp_texture", "path_curve", "material", "ifs_active_map",
                          "kifs_active_plane", "hybrid_active_step"}
LOOK_PRESET_EXCLUDE = {"tile_size", "simd"}


def fractal_preset_names():
    return [name for name in UnboundObjectSettings.__annotations__ if name not in FRACTAL_PRESET_EXCLUDE]


def look_preset_names():
    return [name for name in UnboundSceneSettings.__annotations__
            if name not in LOOK_PRESET_EXCLUDE and not name.startswith("viewport_")]


def _float_text(value):
    """The shortest decimal that gives the same float32 back (Blender stores float properties in
    single precision): 0.1, not 0.10000000149011612."""
    import struct
    single = struct.unpack("f", struct.pack("f", value))[0]
    for digits in range(6, 10):
        text = "%.*g" % (digits, value)
        if struct.unpack("f", struct.pack("f", float(text)))[0] == single:
            return repr(float(text))
    return repr(value)


def _value_text(value):
    if isinstance(value, bool) or isinstance(value, (int, str)):
        return repr(value)
    if isinstance(value, float):
        return _float_text(value)
    return "(%s)" % ", ".join(_value_text(v) for v in value) + ("" if len(value) != 1 else ",")


def preset_lines(owner, path, names):
    """Python lines that set `path`.NAME to owner's value for each name: every value written out in
    full, an IFS map collection as clear() and one add() per item. Nothing is exec'd or eval'd
    here (Blender's AddPresetBase runs `preset_defines` through exec(), which Python 3.13 no longer
    lets define local names, PEP 667)."""
    lines = []
    for name in names:
        value = getattr(owner, name)
        if isinstance(value, bpy.types.bpy_prop_collection):
            lines.append("%s.%s.clear()" % (path, name))
            for item in value:
                lines.append("item = %s.%s.add()" % (path, name))
                for sub in item.bl_rna.properties.keys():
                    if sub not in {"rna_type", "name"}:
                        lines.append("item.%s = %s" % (sub, _value_text(_plain(getattr(item, sub)))))
        else:
            lines.append("%s.%s = %s" % (path, name, _value_text(_plain(value))))
    return lines


def _plain(value):
    try:
        return tuple(value[:]) if not isinstance(value, str) else value
    except TypeError:
        return value


def fractal_preset_text(ob):
    return "\n".join(["import bpy", "ob = bpy.context.object", ""]
                     + preset_lines(ob.unbound, "ob.unbound", fractal_preset_names())) + "\n"


def look_preset_text(scene):
    return "\n".join(["import bpy", "scene = bpy.context.scene", ""]
                     + preset_lines(scene.unbound, "scene.unbound", look_preset_names())) + "\n"


def preset_files(folder):
    """[(display name, path)] of the .py presets in folder, in natural order (20 after 3)."""
    import re
    if not folder or not os.path.isdir(folder):
        return []
    names = [f for f in os.listdir(folder) if f.lower().endswith(".py") and not f.startswith(".")]
    names.sort(key=lambda f: tuple(int(t) if t.isdigit() else t for t in re.split(r"(\d+)", f.lower())))
    return [(bpy.path.display_name(f, title_case=False), os.path.join(folder, f)) for f in names]


def user_preset_folders(subdir):
    """Blender's preset folders for subdir (the user's own and any other script path's)."""
    return bpy.utils.preset_paths(subdir)


def redraw_views(context):
    """Redraw every area (the 3D views in Rendered shading read the scene anew when they draw)."""
    wm = context.window_manager
    for window in wm.windows:
        for area in window.screen.areas:
            area.tag_redraw()


def fractal_edited(context, props):
    """After an operator changed a fractal's collections (maps, fold planes, hybrid entries):
    Python's writes tag nothing, so tag the object for the depsgraph (F12 and the Rendered viewport
    read its evaluated copy, which kept the old items) and redraw the views."""
    props.id_data.update_tag()
    redraw_views(context)
    return {'FINISHED'}


class PresetMenu:
    """What the fractal and look preset popovers (and menus) share: the bundled presets first,
    their remove button greyed out (they ship with the extension), then the user's own, each with
    its remove button, then a name field and + to save the current settings."""
    preset_operator = "script.execute_preset"

    def draw(self, context):
        layout = self.layout
        layout.emboss = 'PULLDOWN_MENU'
        layout.operator_context = 'EXEC_DEFAULT'   # as Blender's preset popovers: + saves at once
        col = layout.column(align=True)
        seen = set()
        folders = [(self.bundled, True)] + [(f, False) for f in user_preset_folders(self.preset_subdir)]
        for folder, bundled in folders:
            real = os.path.realpath(folder)
            if real in seen:
                continue
            seen.add(real)
            for name, path in preset_files(folder):
                row = col.row(align=True)
                props = row.operator(self.preset_operator, text=name, translate=False)
                props.filepath = path
                props.menu_idname = self.bl_idname
                sub = row.row(align=True)
                sub.enabled = not bundled
                props = sub.operator(self.preset_add_operator, text="", icon='REMOVE')
                props.name = name
                props.remove_name = True
        wm = context.window_manager
        layout.separator()
        row = layout.row()
        sub = row.row()
        sub.emboss = 'NORMAL'
        sub.prop(wm, "preset_name", text="")
        props = row.operator(self.preset_add_operator, text="", icon='ADD')
        props.name = wm.preset_name


class FractalPresetMenu(PresetMenu):
    bl_label = "Fractal Presets"
    preset_subdir = PRESET_SUBDIR
    bundled = BUNDLED_PRESETS
    preset_add_operator = "unbound.fractal_preset_add"

    @classmethod
    def post_cb(cls, context, filepath):
        """After a fractal preset ran: Python's property writes tag nothing, so tag the object for
        the depsgraph (F12, the bounding sphere's handler, drivers), size its sphere now and redraw
        the views (the Rendered viewport reads the scene anew when it draws)."""
        ob = context.object
        if utils.is_fractal(ob):
            ob.update_tag()
            _sync_display_size(ob)
        redraw_views(context)


class LookPresetMenu(PresetMenu):
    bl_label = "Look Presets"
    preset_subdir = LOOK_PRESET_SUBDIR
    bundled = BUNDLED_LOOK_PRESETS
    preset_add_operator = "unbound.look_preset_add"

    @classmethod
    def post_cb(cls, context, filepath):
        """After a look preset ran: tag the scene (and its world, which fog may read) and redraw."""
        context.scene.update_tag()
        redraw_views(context)


class UNBOUND_MT_fractal_presets(FractalPresetMenu, bpy.types.Menu):
    """Fractal presets as a menu (scripts and older layouts; the panel header has the popover)"""


class UNBOUND_MT_look_presets(LookPresetMenu, bpy.types.Menu):
    """Look presets as a menu"""


class UNBOUND_PT_fractal_presets(FractalPresetMenu, PresetPanel, bpy.types.Panel):
    """The fractal presets popover in the Unbound Fractal panel's header, as Cycles' sampling presets"""
    draw = PresetMenu.draw


class UNBOUND_PT_look_presets(LookPresetMenu, PresetPanel, bpy.types.Panel):
    """The look presets popover in the Render tab's Unbound panel header"""
    draw = PresetMenu.draw


class PresetOperator:
    """Save the current settings as a preset in the user's preset folder, or remove one of the
    user's presets. Bundled presets cannot be removed: that is reported, never silently skipped."""
    bl_options = {'REGISTER', 'INTERNAL'}

    name: bpy.props.StringProperty(name="Name", description="Name of the preset, used to make the file name",
                                   maxlen=64, options={'SKIP_SAVE'})
    remove_name: bpy.props.BoolProperty(default=False, options={'HIDDEN', 'SKIP_SAVE'})
    remove_active: bpy.props.BoolProperty(default=False, options={'HIDDEN', 'SKIP_SAVE'})

    def menu(self):
        return getattr(bpy.types, self.preset_menu)

    def execute(self, context):
        if self.remove_name or self.remove_active:
            return self.remove(context)
        name = self.name.strip()
        if not name:
            self.report({'ERROR'}, "Give the preset a name")
            return {'CANCELLED'}
        filename = AddPresetBase.as_filename(name)
        if not filename:
            self.report({'ERROR'}, "'%s' does not make a file name" % name)
            return {'CANCELLED'}
        bundled = {os.path.basename(p).lower() for _, p in preset_files(self.bundled)}
        if (filename + ".py").lower() in bundled:
            self.report({'WARNING'}, "Cannot save preset \"%s\": a bundled preset has that name" % name)
            return {'CANCELLED'}
        folder = bpy.utils.user_resource('SCRIPTS', path=os.path.join("presets", self.preset_subdir), create=True)
        if not folder:
            self.report({'ERROR'}, "Failed to create the presets folder")
            return {'CANCELLED'}
        path = os.path.join(folder, filename + ".py")
        if os.path.exists(path):
            self.report({'WARNING'}, "Cannot save preset \"%s\", as the name already exists" % name)
            return {'CANCELLED'}
        text = self.preset_text(context)   # all of it before the file is opened: never a partial file
        tmp = path + ".tmp"
        with open(tmp, "w", encoding="utf-8") as f:
            f.write(text)
        os.replace(tmp, path)
        wm = context.window_manager
        if name == wm.preset_name:
            wm.preset_name = "New Preset"
        self.menu().bl_label = bpy.path.display_name(filename, title_case=False)
        self.report({'INFO'}, "Saved preset \"%s\" (%s)" % (name, path))
        return {'FINISHED'}

    def remove(self, context):
        name = self.menu().bl_label if self.remove_active else self.name
        wanted = {name.lower(), AddPresetBase.as_filename(name).lower() + ".py"}

        def find(folders):
            return next((path for folder in folders for shown, path in preset_files(folder)
                         if shown.lower() in wanted or os.path.basename(path).lower() in wanted), None)
        path = find(user_preset_folders(self.preset_subdir))
        if path is None:
            if find([self.bundled]):
                self.report({'WARNING'}, "\"%s\" is a bundled preset and cannot be removed" % name)
            else:
                self.report({'WARNING'}, "No preset \"%s\" to remove" % name)
            return {'CANCELLED'}
        try:
            os.remove(path)
        except OSError as exc:
            self.report({'ERROR'}, "Unable to remove preset: %s" % exc)
            return {'CANCELLED'}
        self.menu().bl_label = "Presets"
        self.report({'INFO'}, "Removed preset \"%s\"" % name)
        return {'FINISHED'}

    def check(self, _context):
        self.name = AddPresetBase.as_filename(self.name.strip())

    def invoke(self, context, _event):
        if self.remove_active or self.remove_name:
            return self.execute(context)
        return context.window_manager.invoke_props_dialog(self)


class UNBOUND_OT_fractal_preset_add(PresetOperator, bpy.types.Operator):
    """Save the active fractal's parameters as a preset, or remove one of yours"""
    bl_idname = "unbound.fractal_preset_add"
    bl_label = "Add Fractal Preset"
    preset_menu = "UNBOUND_MT_fractal_presets"
    preset_subdir = PRESET_SUBDIR
    bundled = BUNDLED_PRESETS

    @classmethod
    def poll(cls, context):
        return utils.is_fractal(context.object)

    def preset_text(self, context):
        return fractal_preset_text(context.object)


class UNBOUND_OT_look_preset_add(PresetOperator, bpy.types.Operator):
    """Save the scene's Unbound shading (lighting, effects, sea, samples) as a look preset, or remove one of yours"""
    bl_idname = "unbound.look_preset_add"
    bl_label = "Add Look Preset"
    preset_menu = "UNBOUND_MT_look_presets"
    preset_subdir = LOOK_PRESET_SUBDIR
    bundled = BUNDLED_LOOK_PRESETS

    def preset_text(self, context):
        return look_preset_text(context.scene)


class UNBOUND_OT_color_ramp_add(bpy.types.Operator):
    """Give the active fractal a colour ramp (a texture's ramp) for orbit-trap or iteration colouring"""
    bl_idname = "object.unbound_color_ramp_add"
    bl_label = "New Color Ramp"
    bl_options = {'REGISTER', 'UNDO'}

    @classmethod
    def poll(cls, context):
        return utils.is_fractal(context.object)

    def execute(self, context):
        add_color_ramp(context.object)
        return {'FINISHED'}


def add_color_ramp(ob):
    """A new colour ramp texture on `ob` (deep blue, red, gold), orbit-trap colouring if it had one
    colour."""
    props = ob.unbound
    tex = bpy.data.textures.new("%s Ramp" % ob.name, 'BLEND')
    tex.use_color_ramp = True
    ramp = tex.color_ramp
    ramp.elements[0].color = (0.05, 0.1, 0.4, 1.0)
    ramp.elements[1].color = (1.0, 0.85, 0.4, 1.0)
    mid = ramp.elements.new(0.5)
    mid.color = (0.8, 0.2, 0.1, 1.0)
    props.color_ramp_texture = tex
    if props.color_mode == 'BASE':
        props.color_mode = 'ORBIT_TRAP'
    return tex


# -- Frame in Camera ---------------------------------------------------------------------------

def bounding_sphere(ob):
    """(centre, radius) in world space of the core's bounding ball of `ob`'s set; None while its
    settings are invalid."""
    try:
        bound = utils.native().describe(export.object_parameters(ob, with_ramp=False))
    except (ImportError, ValueError, TypeError, export.RenderError):
        return None
    m = ob.matrix_world
    scale = max(abs(v) for v in m.to_scale())
    return m @ Vector(bound["bound_center"]), max(bound["bound_radius"], 0.0) * scale


def camera_frustum(scene, cam_ob):
    """The camera's view as planes [(inward normal, point)] through the frame's four edges (the
    render's aspect, shift and sensor fit, as the camera draws its frame), the eye, the direction
    through the frame's centre, and whether it is a perspective camera."""
    m = cam_ob.matrix_world
    corners = [m @ v for v in cam_ob.data.view_frame(scene=scene)]
    eye = m.translation.copy()
    forward = (m.to_3x3() @ Vector((0.0, 0.0, -1.0))).normalized()
    centre = sum(corners, Vector()) / 4.0
    perspective = cam_ob.data.type == 'PERSP'
    planes = []
    for a, b in zip(corners, corners[1:] + corners[:1]):
        n = (a - eye).cross(b - eye) if perspective else (b - a).cross(forward)
        if n.length == 0.0:
            return None
        n.normalize()
        if n.dot(centre - a) < 0.0:
            n = -n
        planes.append((n, a))
    through = (centre - eye).normalized() if perspective else forward
    return planes, eye, through, forward, perspective


def frame_in_camera(scene, ob, fill=0.9, centre=True, turn=False):
    """Scale `ob` (about its origin) so that its bounding sphere fills `fill` of the active
    camera's view: the sphere touches the nearest frame edges when fill is 1. With `centre`, first
    move it onto the line through the frame's centre, at its depth (or in front of the camera if it
    was behind). With `turn`, a set whose silhouette stands across the frame's long side is first
    turned a quarter about the view axis (a tall set in a wide frame fills twice the area lying
    down). Returns a message when it cannot (no camera, the set behind it), else None."""
    cam_ob = scene.camera
    if cam_ob is None or cam_ob.type != 'CAMERA':
        return "the scene has no active camera"
    if cam_ob.data.type not in {'PERSP', 'ORTHO'}:
        return "Frame in Camera needs a perspective or orthographic camera"
    frustum = camera_frustum(scene, cam_ob)
    sphere = bounding_sphere(ob)
    if frustum is None or sphere is None:
        return "the camera's frame or the fractal's settings are invalid"
    planes, eye, through, forward, perspective = frustum
    c, r = sphere
    near = cam_ob.data.clip_start
    depth = (c - eye).dot(forward)
    if centre:
        if depth <= near + r:
            depth = max((c - eye).length, near + 4.0 * max(r, 1e-6))
        if perspective:
            target = eye + through * (depth / through.dot(forward))
        else:  # the line through the frame's centre, along the axis
            target = planes_centre(planes, eye, forward) + forward * depth
        matrix = ob.matrix_world.copy()
        matrix.translation = matrix.translation + (target - c)
        ob.matrix_world = matrix  # Blender derives location from it, parents included
        bpy.context.view_layer.update()
        c = target
    elif depth <= near:
        return "the fractal is behind the camera"
    if min(n.dot(c - a) for n, a in planes) <= 0.0:
        return "the fractal is outside the camera's view"
    origin = ob.matrix_world.translation.copy()
    factor = 1.0
    for _ in range(6):  # the sphere's centre moves with the scale unless it is the object's origin
        cf = origin + (c - origin) * factor
        room = min(n.dot(cf - a) for n, a in planes)
        if perspective:
            room = min(room, (cf - eye).dot(forward) - near)
        if room <= 0.0 or r * factor <= 0.0:
            break
        factor *= fill * room / (r * factor)
    if not (factor > 0.0) or not math.isfinite(factor):
        return "the fractal cannot be framed from here"
    ob.scale = ob.scale * factor
    if turn:
        turn_to_frame(scene, cam_ob, ob, forward)
    # The bounding sphere is the core's conservative bound, often much larger than the set (the
    # default Julia set fills a tenth of the frame inside it): then fit what the camera sees of
    # the set itself, from a small render through the camera.
    for _ in range(3):
        bpy.context.view_layer.update()
        box = silhouette(scene, ob)
        if box is None:
            break
        x0, y0, x1, y1 = box
        ox, oy = camera_ndc(scene, cam_ob, ob.matrix_world.translation)
        if centre:
            # Move the silhouette's centre to the frame's centre, at the set's depth.
            at = bounding_sphere(ob)[0]
            shift = ndc_to_world(scene, cam_ob, (0.0, 0.0), at) - ndc_to_world(scene, cam_ob, ((x0 + x1) / 2,
                                                                                               (y0 + y1) / 2), at)
            matrix = ob.matrix_world.copy()
            matrix.translation = matrix.translation + shift
            ob.matrix_world = matrix
            x0, x1, y0, y1 = x0 - (x0 + x1) / 2, x1 - (x0 + x1) / 2, y0 - (y0 + y1) / 2, y1 - (y0 + y1) / 2
            ox, oy = camera_ndc(scene, cam_ob, ob.matrix_world.translation)
        # Scaling about the origin (ox, oy) moves each point away from it by the factor.
        limits = []
        for lo, hi, o in ((x0, x1, ox), (y0, y1, oy)):
            if hi > o + 1e-6:
                limits.append((fill - o) / (hi - o))
            if lo < o - 1e-6:
                limits.append((-fill - o) / (lo - o))
        k = min(limits) if limits else 1.0
        if not (k > 0.0) or not math.isfinite(k):
            break
        ob.scale = ob.scale * k
        if abs(k - 1.0) < 0.02:
            break
    return None


MASK_SIZE = 160   # pixels across the silhouette render of Frame in Camera
# Turn to fit only when the silhouette's long side lies across the frame's long side by more than
# this ratio: a nearly round set is left as it was placed.
TURN_RATIO = 1.15


def turn_to_frame(scene, cam_ob, ob, forward):
    """Turn `ob` a quarter about the camera's view axis, through its origin, when its silhouette is
    longer (by TURN_RATIO) across the frame's long side than along it. True when it turned."""
    box = silhouette(scene, ob)
    if box is None:
        return False
    r = scene.render
    aspect = (r.resolution_x * r.pixel_aspect_x) / max(r.resolution_y * r.pixel_aspect_y, 1e-9)
    # The box in frame units where one unit is the frame's height.
    width, height = (box[2] - box[0]) * aspect, box[3] - box[1]
    along, across = (width, height) if aspect >= 1.0 else (height, width)
    if across <= TURN_RATIO * along:
        return False
    quarter = Matrix.Rotation(math.pi / 2.0, 4, forward)
    origin = ob.matrix_world.translation.copy()
    ob.matrix_world = Matrix.Translation(origin) @ quarter @ Matrix.Translation(-origin) @ ob.matrix_world
    bpy.context.view_layer.update()
    return True


def silhouette(scene, ob):
    """The box (x0, y0, x1, y1), in the camera frame's normalised coordinates (-1 .. 1), of what
    the camera sees of `ob`'s set: a MASK_SIZE-pixel render of its depth; None if nothing."""
    r = scene.render
    aspect = (r.resolution_x * r.pixel_aspect_x) / max(r.resolution_y * r.pixel_aspect_y, 1e-9)
    w, h = (MASK_SIZE, max(int(round(MASK_SIZE / aspect)), 8)) if aspect >= 1.0 else \
        (max(int(round(MASK_SIZE * aspect)), 8), MASK_SIZE)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    cam_ob = scene.camera.evaluated_get(depsgraph)
    try:
        camera = export.camera_dict(depsgraph, cam_ob, cam_ob.matrix_world, w, h)
        params = dict(export.object_parameters(ob, with_ramp=False), matrix=[list(row) for row in ob.matrix_world])
        depth = np.empty((h, w, 1), np.float32)
        utils.native().render(camera, [params], {"depth": depth}, threads=0)
    except (ImportError, ValueError, TypeError, export.RenderError):
        return None
    hit = depth[..., 0] < 1e9
    if not hit.any():
        return None
    rows, cols = np.nonzero(hit.any(axis=1))[0], np.nonzero(hit.any(axis=0))[0]
    # Row 0 is the bottom of the image (Blender's order).
    return (2.0 * cols[0] / w - 1.0, 2.0 * rows[0] / h - 1.0, 2.0 * (cols[-1] + 1) / w - 1.0,
            2.0 * (rows[-1] + 1) / h - 1.0)


def camera_ndc(scene, cam_ob, point):
    from bpy_extras.object_utils import world_to_camera_view
    v = world_to_camera_view(scene, cam_ob, point)
    return 2.0 * v.x - 1.0, 2.0 * v.y - 1.0


def ndc_to_world(scene, cam_ob, ndc, at):
    """The world point seen at normalised frame coordinates `ndc` at the depth of point `at`."""
    m = cam_ob.matrix_world
    corners = [m @ v for v in cam_ob.data.view_frame(scene=scene)]   # top right, bottom right, bottom left, top left
    eye = m.translation
    forward = (m.to_3x3() @ Vector((0.0, 0.0, -1.0))).normalized()
    u, v = (ndc[0] + 1.0) / 2.0, (ndc[1] + 1.0) / 2.0
    bottom = corners[2].lerp(corners[1], u)
    top = corners[3].lerp(corners[0], u)
    on_frame = bottom.lerp(top, v)
    depth = (at - eye).dot(forward)
    if cam_ob.data.type == 'PERSP':
        return eye + (on_frame - eye) * (depth / (on_frame - eye).dot(forward))
    return on_frame + forward * (depth - (on_frame - eye).dot(forward))


def planes_centre(planes, eye, forward):
    """Centre of an orthographic frame (the mean of its edge points) in the plane of the eye."""
    mean = sum((a for _, a in planes), Vector()) / len(planes)
    return mean - forward * (mean - eye).dot(forward)


class UNBOUND_OT_frame_camera(bpy.types.Operator):
    """Place the fractal in the middle of the active camera's view, at its depth, and scale it so
    that its bounding sphere fills the frame"""
    bl_idname = "object.unbound_frame_camera"
    bl_label = "Frame in Camera"
    bl_options = {'REGISTER', 'UNDO'}

    fill: bpy.props.FloatProperty(name="Fill", description="Diameter of the bounding sphere as a fraction of "
                                  "the frame's shorter side", default=0.9, min=0.05, max=2.0, subtype='FACTOR')
    centre: bpy.props.BoolProperty(name="Center", description="Move the fractal onto the line through the "
                                   "frame's centre first (otherwise only scale it where it is)", default=True)
    turn: bpy.props.BoolProperty(name="Turn to Fit", description="Turn a set that stands across the frame's "
                                 "long side a quarter about the view axis, so that it fills the frame lying "
                                 "down", default=False)

    @classmethod
    def poll(cls, context):
        return utils.is_fractal(context.object) and context.scene.camera is not None

    def execute(self, context):
        problem = frame_in_camera(context.scene, context.object, self.fill, self.centre, self.turn)
        if problem:
            self.report({'WARNING'}, "Frame in Camera: " + problem)
            return {'CANCELLED'}
        _sync_display_size(context.object)
        return {'FINISHED'}


# -- Deep zoom: the anchor under the mouse -----------------------------------------------------

# The kinds with a deep zoom (README: Deep zoom): the quaternion kinds to zoom 60 (perturbation), the
# formula kinds in double to the core's ZOOM_FORMULA_MAX.
FORMULA_ZOOM_KINDS = {'MANDELBULB', 'MANDELBOX', 'KIFS', 'HYBRID'}
ZOOM_KINDS = {'QUATERNION_JULIA', 'QUATERNION_MANDELBROT'} | FORMULA_ZOOM_KINDS


def surface_hit(ob, origin, direction):
    """World point where the world ray (origin, unit direction) first meets fractal object `ob`, by
    the core at the object's own zoom and anchor (a one-pixel render of its position pass along
    the ray), or None where the ray misses it."""
    uc = utils.native()
    params = export.object_parameters(ob)
    params["matrix"] = [list(row) for row in ob.matrix_world]
    # A fixed hit threshold far below the ray's pixel: the point, not a pixel's worth of surface.
    params["threshold_mode"], params["epsilon"] = 'fixed', 1e-6
    up = (0.0, 0.0, 1.0) if abs(direction[2]) < 0.9 else (0.0, 1.0, 0.0)
    target = tuple(o + d for o, d in zip(origin, direction))
    camera = dict(matrix=uc.look_at(tuple(origin), target, up), projection=uc.perspective(1e-6, 1.0, 1e-6, 1e4),
                  width=1, height=1)
    out = {name: np.zeros((1, 1, uc.PASS_CHANNELS[name]), np.float32) for name in ("alpha", "position")}
    uc.render(camera, [params], out, threads=1)
    if out["alpha"][0, 0, 0] < 1.0:
        return None
    return Vector(out["position"][0, 0].astype(float))


def pick_zoom_anchor(ob, origin, direction):
    """Move the anchor of `ob` to the surface point along the world ray, so that the next zoom dives
    there, and the object by as much in the world, so that the view does not move: the hit's local
    point u becomes the new origin, anchor' = anchor + u 10^-zoom (the core's exact decimal sum),
    and the object's origin goes to matrix_world @ u. Returns None or why not."""
    hit = surface_hit(ob, origin, direction)
    if hit is None:
        # A pick finds the surface to 10^-6 object units (the core's finest fixed threshold is 10^-7):
        # 6 decades deeper the surface may be out of a zoomed object's 64-unit view.
        return ("the ray misses the fractal (at depth, pick again within about 6 decades of zoom of the "
                "last pick)" if ob.unbound.zoom > 0.0 else "the ray misses the fractal")
    u = ob.matrix_world.inverted() @ hit
    props = ob.unbound
    props.zoom_anchor = utils.native().zoom_anchor_move(props.zoom_anchor, props.zoom, tuple(u))
    ob.matrix_world.translation = ob.matrix_world @ u
    return None


class UNBOUND_OT_pick_zoom_anchor(bpy.types.Operator):
    """Set the deep zoom's anchor to the fractal's surface under the mouse (from the Properties
    editor: at the centre of the camera's view), computed at the current zoom, and move the object
    so that the view does not jump; zooming in then dives into that point"""
    bl_idname = "object.unbound_pick_zoom_anchor"
    bl_label = "Pick Anchor"
    bl_options = {'REGISTER', 'UNDO'}

    @classmethod
    def poll(cls, context):
        ob = context.object
        return utils.is_fractal(ob) and ob.unbound.kind in ZOOM_KINDS

    def invoke(self, context, event):
        if context.area is None or context.area.type != 'VIEW_3D' or context.region_data is None:
            return self.execute(context)
        from bpy_extras import view3d_utils
        coord = (event.mouse_region_x, event.mouse_region_y)
        origin = view3d_utils.region_2d_to_origin_3d(context.region, context.region_data, coord)
        direction = view3d_utils.region_2d_to_vector_3d(context.region, context.region_data, coord)
        return self.pick(context, origin, direction.normalized())

    def execute(self, context):
        cam = context.scene.camera
        if cam is None:
            self.report({'WARNING'}, "Pick Anchor: the scene has no camera (or use it in the 3D view, under the mouse)")
            return {'CANCELLED'}
        m = cam.matrix_world
        return self.pick(context, m.translation, (m.to_3x3() @ Vector((0.0, 0.0, -1.0))).normalized())

    def pick(self, context, origin, direction):
        problem = pick_zoom_anchor(context.object, origin, direction)
        if problem:
            self.report({'WARNING'}, "Pick Anchor: " + problem)
            return {'CANCELLED'}
        return {'FINISHED'}


# -- The first look ----------------------------------------------------------------------------

# What Add > Unbound Fractal gives a scene whose Unbound look was never touched (from the Add
# menu only; scripts get the plain defaults, the core's): the gallery's soft look, in balance with
# the scene's own lights. With lights in the scene the axle light is a weak fill from the eye,
# so that it does not double the key light (the startup lamp); without any it stays the paper's
# full axle light. Ambient light from the sky, darkened by ambient occlusion, and soft shadows.
FIRST_LOOK = dict(samples=4, ambient=(0.22, 0.24, 0.28), shadows='SOFT', ao_strength=0.8, ao_distance=0.4,
                  ao_samples=5)
FIRST_LOOK_AXLE = 0.35   # with scene lights; 1.0 (the default) without


def look_untouched(scene):
    """True while every setting a look preset holds is at its default."""
    u = scene.unbound
    for name in look_preset_names():
        prop = u.bl_rna.properties[name]
        value = getattr(u, name)
        default = list(prop.default_array) if getattr(prop, "is_array", False) and prop.array_length else prop.default
        if (list(value) if prop.type != 'ENUM' and getattr(prop, "is_array", False) and prop.array_length else value) \
                != default:
            return False
    return True


def apply_first_look(scene):
    u = scene.unbound
    for name, value in FIRST_LOOK.items():
        setattr(u, name, value)
    has_lights = any(o.type == 'LIGHT' and o.visible_get() for o in scene.objects)
    u.axle_light = FIRST_LOOK_AXLE if has_lights else 1.0
    scene.update_tag()


def menu_options(context):
    """What the Add menu's Add > Unbound Fractal does beyond a script's call (its invoke): frame the
    fractal in the active camera, and give it the first look."""
    return dict(frame_camera=context.scene.camera is not None, turn_to_fit=True, first_look=True)


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


# Knighty's kaleidoscopic IFS shapes (reference/kifs64.py holds them equal to his own code): fold
# planes (normal, offset), scale, offset, final shape, iterations. The Menger sponge's last plane
# (z >= 1/3 before the scale) is his "z.z < -1: z.z += 2" after it, up to a sign the next abs fold
# and the symmetric box undo.
KIFS_SHAPES = {
    'MENGER': ([((1, 0, 0), 0), ((0, 1, 0), 0), ((0, 0, 1), 0), ((1, -1, 0), 0), ((1, 0, -1), 0), ((0, 1, -1), 0),
                ((0, 0, 1), 1.0 / 3.0)], 3.0, (1.0, 1.0, 1.0), 'BOX', 6),
    'SIERPINSKI': ([((1, 1, 0), 0), ((1, 0, 1), 0), ((0, 1, 1), 0)], 2.0, (1.0, 1.0, 1.0), 'TETRAHEDRON', 10),
    'OCTAHEDRAL': ([((1, 1, 0), 0), ((1, 0, 1), 0), ((1, -1, 0), 0), ((1, 0, -1), 0)], 2.0, (1.0, 0.0, 0.0),
                   'OCTAHEDRON', 10),
}
KIFS_SHAPE_ITEMS = [
    ('MENGER', "Menger Sponge", "Abs folds, sorting folds and one offset plane; scale 3, a box", 0),
    ('SIERPINSKI', "Sierpinski Tetrahedron", "Three folds x + y, x + z, y + z >= 0; scale 2, a tetrahedron", 1),
    ('OCTAHEDRAL', "Octahedral Flake", "Four folds; scale 2 toward (1, 0, 0), an octahedron", 2),
]


def set_kifs_shape(props, shape):
    planes, scale, offset, final, iterations = KIFS_SHAPES[shape]
    props.kifs_planes.clear()
    for normal, d in planes:
        p = props.kifs_planes.add()
        p.normal, p.offset = normal, d
    props.kifs_active_plane = 0
    props.kifs_scale, props.kifs_offset, props.kifs_rotation = scale, offset, (0.0, 0.0, 0.0)
    props.kifs_shape, props.kifs_size, props.max_iterations = final, 1.0, iterations


def set_hybrid_steps(props, steps):
    props.hybrid_steps.clear()
    for formula, count in steps:
        e = props.hybrid_steps.add()
        e.formula, e.count = formula, count
    props.hybrid_active_step = 0


ALIGN_ITEMS = [
    ('WORLD', "World", "Align the new object to the world"),
    ('VIEW', "View", "Align the new object to the view"),
    ('CURSOR', "3D Cursor", "Use the 3D cursor orientation for the new object"),
]
# Labels of mu's components in the redo panel, as the Object Data tab shows them.
MU_LABELS = ("Mu 1", "i", "j", "k")


class UNBOUND_OT_fractal_add(bpy.types.Operator):
    """Add an Unbound fractal object: an empty whose sphere shows the set's bounding sphere"""
    bl_idname = "object.unbound_fractal_add"
    bl_label = "Add Unbound Fractal"
    bl_options = {'REGISTER', 'UNDO'}

    kind: bpy.props.EnumProperty(name="Kind", description="Family of fractal", items=FRACTAL_KINDS,
                                 default='QUATERNION_JULIA')
    mu: bpy.props.FloatVectorProperty(name="Mu", description="Constant mu of z^2 + mu (1, i, j, k)", size=4,
                                      default=(-0.2, 0.8, 0.0, 0.0), soft_min=-2.0, soft_max=2.0, step=MU_STEP,
                                      precision=4)
    align: bpy.props.EnumProperty(name="Align", description="The alignment of the new object", items=ALIGN_ITEMS,
                                  default='WORLD')
    location: bpy.props.FloatVectorProperty(name="Location", description="Where to place the fractal",
                                            subtype='TRANSLATION', size=3)
    rotation: bpy.props.FloatVectorProperty(name="Rotation", description="Rotation of the fractal",
                                            subtype='EULER', size=3)
    use_cursor: bpy.props.BoolProperty(name="At 3D Cursor", description="Place the fractal at the 3D cursor",
                                       default=True, options={'SKIP_SAVE'})
    frame_camera: bpy.props.BoolProperty(name="Frame in Camera", description="Scale the fractal where it is "
                                         "added so that its bounding sphere fills the active camera's view "
                                         "(from the Add menu: on when the scene has a camera)", default=False,
                                         options={'SKIP_SAVE'})
    turn_to_fit: bpy.props.BoolProperty(name="Turn to Fit", description="With Frame in Camera: turn a set "
                                        "that stands across the frame's long side a quarter about the view "
                                        "axis, so that it fills the frame lying down (on from the Add menu)",
                                        default=False, options={'SKIP_SAVE'})
    first_look: bpy.props.BoolProperty(name="First Look", description="Colour the fractal by orbit trap with a "
                                       "new colour ramp and, in a scene whose Unbound look is untouched, light "
                                       "it softly (ambient occlusion, sky, soft shadows, 4 samples; Render tab "
                                       "> Unbound > look presets to change it). On from the Add menu",
                                       default=False, options={'SKIP_SAVE'})

    def invoke(self, context, event):
        # From the Add menu: a fractal is drawn and rendered only by Unbound, so make it the
        # scene's engine (scripts calling the operator keep theirs).
        if context.scene.render.engine != utils.ENGINE_ID:
            context.scene.render.engine = utils.ENGINE_ID
            self.report({'INFO'}, "Render engine set to Unbound: only Unbound draws and renders fractals")
        if not self.properties.is_property_set("rotation") and not self.properties.is_property_set("align"):
            self.align = context.preferences.edit.object_align
        for key, value in menu_options(context).items():
            if not self.properties.is_property_set(key):
                setattr(self, key, value)
        return self.execute(context)

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        layout.prop(self, "kind")
        if self.kind == 'QUATERNION_JULIA':
            col = layout.column(align=True)
            for i, text in enumerate(MU_LABELS):
                col.prop(self, "mu", index=i, text=text)
        layout.separator()
        layout.prop(self, "align")
        layout.prop(self, "use_cursor")
        col = layout.column()
        col.enabled = not self.use_cursor
        col.prop(self, "location")
        layout.column().prop(self, "rotation")
        layout.separator()
        layout.prop(self, "frame_camera")
        row = layout.row()
        row.enabled = self.frame_camera
        row.prop(self, "turn_to_fit")
        layout.prop(self, "first_look")

    def rotation_matrix(self, context):
        """As Blender's primitives: the Rotation after the alignment's own (the view's rotation
        or the cursor's, written back into Rotation so that the redo panel shows it)."""
        if self.align == 'VIEW':
            rv3d = getattr(context, "region_data", None) or getattr(context.space_data, "region_3d", None)
            if rv3d is not None:
                self.rotation = rv3d.view_matrix.to_3x3().inverted().to_euler()
        elif self.align == 'CURSOR':
            self.rotation = context.scene.cursor.matrix.to_3x3().to_euler()
        return Euler(self.rotation, 'XYZ')

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
        elif self.kind == 'KIFS':
            set_kifs_shape(props, 'MENGER')
        elif self.kind == 'HYBRID':
            # A Mandelbulb step, then a Mandelbox step at the Mandelbox's Add size (below).
            set_hybrid_steps(props, [('MANDELBULB', 1), ('MANDELBOX', 1)])
            set_kifs_shape(props, 'SIERPINSKI')
            props.max_iterations = 10
            props.box_fold, props.min_radius, props.fixed_radius = 1.0 / 6.0, 1.0 / 12.0, 1.0 / 6.0
        elif self.kind == 'MANDELBOX':
            # The set scales with the fold limit and both radii together: at scale 2 its cube spans
            # +-6 fold limits, so 1/6 makes it +-1, the other kinds' size.
            props.box_fold, props.min_radius, props.fixed_radius = 1.0 / 6.0, 1.0 / 12.0, 1.0 / 6.0
        ob.empty_display_size = display_radius(ob) or 2.0
        if self.use_cursor:
            self.location = context.scene.cursor.location
        ob.location = self.location
        ob.rotation_euler = self.rotation_matrix(context)
        collection = context.collection or context.scene.collection
        collection.objects.link(ob)
        for other in context.view_layer.objects:
            other.select_set(False)
        ob.select_set(True)
        context.view_layer.objects.active = ob
        if self.first_look:
            add_color_ramp(ob)
            if look_untouched(context.scene):
                apply_first_look(context.scene)
        if self.frame_camera:
            context.view_layer.update()
            # At the 3D cursor, as every Add does: only the scale changes (Frame in Camera, in the
            # Object Data tab, also centres it in the view).
            problem = frame_in_camera(context.scene, ob, centre=False, turn=self.turn_to_fit)
            if problem:
                self.report({'INFO'}, "Not framed in the camera: " + problem)
            _sync_display_size(ob)
        return {'FINISHED'}


class UNBOUND_OT_use_engine(bpy.types.Operator):
    """Render this scene with Unbound, the engine that draws and renders fractal objects"""
    bl_idname = "scene.unbound_use_engine"
    bl_label = "Use Unbound"
    bl_options = {'REGISTER', 'UNDO'}

    def execute(self, context):
        context.scene.render.engine = utils.ENGINE_ID
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
        return fractal_edited(context, context.object.unbound)


def add_list_item(op, props, items, active, limit, what, fields):
    """Add an item to the collection props.<items> (a copy of the active one's `fields`, else the
    defaults) and make it active; at `limit` items, report and cancel."""
    collection = getattr(props, items)
    if len(collection) >= limit:
        op.report({'ERROR'}, "%s has at most %d %s" % (what[0], limit, what[1]))
        return {'CANCELLED'}
    index = getattr(props, active)
    source = collection[index] if index < len(collection) else None
    item = collection.add()
    if source is not None:
        for field in fields:
            setattr(item, field, getattr(source, field))
    setattr(props, active, len(collection) - 1)
    return fractal_edited(bpy.context, props)


def remove_list_item(props, items, active):
    """Remove the active item of props.<items>; the next one (or the last) becomes active."""
    collection, index = getattr(props, items), getattr(props, active)
    if not 0 <= index < len(collection):
        return {'CANCELLED'}
    collection.remove(index)
    setattr(props, active, max(0, min(index, len(collection) - 1)))
    return fractal_edited(bpy.context, props)


class UNBOUND_OT_ifs_map_add(IFSOperator, bpy.types.Operator):
    """Add a map to the IFS (a copy of the active one, or a half-size map)"""
    bl_idname = "object.unbound_ifs_map_add"
    bl_label = "Add IFS Map"

    def execute(self, context):
        return add_list_item(self, context.object.unbound, "ifs_maps", "ifs_active_map", 32, ("An IFS", "maps"),
                             ("location", "rotation", "scale"))


class UNBOUND_OT_ifs_map_remove(IFSOperator, bpy.types.Operator):
    """Remove the active map from the IFS"""
    bl_idname = "object.unbound_ifs_map_remove"
    bl_label = "Remove IFS Map"

    def execute(self, context):
        return remove_list_item(context.object.unbound, "ifs_maps", "ifs_active_map")


class KIFSOperator:
    bl_options = {'REGISTER', 'UNDO'}

    @classmethod
    def poll(cls, context):
        return utils.is_fractal(context.object) and context.object.unbound.kind in {'KIFS', 'HYBRID'}


class UNBOUND_OT_kifs_shape(KIFSOperator, bpy.types.Operator):
    """Replace the KIFS's planes, scale, offset and shape with a classic shape's"""
    bl_idname = "object.unbound_kifs_shape"
    bl_label = "Load KIFS Shape"

    shape: bpy.props.EnumProperty(name="Shape", description="Set of folds to load", items=KIFS_SHAPE_ITEMS)

    def execute(self, context):
        set_kifs_shape(context.object.unbound, self.shape)
        return fractal_edited(context, context.object.unbound)


class UNBOUND_OT_kifs_plane_add(KIFSOperator, bpy.types.Operator):
    """Add a fold plane (a copy of the active one)"""
    bl_idname = "object.unbound_kifs_plane_add"
    bl_label = "Add Fold Plane"

    def execute(self, context):
        return add_list_item(self, context.object.unbound, "kifs_planes", "kifs_active_plane", 16,
                             ("A KIFS", "fold planes"), ("normal", "offset"))


class UNBOUND_OT_kifs_plane_remove(KIFSOperator, bpy.types.Operator):
    """Remove the active fold plane"""
    bl_idname = "object.unbound_kifs_plane_remove"
    bl_label = "Remove Fold Plane"

    def execute(self, context):
        return remove_list_item(context.object.unbound, "kifs_planes", "kifs_active_plane")


class HybridOperator:
    bl_options = {'REGISTER', 'UNDO'}

    @classmethod
    def poll(cls, context):
        return utils.is_fractal(context.object) and context.object.unbound.kind == 'HYBRID'


class UNBOUND_OT_hybrid_step_add(HybridOperator, bpy.types.Operator):
    """Add an entry to the hybrid (a copy of the active one)"""
    bl_idname = "object.unbound_hybrid_step_add"
    bl_label = "Add Hybrid Step"

    def execute(self, context):
        return add_list_item(self, context.object.unbound, "hybrid_steps", "hybrid_active_step", 8,
                             ("A hybrid", "entries"), ("formula", "count"))


class UNBOUND_OT_hybrid_step_remove(HybridOperator, bpy.types.Operator):
    """Remove the active entry of the hybrid"""
    bl_idname = "object.unbound_hybrid_step_remove"
    bl_label = "Remove Hybrid Step"

    def execute(self, context):
        return remove_list_item(context.object.unbound, "hybrid_steps", "hybrid_active_step")


def _output_socket(rl_node, name):
    sock = rl_node.outputs.get(name)
    return sock if sock is not None and sock.enabled else None


# Names of the compositor nodes Set Up Compositing makes: a second run replaces exactly these.
NODE_PREFIX = "Unbound "


def add_denoise(tree, rl, add):
    """A Denoise node fed by the image and the Denoising Normal and Albedo passes, as Cycles'
    compositing denoise is set up; returns its image output."""
    node = add("CompositorNodeDenoise", "Denoise", 50, 200)
    tree.links.new(rl.outputs["Image"], node.inputs["Image"])
    for name in ("Normal", "Albedo"):
        sock = _output_socket(rl, "Denoising " + name)
        if sock is not None:
            tree.links.new(sock, node.inputs[name])
    return node.outputs["Image"]


class UNBOUND_OT_setup_compositing(bpy.types.Operator):
    """Add compositor nodes for Unbound's passes beside the user's own: the image (denoised with
    Denoise) to the output (unless the tree has one), every enabled pass into a multilayer OpenEXR
    file, and a normalised depth preview in a Viewer"""
    bl_idname = "scene.unbound_setup_compositing"
    bl_label = "Set Up Compositing"
    bl_options = {'REGISTER', 'UNDO'}

    directory: bpy.props.StringProperty(name="Directory", description="Where the pass files are written",
                                        default="//unbound_passes/", subtype='DIR_PATH')
    denoise: bpy.props.BoolProperty(name="Denoise", description="Turn on the Denoising Data passes and denoise "
                                    "the image with the Denoise node (OpenImageDenoise) fed by them, as Cycles' "
                                    "denoising does; the denoised image goes to the output and the pass file",
                                    default=True)

    def execute(self, context):
        scene = context.scene
        if scene.render.engine != utils.ENGINE_ID:
            scene.render.engine = utils.ENGINE_ID
        if self.denoise:
            context.view_layer.unbound.use_pass_denoising_data = True
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
        image = rl.outputs["Image"]
        if self.denoise:
            image = add_denoise(tree, rl, add)
        if not any(n.bl_idname == output_type for n in theirs):
            final = add(output_type, "Output", 300, 200)
            tree.links.new(image, final.inputs[0] if new_api else final.inputs["Image"])

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
        if self.denoise:
            if new_api:
                fo.file_output_items.new('RGBA', "Denoised")
            else:
                fo.layer_slots.new("Denoised")
            tree.links.new(image, fo.inputs["Denoised"])
        self.report({'INFO'}, "Unbound: compositor writes %d passes to %s" % (linked, self.directory))
        return {'FINISHED'}


class UNBOUND_OT_composite_with_cycles(bpy.types.Operator):
    """Render the scene's meshes, curves and other objects Unbound does not render with Cycles, in a
    linked copy of this scene ("<scene> Cycles"), and combine them with the fractal by depth in this
    scene's compositor (Z Combine): F12 here renders both, with the fractals' shadows on the meshes.
    Run it again after adding objects directly to the Scene Collection or changing a fractal"""
    bl_idname = "scene.unbound_composite_with_cycles"
    bl_label = "Composite with Cycles"
    bl_options = {'REGISTER', 'UNDO'}

    fractal_shadows: bpy.props.BoolProperty(
        name="Fractal Shadows", default=True,
        description="Cycles renders the fractals' shadows and reflections on the meshes: in the Cycles scene "
        "only, each fractal as a mesh invisible to the camera (Convert to Mesh at Shadow Resolution), of the "
        "current frame's shape. Meshes cast no shadow on the fractal: Unbound does not trace meshes")
    shadow_resolution: bpy.props.IntProperty(
        name="Shadow Resolution", default=128, min=8, max=2048,
        description="Lattice cells across each fractal's bounding ball for its shadow mesh; time and memory "
        "grow with its square")

    def execute(self, context):
        scene = context.scene
        if scene.name.endswith(composite.SCENE_SUFFIX) and scene.render.engine == 'CYCLES':
            self.report({'ERROR'}, "Run Composite with Cycles in the Unbound scene, not in its Cycles copy")
            return {'CANCELLED'}
        if scene.render.engine != utils.ENGINE_ID:
            scene.render.engine = utils.ENGINE_ID
        view_layer = context.view_layer
        view_layer.unbound.use_pass_depth = True  # Z Combine reads both scenes' Depth
        fractals = composite.rendered_fractals(view_layer)
        try:
            copy, copy_layer = composite.cycles_scene(scene, view_layer)
            composite.build_nodes(scene, view_layer, copy, copy_layer)
            shadows = composite.make_shadow_proxies(copy, fractals if self.fractal_shadows else [],
                                                    context.evaluated_depsgraph_get(), self.shadow_resolution)
        except convert.CONVERT_ERRORS as exc:  # the core's and Blender's refusals, a fractal's bad settings
            self.report({'ERROR'}, "Unbound: %s" % exc)
            return {'CANCELLED'}
        self.report({'INFO'}, self.summary(copy, fractals, shadows, scene.frame_current))
        return {'FINISHED'}

    def summary(self, copy, fractals, shadows, frame):
        proxies = {p.as_pointer() for p in shadows}
        count = sum(1 for ob in copy.objects
                    if ob.type in composite.GEOMETRY_TYPES and ob.as_pointer() not in proxies)
        text = "Unbound: scene '%s' renders %d object%s with Cycles" % (copy.name, count, "" if count == 1 else "s")
        if shadows:
            text += " and the shadows of %d fractal%s (each a mesh of %d cells, invisible to the camera)" % (
                len(shadows), "" if len(shadows) == 1 else "s", self.shadow_resolution)
            keyframed = [ob.name for ob in fractals if composite.keyframed_shape(ob)]
            if keyframed:
                text += "; keyframed (%s): the shadow keeps frame %d's shape, run again on another frame" % (
                    ", ".join(keyframed), frame)
        elif fractals:
            text += "; no fractal shadows (Fractal Shadows off)"
        return text + "; F12 here combines them with the fractal by depth. Meshes cast no shadow on the fractal: " \
            "Unbound does not trace meshes"


def menu_add(self, context):
    self.layout.operator_menu_enum(UNBOUND_OT_fractal_add.bl_idname, "kind", text="Unbound Fractal",
                                   icon='MESH_UVSPHERE')


classes = (UNBOUND_OT_fractal_add, UNBOUND_OT_frame_camera, UNBOUND_OT_use_engine, UNBOUND_OT_setup_compositing,
           UNBOUND_OT_composite_with_cycles, UNBOUND_MT_fractal_presets,
           UNBOUND_MT_look_presets, UNBOUND_PT_fractal_presets, UNBOUND_PT_look_presets,
           UNBOUND_OT_fractal_preset_add, UNBOUND_OT_look_preset_add, UNBOUND_OT_color_ramp_add, UNBOUND_OT_ifs_shape, UNBOUND_OT_ifs_map_add,
           UNBOUND_OT_ifs_map_remove, UNBOUND_OT_kifs_shape, UNBOUND_OT_kifs_plane_add, UNBOUND_OT_kifs_plane_remove,
           UNBOUND_OT_hybrid_step_add, UNBOUND_OT_hybrid_step_remove, UNBOUND_OT_pick_zoom_anchor)


def register():
    for cls in classes:
        bpy.utils.register_class(cls)
    bpy.types.VIEW3D_MT_add.append(menu_add)


def unregister():
    bpy.types.VIEW3D_MT_add.remove(menu_add)
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
