"""Benchmark: what F12's sample-by-sample display costs (addon/engine.py shows the mean so far
after each sample, as Cycles does), in bpy.

For 1 and 8 samples at 1920x1080: F12 (bpy.ops.render.render, nothing written) against one native
render of all samples into the same buffers (what the engine did before), the same scene; and F12
through band results (engine.DIRECT_IN_BACKGROUND off), as Blender with a window renders. Medians
with min-max over --repeats rounds of wall time and of this process's CPU time (the machine may be
shared: the CPU ratio is the steadier figure).

With --motion-blur: what motion blur costs (issue 19: the engine evaluates and exports the scene at
each sample's time within the shutter): F12 of --samples samples of a moving, mu-keyframed fractal
with a sun, motion blur off against on; and the engine's own figure for the scene's evaluation and
export (LAST_STATS['motion_blur_seconds']) per sample.

With --memory: the peak resident memory of one F12 at --res with every pass on, 1 sample (or
--samples; with several, F12 through a band result as well: engine.DIRECT_IN_BACKGROUND off), against
one copy of the passes (4 bytes per channel per pixel) and against a bare core call into one copy;
each measured in a fresh process (the peak is a process's high-water mark: ru_maxrss after the
render minus before it, the scene built and a small render done first).

With --animation: a 48-frame animation (examples/animate_mu.py's scene: mu keyframed around a
loop, every pass of that example on) rendered by bpy.ops.render.render(animation=True) into PNGs,
against the bare core rendering the same 48 frames' scenes: each frame exported beforehand
(untimed), then one core call per frame into buffers of the same passes. Blender's PNG writing
is the user's cost with either (the core alone writes no file), so it is measured apart: the same
48 frames as F12s that write nothing (frame_set, then bpy.ops.render.render()), whose difference
to the animation is what saving the frames costs; and those F12s once more through a band result
(engine.DIRECT_IN_BACKGROUND off), as Blender with a window renders them, where in the background
a frame of one band goes straight into Blender's result. Interleaved rounds, medians of CPU time;
and what an F12 frame costs beyond its core calls (its CPU less theirs: steadier than the ratio, which
moves with the core's own time), split into the calling thread's CPU (time.thread_time) and the
other threads' (Blender's thread pool), and the core calls' own CPU against the bare core's.

    python bench/bench_f12.py [--repeats 3] [--res 1920x1080] [--memory [--samples N]] [--motion-blur [--samples 16]]
                              [--animation [--res 640x360]]
"""
import argparse
import atexit
import os
import pathlib
import shutil
import statistics
import sys
import tempfile
import time

REPO = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "bench"))
from blender_user import private_user_directory  # noqa: E402

USER = private_user_directory()  # before bpy starts

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


def peak_rss_bytes():
    import resource
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024   # kilobytes on Linux


def through_bands(engine, run):
    """`run` as Blender with a window renders it: through band results (engine.DIRECT_IN_BACKGROUND
    off; in the background a frame of one band, or of several samples, goes straight into Blender's
    result)."""
    def banded():
        engine.DIRECT_IN_BACKGROUND = False
        try:
            return run()
        finally:
            engine.DIRECT_IN_BACKGROUND = True
    return banded


def memory_child(mode, width, height, samples=1):
    """One render in this fresh process (`mode` 'f12', 'f12-bands' or 'core'), every pass on,
    `samples` samples: prints the growth of the peak resident memory and the size of one copy of
    the passes."""
    module = ensure_extension(prog="bench_f12")
    export = sys.modules[module + ".export"]
    passes = sys.modules[module + ".passes"]
    core = sys.modules[module + ".utils"].native()
    scene = new_scene(width, height, world_color=(0.05, 0.05, 0.05))
    add_camera(scene, (0.4, -3.0, 0.9), (0.0, 0.0, 0.0), lens=50.0)
    bpy.ops.object.unbound_fractal_add(use_cursor=False)
    scene.unbound.samples = samples
    vl = scene.view_layers[0]
    for toggle, _label, _description in passes.toggles():
        setattr(vl.unbound, toggle, True)
    channels = sum(p.channels for p in passes.PASSES)
    dg = bpy.context.evaluated_depsgraph_get()
    scene.render.resolution_percentage = 10
    bpy.ops.render.render()   # Blender's and the core's one-time allocations, at a tenth of the size
    scene.render.resolution_percentage = 100
    dg = bpy.context.evaluated_depsgraph_get()
    before = peak_rss_bytes()
    if mode.startswith("f12"):
        sys.modules[module + ".engine"].DIRECT_IN_BACKGROUND = mode == "f12"
        bpy.ops.render.render()
    else:
        camera = export.camera_description(EyeCamera(), dg, width, height)
        buffers = {p.native: np.zeros((height, width, p.channels), np.float32) for p in passes.PASSES}
        buffers["alpha"] = np.zeros((height, width, 1), np.float32)
        core.render(camera, export.fractal_objects(dg), buffers, shading=export.shading_description(dg),
                    **export.render_options(scene))
    print("MEMORY %s %d %d" % (mode, peak_rss_bytes() - before, 4 * channels * width * height))


