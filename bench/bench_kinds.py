"""Benchmark: render time and marching steps per ray of each fractal kind of the native core.

One object per kind (``KINDS`` below), each seen through its own camera that frames it (z up,
perspective), with the default shading (axle light, Lambert, no lights) and the passes combined,
alpha and depth:

  quaternion Julia (the peer scene of bench_core.py: mu = -0.2+0.8i, 16 iterations, camera (-2,-2,1)
  looking at the origin, vertical FOV 53.13 degrees), a quaternion Mandelbrot slice (the (1, i, k)
  slice, 24 iterations), a Julia stack (c on the real segment -1.75 .. 0.25, height 2, 32
  iterations), the cubic connectedness locus (both components, extent 2, 24 iterations), the
  Sierpinski tetrahedron (IFS, the default maps, depth 7) and the Menger sponge (IFS, 20 maps of
  scale 1/3, depth 4).

Each row is labelled with ``unbound_core.describe(obj)["exact"]``: "exact" where the distance
estimate is proven never to overshoot (marched with step factor 1), "empirical" where it is not (the
core then marches with describe()'s step_factor and max_step, which costs steps).

All kinds render at --res with --threads, timed by the core's own timer (stats["seconds"]). Rows are
interleaved round by round (julia, mandelbrot, stack, ..., julia, mandelbrot, ...) after one warm-up
round; the table gives medians (min-max) over --repeats rounds, the ratio to the quaternion Julia row
as the median of the per-round ratios (each round's time over the same round's Julia time, which
cancels slow drifts of the machine's load), Mrays/s (primary rays, i.e. pixels, over the median
time), the fraction of pixels that hit the object (alpha > 0.5), and marching steps and formula
iterations per primary ray (stats["steps"], stats["iterations"] over stats["rays"]; the DE
evaluations of normals are counted in neither). Different kinds cover different fractions of their
images and have different iteration costs, so the rows compare what a user pays for a framed view of
each kind, not the kernels alone.

    python bench/bench_kinds.py [--repeats 3] [--res 640x480] [--threads 2] [--out bench/out/kinds]

Writes one PNG per kind (combined pass) and results.json into --out.
"""
from __future__ import annotations

import argparse
import itertools
import json
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

import bench_core as bc  # also puts the built wheel (build/wheel) and native/ on sys.path
from bench_core import FOV_Y, REPO, machine, med, parse_res, to_u8, write_png

uc = bc.uc

UP = (0.0, 0.0, 1.0)
FOV = 0.7  # radians, vertical (40.1 degrees), as tests/native/conftest.py's make_camera

# The Menger sponge: the 20 of the 27 sub-cubes of scale 1/3 that are not a face centre or the centre.
MENGER_MAPS = [[[1 / 3, 0.0, 0.0, 2 * x / 3], [0.0, 1 / 3, 0.0, 2 * y / 3], [0.0, 0.0, 1 / 3, 2 * z / 3]]
               for x, y, z in itertools.product((-1, 0, 1), repeat=3) if abs(x) + abs(y) + abs(z) > 1]

# (key, name, object, eye, target, vertical fov in radians)
KINDS = [
    ("qjulia", "quaternion Julia mu=-0.2+0.8i, 16 it",
     dict(kind="quaternion_julia", mu=(-0.2, 0.8, 0.0, 0.0), max_iterations=16),
     (-2.0, -2.0, 1.0), (0.0, 0.0, 0.0), FOV_Y),
    ("qmandelbrot", "quaternion Mandelbrot (1,i,k) slice, 24 it",
     dict(kind="quaternion_mandelbrot", max_iterations=24,
          slice_basis=[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 1.0]]),
     (-1.2, -3.6, 2.0), (-0.5, 0.0, 0.0), FOV),
    ("julia_stack", "Julia stack c in [-1.75, 0.25], h 2, 32 it",
     dict(kind="julia_stack", path=[(-1.75, 0.0), (0.25, 0.0)], stack_height=2.0, max_iterations=32),
     (-3.2, -5.2, 3.0), (0.0, 0.0, -0.1), FOV),
    ("cubic_locus", "cubic locus, both components, 24 it",
     dict(kind="cubic_locus", cubic_component="both", extent=2.0, max_iterations=24),
     (-2.2, -3.4, 2.0), (0.0, 0.0, 0.0), FOV),
    ("sierpinski", "IFS Sierpinski tetrahedron, depth 7",
     dict(kind="ifs", ifs_depth=7),
     (-2.4, -4.2, 1.9), (0.0, 0.0, 0.0), FOV),
    ("menger", "IFS Menger sponge (20 maps), depth 4",
     dict(kind="ifs", maps=MENGER_MAPS, ifs_depth=4),
     (-3.0, -4.4, 2.9), (0.0, 0.0, 0.0), FOV),
]
BASE = "qjulia"
PASSES = ("combined", "alpha", "depth")


