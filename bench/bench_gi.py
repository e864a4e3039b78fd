"""Benchmark: what global illumination (shading use_gi) costs per sample.

Two scenes, each rendered with GI off and on (Cycles' default limits: 12 bounces, 4 diffuse,
4 glossy), at --res with --threads, --samples samples per pixel:

  ball   the unit ball (mu = 0, red) over the flat white sea, a sun and a uniform world: the
         scene of tests/blender/test_gi_blender.py (GI there within 0.5 % of Cycles);
  julia  bench_core.py's peer quaternion Julia set over the same sea, sun and world: a fractal
         whose bounce rays march long and often hit the set again.

Rows are interleaved round by round (ball off, ball on, julia off, julia on) after one warm-up
round; the table gives medians (min-max) over --repeats rounds of the core's own timer
(stats["seconds"]) per sample, the process CPU seconds per sample, and the on/off ratio as the
median of the per-round ratios (wall and CPU), which cancels slow drifts of a shared machine's load.

    python bench/bench_gi.py [--repeats 5] [--res 320x240] [--samples 4] [--threads 2]
"""
from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

import bench_core as bc  # also puts the built wheel (build/wheel) on sys.path
from bench_core import OBJECT, machine, med, parse_res

uc = bc.uc

SUN = dict(type="sun", direction=(-0.25, 0.6, -0.75), color=(3.0, 3.0, 3.0))
FLOOR = dict(use_sea=True, sea_height=-1.0, sea_amplitude=0.0, sea_color=(0.8, 0.8, 0.8), sea_reflectivity=0.0)
WORLD = np.full((1, 1, 3), (0.25, 0.3, 0.35), np.float32)
BALL = dict(mu=(0.0, 0.0, 0.0, 0.0), max_iterations=32, threshold_mode="fixed", epsilon=1e-4,
            color=(0.8, 0.05, 0.05))
SCENES = {
    "ball": (BALL, uc.look_at((0.0, -5.0, 0.8), (0.0, 0.0, -0.5), (0.0, 0.0, 1.0))),
    "julia": (dict(OBJECT, color=(0.8, 0.6, 0.4)), uc.look_at(bc.EYE, bc.TARGET, bc.UP)),
}


def run(scene, gi, width, height, samples, threads):
    obj, matrix = SCENES[scene]
    cam = dict(matrix=matrix, projection=uc.perspective(bc.FOV_Y, width / height, 0.1, 100.0), width=width,
               height=height)
    passes = {"combined": np.zeros((height, width, 4), np.float32)}
    shading = dict(FLOOR, axle_light=0.0, shadows="hard", lights=[SUN], world_samples=1, samples=samples,
                   use_gi=gi)
    c0 = time.process_time()
    stats = uc.render(cam, [obj], passes, threads=threads, world=WORLD, shading=shading)
    return stats["seconds"] / samples, (time.process_time() - c0) / samples


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--res", default="320x240")
    ap.add_argument("--samples", type=int, default=4)
    ap.add_argument("--threads", type=int, default=2)
    args = ap.parse_args(argv)
    W, H = parse_res(args.res, ap)
    rows = [(scene, gi) for scene in SCENES for gi in (False, True)]
    for row in rows:  # warm-up
        run(*row, W, H, args.samples, args.threads)
    wall = {row: [] for row in rows}
    cpu = {row: [] for row in rows}
    for _ in range(args.repeats):
        for row in rows:
            w, c = run(*row, W, H, args.samples, args.threads)
            wall[row].append(w)
            cpu[row].append(c)
    print(f"{machine()}; {W}x{H}, {args.samples} samples, {args.threads} threads, {args.repeats} rounds")
    print(f"{'scene':6} {'GI':4} {'wall s/sample':>26} {'CPU s/sample':>26}")
    for row in rows:
        print(f"{row[0]:6} {'on' if row[1] else 'off':4} {med(wall[row]):>26} {med(cpu[row]):>26}")
    for scene in SCENES:
        on, off = (scene, True), (scene, False)
        rw = statistics.median(a / b for a, b in zip(wall[on], wall[off]))
        rc = statistics.median(a / b for a, b in zip(cpu[on], cpu[off]))
        print(f"{scene}: GI on / off = {rw:.2f}x wall, {rc:.2f}x CPU")


if __name__ == "__main__":
    main()
