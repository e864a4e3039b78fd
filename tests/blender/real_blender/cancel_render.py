"""Runs inside the real `blender -b` with the extension installed (see cancel_driver.py): a
1920x1080 frame with soft shadows and reflections. Prints `UNBOUND_RENDER_STARTED` when the
render begins and `UNBOUND_RENDER_RETURNED {json}` (wall-clock time, the engine's stats) when
bpy.ops.render.render returns, cancelled or not."""
import json
import sys
import time

import os

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from scene import camera_scene  # noqa: E402

MODULE = "bl_ext.user_default.unbound"
scene = camera_scene()
bpy.ops.object.unbound_fractal_add(use_cursor=False)
ob = bpy.context.object
ob.unbound.max_iterations = 60
ob.unbound.detail = 2.0
ob.unbound.reflectivity = 0.5
scene.render.engine = "UNBOUND"
scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 1920, 1080, 100
scene.unbound.shadows = 'SOFT'
scene.unbound.reflection_depth = 2
scene.unbound.use_sea = True
scene.unbound.sea_height = -1.1
scene.unbound.sea_reflectivity = 0.4


def started(*args):
    print("UNBOUND_RENDER_STARTED %.6f" % time.time(), flush=True)


bpy.app.handlers.render_init.append(started)
try:
    bpy.ops.render.render()
    outcome = "finished"
except RuntimeError as exc:
    outcome = str(exc)
returned = time.time()
engine = sys.modules.get(MODULE + ".engine")
stats = dict(engine.LAST_STATS) if engine else None
print("UNBOUND_RENDER_RETURNED " + json.dumps(dict(t=returned, outcome=outcome, stats=stats)), flush=True)
import addon_utils  # noqa: E402
addon_utils.disable(MODULE, default_set=False)
