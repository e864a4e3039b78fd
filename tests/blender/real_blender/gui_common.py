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
