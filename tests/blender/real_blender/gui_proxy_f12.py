"""Runs inside the real Blender GUI (under Xvfb, see tools/blender_gui.sh) with the extension
installed and enabled in the user preferences:
    blender -p 0 0 W H --python gui_proxy_f12.py -- OUTDIR
One Blender session for two checks of issue 17 (each GUI start costs CPU), F12 first (before
Material Preview and Rendered shading start background work that would slow it down):

1. The proxy (addon/proxy.py) in Solid shading: a fractal with mu = 0 (the unit ball) in a front
   orthographic view, with a small cube between it and the eye. Screenshots with the proxy off and
   on (and of the Julia set mu = -0.2+0.8i, and in Wireframe shading); the projected ball and cube
   in region pixels are logged for the test to compare with. Material Preview and Rendered shading:
   how many fractals the draw handler drew there.
2. F12: a 12-sample render started with INVOKE_DEFAULT in the render window (View > Render,
   opened first: its Image Editor shows the render) with every sample uploaded
   (engine.UPDATE_SHARE = 1), filmed by ffmpeg from before F12 until after its end; then the
   Render Result, and the same render once more, blocking, for reference.

Prints `UNBOUND_GUI {json}` lines; screenshots are grabbed from the X screen with ffmpeg."""
import hashlib
import math
import os
import sys
import tempfile
import time

import bpy
import numpy as np
from bpy_extras.view3d_utils import location_3d_to_region_2d
from mathutils import Euler

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import gui_common  # noqa: E402
from gui_common import MODULE, OUT, after, area, fractal_scene, grab, guarded, log, region, window  # noqa: E402

F12_SAMPLES = 192  # about 4 s with one thread on a fast host: Blender refreshes the window about every
#                    half second. (24 took 3 s before the core got 2.5x faster, then 1.1-1.5 s; 64 took
#                    0.85-1.13 s on a Xeon of 2026-12-05, where one run showed only one picture.)
SCRATCH = tempfile.mkdtemp()


def mod(name):
    return sys.modules[MODULE + "." + name]


def fractal():
    return next(o for o in bpy.data.objects if o.type == 'EMPTY' and o.unbound.is_fractal)


def redraw():
    area('VIEW_3D').tag_redraw()


def when_proxy_drawn(then, timeout=60.0):
    """then() once the proxy's newest surface is built and the draw handler drew it twice."""
    P = mod("proxy")
    start, marks = time.time(), {}

    def poll():
        latest = P.BUILDER.latest(P.object_id(fractal()))
        if latest is not None and latest.done and not P.BUILDER.busy():
            marks.setdefault("drawn", P.DRAW_STATS["objects"])
            if P.DRAW_STATS["objects"] >= marks["drawn"] + 2:
                after(0.2, then)
                return None
        if time.time() - start > timeout:
            log(error="the proxy was not drawn within %.0f s" % timeout, stats=dict(P.DRAW_STATS))
            quit_blender()
            return None
        redraw()
        return 0.1
    bpy.app.timers.register(guarded(poll), first_interval=0.1)


def projection():
    """The unit ball's centre and radius and the cube's rectangle in region pixels, the region's
    rectangle in the window (bottom-left origin)."""
    view3d = area('VIEW_3D')
    reg, rv3d = region(view3d), view3d.spaces.active.region_3d
    centre = location_3d_to_region_2d(reg, rv3d, (0.0, 0.0, 0.0))
    right = location_3d_to_region_2d(reg, rv3d, (1.0, 0.0, 0.0))
    up = location_3d_to_region_2d(reg, rv3d, (0.0, 0.0, 1.0))
    cube = bpy.data.objects["Occluder"]
    corners = [location_3d_to_region_2d(reg, rv3d, cube.matrix_world @ v.co) for v in cube.data.vertices]
    return dict(region=[reg.x, reg.y, reg.width, reg.height], centre=list(centre),
                radius=[right.x - centre.x, up.y - centre.y],
                cube=[min(c.x for c in corners), min(c.y for c in corners), max(c.x for c in corners),
                      max(c.y for c in corners)])


# 1. The proxy ---------------------------------------------------------------------------------

def setup():
    res, ob, scene = F12["add"], fractal(), bpy.context.scene
    ob.unbound.mu = (0.0, 0.0, 0.0, 0.0)
    ob.unbound.proxy_resolution = 48
    ob.unbound.show_proxy = False
    ob.location = (0.0, 0.0, 0.0)
    mesh = bpy.data.meshes.new("Occluder")
    s = 0.2   # a cube of half-width 0.2 at y = -2, in front of the ball (the view looks along +y)
    mesh.from_pydata([(x, y, z) for x in (-s, s) for y in (-s, s) for z in (-s, s)], [],
                     [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)])
    cube = bpy.data.objects.new("Occluder", mesh)
    cube.location = (0.4, -2.0, 0.3)
    scene.collection.objects.link(cube)
    space = area('VIEW_3D').spaces.active
    space.shading.type = 'SOLID'
    space.show_gizmo = False
    rv3d = space.region_3d
    rv3d.view_perspective = 'ORTHO'
    rv3d.view_rotation = Euler((math.pi / 2, 0.0, 0.0)).to_quaternion()   # Front: looking along +y
    rv3d.view_location = (0.0, 0.0, 0.0)
    rv3d.view_distance = 3.0
    redraw()
    log(step="setup", add_op=sorted(res), engine=scene.render.engine, is_fractal=ob.unbound.is_fractal,
        shading=space.shading.type)
    after(1.5, proxy_off)


