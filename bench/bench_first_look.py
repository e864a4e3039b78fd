"""Benchmark (issues 17 and 21): F12 of Blender's startup scene after Add > Unbound Fractal as the Add
menu runs it (framed in the camera, the orbit-trap colour ramp, the soft first look: 4 samples, soft
shadows, ambient occlusion with 5 samples), at the startup scene's 1920x1080, per kind, in bpy.

Each round renders every kind in turn (interleaved, so that load changes of a shared machine hit all
alike), after one warm-up round; per kind: F12's wall time and this process's CPU time
(bpy.ops.render.render, nothing written), and the native core's own seconds (the engine's
LAST_STATS, all samples), as medians (min-max), and the median of the per-round ratios to the
quaternion Julia row (CPU time: the steadier figure where other jobs share the cores).

    python bench/bench_first_look.py [--repeats 3] [--kinds IFS,QUATERNION_JULIA] [--percentage 100]
                                     [--dump DIR] [--extension ZIP]

--kinds takes the Add menu's kinds; IFS:MENGER (IFS:KOCH) is the IFS with that shape preset.

--extension ZIP installs that build instead of dist/'s (another branch's, for a before/after).

--dump DIR also writes each kind's core call (camera, objects, shading, options) as a pickle,
DIR/<kind>.pkl, so that the same render can be replayed by the core alone (bench_core's path):
    core.render(d["camera"], d["objects"], buffers, **d["options"]).
"""
import argparse
import os
import pathlib
import pickle
import statistics
import sys
import time

REPO = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "bench"))
from blender_user import private_user_directory  # noqa: E402

USER = private_user_directory()  # before bpy starts

import bpy  # noqa: E402

sys.path.insert(0, str(REPO / "examples"))
from unbound_extension import ensure_extension  # noqa: E402

BASE = "QUATERNION_JULIA"


def startup_scene_add(mod, kind, percentage):
    """What tests/blender/bpy_scripts/first_render.py does: the factory startup file, the engine
    switched as the Add menu's invoke does, the fractal added with the menu's options. A kind
    written IFS:SHAPE then takes the IFS panel's shape preset (IFS:MENGER: the Menger sponge)."""
    kind, _, shape = kind.partition(":")
    bpy.ops.wm.read_homefile(use_factory_startup=True)
    scene = bpy.context.scene
    scene.render.engine = 'UNBOUND'
    scene.render.resolution_percentage = percentage
    result = bpy.ops.object.unbound_fractal_add(kind=kind, **mod.operators.menu_options(bpy.context))
    assert result == {'FINISHED'}, result
    if shape:
        result = bpy.ops.object.unbound_ifs_shape(shape=shape)
        assert result == {'FINISHED'}, result
        bpy.context.object.update_tag()  # else --dump's evaluated depsgraph keeps the old maps
    return scene


def f12(mod):
    t, c = time.perf_counter(), time.process_time()
    bpy.ops.render.render()
    return time.perf_counter() - t, time.process_time() - c, mod.engine.LAST_STATS["seconds"]


def dump(mod, scene, path):
    """The core call F12 makes (one call of all samples), for a replay without bpy."""
    export = mod.export
    dg = bpy.context.evaluated_depsgraph_get()

    class EyeCamera:  # what camera_description asks of a RenderEngine, for a mono camera
        camera_override = None

        def camera_model_matrix(self, ob, use_spherical_stereo=False):
            return ob.matrix_world

        def camera_shift_x(self, ob, use_spherical_stereo=False):
            return ob.data.shift_x

    width, height, window = export.image_window(scene)
    call = dict(camera=export.camera_description(EyeCamera(), dg, width, height),
                objects=export.fractal_objects(dg),
                options=dict(window=window, shading=export.shading_description(dg),
                             **export.render_options(scene)))
    path.write_bytes(pickle.dumps(call))


def summary(values):
    return "%.3f (%.3f-%.3f)" % (statistics.median(values), min(values), max(values))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--kinds", default="IFS,QUATERNION_JULIA")
    ap.add_argument("--percentage", type=int, default=100)
    ap.add_argument("--dump", default=None)
    ap.add_argument("--extension", default=None)
    args = ap.parse_args()
    kinds = args.kinds.split(",")
    name = ensure_extension(args.extension, prog="bench_first_look")
    mod = type("mod", (), {k: sys.modules[name + "." + k] for k in ("operators", "engine", "export")})
    if args.dump:
        os.makedirs(args.dump, exist_ok=True)
    times = {k: [] for k in kinds}
    for rnd in range(args.repeats + 1):
        for kind in kinds:
            scene = startup_scene_add(mod, kind, args.percentage)
            if rnd == 0 and args.dump:
                dump(mod, scene, pathlib.Path(args.dump) / (kind.lower().replace(":", "-") + ".pkl"))
            t = f12(mod)
            if rnd:  # round 0 warms up
                times[kind].append(t)
    r = bpy.context.scene.render
    print("F12 of the startup scene + Add (first look), %dx%d, %d rounds, medians (min-max):"
          % (r.resolution_x * args.percentage // 100, r.resolution_y * args.percentage // 100, args.repeats))
    print("| kind | F12 wall s | F12 CPU s | core s | CPU x %s |" % BASE)
    print("|---|---|---|---|---|")
    for kind in kinds:
        rows = times[kind]
        ratio = "%.2f" % statistics.median(a[1] / b[1] for a, b in zip(rows, times[BASE])) if BASE in times else "-"
        print("| %s | %s | %s | %s | %s |" % (kind, summary([t[0] for t in rows]), summary([t[1] for t in rows]),
                                              summary([t[2] for t in rows]), ratio))


if __name__ == "__main__":
    main()
