"""Fraction of the FMA peak and thread scaling on the peer scene (issue 21).

The peak is measured, not taken from a data sheet: `fma_peak.c` (built here with the system C
compiler) runs twelve independent FMA chains per vector width on one core, best of three. The
render's FLOP are counted as issue 21 counts them: 24 per quaternion iteration of the estimate
(z <- z^2 + mu and |z|^2, with FMA: 1 + 8 + 3 x 2 for the square, 7 for the norm, 2 for the running
derivative), times the iterations of f the render runs: `stats["iterations"]` (the march, its cones
and its bisection) plus `stats["normal_iterations"]` (the six estimates of each hit's central
differences, the same iteration; counted since 2026-12-01, before that the figure was the march's
alone, which it also prints). GFLOP/s per core = FLOP / process CPU seconds of the whole call.
Since 2026-12-05 the core carries the iteration's vector part as |v|^2 and 2 v.mu_v, since
2026-12-06 doubled (estimators.h, doubled_step): an iteration now executes 14 FLOP (4(a^2 + mu_0): 2;
2a' from it and 2|v|^2: 2; the next 2|v|^2 and 2s: 6; 4|z|^2: 3; the derivative: 1; it was 15 from
12-05 and 14 with Horner's form), so the same iterations are also reported by the FLOP they execute; the issue's count (24) stays the headline, the work of a
quaternion iteration, comparable with the figures before.

Each kernel (avx512, avx2) renders the peer scene (bench_core.py's camera and object, 1280x1024,
passes combined, alpha, depth) on 1 and 2 threads, interleaved, after a warm-up; medians (min-max).
Thread scaling: wall 1 thread / wall 2 threads, and CPU 2 threads / CPU 1 thread (1.00: no CPU
spent on threading); the wall figure needs a quiet machine. Beside it, what the machine itself does
to two busy cores (clock, shared caches, the host): the same 1-thread render in two processes at
once, their CPU per render against one process alone (`--pair`).

With --ceiling, what the iteration loop itself reaches: `estimate()` (since 2026-12-05 two packets at
a time, the loop of the march's pairs; before, one packet's, whose chain of dependent operations left
half of a Xeon's two 512-bit FMA ports idle) with mu = -1/2 on points near
its attracting fixed point (1 - sqrt 3) / 2 (no lane ever escapes, so every lane iterates
max_iterations times, all 16 busy; the orbits converge at the rate 0.73 per step, so no value
becomes subnormal, which would cost microcode assists the render does not pay),
at max_iterations 16 and 80; the difference of the two CPU times is 64 iterations per point with
no per-call cost (the slope). That loop rate is the most the whole render could reach if it did
nothing but iterate; the render's fraction of it is the share of its time that is useful iteration.

    python bench/bench_flops.py [--repeats 5] [--res 1280x1024] [--pair] [--ceiling]
"""
from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import bench_core  # noqa: E402  (puts the built module on the path)
import unbound_core as uc  # noqa: E402

FLOP_PER_ITERATION = 24
FLOP_EXECUTED_PER_ITERATION = 14
WIDTHS = {"avx512": "1", "avx2": "0"}


def measured_peaks(kernels):
    """GFLOP/s of one core per kernel's vector width, from fma_peak.c; {} without a C compiler."""
    cc = os.environ.get("CC", "cc")
    with tempfile.TemporaryDirectory() as tmp:
        exe = os.path.join(tmp, "fma_peak")
        try:
            subprocess.run([cc, "-O2", str(HERE / "fma_peak.c"), "-o", exe], check=True, capture_output=True)
        except (OSError, subprocess.CalledProcessError) as e:
            print("no FMA peak: cannot build fma_peak.c (%s)" % e)
            return {}
        peaks = {}
        for kernel in kernels:
            out = subprocess.run([exe, WIDTHS[kernel]], check=True, capture_output=True, text=True).stdout
            peaks[kernel] = max(float(line.split()[1]) for line in out.split("\n") if line.strip())
        return peaks


_passes = {}


def render(width, height, threads, simd):
    cam = bench_core.camera(width, height)
    # Kept from one render to the next, as the add-on keeps its band buffers (engine.BandBuffers):
    # fresh buffers from the allocator cost their page faults in some renders and not in others.
    passes = _passes.setdefault((width, height), {n: uc.pass_array(height, width, uc.PASS_CHANNELS[n])
                                                  for n in ("combined", "alpha", "depth")})
    c0, t0 = time.process_time(), time.perf_counter()
    stats = uc.render(cam, [bench_core.OBJECT], passes, threads=threads, simd=simd)
    return (time.process_time() - c0, time.perf_counter() - t0, stats["iterations"] + stats["normal_iterations"],
            stats["iterations"])


PAIR_CHILD = r"""
import sys, time
sys.path.insert(0, sys.argv[1])
import bench_flops
bench_flops.render(1280, 1024, 1, sys.argv[2])
cpu = [bench_flops.render(1280, 1024, 1, sys.argv[2])[0] for _ in range(int(sys.argv[3]))]
print(" ".join("%.5f" % c for c in cpu))
"""