def proxy_off():
    log(shot="proxy_off.png", rc=grab("proxy_off.png")[0], step="proxy_off", **projection())
    fractal().unbound.show_proxy = True
    redraw()
    when_proxy_drawn(proxy_on)


def proxy_on():
    P = mod("proxy")
    ob = fractal()
    job = P.BUILDER.ready(P.object_id(ob))
    log(shot="proxy_solid.png", rc=grab("proxy_solid.png")[0], step="proxy_solid", stats=dict(P.DRAW_STATS),
        faces=len(job.surface.faces), cell=job.surface.cell_size, seconds=job.surface.seconds,
        shader_ok=bool(P._shader), **projection())
    ob.unbound.mu = (-0.2, 0.8, 0.0, 0.0)
    redraw()
    when_proxy_drawn(julia)


def julia():
    log(shot="proxy_julia.png", rc=grab("proxy_julia.png")[0], step="proxy_julia")
    fractal().unbound.mu = (0.0, 0.0, 0.0, 0.0)
    area('VIEW_3D').spaces.active.shading.type = 'WIREFRAME'
    redraw()
    when_proxy_drawn(wireframe)


def wireframe():
    log(shot="proxy_wire.png", rc=grab("proxy_wire.png")[0], step="proxy_wire")
    fractal().unbound.show_proxy = False
    redraw()
    after(1.0, wireframe_off)


def wireframe_off():
    log(shot="proxy_wire_off.png", rc=grab("proxy_wire_off.png")[0], step="proxy_wire_off")
    fractal().unbound.show_proxy = True
    P = mod("proxy")
    before = dict(P.DRAW_STATS)
    area('VIEW_3D').spaces.active.shading.type = 'MATERIAL'
    start = time.time()

    def poll():
        if P.DRAW_STATS["objects"] >= before.get("objects", 0) + 2 or time.time() - start > 20:
            log(step="material", drawn=P.DRAW_STATS["objects"] - before.get("objects", 0),
                draws=P.DRAW_STATS["MATERIAL"] - before.get("MATERIAL", 0), waited=time.time() - start)
            after(0.3, material_shot)
            return None
        redraw()
        return 0.2
    bpy.app.timers.register(guarded(poll), first_interval=0.2)


def material_shot():
    log(shot="proxy_material.png", rc=grab("proxy_material.png")[0])
    P = mod("proxy")
    before = P.DRAW_STATS["objects"]
    area('VIEW_3D').spaces.active.shading.type = 'RENDERED'
    redraw()

    def rendered():
        sessions = list(mod("viewport").SESSIONS)
        log(step="rendered", drawn=P.DRAW_STATS["objects"] - before, sessions=len(sessions),
            frames=len(sessions[0].log) if sessions else 0)
        quit_blender()
    after(1.5, rendered)


# 2. F12 ----------------------------------------------------------------------------------------
# What the render window shows is filmed from outside Blender: ffmpeg grabs it FPS times a second
# into OUT/f12_frames/ from before F12 until after its end. (Blender's own timers are no clock for
# this: on the 2 shared cores a main-loop timer did not fire for seconds of a render.)

F12 = dict(complete=None, started=None)
FPS = 5
FRAMES = "f12_frames"


def result_pixels():
    """The Render Result as float RGBA (rows, columns, 4) through save_render (its .pixels are
    empty: a render result has no buffer of its own)."""
    img = bpy.data.images["Render Result"]
    path = os.path.join(SCRATCH, "result.exr")
    img.save_render(path, scene=bpy.context.scene)
    loaded = bpy.data.images.load(path, check_existing=False)
    try:
        w, h = loaded.size
        px = np.empty(w * h * 4, np.float32)
        loaded.pixels.foreach_get(px)
    finally:
        bpy.data.images.remove(loaded)
    return px.reshape(h, w, 4)


def describe(px):
    return dict(digest=hashlib.sha1(px.tobytes()).hexdigest()[:16], coverage=float((px[..., 3] > 0).mean()))


