"""Animate mu of a quaternion Julia set and render it with Unbound: a PNG of the image and a
multilayer OpenEXR of every pass (Combined, Depth, Normal, Position, Iterations, Steps,
Distance) per frame.

The same script runs unchanged in Blender and with the bpy module:

    blender --background --python examples/animate_mu.py -- [options]
    python examples/animate_mu.py [options]        # bpy from PyPI, e.g. make venv

Options (after `--` in Blender; `--` is optional with python):
    --out DIR               where png/ and exr/ go (default ./out/animate_mu)
    --frames START END      frames to render, inclusive (default 1 12: a quarter of the loop)
    --resolution W H        image size in pixels (default 640 360)
    --percentage P          resolution percentage (default 100)
    --loop N                frames per loop of mu around its path (default 48)
    --extension PATH        the extension zip to install when Unbound is not enabled
                            (default: $UNBOUND_EXTENSION, else dist/unbound-*.zip of this repository)

mu travels once around a closed loop every --loop frames, starting at frame 1, whatever frames are
rendered: any frame range, or a render farm's split of one, gives the same frames.

The extension: where Unbound is already enabled (installed and enabled in Blender's Preferences)
the script uses it. Otherwise it installs the zip into the "user_default" extension repository and
enables it, as Preferences > Install from Disk does; the installed files stay in the Blender user
folder. The bpy module starts with factory preferences, so there it always installs, into its own
user folder: ~/.config/blender/X.Y on Linux, the very folder of a Blender X.Y. To keep your
Blender's folder untouched, point BLENDER_USER_RESOURCES at another folder; bpy and Blender both
honour it (the Makefile's demo sets it to a folder under build/):

    BLENDER_USER_RESOURCES=build/blender-user python examples/animate_mu.py
"""
import argparse
import math
import os
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)  # Blender's --python does not put the script's folder on the path
# unbound_extension imports bpy first; where that fails it exits with the real error and the fix.
from unbound_extension import add_camera, ensure_extension, new_scene, script_args, set_png_format  # noqa: E402
import bpy  # noqa: E402

LOOP_FRAMES = 48      # frames per loop of mu around its path
KEYS_PER_LOOP = 8     # keyframes per loop; Bezier curves with cyclic auto handles in between
MU_CENTER = (-0.2, 0.8)  # the paper's mu = -0.2 + 0.8i ...
MU_RADIUS = 0.12         # ... circled at this radius in the complex plane
MU_K = 0.1               # ... while the k component swings by this much (changes the 3-D slice)


# -- arguments -------------------------------------------------------------------------------------

def parse_args(args):
    p = argparse.ArgumentParser(prog="animate_mu.py", description=__doc__.split("\n\n")[0])
    p.add_argument("--out", default=os.path.join("out", "animate_mu"), help="output folder")
    p.add_argument("--frames", nargs=2, type=int, default=(1, 12), metavar=("START", "END"))
    p.add_argument("--resolution", nargs=2, type=int, default=(640, 360), metavar=("W", "H"))
    p.add_argument("--percentage", type=int, default=100)
    p.add_argument("--loop", type=int, default=LOOP_FRAMES, help="frames per loop of mu")
    p.add_argument("--extension", default=os.environ.get("UNBOUND_EXTENSION"),
                   help="extension zip to install if Unbound is not enabled")
    a = p.parse_args(args)
    if a.frames[1] < a.frames[0]:
        p.error("--frames: END is before START")
    if a.loop < KEYS_PER_LOOP:
        p.error("--loop: at least %d frames" % KEYS_PER_LOOP)
    return a


# -- the scene -------------------------------------------------------------------------------------

def mu_on_path(t):
    """mu (1, i, j, k) at fraction t of the loop: a circle around the paper's -0.2 + 0.8i in the
    complex plane, with a k component that swings out and back twice per loop."""
    a = 2.0 * math.pi * t
    return (MU_CENTER[0] + MU_RADIUS * math.cos(a), MU_CENTER[1] + MU_RADIUS * math.sin(a), 0.0,
            MU_K * math.sin(2.0 * a))


def fcurves(ob):
    """The F-curves of an object's action, in 4.x (Action.fcurves) and in layered actions (5.x)."""
    action = ob.animation_data.action
    if hasattr(action, "fcurves"):
        return list(action.fcurves)
    from bpy_extras import anim_utils
    return list(anim_utils.action_get_channelbag_for_slot(action, ob.animation_data.action_slot).fcurves)


