"""Runs inside the real Blender GUI (under Xvfb, see tools/blender_gui.sh) with the extension
installed and enabled in the user preferences:
    blender -p 0 0 W H --python gui_ui.py -- OUTDIR
Drives what a Blender user trips over (issue 17), from timers:
  * Add > Unbound Fractal from the Add menu (INVOKE) with Cycles active switches the engine;
  * the Properties editor's tabs: Object Data (the fractal's parameters), Render (Color
    Management, Performance > Threads), World (Surface), Light (one Light panel): which panels
    Blender polls true there and which of them it draws, with a screenshot of each;
  * the fractal presets popover opened in the GUI (screenshot);
  * a bundled fractal preset applied with the 3D view in Rendered shading: the viewport starts a
    new generation and finishes a frame of the preset's mu without any redraw asked by the test,
    and the empty's sphere follows the new set;
  * a preset saved (Python 3.13 here) into a non-empty file that applies, and a bundled preset's
    removal refused.
Prints `UNBOUND_GUI {json}` lines."""
import os
import sys
import time

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from gui_common import MODULE, area, grab, log, region, window  # noqa: E402

DRAWN = set()
WATCHED = ["RENDER_PT_color_management", "UNBOUND_PT_light", "UNBOUND_PT_world", "UNBOUND_PT_fractal",
           "UNBOUND_PT_performance_threads", "UNBOUND_PT_render", "DATA_PT_light"]


def mod(name):
    return sys.modules[MODULE + "." + name]


def watch():
    for name in WATCHED:
        cls = getattr(bpy.types, name, None)
        if cls is not None:
            cls.append(lambda self, context, _name=name: DRAWN.add(_name))


def polled(tab):
    """Names and labels of the Properties panels of `tab` (bl_context) whose poll is true in the
    Properties editor, as Blender asks them."""
    props = area('PROPERTIES')
    out = []
    with bpy.context.temp_override(window=window(), area=props, region=region(props),
                                   space_data=props.spaces.active):
        ctx = bpy.context
        for cls in bpy.types.Panel.__subclasses__():
            if getattr(cls, "bl_space_type", None) != 'PROPERTIES' or getattr(cls, "bl_context", None) != tab:
                continue
            if getattr(cls, "bl_region_type", None) != 'WINDOW':
                continue
            try:
                ok = cls.poll(ctx) if hasattr(cls, "poll") else True
            except Exception:
                ok = False
            if ok:
                out.append([cls.__name__, cls.bl_label])
    return sorted(out)


def show_tab(tab):
    props = area('PROPERTIES')
    props.spaces.active.context = tab
    DRAWN.clear()
    props.tag_redraw()


def session():
    live = list(mod("viewport").SESSIONS)
    return live[0] if len(live) == 1 else None


STATE = {}


def add_from_menu():
    """The Add menu's call (INVOKE, as a click does) with Cycles active and the cube removed."""
    win = window()
    scene = bpy.context.scene
    for ob in list(scene.objects):
        if ob.type == 'MESH':
            bpy.data.objects.remove(ob)
    scene.render.engine = 'CYCLES'
    view3d = area('VIEW_3D')
    with bpy.context.temp_override(window=win, area=view3d, region=region(view3d)):
        res = bpy.ops.object.unbound_fractal_add('INVOKE_DEFAULT')
    ob = bpy.context.view_layer.objects.active
    STATE["ob"] = ob.name
    log(step="add", op=sorted(res), engine=scene.render.engine, is_fractal=bool(ob and ob.unbound.is_fractal))
    scene.unbound.viewport_start_divisor = '8'
    show_tab('DATA')


def data_tab():
    log(step="data_tab", tab='DATA', polled=polled('data'), drawn=sorted(DRAWN), shot="ui_data_tab.png",
        rc=grab("ui_data_tab.png")[0])
    show_tab('RENDER')


def render_tab():
    log(step="render_tab", tab='RENDER', polled=polled('render'), drawn=sorted(DRAWN), shot="ui_render_tab.png",
        rc=grab("ui_render_tab.png")[0])
    show_tab('WORLD')


def world_tab():
    log(step="world_tab", tab='WORLD', polled=polled('world'), drawn=sorted(DRAWN), shot="ui_world_tab.png",
        rc=grab("ui_world_tab.png")[0])
    light = next(ob for ob in bpy.context.scene.objects if ob.type == 'LIGHT')
    bpy.context.view_layer.objects.active = light
    show_tab('DATA')


def light_tab():
    log(step="light_tab", tab='DATA', polled=polled('data'), drawn=sorted(DRAWN), shot="ui_light_tab.png",
        rc=grab("ui_light_tab.png")[0])
    ob = bpy.data.objects[STATE["ob"]]
    bpy.context.view_layer.objects.active = ob
    ob.select_set(True)
    show_tab('DATA')
    # The fractal presets popover, as the panel header's preset button opens it.
    props = area('PROPERTIES')
    with bpy.context.temp_override(window=window(), area=props, region=region(props)):
        res = bpy.ops.wm.call_panel(name="UNBOUND_PT_fractal_presets", keep_open=True)
    log(step="popover", op=sorted(res))