def f12_start():
    scene = bpy.context.scene
    r = scene.render
    r.resolution_x, r.resolution_y, r.resolution_percentage = 640, 480, 100
    # One render thread: a core stays free for Blender's window and the X server to draw what the
    # render shows (with every core rendering on a busy machine the window missed the samples),
    # and the render lasts long enough to be filmed on a fast one.
    r.threads_mode, r.threads = 'FIXED', 1
    r.film_transparent = True   # alpha marks the fractal's pixels
    r.image_settings.file_format = 'OPEN_EXR'
    r.image_settings.color_depth = '32'
    scene.view_settings.view_transform = 'Standard'
    u = scene.unbound
    u.samples = F12_SAMPLES
    u.shadows = 'SOFT'
    u.ao_strength = 0.5
    u.ao_samples = 8
    u.ambient = (0.1, 0.1, 0.1)
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", 'SUN'))
    sun.data.angle = 0.3
    sun.rotation_euler = (0.6, 0.3, 0.4)
    scene.collection.objects.link(sun)
    fractal().unbound.mu = (-0.2, 0.8, 0.0, 0.0)
    mod("engine").UPDATE_SHARE = 1.0   # every sample uploaded: the test does not depend on the machine's speed
    # The render window first (View > Render): F12 then renders into it.
    with bpy.context.temp_override(window=window()):
        bpy.ops.render.view_show('INVOKE_DEFAULT')
    after(2.0, f12_render)


def film(win, seconds):
    """ffmpeg grabbing window `win` (Blender's x, y: bottom-left origin) FPS times a second."""
    import subprocess
    screen_h = window().height   # the main window fills the screen
    top = screen_h - (win.y + win.height)
    os.makedirs(os.path.join(OUT, FRAMES), exist_ok=True)
    for old in os.listdir(os.path.join(OUT, FRAMES)):
        os.unlink(os.path.join(OUT, FRAMES, old))
    return subprocess.Popen(["ffmpeg", "-hide_banner", "-loglevel", "error", "-y", "-f", "x11grab", "-draw_mouse", "0",
                             "-framerate", str(FPS), "-video_size", "%dx%d" % (win.width, win.height),
                             "-t", str(seconds), "-i", "%s+%d,%d" % (os.environ["DISPLAY"], win.x, top),
                             "-fps_mode", "passthrough", os.path.join(OUT, FRAMES, "%03d.png")],
                            stdin=subprocess.PIPE)


def f12_render():
    wm = bpy.context.window_manager
    win = wm.windows[len(wm.windows) - 1]
    F12["window"] = [win.x, win.y, win.width, win.height]
    F12["ffmpeg"] = film(win, 60)   # stopped with "q" after the render
    F12["filming"] = time.time()
    after(1.0, f12_invoke)   # ffmpeg's first frames: the empty render window


def f12_invoke():
    bpy.app.handlers.render_complete.append(on_complete)
    F12["started"] = time.time()
    with bpy.context.temp_override(window=window()):
        op = bpy.ops.render.render('INVOKE_DEFAULT')
    log(step="f12_invoked", op=sorted(op), windows=len(bpy.context.window_manager.windows),
        returned_after=time.time() - F12["started"])
    bpy.app.timers.register(guarded(wait_render), first_interval=0.1)


@bpy.app.handlers.persistent
def on_complete(*_args):
    F12["complete"] = time.time()


def wait_render():
    if bpy.app.is_job_running('RENDER') or F12["complete"] is None:
        if time.time() - F12["started"] > 60:
            log(error="the F12 render did not end within 60 s")
            quit_blender()
            return None
        return 0.1
    after(1.0, f12_done)
    return None


def f12_done():
    F12["ffmpeg"].communicate(b"q", timeout=30)   # ffmpeg's own key to stop, writing what it has
    shown = describe(result_pixels())
    bpy.app.handlers.render_complete.remove(on_complete)
    stats = dict(mod("engine").LAST_STATS)
    # The same render again, blocking (no window): what a finished render is.
    t0 = time.time()
    op = bpy.ops.render.render()
    reference = describe(result_pixels())
    log(step="f12", window=F12["window"], fps=FPS, frames=FRAMES, filming_to_start=F12["started"] - F12["filming"],
        render_seconds=F12["complete"] - F12["started"], shown_after_end=shown, reference=reference,
        reference_op=sorted(op), reference_seconds=time.time() - t0, ffmpeg_rc=F12["ffmpeg"].returncode,
        samples_done=stats.get("samples_done"), cancelled=stats.get("cancelled"), sample_count=F12_SAMPLES)
    log(shot="f12_window.png", rc=grab("f12_window.png")[0])
    # The render window goes (it lies over the 3D view), then the proxy's part.
    render_window = bpy.context.window_manager.windows[-1]
    with bpy.context.temp_override(window=render_window):
        bpy.ops.wm.window_close()
    after(1.0, setup)


def quit_blender():
    area('VIEW_3D').spaces.active.shading.type = 'SOLID'   # the proxy's draw handler off first
    gui_common.quit_blender()


def start():
    F12["add"], _, _ = fractal_scene()
    f12_start()


after(1.0, start)
