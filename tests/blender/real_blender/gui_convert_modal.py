"""Runs inside the real Blender GUI (under Xvfb, see tools/blender_gui.sh) with the extension
installed and enabled, and with simulated input (Blender's --enable-event-simulate: the script's
Window.event_simulate() events go through Blender's own event handling, as keys do):
    blender -p 0 0 W H --enable-event-simulate --python gui_convert_modal.py -- OUTDIR
Convert to Mesh as a user meets it (issue 20), on the default Julia set:

1. cancel: Object > Convert to Mesh (INVOKE_DEFAULT) at resolution 1024, its dialog confirmed with
   Enter; once the conversion runs modal (seconds of work), Esc. Logged: the wall time from the Esc
   to the operator's end, whether it was still running at the Esc, the data before and after, and
   X screen grabs before, during and after (the test compares their status bars).
2. complete: the same at a low resolution without Esc, until it ends; then the same conversion
   from a script (EXEC_DEFAULT). Logged: each new active mesh's vertex and face counts and hashes.

Prints `UNBOUND_GUI {json}` lines."""
import hashlib
import os
import sys
import time

import bpy
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from gui_common import (after, area, fractal_scene, grab, guarded, log, quit_blender, region,  # noqa: E402
                        window)

OPERATOR = "OBJECT_OT_unbound_convert_to_mesh"
CANCEL_RESOLUTION = 1024   # seconds of extraction on 2 cores: long enough to cancel midway
COMPLETE_RESOLUTION = 96   # quick, for the comparison with the script's conversion
RUNNING_BEFORE_ESC = 1.0   # seconds the modal conversion runs before the Esc


def state():
    active = bpy.context.view_layer.objects.active
    return dict(active=active.name if active else None, objects=sorted(o.name for o in bpy.data.objects),
                meshes=sorted(m.name for m in bpy.data.meshes), materials=sorted(m.name for m in bpy.data.materials),
                frame=bpy.context.scene.frame_current)


def running():
    return any(op.bl_idname == OPERATOR for op in window().modal_operators)


def mesh_digest(ob):
    """Vertex and face counts and SHA-256 of the float32 positions, vertex indices and trap."""
    me = ob.data
    co = np.empty(3 * len(me.vertices), np.float32)
    me.vertices.foreach_get("co", co)
    loops = np.empty(len(me.loops), np.int32)
    me.loops.foreach_get("vertex_index", loops)
    trap = np.empty(len(me.vertices), np.float32)
    me.attributes["unbound_trap"].data.foreach_get("value", trap)
    return dict(name=ob.name, type=ob.type, vertices=len(me.vertices), faces=len(me.polygons),
                co=hashlib.sha256(co.tobytes()).hexdigest(), loops=hashlib.sha256(loops.tobytes()).hexdigest(),
                trap=hashlib.sha256(trap.tobytes()).hexdigest())


def when(condition, then, timeout, what):
    """then() once condition() holds, looked at every 2 ms (Blender's main loop permitting)."""
    start = time.perf_counter()

    def poll():
        if condition():
            then()
            return None
        if time.perf_counter() - start > timeout:
            raise RuntimeError("%s: not within %.0f s" % (what, timeout))
        return 0.002
    bpy.app.timers.register(guarded(poll), first_interval=0.002)


def centre():
    view3d = area('VIEW_3D')
    r = region(view3d)
    return r.x + r.width // 2, r.y + r.height // 2


def key(kind):
    """A press and a release of key `kind` at the viewport's centre, through Blender's event queue."""
    x, y = centre()
    window().event_simulate(kind, 'PRESS', x=x, y=y)
    window().event_simulate(kind, 'RELEASE', x=x, y=y)


def invoke(resolution):
    """Convert to Mesh as from the Object menu (its dialog, then Enter), with the pointer in the 3D view."""
    view3d = area('VIEW_3D')
    x, y = centre()
    window().event_simulate('MOUSEMOVE', 'NOTHING', x=x, y=y)
    with bpy.context.temp_override(window=window(), area=view3d, region=region(view3d)):
        op = bpy.ops.object.unbound_convert_to_mesh('INVOKE_DEFAULT', resolution=resolution)
    after(0.5, lambda: key('RET'))
    return sorted(op)


def setup():
    res, ob, scene = fractal_scene()
    log(step="setup", add_op=sorted(res), is_fractal=ob.unbound.is_fractal, mu=list(ob.unbound.mu))
    x, y = centre()
    window().event_simulate('MOUSEMOVE', 'NOTHING', x=x, y=y)
    after(1.0, cancel_run)


# The status bar after a cancel, 0.5 s apart (test_real_blender.py names the same files).
AFTER_SHOTS = ["convert_status_after.png"] + ["convert_status_after_%d.png" % k for k in (1, 2, 3)]


def cancel_run():
    before = state()
    shot_before = grab("convert_status_before.png")
    op = invoke(CANCEL_RESOLUTION)
    started = {}

    def started_running():
        started["t"] = time.perf_counter()
        after(RUNNING_BEFORE_ESC, send_esc)

    def send_esc():
        shot_during = grab("convert_status_during.png")
        was_running = running()
        esc = time.perf_counter()
        key('ESC')

        def ended():
            end = time.perf_counter()
            log(step="cancel", invoke_op=op, before=before, after=state(), was_running=was_running,
                esc_to_end=end - esc, ran=esc - started["t"], shots=[shot_before, shot_during])
            # the report banner fades from the status bar's middle; its left part is compared.
            # A few shots half a second apart: on a loaded machine Blender may redraw the bar
            # only after the first (the test asks that its text comes back, not how soon).
            after(0.5, lambda: shot_after(0))

        def shot_after(k):
            log(step="cancel_after", shot=grab(AFTER_SHOTS[k]))
            after(0.5, (lambda: shot_after(k + 1)) if k + 1 < len(AFTER_SHOTS) else complete_run)
        when(lambda: not running(), ended, 30.0, "the end of the cancelled conversion")
    when(running, started_running, 30.0, "the modal conversion")


def complete_run():
    fractal = next(o for o in bpy.data.objects if o.type == 'EMPTY' and o.unbound.is_fractal)
    before = state()
    start = {}

    seen = {}

    def ended():
        """The modal conversion was seen running (it polls every 50 ms) and has ended."""
        if running():
            seen["running"] = True
        return seen.get("running", False) and not running()

    def finished():
        modal = bpy.context.view_layer.objects.active
        after_modal = state()
        modal_digest = mesh_digest(modal)
        # the script's way: the fractal active again, EXEC_DEFAULT
        view3d = area('VIEW_3D')
        with bpy.context.temp_override(window=window(), area=view3d, region=region(view3d)):
            bpy.context.view_layer.objects.active = fractal
            op = bpy.ops.object.unbound_convert_to_mesh('EXEC_DEFAULT', resolution=COMPLETE_RESOLUTION)
        log(step="complete", before=before, after_modal=after_modal, modal=modal_digest,
            modal_seconds=time.perf_counter() - start["t"], exec_op=sorted(op),
            exec=mesh_digest(bpy.context.view_layer.objects.active), after_exec=state())
        after(0.5, quit_blender)
    start["t"] = time.perf_counter()
    invoke(COMPLETE_RESOLUTION)
    when(ended, finished, 120.0, "the modal conversion's end")


after(1.0, setup)