def popover_shot():
    log(step="popover_shot", shot="ui_fractal_presets.png", rc=grab("ui_fractal_presets.png")[0])
    # Close the popover: Esc is not ours to send; a redraw of the whole window after moving on
    # is enough for the next steps (timers run regardless).
    space = area('VIEW_3D').spaces.active
    space.shading.type = 'RENDERED'
    area('VIEW_3D').tag_redraw()
    wait_final(apply_preset)


def wait_final(then, timeout=90.0, newer_than=None):
    start = time.time()

    def poll():
        s = session()
        f = s.frame() if s else None
        if (f is not None and f.final and f.generation == s._generation and s.drawn and s.drawn[0] == f.sequence
                and (newer_than is None or f.generation > newer_than)):
            bpy.app.timers.register(then, first_interval=0.3)
            return None
        if time.time() - start > timeout:
            log(error="the viewport did not show a new final frame", step="wait",
                frame=None if f is None else [f.generation, f.divisor, f.final], newer_than=newer_than)
            quit_blender()
            return None
        return 0.25
    bpy.app.timers.register(poll, first_interval=0.5)


def apply_preset():
    """A bundled fractal preset, run as the popover's button runs it (script.execute_preset from
    the Properties editor); no redraw or tag from the test."""
    ob = bpy.data.objects[STATE["ob"]]
    s = session()
    STATE["generation"] = s.frame().generation
    STATE["size_before"] = ob.empty_display_size
    path = os.path.join(mod("operators").BUNDLED_PRESETS, "basilica.py")
    props = area('PROPERTIES')
    with bpy.context.temp_override(window=window(), area=props, region=region(props)):
        res = bpy.ops.script.execute_preset(filepath=path, menu_idname="UNBOUND_PT_fractal_presets")
    log(step="apply", op=sorted(res), generation=STATE["generation"])
    wait_final(preset_applied, timeout=60.0, newer_than=STATE["generation"])


def preset_applied():
    ob = bpy.data.objects[STATE["ob"]]
    s = session()
    f = s.frame()
    mus = [o["mu"] for o in s._request.objects]
    log(step="preset_applied", generation=f.generation, before=STATE["generation"], final=f.final,
        request_mu=[list(m) for m in mus], mu=list(ob.unbound.mu), theta=ob.unbound.theta,
        size_before=STATE["size_before"], size_after=ob.empty_display_size,
        expected_size=mod("properties").display_radius(ob), shot="ui_preset_applied.png",
        rc=grab("ui_preset_applied.png")[0])
    area('VIEW_3D').spaces.active.shading.type = 'SOLID'
    save_preset()


def save_preset():
    """Save (Python 3.13: Blender's AddPresetBase with preset_defines fails here), change the
    object, apply the saved file, and try to remove a bundled preset."""
    ob = bpy.data.objects[STATE["ob"]]
    saved_mu = list(ob.unbound.mu)
    props = area('PROPERTIES')
    with bpy.context.temp_override(window=window(), area=props, region=region(props)):
        res = bpy.ops.unbound.fractal_preset_add(name="GUI Preset")
    folder = bpy.utils.preset_paths("unbound/fractal")[-1]
    path = os.path.join(folder, "GUI_Preset.py")
    size = os.path.getsize(path) if os.path.exists(path) else -1
    ob.unbound.mu = (0.3, 0.3, 0.3, 0.3)
    with bpy.context.temp_override(window=window(), area=props, region=region(props)):
        run = bpy.ops.script.execute_preset(filepath=path, menu_idname="UNBOUND_PT_fractal_presets")
        removed = bpy.ops.unbound.fractal_preset_add(name="douady rabbit", remove_name=True)
    bundled = os.path.join(mod("operators").BUNDLED_PRESETS, "douady_rabbit.py")
    log(step="save", op=sorted(res), size=size, run=sorted(run), saved_mu=saved_mu, mu=list(ob.unbound.mu),
        python=sys.version.split()[0], remove_bundled=sorted(removed), bundled_kept=os.path.exists(bundled))
    quit_blender()


def quit_blender():
    log(step="quit")
    import addon_utils
    addon_utils.disable(MODULE, default_set=False)
    with bpy.context.temp_override(window=window()):
        bpy.ops.wm.quit_blender()


STEPS = [watch, add_from_menu, data_tab, render_tab, world_tab, light_tab, popover_shot]


def run_steps():
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
    return 1.0 if STEPS else None


bpy.app.timers.register(run_steps, first_interval=1.0)
