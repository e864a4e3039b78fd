"""Runs inside the real Blender GUI (under Xvfb, see tools/blender_gui.sh) with the extension
installed and enabled in the user preferences:
    blender -p 0 0 W H --python gui_panels.py -- OUTDIR
From timers: adds a fractal with the add-on's operator, selects it, sets the engine to Unbound,
shows the Properties editor on the Object, Render (its Motion Blur panels open) and View Layer
tabs in turn and grabs the X
screen with ffmpeg after each (bpy.ops.screen.screenshot is black on Mesa's software GL), then
quits. Prints `UNBOUND_GUI {json}` lines."""
import os
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from gui_common import MODULE, area, fractal_scene, grab, log, region, watch_panels, window  # noqa: E402

STEP_S = 1.0      # between a change and its screenshot: a few redraws of the whole window
DRAWN = set()   # the add-on's panels whose draw() ran since the last tab change


def shot(name):
    rc, err = grab(name)
    log(shot=name, rc=rc, err=err, tab=area('PROPERTIES').spaces.active.context, panels=sorted(DRAWN))


def show_tab(tab):
    props = area('PROPERTIES')
    props.spaces.active.context = tab
    DRAWN.clear()
    props.tag_redraw()
    log(tab=props.spaces.active.context, size=[props.width, props.height])


def scroll_to_end():
    # The add-on's panels come after Blender's own: scroll to the end so that they are in view.
    # (After a redraw: scrolling is clamped to the panel layout of the last drawn tab.)
    props = area('PROPERTIES')
    with bpy.context.temp_override(window=window(), area=props, region=region(props)):
        for _ in range(10):
            bpy.ops.view2d.scroll_down(page=True)
    props.tag_redraw()


def setup():
    watch_panels(DRAWN)
    win = window()
    res, ob, scene = fractal_scene()
    log(step="setup", addon_enabled=MODULE in bpy.context.preferences.addons, add_op=sorted(res),
        active=ob.name if ob else None, is_fractal=bool(ob and ob.unbound.is_fractal), engine=scene.render.engine,
        window=[win.width, win.height])
    open_motion_blur()
    show_tab('DATA')


def open_motion_blur():
    """Motion blur on, and its two panels (closed by default, as Cycles' are) registered again open
    before the Render tab is first drawn (a region keeps a panel's open state from then on), so
    that the Render tab draws them."""
    ui = sys.modules[MODULE + ".ui"]
    parent, child = ui.UNBOUND_PT_motion_blur, ui.UNBOUND_PT_motion_blur_curve
    bpy.utils.unregister_class(child)
    bpy.utils.unregister_class(parent)
    for cls in (parent, child):
        cls.bl_options = set()
        bpy.utils.register_class(cls)
    bpy.context.scene.render.use_motion_blur = True


def make_ifs():
    """The active fractal becomes a Menger sponge IFS: its panel then draws the maps' list."""
    ob = bpy.context.view_layer.objects.active
    ob.unbound.kind = 'IFS'
    with bpy.context.temp_override(window=window(), object=ob, active_object=ob):
        res = bpy.ops.object.unbound_ifs_shape(shape='MENGER')
    log(step="ifs", op=sorted(res), maps=len(ob.unbound.ifs_maps))
    show_tab('DATA')


def quit_blender():
    log(step="quit")
    import addon_utils
    addon_utils.disable(MODULE, default_set=False)
    with bpy.context.temp_override(window=window()):
        bpy.ops.wm.quit_blender()


STEPS = [setup, scroll_to_end, lambda: shot("object_tab.png"),
         make_ifs, scroll_to_end, lambda: shot("object_tab_ifs.png"),
         lambda: show_tab('RENDER'), scroll_to_end, lambda: shot("render_tab.png"),
         lambda: show_tab('VIEW_LAYER'), scroll_to_end, lambda: shot("view_layer_tab.png"), quit_blender]


def run_steps():
    step = STEPS.pop(0)
    try:
        step()
    except Exception as exc:  # report, then quit: a hanging GUI would only hit the timeout
        import traceback
        traceback.print_exc()
        log(error=repr(exc))
        STEPS[:] = [quit_blender] if step is not quit_blender else []
    return STEP_S if STEPS else None


bpy.app.timers.register(run_steps, first_interval=1.0)
