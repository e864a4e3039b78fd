"""Benchmark: what F12's sample-by-sample display costs (addon/engine.py shows the mean so far
after each sample, as Cycles does), in bpy.

For 1 and 8 samples at 1920x1080: F12 (bpy.ops.render.render, nothing written) against one native
render of all samples into the same buffers (what the engine did before), the same scene. Medians
with min-max over --repeats rounds of wall time and of this process's CPU time (the machine may be
shared: the CPU ratio is the steadier figure).

    python bench/bench_f12.py [--repeats 3] [--res 1920x1080]
"""
import argparse
import os
import pathlib
import statistics
import sys
import tempfile
import time

REPO = pathlib.Path(__file__).resolve().parents[1]
USER = pathlib.Path(tempfile.mkdtemp(prefix="unbound-bench-user-"))
(USER / "config").mkdir()
os.environ["BLENDER_USER_RESOURCES"] = str(USER)  # before bpy starts: a private user directory

import bpy  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, str(REPO / "examples"))
from unbound_extension import add_camera, ensure_extension, new_scene  # noqa: E402


class EyeCamera:
    """What camera_description asks of a RenderEngine, for a mono camera outside a render."""
    camera_override = None

    def camera_model_matrix(self, ob, use_spherical_stereo=False):
        return ob.matrix_world

    def camera_shift_x(self, ob, use_spherical_stereo=False):
        return ob.data.shift_x


def timed(fn):
    t, c = time.perf_counter(), time.process_time()
    fn()
    return time.perf_counter() - t, time.process_time() - c


def summary(values):
    return "%.3f (%.3f-%.3f)" % (statistics.median(values), min(values), max(values))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--res", default="1920x1080")
    args = ap.parse_args()
    width, height = map(int, args.res.split("x"))
    module = ensure_extension(prog="bench_f12")
    export = sys.modules[module + ".export"]
    core = sys.modules[module + ".utils"].native()
    for samples in (1, 8):
        scene = new_scene(width, height, world_color=(0.05, 0.05, 0.05))
        add_camera(scene, (0.4, -3.0, 0.9), (0.0, 0.0, 0.0), lens=50.0)
        bpy.ops.object.unbound_fractal_add(use_cursor=False)
        scene.unbound.samples = samples
        dg = bpy.context.evaluated_depsgraph_get()
        camera = export.camera_description(EyeCamera(), dg, width, height)
        buffers = {"combined": np.empty((height, width, 4), np.float32),
                   "depth": np.empty((height, width, 1), np.float32)}

        def direct():
            core.render(camera, export.fractal_objects(dg), buffers, shading=export.shading_description(dg),
                        **export.render_options(scene))

        f12, one = [], []
        for _ in range(args.repeats):  # interleaved, so that load changes hit both alike
            f12.append(timed(lambda: bpy.ops.render.render()))
            one.append(timed(direct))
        ratio = [a[1] / b[1] for a, b in zip(f12, one)]
        print("%d sample%s at %dx%d: F12 wall %s s, CPU %s s | one core call wall %s s, CPU %s s | "
              "CPU ratio %s" % (samples, "" if samples == 1 else "s", width, height, summary([t[0] for t in f12]),
                                summary([t[1] for t in f12]), summary([t[0] for t in one]),
                                summary([t[1] for t in one]), summary(ratio)))


if __name__ == "__main__":
    main()
