"""Shared by the GUI scripts (gui_panels.py, gui_viewport.py), which Blender runs with
`--python SCRIPT -- OUTDIR`: the output folder, `UNBOUND_GUI {json}` log lines, the window's
areas and regions, and X screen grabs (bpy.ops.screen.screenshot is black on Mesa's software GL)."""
import json
import os
import subprocess
import sys
import time

import bpy

OUT = sys.argv[sys.argv.index("--") + 1]
MODULE = "bl_ext.user_default.unbound"
T0 = time.time()
bpy.context.preferences.view.show_splash = False   # --python runs before the splash opens
bpy.context.preferences.use_preferences_save = False  # no auto-save of the test's prefs at quit


def log(**values):
    values["t"] = round(time.time() - T0, 2)
    print("UNBOUND_GUI " + json.dumps(values), flush=True)


def window():
    return bpy.context.window_manager.windows[0]


def area(kind):
    return max((a for a in window().screen.areas if a.type == kind), key=lambda a: a.width * a.height)


def region(a, kind='WINDOW'):
    return next(r for r in a.regions if r.type == kind)


def grab(name):
    """The X screen as OUT/name; ffmpeg's status and the end of its error output."""
    cp = subprocess.run(["ffmpeg", "-loglevel", "error", "-y", "-f", "x11grab", "-draw_mouse", "0",
                         "-i", os.environ["DISPLAY"], "-frames:v", "1", os.path.join(OUT, name)],
                        capture_output=True, text=True)
    return cp.returncode, cp.stderr.strip()[-300:]


def watch_panels(drawn):
    """Record in the set `drawn` which of the add-on's panels Blender draws: an extra draw
    function appended to each (it draws nothing). (Replacing Panel.draw after registration
    crashes 4.3.)"""
    for cls in sys.modules[MODULE + ".ui"].classes:
        if issubclass(cls, bpy.types.Panel):
            cls.append(lambda self, context, _name=cls.__name__: drawn.add(_name))


def fractal_scene():
    """The startup scene with its cube replaced by a fractal (the add-on's operator, in the 3D
    viewport), selected and active, rendered by Unbound: (operator result, object, scene)."""
    view3d = area('VIEW_3D')
    with bpy.context.temp_override(window=window(), area=view3d, region=region(view3d)):
        for ob in list(bpy.context.scene.objects):
            if ob.type == 'MESH':
                bpy.data.objects.remove(ob)
        res = bpy.ops.object.unbound_fractal_add()
    ob = bpy.context.view_layer.objects.active
    ob.select_set(True)
    scene = bpy.context.scene
    scene.render.engine = 'UNBOUND'
    return res, ob, scene


def quit_blender():
    log(step="quit")
    import addon_utils
    addon_utils.disable(MODULE, default_set=False)
    with bpy.context.temp_override(window=window()):
        bpy.ops.wm.quit_blender()


def guarded(step):
    """A failing step reports and quits: a hanging GUI would only hit the timeout."""
    def run():
        try:
            return step()
        except Exception as exc:
            import traceback
            traceback.print_exc()
            log(error=repr(exc))
            quit_blender()
            return None
    return run


def after(seconds, step):
    bpy.app.timers.register(guarded(step), first_interval=seconds)