def pair(kernel, renders=8):
    """CPU seconds per 1-thread render: one process alone, then two at once (each its own core)."""
    def start():
        return subprocess.Popen([sys.executable, "-c", PAIR_CHILD, str(HERE), kernel, str(renders)],
                                stdout=subprocess.PIPE, text=True)

    def cpu_of(procs):
        return [float(x) for p in procs for x in p.communicate()[0].split()]

    alone = cpu_of([start()])
    together = cpu_of([start(), start()])
    return alone, together


def loop_gflops(kernel, points=1 << 19, low=16, high=80, repeats=5):
    """GFLOP/s of the iteration loop alone (slope between two iteration counts, every lane busy)."""
    pts = ((np.random.default_rng(1).random((points, 3)) - 0.5) * 0.4).astype(np.float32)  # |p| < 0.35
    est, its = np.zeros(points, np.float32), np.zeros(points, np.float32)

    def cpu(max_iterations):
        obj = dict(mu=(-0.5, 0.0, 0.0, 0.0), max_iterations=max_iterations, bailout=4.0)
        best = float("inf")
        for _ in range(repeats):
            c0 = time.process_time()
            uc.estimate(obj, pts, est, its, simd=kernel)
            best = min(best, time.process_time() - c0)
        assert np.all(its == max_iterations), "a lane escaped: not every lane iterated"
        return best

    t_low, t_high = cpu(low), cpu(high)
    return FLOP_PER_ITERATION * points * (high - low) / (t_high - t_low) * 1e-9


def med(values):
    return "%.4g (%.4g-%.4g)" % (statistics.median(values), min(values), max(values))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--res", default="1280x1024")
    ap.add_argument("--pair", action="store_true", help="also two 1-thread processes at once")
    ap.add_argument("--ceiling", action="store_true", help="also the iteration loop's own rate")
    args = ap.parse_args()
    width, height = map(int, args.res.split("x"))
    info = uc.cpu_info()
    kernels = [k for k in ("avx512", "avx2") if info[{"avx512": "avx512", "avx2": "avx2_fma"}[k]]]
    peaks = measured_peaks(kernels)
    runs = {(k, t): [] for k in kernels for t in (1, 2)}
    for k in kernels:  # warm-up
        render(width, height, 2, k)
    for _ in range(args.repeats):
        for key in runs:
            runs[key].append(render(width, height, key[1], key[0]))
    print("peer scene %dx%d, %d repeats, load average %s" % (width, height, args.repeats,
                                                            " ".join("%.2f" % x for x in os.getloadavg())))
    for k in kernels:
        one, two = runs[(k, 1)], runs[(k, 2)]
        gflops = [FLOP_PER_ITERATION * it / cpu * 1e-9 for cpu, _, it, _ in one + two]
        march = [FLOP_PER_ITERATION * it / cpu * 1e-9 for cpu, _, _, it in one + two]
        print("%s: CPU s 1 thread %s, 2 threads %s; wall s 1 thread %s, 2 threads %s" % (
            k, med([r[0] for r in one]), med([r[0] for r in two]), med([r[1] for r in one]), med([r[1] for r in two])))
        print("  %.1f M iterations per render (%.1f M the march's, %.1f M the normals'); %s GFLOP/s per core" % (
            one[0][2] * 1e-6, one[0][3] * 1e-6, (one[0][2] - one[0][3]) * 1e-6, med(gflops)))
        if k in peaks:
            print("  measured FMA peak %.1f GFLOP/s per core: %s %% of it (the march's iterations alone: %s %%)" % (
                peaks[k], med([100.0 * g / peaks[k] for g in gflops]), med([100.0 * g / peaks[k] for g in march])))
            # The two halves of that median apart: on some hosts a second thread in the same
            # process costs CPU that a second process does not (bench/README.md, 2026-12-04).
            print("  of the peak: 1 thread %s %%, 2 threads %s %%" % tuple(
                med([100.0 * g / peaks[k] for g in gflops[i * len(one):(i + 1) * len(one)]]) for i in (0, 1)))
            print("  by the FLOP an iteration executes (%d, not %d): %s %% of the peak" % (
                FLOP_EXECUTED_PER_ITERATION, FLOP_PER_ITERATION, med([100.0 * g * FLOP_EXECUTED_PER_ITERATION
                                                                       / FLOP_PER_ITERATION / peaks[k] for g in gflops])))
        if args.ceiling:
            loop = loop_gflops(k)
            print("  the iteration loop alone (every lane busy): %.1f GFLOP/s per core%s; the render %s %% of it"
                  % (loop, " = %.0f %% of the peak" % (100.0 * loop / peaks[k]) if k in peaks else "",
                     med([100.0 * g / loop for g in gflops])))
        print("  thread scaling 1 -> 2: wall %s x, CPU 2 threads / 1 thread %s" % (
            med([a[1] / b[1] for a, b in zip(one, two)]), med([b[0] / a[0] for a, b in zip(one, two)])))
        if args.pair:
            alone, together = pair(k)
            print("  1-thread render, CPU s: one process alone %s, two processes at once %s (ratio %.3f)" % (
                med(alone), med(together), statistics.median(together) / statistics.median(alone)))


if __name__ == "__main__":
    main()
