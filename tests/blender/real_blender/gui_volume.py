"""Runs inside the real Blender GUI (under Xvfb, see tools/blender_gui.sh) with the extension
installed and enabled:  blender -p 0 0 W H --python gui_volume.py -- OUTDIR
Convert to Volume as a user meets it, from timers: the unit ball converted from the 3D viewport
(the .blend saved in OUTDIR first, so the .vdb goes beside it), then Edit > Undo and Redo through
Blender's undo stack (which background bpy has not); screenshots of the volume in Solid and in
Rendered shading by EEVEE, and of the Object > Convert menu. Prints `UNBOUND_GUI {json}`."""
import os
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from gui_common import MODULE, OUT, area, fractal_scene, grab, log, region, window  # noqa: E402


def state():
    active = bpy.context.view_layer.objects.active
    return dict(active=active.name if active else None, active_type=active.type if active else None,
                volumes=len(bpy.data.volumes), objects=sorted(o.name for o in bpy.data.objects),
                meshes=len(bpy.data.meshes), node_groups=len(bpy.data.node_groups))


def view3d_override():
    view3d = area('VIEW_3D')
    return bpy.context.temp_override(window=window(), area=view3d, region=region(view3d))


def convert():
    res, ob, scene = fractal_scene()
    ob.unbound.mu = (0.0, 0.0, 0.0, 0.0)
    folder = os.path.join(OUT, "volume")
    os.makedirs(folder, exist_ok=True)
    blend = os.path.join(folder, "volume.blend")
    for name in os.listdir(folder):
        os.remove(os.path.join(folder, name))
    bpy.ops.wm.save_as_mainfile(filepath=blend)
    before = state()
    with view3d_override():
        bpy.ops.ed.undo_push(message="Unit ball")  # the state undo returns to (set up by script, not by operators)
        # undo=True: an undo step as from a menu (bpy.ops pushes none by default)
        op = bpy.ops.object.unbound_convert_to_volume('EXEC_DEFAULT', True, resolution=64)
    after = state()
    new = bpy.context.view_layer.objects.active
    log(step="convert", add_op=sorted(res), op=sorted(op), before=before, after=after, filepath=new.data.filepath,
        file_exists=os.path.isfile(bpy.path.abspath(new.data.filepath)))


def undo_redo():
    with bpy.context.temp_override(window=window()):
        undo = bpy.ops.ed.undo()
        undone = state()
        redo = bpy.ops.ed.redo()
    log(step="undo", undo=sorted(undo), undone=undone, redo=sorted(redo), redone=state())


def shading(kind, shot, engine=None, wait=4.0):
    def step():
        view3d = area('VIEW_3D')
        view3d.spaces.active.shading.type = kind
        if engine:
            bpy.context.scene.render.engine = engine
        fractal = next(o for o in bpy.data.objects if getattr(o, "unbound", None) and o.unbound.is_fractal)
        fractal.hide_set(True)  # the volume alone
        r3d = view3d.spaces.active.region_3d
        r3d.view_location, r3d.view_distance = (0.0, 0.0, 0.0), 6.0
        view3d.tag_redraw()
        bpy.app.timers.register(lambda: log(shot=shot, grab=grab(shot)) and None, first_interval=wait)
    return step


def menu():
    with view3d_override():
        bpy.ops.wm.call_menu(name="VIEW3D_MT_object_convert")
    bpy.app.timers.register(lambda: log(shot="volume_convert_menu.png", grab=grab("volume_convert_menu.png"))
                            and None, first_interval=1.5)


def quit_blender():
    log(step="quit")
    import addon_utils
    addon_utils.disable(MODULE, default_set=False)
    with bpy.context.temp_override(window=window()):
        bpy.ops.wm.quit_blender()


STEPS = [convert, undo_redo, shading('SOLID', "volume_solid.png"), shading('RENDERED', "volume_eevee.png",
                                                                            "BLENDER_EEVEE_NEXT", wait=25.0),
         menu]


def run_steps():
    if not STEPS:
        quit_blender()
        return None
    step = STEPS.pop(0)
    try:
        step()
    except Exception as exc:  # report, then quit: a hanging GUI would only hit the timeout
        import traceback
        traceback.print_exc()
        log(error=repr(exc))
        STEPS[:] = []
        quit_blender()
        return None
    return 6.0 if STEPS[:1] != [menu] else 30.0


bpy.app.timers.register(run_steps, first_interval=1.0)
