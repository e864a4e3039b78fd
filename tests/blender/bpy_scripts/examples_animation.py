"""Scripts of test_examples_animation.py (run inside bpy by conftest.run_bpy: see
bpy_scripts/__init__.py)."""
import importlib.util
import os

import bpy


def keyframed_mu_reaches_each_frame(S, mod, example, extension, size, frame_range):
    spec = importlib.util.spec_from_file_location("animate_mu", example)
    A = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(A)
    A.ensure_extension(extension)
    scene, ob = A.build_scene(size[0], size[1])
    frames = list(range(frame_range[0], frame_range[1] + 1))
    mus = {}
    for k in frames + [1 + A.LOOP_FRAMES, 1 + A.LOOP_FRAMES // 16]:
        scene.frame_set(k)
        mus[k] = list(ob.unbound.mu)
    key0 = list(A.mu_on_path(0.0))
    mid = A.mu_on_path(1.0 / 16)  # halfway between two keyframes
    ob.animation_data_clear()
    singles = {}
    for k in frames:
        scene.frame_set(k)
        ob.unbound.mu = mus[k]
        assert list(ob.unbound.mu) == mus[k]
        A.set_format(scene, 'EXR')
        scene.render.filepath = os.path.join(os.environ["UNBOUND_TEST_TMP"], "single_%d.exr" % k)
        bpy.ops.render.render(write_still=True)
        singles[k] = scene.render.filepath
    S.report(mus=mus, key0=key0, mid=mid, singles=singles, loop=A.LOOP_FRAMES)