def keyframe_mu(ob, loop=LOOP_FRAMES):
    """Keyframe Object.unbound.mu around the loop: keys every loop/KEYS_PER_LOOP frames from frame 1,
    Bezier with automatic handles, repeated forever by a Cycles modifier (seamless loop)."""
    for i in range(KEYS_PER_LOOP + 1):
        ob.unbound.mu = mu_on_path((i % KEYS_PER_LOOP) / KEYS_PER_LOOP)  # last key = first
        ob.unbound.keyframe_insert("mu", frame=1.0 + loop * i / KEYS_PER_LOOP)
    for fc in fcurves(ob):
        if fc.data_path != "unbound.mu":
            continue
        for kp in fc.keyframe_points:
            kp.interpolation = 'BEZIER'
            kp.handle_left_type = kp.handle_right_type = 'AUTO'
        fc.modifiers.new('CYCLES')  # first modifier, default settings: handles are cycle-aware
        fc.update()


def build_scene(width=640, height=360, percentage=100, loop=LOOP_FRAMES):
    """A new empty scene: camera, world colour, an animated Quaternion Julia fractal, every pass.
    Returns (scene, fractal object)."""
    scene = new_scene(width, height, (0.018, 0.022, 0.035), percentage)
    scene.render.fps = 24
    add_camera(scene, (0.6, -4.4, 2.8), (0.0, 0.0, 0.0), 40.0)

    bpy.ops.object.unbound_fractal_add(mu=mu_on_path(0.0), use_cursor=False)
    ob = bpy.context.object
    ob.name = "Julia"
    ob.unbound.color = (0.85, 0.55, 0.25)
    keyframe_mu(ob, loop)

    vl = scene.view_layers[0].unbound
    for toggle in ("use_pass_depth", "use_pass_normal", "use_pass_position", "use_pass_iterations",
                   "use_pass_steps", "use_pass_distance"):
        setattr(vl, toggle, True)
    scene.frame_start, scene.frame_end = 1, loop
    scene.frame_set(1)
    return scene, ob


# -- rendering -------------------------------------------------------------------------------------

def set_format(scene, kind):
    ims = scene.render.image_settings
    if kind == 'PNG':
        set_png_format(scene)
    else:
        if bpy.app.version >= (5, 0, 0):
            ims.media_type = 'MULTI_LAYER_IMAGE'
        else:
            ims.file_format = 'OPEN_EXR_MULTILAYER'
        ims.color_depth = '32'  # full float: the passes exactly as rendered
        ims.exr_codec = 'ZIP'


def render_animation(scene, start, end, pattern, kind):
    """Render frames start..end through Blender's pipeline to pattern (#### = frame number);
    returns the files written."""
    set_format(scene, kind)
    scene.render.filepath = pattern
    scene.render.use_file_extension = True
    scene.render.use_overwrite = True
    scene.frame_start, scene.frame_end = start, end
    files = [scene.render.frame_path(frame=f) for f in range(start, end + 1)]
    for f in files:  # so that files from an earlier run cannot pass for this one's
        if os.path.isfile(f):
            os.remove(f)
    bpy.ops.render.render(animation=True)
    missing = [f for f in files if not os.path.isfile(f)]
    if missing:
        sys.exit("animate_mu: the render wrote no %s (see Blender's messages above)" % missing[0])
    return files


def main(argv=None):
    a = parse_args(script_args(argv))
    started = time.perf_counter()
    ensure_extension(a.extension, prog='animate_mu')
    scene, _ = build_scene(a.resolution[0], a.resolution[1], a.percentage, a.loop)
    out = os.path.abspath(a.out)
    start, end = a.frames
    written = []
    # Two passes over the frames, one per format (the render is deterministic, so both see the same
    # pixels); Blender adds the frame number for #### and the extension.
    for kind, sub in (('PNG', "png"), ('EXR', "exr")):
        files = render_animation(scene, start, end, os.path.join(out, sub, "frame_####"), kind)
        for f in files:
            print(f)
        written += files
    print("animate_mu: frames %d-%d (%d x %d px, mu looping every %d frames): %d files in %s, %.1f s"
          % (start, end, scene.render.resolution_x * a.percentage // 100,
             scene.render.resolution_y * a.percentage // 100, a.loop, len(written), out,
             time.perf_counter() - started))
    return written


if __name__ == "__main__":
    main()