def memory(width, height, repeats, samples=1):
    import subprocess
    rows = {}
    labels = {"f12": "F12", "f12-bands": "F12 through a band result", "core": "bare core call"}
    for _ in range(repeats):
        for mode in ("f12", "f12-bands", "core") if samples > 1 else ("f12", "core"):
            out = subprocess.run([sys.executable, __file__, "--memory-child", mode, "--res", "%dx%d" % (width, height),
                                  "--samples", str(samples)], capture_output=True, text=True, check=True).stdout
            line = [x for x in out.splitlines() if x.startswith("MEMORY ")][-1].split()
            rows.setdefault(mode, []).append(int(line[2]))
            copy = int(line[3])
    for mode, values in rows.items():
        print("%s at %dx%d, every pass, %d sample%s: peak growth %s MB = %s copies of the passes (one copy %.0f MB)"
              % (labels[mode], width, height, samples, "" if samples == 1 else "s", summary([v / 1e6 for v in values]),
                 summary([v / copy for v in values]), copy / 1e6))


def motion_blur(width, height, samples, repeats):
    module = ensure_extension(prog="bench_f12")
    engine = sys.modules[module + ".engine"]
    scene = new_scene(width, height, world_color=(0.05, 0.05, 0.05))
    add_camera(scene, (0.4, -3.0, 0.9), (0.0, 0.0, 0.0), lens=50.0)
    bpy.ops.object.unbound_fractal_add(use_cursor=False)
    ob = bpy.context.object
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", 'SUN'))
    sun.rotation_euler = (0.6, 0.3, 0.4)
    scene.collection.objects.link(sun)
    for frame, x, mu in ((0, -0.3, 0.7), (2, 0.3, 0.9)):
        ob.location.x, ob.unbound.mu[1] = x, mu
        ob.keyframe_insert("location", index=0, frame=frame)
        ob.keyframe_insert("unbound.mu", index=1, frame=frame)
    scene.frame_set(1)
    scene.unbound.samples = samples
    rounds = {False: [], True: []}
    evaluation = []
    for _ in range(repeats):  # interleaved, so that load changes hit both alike
        for blur in (False, True):
            scene.render.use_motion_blur = blur
            rounds[blur].append(timed(lambda: bpy.ops.render.render()))
            if blur:
                evaluation.append(engine.LAST_STATS["motion_blur_seconds"] / samples * 1e3)
    ratio = [a[1] / b[1] for a, b in zip(rounds[True], rounds[False])]
    print("%d samples at %dx%d: F12 without blur wall %s s, CPU %s s | with blur wall %s s, CPU %s s | CPU ratio %s "
          "| the scene's evaluation and export %s ms per sample"
          % (samples, width, height, summary([t[0] for t in rounds[False]]), summary([t[1] for t in rounds[False]]),
             summary([t[0] for t in rounds[True]]), summary([t[1] for t in rounds[True]]), summary(ratio),
             summary(evaluation)))


