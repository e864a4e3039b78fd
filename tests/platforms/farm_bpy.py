"""The bpy side of test_farm.py (never collected: it imports bpy). Each call is a fresh process, as
each farm job is a fresh Blender; the environment holds BLENDER_SYSTEM_EXTENSIONS and a HOME of
the worker's own (no BLENDER_USER_RESOURCES), so Blender's user directory is the worker's default
one, ~/.config/blender/4.2/, empty at first.

    python farm_bpy.py author SCENE.blend
    python farm_bpy.py render SCENE.blend FIRST LAST OUTPUT THREADS [after|before|before-guard]
    python farm_bpy.py probe

The add-on is enabled as `blender --addons bl_ext.system.unbound` enables it: Blender 4.2's
command line runs _bpy_internal.addons.cli.set_from_cli (extract the wheels of the pending
extensions into the user directory's extensions/.local/, then addon_utils.enable), which the bpy
module, having no command line, is given here by hand - after loading the file, as
`blender -b SCENE.blend --addons ... -f N` does. The result is one JSON line, FARM_RESULT {...}."""
import json
import os
import pathlib
import sys

import bpy

BLENDER_TESTS = pathlib.Path(__file__).resolve().parents[1] / "blender"
sys.path.insert(0, str(BLENDER_TESTS))   # the scene helpers of tests/blender (bpy_session, bpy_scripts)

MODULE = "bl_ext.system.unbound"


def enable_like_the_command_line():
    import addon_utils
    from _bpy_internal.addons.cli import set_from_cli
    set_from_cli(MODULE)
    # Enabled and persistent for the session (it survives loading files), as `--addons` leaves it;
    # not added to the preferences.
    assert addon_utils.check(MODULE) == (True, True), "%s was not enabled" % MODULE
    assert MODULE not in bpy.context.preferences.addons
    return sys.modules[MODULE]


def where(mod):
    import unbound_core
    import unbound_core._native as native
    repos = {r.module: (r.source, r.directory) for r in bpy.context.preferences.extensions.repos}
    import addon_utils
    import hashlib
    with open(native.__file__, "rb") as f:
        native_sha256 = hashlib.sha256(f.read()).hexdigest()
    return dict(addon_file=mod.__file__, core_file=unbound_core.__file__, native_file=native.__file__,
                native_sha256=native_sha256,
                core_version=unbound_core.__version__,
                addon_version=list(addon_utils.module_bl_info(mod)["version"]),
                user_extensions=bpy.utils.user_resource('EXTENSIONS'), repos=repos,
                blender=bpy.app.version_string,
                enabled=sorted(m for m in sys.modules if m.startswith("bl_ext.") and m.count(".") == 2))


def leave(mod, **values):
    """Reports, unregisters the add-on (bpy 4.2 crashes at exit with a RenderEngine registered)
    and ends the process. (Disabling the last enabled extension makes Blender remove the wheels it
    extracted into the user directory; Blender itself, exiting, leaves them.)"""
    print("FARM_RESULT " + json.dumps(values), flush=True)
    import addon_utils
    addon_utils.disable(MODULE, default_set=False)
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(0)


def author(path):
    """The keyframed μ animation of tests/blender's farm test (shadows, reflections, AO, sea, two
    samples, a multilayer EXR of several passes), frames 1-3, saved for the workers. Threads
    'AUTO': each worker uses what its machine (or -t) gives."""
    import bpy_session as S
    from bpy_scripts import farm
    mod = enable_like_the_command_line()
    scene = farm.keyframed_scene(S)
    scene.frame_start, scene.frame_end = 1, 3
    scene.render.threads_mode = 'AUTO'
    scene.render.filepath = "//frames/frame_"
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    leave(mod, **where(mod))


# The worker guard of docs/farm.md, run by `--python-expr` before `-f`/`-a`: fail when Unbound is
# not enabled (Blender would otherwise render the frame with another engine and exit 0).
GUARD = ("import bpy; s = bpy.context.scene; "
         "assert s.render.engine == 'UNBOUND', 'Unbound is not enabled on this worker: ' + s.render.engine")


def render(path, first, last, output, threads, order="after"):
    """`blender -b SCENE.blend --addons bl_ext.system.unbound -o OUTPUT -t THREADS -s FIRST -e LAST -a`.
    order "before": `blender -b --addons ... SCENE.blend ...` (the add-on registered before the file
    loads, as it is when a worker's preferences enable it); "before-guard": the same with GUARD run
    after loading, as docs/farm.md's command lines do. Every order gives the same frames (the first
    frame of the range once had the saved frame's animated values with the add-on registered
    first: docs/farm.md, 'Load order does not matter')."""
    if order == "after":
        bpy.ops.wm.open_mainfile(filepath=str(path))
        mod = enable_like_the_command_line()
    else:
        mod = enable_like_the_command_line()
        bpy.ops.wm.open_mainfile(filepath=str(path))
        if order == "before-guard":
            exec(GUARD, {})
    scene = bpy.context.scene
    assert scene.render.engine == "UNBOUND", scene.render.engine
    scene.render.filepath = output
    scene.render.threads_mode = 'FIXED'   # as -t THREADS: another machine's core count
    scene.render.threads = threads
    scene.frame_start, scene.frame_end = first, last
    bpy.ops.render.render(animation=True)
    leave(mod, stats=dict(mod.engine.LAST_STATS), **where(mod))


def probe():
    leave(enable_like_the_command_line(), **where(sys.modules[MODULE]))


if __name__ == "__main__":
    cmd, args = sys.argv[1], sys.argv[2:]
    if cmd == "author":
        author(args[0])
    elif cmd == "render":
        render(args[0], int(args[1]), int(args[2]), args[3], int(args[4]), *args[5:])
    elif cmd == "probe":
        probe()
    else:
        sys.exit("unknown command %r" % cmd)
