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
