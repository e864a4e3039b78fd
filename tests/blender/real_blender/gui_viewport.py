"""Runs inside the real Blender GUI (under Xvfb, see tools/blender_gui.sh) with the extension
installed and enabled in the user preferences:
    blender -p 0 0 W H --python gui_viewport.py -- OUTDIR
From timers: adds a fractal, shows its parameters on the Properties editor's Object Data tab, switches
the 3D viewport to Rendered shading with the Unbound engine, and waits for the refinement to end.
Then, in turn: the same view without overlays (its screenshot is compared with the frame passed
through Blender's own colour management), a changed mu, the camera view with a render border
(and the camera's depth of field), and an orthographic view. For each it checks that the viewport's request is the one built from
the region's view, and that the final frame equals a direct render of that request, bit for bit.
Prints `UNBOUND_GUI {json}` lines; screenshots are grabbed from the X screen with ffmpeg."""
import os
import sys
import time

import bpy
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from gui_common import MODULE, OUT, area, fractal_scene, grab, log, region, watch_panels, window  # noqa: E402

DRAWN = set()


def mod(name):
    return sys.modules[MODULE + "." + name]


def session():
    live = list(mod("viewport").SESSIONS)
    return live[0] if len(live) == 1 else None


def check_view(label):
    """The viewport's request equals the one built here from the region's view; its final frame
    equals a direct render of it."""
    viewport = mod("viewport")
    s = session()
    frame = s.frame()
    view3d = area('VIEW_3D')
    win_region = region(view3d)
    with bpy.context.temp_override(window=window(), area=view3d, region=win_region,
                                   space_data=view3d.spaces.active):
        dg = bpy.context.evaluated_depsgraph_get()
        req = viewport.request(viewport.scene_part(dg), viewport.view_part(bpy.context, dg))
    x, y, w, h = req.window
    core = mod("utils").native()
    expected = np.zeros((h, w, 4), np.float32)
    core.render(req.camera, req.objects, {"combined": expected}, window=req.window, background=req.background,
                shading=req.shading, world=req.world.texels if req.world is not None else None)
    levels = [[d, n] for g, d, n, _, _ in s.log if g == frame.generation]
    first = next(e[3] for e in s.log if e[0] == frame.generation)
    log(step=label, aperture=req.camera.get("aperture_size", 0.0), same_request=req == s._request, drawn=list(s.drawn), final=frame.final, error=frame.error, window=list(req.window),
        region=[win_region.x, win_region.y, win_region.width, win_region.height],
        identical=bool(frame.pixels is not None and np.array_equal(frame.pixels, expected)),
        levels=levels, generation=frame.generation, first_image_s=first, full_s=frame.elapsed,
        coverage=float((expected[..., 3] > 0).mean()), panels=sorted(DRAWN))
    return frame


def save_reference(frame, name):
    """The frame through Blender's own colour management (the scene's view transform), as a PNG."""
    rows, cols = frame.pixels.shape[:2]
    img = bpy.data.images.new("reference", cols, rows, alpha=True, float_buffer=True)
    img.pixels.foreach_set(frame.pixels.ravel())
    img.save_render(os.path.join(OUT, name), scene=bpy.context.scene)
    bpy.data.images.remove(img)


def setup():
    watch_panels(DRAWN)
    res, ob, scene = fractal_scene()
    view3d = area('VIEW_3D')
    scene.render.dither_intensity = 0.0  # screenshots compared with Blender's own colour management
    scene.unbound.viewport_start_divisor = '8'
    props = area('PROPERTIES')
    props.spaces.active.context = 'DATA'
    space = view3d.spaces.active
    rv3d = space.region_3d
    rv3d.view_location = (0.0, 0.0, 0.0)
    rv3d.view_distance = 6.0
    space.shading.type = 'RENDERED'
    DRAWN.clear()
    props.tag_redraw()
    view3d.tag_redraw()
    log(step="setup", add_op=sorted(res), engine=scene.render.engine, is_fractal=ob.unbound.is_fractal,
        shading=space.shading.type, view_transform=scene.view_settings.view_transform)