def animation(width, height, repeats, frames=48):
    sys.path.insert(0, str(REPO / "examples"))
    import animate_mu
    module = ensure_extension(prog="bench_f12")
    export = sys.modules[module + ".export"]
    passes = sys.modules[module + ".passes"]
    core = sys.modules[module + ".utils"].native()
    scene, _ob = animate_mu.build_scene(width, height)
    animate_mu.set_format(scene, 'PNG')
    scene.frame_start, scene.frame_end = 1, frames
    out = tempfile.mkdtemp(prefix="unbound-bench-animation-")
    atexit.register(shutil.rmtree, out, True)
    scene.render.filepath = os.path.join(out, "frame_####")
    vl = scene.view_layers[0]
    scenes = []
    for frame in range(1, frames + 1):  # each frame's export, untimed: what the bare core is given
        scene.frame_set(frame)
        dg = bpy.context.evaluated_depsgraph_get()
        scenes.append((export.camera_description(EyeCamera(), dg, width, height), export.fractal_objects(dg),
                       export.shading_description(dg), export.render_options(scene)))
    buffers = {p.native: np.empty((height, width, p.channels), np.float32) for p in passes.enabled(vl)}
    buffers.setdefault("depth", np.empty((height, width, 1), np.float32))

    def bare_core():
        for camera, objects, shading, options in scenes:
            core.render(camera, objects, buffers, shading=shading, **options)

    # The CPU of the core's calls within F12, so that the rest (Blender's frame change and render
    # pipeline, the add-on's export and copies) is known apart from the core's own variation.
    # Of that rest, the calling thread's own CPU (time.thread_time) is told apart from the other
    # threads' (Blender's thread pool evaluating the depsgraph, and spinning after it).
    utils = sys.modules[module + ".utils"]
    inside = {"process": 0.0, "calling": 0.0}  # CPU seconds within the core's calls

    class TimedCore:
        def __getattr__(self, name):
            return getattr(core, name)

        def render(self, *args, **kw):
            c, t = time.process_time(), time.thread_time()
            try:
                return core.render(*args, **kw)
            finally:
                inside["process"] += time.process_time() - c
                inside["calling"] += time.thread_time() - t

    def f12_each_frame():
        native, utils.native = utils.native, TimedCore
        try:
            for frame in range(1, frames + 1):
                scene.frame_set(frame)
                bpy.ops.render.render()
        finally:
            utils.native = native

    rows = {"animation": [], "f12": [], "f12_bands": [], "core": []}
    runs = {"animation": lambda: bpy.ops.render.render(animation=True), "f12": f12_each_frame,
            "f12_bands": through_bands(sys.modules[module + ".engine"], f12_each_frame), "core": bare_core}
    beside, beside_calling = [], []  # ms of CPU a frame of F12 beyond its core calls: all, calling thread
    within = []  # ms of CPU a frame of F12's core calls
    for _ in range(repeats):  # interleaved, so that load changes hit all alike
        for name, run in runs.items():
            inside.update(process=0.0, calling=0.0)
            calling = time.thread_time()
            rows[name].append(timed(run))
            if name == "f12":  # the F12s in the background, as the animation renders
                beside.append((rows[name][-1][1] - inside["process"]) / frames * 1e3)
                beside_calling.append((time.thread_time() - calling - inside["calling"]) / frames * 1e3)
                within.append(inside["process"] / frames * 1e3)
    labels = {"animation": "animation (PNGs)", "f12": "F12 per frame, no files",
              "f12_bands": "the same F12s through a band (as with a window)"}
    for name, label in labels.items():
        ratio = [a[1] / b[1] for a, b in zip(rows[name], rows["core"])]
        print("%s: wall %s s, CPU %s s; CPU / bare core %s" % (
            label, summary([t[0] for t in rows[name]]), summary([t[1] for t in rows[name]]), summary(ratio)))
    print("F12 per frame beyond its core calls (Blender's frame change and pipeline, the add-on): %s ms of CPU; "
          "of it the calling thread %s ms, the other threads %s ms"
          % (summary(beside), summary(beside_calling), summary([a - b for a, b in zip(beside, beside_calling)])))
    print("F12's core calls: %s ms of CPU a frame, against the bare core's %s"
          % (summary(within), summary([t[1] / frames * 1e3 for t in rows["core"]])))
    print("bare core, %d frames at %dx%d, passes %s: wall %s s, CPU %s s" % (
        frames, width, height, ",".join(sorted(buffers)), summary([t[0] for t in rows["core"]]),
        summary([t[1] for t in rows["core"]])))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--res", default="1920x1080")
    ap.add_argument("--memory", action="store_true")
    ap.add_argument("--memory-child", choices=("f12", "f12-bands", "core"))
    ap.add_argument("--motion-blur", action="store_true")
    ap.add_argument("--samples", type=int, default=None, help="--motion-blur: 16; --memory: 1")
    ap.add_argument("--animation", action="store_true")
    args = ap.parse_args()
    width, height = map(int, args.res.split("x"))
    if args.memory_child:
        return memory_child(args.memory_child, width, height, args.samples or 1)
    if args.memory:
        return memory(width, height, args.repeats, args.samples or 1)
    if args.motion_blur:
        return motion_blur(width, height, args.samples or 16, args.repeats)
    if args.animation:
        return animation(width, height, args.repeats)
    module = ensure_extension(prog="bench_f12")
    export = sys.modules[module + ".export"]
    f12_through_bands = through_bands(sys.modules[module + ".engine"], lambda: bpy.ops.render.render())
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

        f12, bands, one = [], [], []
        for _ in range(args.repeats):  # interleaved, so that load changes hit all alike
            f12.append(timed(lambda: bpy.ops.render.render()))
            bands.append(timed(f12_through_bands))
            one.append(timed(direct))
        ratio = [a[1] / b[1] for a, b in zip(f12, one)]
        ratio_bands = [a[1] / b[1] for a, b in zip(bands, one)]
        print("%d sample%s at %dx%d: F12 wall %s s, CPU %s s | one core call wall %s s, CPU %s s | "
              "CPU ratio %s; through band results %s" % (
                  samples, "" if samples == 1 else "s", width, height, summary([t[0] for t in f12]),
                  summary([t[1] for t in f12]), summary([t[0] for t in one]), summary([t[1] for t in one]),
                  summary(ratio), summary(ratio_bands)))


if __name__ == "__main__":
    main()
