"""Scripts of test_farm_determinism.py (run inside bpy by conftest.run_bpy: see bpy_scripts/__init__.py)."""
import os

import bpy


def keyframed_scene(S):
    """A keyframed mu animation with shadows, reflections, AO, samples and the sea, written as
    multilayer EXR of several passes, with a fixed thread count."""
    scene = S.empty_scene(48, 36)
    S.add_camera(scene)
    ob = S.add_fractal(mu=(-0.2, 0.8, 0.0, 0.0))
    ob.keyframe_insert("unbound.mu", frame=1)
    ob.unbound.mu = (-0.5, 0.5, 0.1, 0.0)
    ob.keyframe_insert("unbound.mu", frame=4)
    ob.unbound.reflectivity = 0.3
    scene.unbound.shadows = 'SOFT'
    scene.unbound.reflection_depth = 2
    scene.unbound.ao_strength = 0.5
    scene.unbound.samples = 2
    scene.unbound.use_sea = True
    scene.unbound.sea_height = -1.2
    layer = scene.view_layers[0].unbound
    for name in ("depth", "normal", "position", "iterations", "shadow", "reflection", "ao"):
        setattr(layer, "use_pass_" + name, True)
    S.exr_output(scene)
    scene.render.threads_mode = 'FIXED'
    return scene


def render_range(S, mod, prefix, first, last, threads, tile):
    """Frames first..last of keyframed_scene as an animation render, files prefix####.exr."""
    scene = keyframed_scene(S)
    scene.frame_start, scene.frame_end = first, last
    scene.render.threads = threads
    scene.unbound.tile_size = tile
    scene.render.filepath = os.path.join(os.environ["UNBOUND_TEST_TMP"], prefix)
    bpy.ops.render.render(animation=True)
    S.report(stats=dict(mod.engine.LAST_STATS))


def save_keyframed_scene(S, mod, path):
    """keyframed_scene saved at frame 1, as an artist leaves it: mu keyed at frames 1 and 4, the
    object's own value that of the last key set (frame 4's), and the current frame 1."""
    scene = keyframed_scene(S)
    scene.frame_start, scene.frame_end = 1, 4
    assert scene.frame_current == 1
    bpy.ops.wm.save_as_mainfile(filepath=path)
    S.report(saved=path)


def render_saved(S, mod, path, order, first, last, prefix):
    """Frames first..last of the .blend at `path` as an animation render, files prefix####.exr.
    order "before": the add-on is registered before the file loads (as `blender -b --addons
    MODULE FILE` or a worker whose preferences enable it: bpy_main.py enabled it at start);
    "after": the file loads first, then the add-on is enabled (`blender -b FILE --addons MODULE`)."""
    import sys
    import addon_utils
    if order == "after":
        addon_utils.disable(S.MODULE, default_set=False)
        assert not hasattr(bpy.types.Object, "unbound")
        bpy.ops.wm.open_mainfile(filepath=path)
        addon_utils.enable(S.MODULE, default_set=False, persistent=True)
        mod = sys.modules[S.MODULE]
    else:
        assert order == "before", order
        bpy.ops.wm.open_mainfile(filepath=path)
    scene = bpy.context.scene
    assert scene.render.engine == "UNBOUND", scene.render.engine
    assert scene.frame_current == 1, scene.frame_current
    scene.frame_start, scene.frame_end = first, last
    scene.render.filepath = os.path.join(os.environ["UNBOUND_TEST_TMP"], prefix)
    bpy.ops.render.render(animation=True)
    S.report(stats=dict(mod.engine.LAST_STATS))
