"""What an artist's first scene costs, build against build (issue 21): Blender's factory startup
(its camera, point light and grey World), the cube deleted, one fractal added by Add > Unbound
Fractal with every default, the camera moved to 0.3 of its distance so that the fractal fills
the frame, F12 at 1920x1080 through Blender's pipeline. The defaults light it the way Cycles
would: the World as a light (one pair of samples a hit, each with a shadow ray) and the point
light's hard shadow; most of the time is those shadow rays.

Each build (an extension zip, `make extension`) renders in its own Blender process with a private
user directory; the builds alternate round by round. Per round and build: process CPU seconds of
F12 (after one warm-up F12), then with the World's samples off, then with shadows off too (where
the time goes). Medians (min-max) and the ratio of the first build's medians to each other's.

    python bench/bench_default_scene.py A.zip [B.zip ...] [--rounds 3] [--res 1920x1080]
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile

CHILD = r'''
import json, os, sys, time
sys.path.insert(0, os.path.join(sys.argv[1], os.pardir, "bench"))
from blender_user import private_user_directory
private_user_directory()  # before bpy starts
import bpy
sys.path.insert(0, sys.argv[1])
from unbound_extension import ENGINE_ID, ensure_extension
zip_path, width, height = sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
bpy.ops.wm.read_factory_settings(use_empty=False)
ensure_extension(zip_path, prog="bench_default_scene")
scene = bpy.context.scene
bpy.data.objects.remove(bpy.data.objects["Cube"])
scene.render.engine = ENGINE_ID
scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = width, height, 100
bpy.ops.object.unbound_fractal_add(use_cursor=False)
scene.camera.location = scene.camera.location * 0.3

def f12():
    c = time.process_time()
    bpy.ops.render.render()
    return time.process_time() - c

f12()
rows = {"default": f12()}
scene.unbound.world_samples = 0
rows["World samples 0"] = f12()
scene.unbound.shadows = 'NONE'
rows["World samples 0, no shadows"] = f12()
print("ROWS " + json.dumps(rows))
'''


def summary(values):
    return "%.3f (%.3f-%.3f)" % (statistics.median(values), min(values), max(values))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("zips", nargs="+")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--res", default="1920x1080")
    args = ap.parse_args(argv)
    width, height = (int(v) for v in args.res.split("x"))
    examples = os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, "examples")
    cpu = {z: {} for z in args.zips}
    for _ in range(args.rounds):
        for z in args.zips:
            with tempfile.TemporaryDirectory() as cwd:
                out = subprocess.run([sys.executable, "-c", CHILD, examples, os.path.abspath(z), str(width),
                                      str(height)], capture_output=True, text=True, check=True, cwd=cwd).stdout
            rows = json.loads(next(line for line in out.splitlines() if line.startswith("ROWS "))[5:])
            for name, seconds in rows.items():
                cpu[z].setdefault(name, []).append(seconds)
    first = args.zips[0]
    print("default scene close-up, %dx%d, F12 CPU seconds, %d rounds, medians (min-max):" % (width, height, args.rounds))
    for name in cpu[first]:
        print("  " + name)
        for z in args.zips:
            ratio = statistics.median(cpu[first][name]) / statistics.median(cpu[z][name])
            print("    %s: %s s%s" % (z, summary(cpu[z][name]), "" if z == first else "; %s / this %.3f" % (first, ratio)))


if __name__ == "__main__":
    main()