def guarded(step):
    """A failing step reports and quits: a hanging GUI would only hit the timeout."""
    def run():
        try:
            step()
        except Exception as exc:
            import traceback
            traceback.print_exc()
            log(error=repr(exc))
            quit_blender()
    return run


def wait_final(then, timeout=90.0):
    """Calls then() once the viewport's refinement of the latest change has ended."""
    start = time.time()

    def poll():
        s = session()
        f = s.frame() if s else None
        # Final, and drawn on screen (view_draw uploaded it), then one more redraw's time.
        if f is not None and f.final and f.generation == s._generation and s.drawn and s.drawn[0] == f.sequence:
            bpy.app.timers.register(then, first_interval=0.3)
            return None
        if time.time() - start > timeout:
            log(error="the viewport did not finish refining", frame=None if f is None else [f.divisor, f.final])
            quit_blender()
            return None
        return 0.25
    bpy.app.timers.register(poll, first_interval=0.5)


@guarded
def rendered_view():
    check_view("rendered")
    log(shot="viewport_rendered.png", rc=grab("viewport_rendered.png")[0], panels=sorted(DRAWN))
    space = area('VIEW_3D').spaces.active
    space.overlay.show_overlays = False
    space.show_gizmo = False
    space.show_region_toolbar = space.show_region_header = space.show_region_ui = False
    space.show_region_tool_header = False
    area('VIEW_3D').tag_redraw()
    bpy.app.timers.register(no_overlays, first_interval=1.5)


@guarded
def no_overlays():
    frame = check_view("no_overlays")
    save_reference(frame, "viewport_reference.png")
    log(shot="viewport_no_overlays.png", rc=grab("viewport_no_overlays.png")[0])
    ob = bpy.context.view_layer.objects.active
    ob.unbound.mu[1] = 0.6  # as a script sets it: no depsgraph tag, only a redraw
    area('VIEW_3D').tag_redraw()
    wait_final(changed_mu)


@guarded
def changed_mu():
    check_view("changed_mu")
    scene = bpy.context.scene
    scene.render.use_border = True
    scene.render.border_min_x, scene.render.border_max_x = 0.2, 0.7
    scene.render.border_min_y, scene.render.border_max_y = 0.25, 0.8
    space = area('VIEW_3D').spaces.active
    space.overlay.show_overlays = True
    dof = scene.camera.data.dof  # looking through the camera shows its depth of field, as in Cycles
    dof.use_dof, dof.focus_distance, dof.aperture_fstop = True, 2.0, 0.5
    space.region_3d.view_perspective = 'CAMERA'
    area('VIEW_3D').tag_redraw()
    wait_final(camera_border)


@guarded
def camera_border():
    view3d = area('VIEW_3D')
    with bpy.context.temp_override(window=window(), area=view3d, region=region(view3d)):
        frame_rect = mod("viewport").camera_frame(bpy.context.scene, region(view3d), view3d.spaces.active.region_3d,
                                                  bpy.context.scene.camera)
    log(step="camera_frame", rect=list(frame_rect), aperture=bpy.context.scene.camera.data.lens * 1e-3 / (2 * 0.5))
    check_view("camera_border")
    log(shot="viewport_camera_border.png", rc=grab("viewport_camera_border.png")[0])
    bpy.context.scene.render.use_border = False
    rv3d = view3d.spaces.active.region_3d
    rv3d.view_perspective = 'ORTHO'
    rv3d.view_distance = 6.0
    view3d.tag_redraw()
    wait_final(ortho)


@guarded
def ortho():
    check_view("ortho")
    log(shot="viewport_ortho.png", rc=grab("viewport_ortho.png")[0])
    quit_blender()


def quit_blender():
    log(step="quit")
    import addon_utils
    area('VIEW_3D').spaces.active.shading.type = 'SOLID'
    addon_utils.disable(MODULE, default_set=False)
    with bpy.context.temp_override(window=window()):
        bpy.ops.wm.quit_blender()


@guarded
def start():
    setup()
    wait_final(rendered_view)


bpy.app.timers.register(start, first_interval=1.0)
