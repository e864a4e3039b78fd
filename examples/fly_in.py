"""Fly into the default quaternion Julia set's surface from zoom 0 to zoom 30 (issue 18, deep zoom):
a PNG per frame.

    blender --background --python examples/fly_in.py -- [options]
    python examples/fly_in.py [options]        # bpy from PyPI, e.g. make venv

Options (after `--` in Blender; `--` is optional with python):
    --out DIR               where the PNGs go (default ./out/fly_in)
    --frames N              frames of the fly-in (default 48)
    --zoom Z                the last frame's zoom (default 30)
    --resolution W H        image size in pixels (default 160 120)
    --extension PATH        the extension zip to install when Unbound is not enabled (see animate_mu.py)

The anchor is picked as a user picks it, with Pick Anchor at the centre of the camera's view: once at
zoom 0, then again every 6 decades down to the last frame's zoom, each pick refining the point the
last one found (and moving the object so that the view does not jump). Zoom is then keyframed
linearly from 0 at the first frame to Z at the last: a fly-in at constant speed in scale.
"""
import argparse
import os
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)  # Blender's --python does not put the script's folder on the path
from unbound_extension import add_camera, ensure_extension, new_scene, script_args, set_png_format  # noqa: E402
import bpy  # noqa: E402

PICK_EVERY = 6.0  # decades between picks: the last anchor is within a pixel of the surface at the next


def parse_args(args):
    p = argparse.ArgumentParser(prog="fly_in.py", description=__doc__.split("\n\n")[0])
    p.add_argument("--out", default=os.path.join("out", "fly_in"), help="output folder")
    p.add_argument("--frames", type=int, default=48)
    p.add_argument("--zoom", type=float, default=30.0)
    p.add_argument("--resolution", nargs=2, type=int, default=(160, 120), metavar=("W", "H"))
    p.add_argument("--extension", default=os.environ.get("UNBOUND_EXTENSION"),
                   help="extension zip to install if Unbound is not enabled")
    a = p.parse_args(args)
    if a.frames < 2:
        p.error("--frames: at least 2")
    if not 0.0 < a.zoom <= 60.0:
        p.error("--zoom: within (0, 60]")
    return a


def pick_anchor(ob, last_zoom):
    """Pick Anchor at the camera's centre at zoom 0, PICK_EVERY, 2 PICK_EVERY, ... and last_zoom."""
    bpy.context.view_layer.objects.active = ob
    zoom = 0.0
    while True:
        ob.unbound.zoom = zoom
        if bpy.ops.object.unbound_pick_zoom_anchor() != {'FINISHED'}:
            sys.exit("fly_in: the camera's centre misses the fractal at zoom %g" % zoom)
        if zoom >= last_zoom:
            return
        zoom = min(zoom + PICK_EVERY, last_zoom)


def build_scene(width, height, frames, last_zoom):
    scene = new_scene(width, height, (0.018, 0.022, 0.035), 100)
    add_camera(scene, (0.4, -3.0, 0.9), (0.0, 0.0, 0.0), 40.0)
    bpy.ops.object.unbound_fractal_add(use_cursor=False)
    ob = bpy.context.object
    ob.name = "Julia"
    ob.unbound.color = (0.85, 0.55, 0.25)
    pick_anchor(ob, last_zoom)
    for frame, zoom in ((1, 0.0), (frames, last_zoom)):
        ob.unbound.zoom = zoom
        ob.unbound.keyframe_insert("zoom", frame=frame)
    for fc in ob.animation_data.action.fcurves if hasattr(ob.animation_data.action, "fcurves") else []:
        for kp in fc.keyframe_points:
            kp.interpolation = 'LINEAR'  # constant speed in scale
    scene.frame_start, scene.frame_end = 1, frames
    return scene, ob


def main(argv=None):
    a = parse_args(script_args(argv))
    started = time.perf_counter()
    ensure_extension(a.extension, prog='fly_in')
    scene, ob = build_scene(a.resolution[0], a.resolution[1], a.frames, a.zoom)
    out = os.path.abspath(a.out)
    set_png_format(scene)
    scene.render.filepath = os.path.join(out, "frame_####")
    scene.render.use_file_extension = True
    bpy.ops.render.render(animation=True)
    print("fly_in: %d frames, zoom 0 -> %g, anchor %s: %s, %.1f s"
          % (a.frames, a.zoom, ob.unbound.zoom_anchor, out, time.perf_counter() - started))


if __name__ == "__main__":
    main()
