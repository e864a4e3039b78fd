"""Benchmark: the formula kinds' deep zoom (double, native/src/zoom_formulas.c) against their float32
kernels (issue 22), CPU time per iteration.

One view per kind: the camera 3 local units from an anchor on the surface (tests/native/
test_deep_zoom_formulas.py finds it with the float64 references), fixed threshold 1e-3 local units,
zoom 4 (the double path), against zoom 0 with the camera flown in by 10^4 and the threshold 10^4 finer,
at the same iteration count (the float32 kernels: the same view, the same rays). Interleaved, --repeats
times; printed: median wall and process CPU time (all threads), min-max, the core's iteration count,
CPU ns per iteration, and the ratio double / float32.

    python bench/bench_formula_zoom.py [--repeats 5] [--res 160x120] [--threads 2]
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "build" / "wheel"))
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "tests" / "native"))

import unbound_core as uc  # noqa: E402
import test_deep_zoom_formulas as views  # noqa: E402

ZOOM = 4


def run(camera, obj, threads):
    passes = {"depth": np.zeros((camera["height"], camera["width"], 1), np.float32)}
    wall, cpu = time.perf_counter(), time.process_time()
    stats = uc.render(camera, [obj], passes, threads=threads)
    return time.perf_counter() - wall, time.process_time() - cpu, stats["iterations"]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--res", default="160x120")
    ap.add_argument("--threads", type=int, default=2)
    args = ap.parse_args()
    width, height = (int(v) for v in args.res.split("x"))
    print("%s, %d threads, zoom %d, %d repeats; kernels %s" % (args.res, args.threads, ZOOM, args.repeats,
                                                                views.KERNELS))
    for name in ("mandelbulb", "mandelbox", "kifs", "hybrid"):
        text, anchor, direction = views.surface_anchor(name, ZOOM)
        iterations, _ = views.derived(name, ZOOM)
        scale = 10.0 ** -ZOOM
        runs = {
            "double": (views.view(direction, width, height), views.zoomed(name, ZOOM, text)),
            "float32": (views.view(direction, width, height, eye_scale=scale, center=anchor, clip=(1e-6, 10.0)),
                        dict(views.CASES[name], max_iterations=iterations, threshold_mode="fixed",
                             epsilon=views.EPSILON * scale)),
        }
        times = {k: [] for k in runs}
        count = {}
        for _ in range(args.repeats):
            for key, (camera, obj) in runs.items():
                wall, cpu, count[key] = run(camera, obj, args.threads)
                times[key].append((wall, cpu))
        ns = {}
        for key in runs:
            walls, cpus = zip(*times[key])
            ns[key] = statistics.median(cpus) / count[key] * 1e9
            print("  %-10s %-7s wall %.3f s (%.3f-%.3f)  cpu %.3f s  %d iterations  %.1f ns/iteration"
                  % (name, key, statistics.median(walls), min(walls), max(walls), statistics.median(cpus),
                     count[key], ns[key]))
        print("  %-10s double / float32: %.1fx per iteration" % (name, ns["double"] / ns["float32"]))


if __name__ == "__main__":
    main()
