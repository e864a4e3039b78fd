"""Runs inside the real `blender -b` (not bpy from PyPI) with the extension installed by
`blender --command extension install-file`:  blender -b --python bg_render.py -- OUT.png
Builds a scene with a camera and a fractal made by the add-on's operator, renders a small still
with the Unbound engine and writes it to OUT.png. Prints one line `UNBOUND_RESULT {json}`."""
import json
import sys
import time

import os

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from scene import camera_scene  # noqa: E402

MODULE = "bl_ext.user_default.unbound"
out = sys.argv[sys.argv.index("--") + 1]
result = {"blender": bpy.app.version_string, "python": sys.version.split()[0],
          "addon_enabled": MODULE in bpy.context.preferences.addons}

scene = camera_scene()
result["add_op"] = sorted(bpy.ops.object.unbound_fractal_add(use_cursor=False))
result["fractal"] = bpy.context.object.name if bpy.context.object else None

scene.render.engine = "UNBOUND"
result["engine"] = scene.render.engine
scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 96, 72, 100
scene.render.film_transparent = True
scene.render.image_settings.file_format = 'PNG'
scene.render.image_settings.color_mode = 'RGBA'
scene.render.filepath = out
t = time.time()
result["render_op"] = sorted(bpy.ops.render.render(write_still=True))
result["render_s"] = round(time.time() - t, 3)
engine = sys.modules.get(MODULE + ".engine")
result["stats"] = dict(engine.LAST_STATS) if engine else None

# Disable before exit, as tests/blender/bpy_session.py does (a registered engine at exit has
# crashed or hung some Blender builds).
import addon_utils  # noqa: E402
addon_utils.disable(MODULE, default_set=False)
print("UNBOUND_RESULT " + json.dumps(result), flush=True)