def kind_camera(case, width, height):
    _, _, _, eye, target, fov = case
    return dict(matrix=uc.look_at(eye, target, UP), projection=uc.perspective(fov, width / height, 0.1, 100.0),
                width=width, height=height)


def run_kind(case, width, height, threads, names=PASSES):
    obj = case[2]
    passes = {n: np.zeros((height, width, uc.PASS_CHANNELS[n]), np.float32) for n in names}
    c0 = time.process_time()
    stats = uc.render(kind_camera(case, width, height), [dict(obj)], passes, threads=threads, shading=None)
    return dict(stats, cpu_s=time.process_time() - c0), passes


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--res", default="640x480")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--out", default=str(REPO / "bench" / "out" / "kinds"))
    args = ap.parse_args(argv)
    W, H = parse_res(args.res, ap)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    mach = machine()
    load0 = os.getloadavg()
    print(f"machine: nproc {mach['nproc']}, {mach['cpu']}, AVX2+FMA {mach['simd_avx2_fma']}; "
          f"python {mach['python']}, numpy {mach['numpy']}")
    print(f"scenes: {len(KINDS)} kinds {W}x{H}, {args.threads} threads, default shading; {args.repeats} "
          f"interleaved rounds after one warm-up; load average {load0[0]:.2f}")

    desc = {case[0]: uc.describe(case[2]) for case in KINDS}

    # Warm-up round (not counted); its images are written out and give the hit coverage.
    coverage = {}
    for case in KINDS:
        _, img = run_kind(case, W, H, args.threads)
        coverage[case[0]] = float(np.mean(img["alpha"][..., 0] > 0.5))
        write_png(out / f"{case[0]}.png", to_u8(img["combined"][::-1, :, :3]))

    T = {c[0]: [] for c in KINDS}
    for i in range(args.repeats):
        for case in KINDS:
            T[case[0]].append(run_kind(case, W, H, args.threads)[0])
        line = " ".join(f"{k} {T[k][-1]['seconds']:.3f}" for k in T)
        print(f"  round {i + 1}: {line} s", flush=True)

    rep = dict(machine=mach, date=time.strftime("%Y-%m-%d %H:%M %Z"), res=[W, H], threads=args.threads,
               repeats=args.repeats, loadavg_start=load0, kinds={})
    base_sec = [t["seconds"] for t in T[BASE]]
    t0 = T[BASE][0]
    print(f"\nnative core {W}x{H}, {t0['threads']} threads, simd {t0['simd']}; "
          f"x julia = median of per-round ratios; hits = pixels with alpha > 0.5")
    print("| kind | DE | seconds, median (min–max) | × julia | Mrays/s | hits | steps/ray | iterations/ray "
          "| cpu/wall |")
    print("|---|---|---|---|---|---|---|---|---|")
    rows = {}
    for case in KINDS:
        key, name, obj = case[0], case[1], case[2]
        runs = T[key]
        sec = [t["seconds"] for t in runs]
        ms = statistics.median(sec)
        ratio = statistics.median([s / b for s, b in zip(sec, base_sec)])
        r0 = runs[0]
        d = desc[key]
        exact = "exact" if d["exact"] else "empirical"
        cpu_wall = statistics.median([t["cpu_s"] / t["seconds"] for t in runs])
        row = dict(name=name, exact=bool(d["exact"]), step_factor=d["step_factor"], max_step=d["max_step"],
                   bound_radius=d["bound_radius"], seconds=sec, median_s=ms, ratio_to_julia=ratio,
                   rays=r0["rays"], steps=r0["steps"], iterations=r0["iterations"],
                   mrays_per_s=r0["rays"] / ms / 1e6, steps_per_ray=r0["steps"] / r0["rays"],
                   iterations_per_ray=r0["iterations"] / r0["rays"], hit_fraction=coverage[key],
                   cpu_over_wall=cpu_wall, object=obj, eye=case[3], target=case[4], fov_y=case[5])
        # max_step may be inf, which json cannot write
        row["max_step"] = None if row["max_step"] == float("inf") else row["max_step"]
        rows[key] = row
        print(f"| {name} | {exact} | {med(sec)} | {ratio:.2f} | {row['mrays_per_s']:.2f} | {coverage[key]:.3f} | "
              f"{row['steps_per_ray']:.2f} | {row['iterations_per_ray']:.1f} | {cpu_wall:.2f} |")
    rep["kinds"] = rows

    load = os.getloadavg()
    rep["loadavg_end"] = load
    (out / "results.json").write_text(json.dumps(rep, indent=1))
    print(f"\nload average at the end {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} (other jobs on the machine skew all "
          f"timings; cpu/wall near {args.threads} means the core's threads really ran in parallel)")
    print(f"images and results.json in {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
