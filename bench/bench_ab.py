"""A/B of two builds of the native core, interleaved: each round renders with build A, then with
build B, each in a fresh subprocess (so the two never share a process or its caches), and reads the
process CPU seconds of one render (after one warm-up render into the same buffers). Reports the
medians (min-max) per build, the ratio A/B of the medians, and a digest of every pass per build:
a change meant to keep the pixels must show the same digest.

Scenes (bench_core.py's peer scene, quaternion Julia set mu = -0.2+0.8i, 16 iterations, camera
(-2,-2,1) looking at the origin):
  peer  1280x1024, passes combined, alpha, depth, the default shading (the axle light);
  all   640x512, every pass, bench_effects.py's "everything" row (a soft sun with shadows, AO,
        reflections and the sea, fog, glow, 4 samples);
  NAME  640x512, passes combined, alpha, depth, any other row of bench_effects.py (hard, soft, ao,
        reflect, sea, fog, glow, samples4, n_potential, n_zbuffer, n_analytic);
  world 640x512, passes combined, alpha, depth, the "hard" row with a grey World as a light (a 1x1
        map, one sample a hit): the shading of an artist's first scene, most of it shadow rays.

A build is a directory holding the unpacked wheel (`build/wheel` after `make wheel`; copy it
aside before rebuilding the other). Each build is run from --copies fresh copies of it, taken in
turn: on this project's virtual machines the same bytes measured up to 6.5 % apart from one file
to another (the file `make wheel` wrote against a copy of it; two copies 2 % apart, every round,
either order), which is where the copy's pages happen to lie in memory, not the build.

    python bench/bench_ab.py OLD/wheel NEW/wheel [--scene peer|all|world|NAME] [--rounds 6] [--threads 1] [--copies 3]
        [--simd auto|avx512|avx2|portable] [--paired N]

With --paired N each round is one process holding both builds, N renders of each alternated, and
the figure is the median of the ratios of adjacent renders (with quartiles): on hosts whose speed
changes for minutes at a time (other guests), this resolves 1-2 % where medians over processes
cannot.
"""
from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile

SCENE = r'''
import sys, time, math, hashlib
sys.path.insert(0, sys.argv[1])
sys.path.insert(0, sys.argv[2])
import numpy as np, unbound_core as uc
import bench_effects as fx
scene, threads, simd = sys.argv[3], int(sys.argv[4]), sys.argv[5]
W, H = (1280, 1024) if scene == "peer" else (640, 512)
cam = dict(matrix=uc.look_at((-2.0, -2.0, 1.0), (0, 0, 0), (0, 0, 1)),
           projection=uc.perspective(2 * math.atan(0.5), W / H, 0.1, 100.0), width=W, height=H)
obj = dict(mu=(-0.2, 0.8, 0.0, 0.0), max_iterations=16, bailout=4.0)
names, shading, world = ("combined", "alpha", "depth"), {}, None
if scene == "world":  # an artist's first scene: a grey World as a light, and a hard-shadowed sun
    shading = [c for c in fx.CASES if c[0] == "hard"][0][3]
    world = np.full((1, 1, 3), 0.5, np.float32)
elif scene != "peer":
    _, _, over, shading = [c for c in fx.CASES if c[0] == scene][0]
    obj = dict(obj, **over)
    names = uc.PASSES if scene == "all" else names
# Passes on cache lines as the add-on's (unbound_core.pass_array); older builds lack it.
new_pass = getattr(uc, "pass_array", lambda h, w, c: np.zeros((h, w, c), np.float32))

def digest(p):
    return hashlib.sha256(b"".join(p[n].tobytes() for n in sorted(p))).hexdigest()[:16]
'''

# One render of one build (after one warm-up into the same buffers): its CPU seconds and digest.
CHILD = SCENE + r'''
p = {n: new_pass(H, W, uc.PASS_CHANNELS[n]) for n in names}
uc.render(cam, [obj], p, shading=shading, threads=threads, simd=simd, world=world)
c0 = time.process_time()
uc.render(cam, [obj], p, shading=shading, threads=threads, simd=simd, world=world)
c = time.process_time() - c0
print(c, digest(p))
'''

# --paired: both builds' compiled modules in this one process (the second loaded from its own file
# under the same name), their renders alternated A B, B A, ...: each pair of renders runs at the
# same moment of the host, so its ratio is free of the minutes-long slow spells the host's other
# guests cause (bench/README.md, 2026-12-05 22:49), which a median over processes is not.
CHILD_PAIRED = SCENE + r'''
import glob, importlib.machinery, importlib.util
path = glob.glob(sys.argv[6] + "/unbound_core/_native*")[0]
loader = importlib.machinery.ExtensionFileLoader("unbound_core._native", path)
other = importlib.util.module_from_spec(importlib.util.spec_from_loader("unbound_core._native", loader, origin=path))
loader.exec_module(other)
cores = (uc, other)
p = [{n: new_pass(H, W, uc.PASS_CHANNELS[n]) for n in names} for _ in cores]
def run(k):
    c0 = time.process_time()
    cores[k].render(cam, [obj], p[k], shading=shading, threads=threads, simd=simd, world=world)
    return time.process_time() - c0
for k in (0, 1):
    run(k)
cpu = ([], [])
for i in range(int(sys.argv[7])):
    for k in ((0, 1) if i % 2 == 0 else (1, 0)):
        cpu[k].append(run(k))
print(" ".join("%.6f" % c for c in cpu[0]))
print(" ".join("%.6f" % c for c in cpu[1]))
print(digest(p[0]), digest(p[1]))
'''


def paired(args, builds, copies, bench_dir):
    """--paired: per round one process holding both builds (fresh copies, taken in turn), N renders
    of each alternated; the ratio of each adjacent pair of renders, their median and quartiles."""
    cpu, ratios, digests = ([], []), [], set()
    for r in range(args.rounds):
        out = subprocess.run([sys.executable, "-c", CHILD_PAIRED, copies[builds[0]][r % args.copies], bench_dir,
                              args.scene, str(args.threads), args.simd, copies[builds[1]][r % args.copies],
                              str(args.paired)], capture_output=True, text=True, check=True).stdout.split("\n")
        a, b = ([float(x) for x in line.split()] for line in out[:2])
        cpu[0].extend(a)
        cpu[1].extend(b)
        ratios.extend(x / y for x, y in zip(a, b))
        digests.add(tuple(out[2].split()))
    for b, v in zip(builds, cpu):
        print("%s: median %.4f s CPU (%.4f-%.4f)" % (b, statistics.median(v), min(v), max(v)))
    q = statistics.quantiles(ratios, n=4)
    same = all(d[0] == d[1] for d in digests)
    print("paired ratio A/B %.3f (quartiles %.3f-%.3f; %s scene, %d thread(s), %s kernel, %d rounds of %d pairs)%s"
          % (statistics.median(ratios), q[0], q[2], args.scene, args.threads, args.simd, args.rounds, args.paired,
             ", passes %s" % sorted(digests)[0][0] if same else "; THE PASSES DIFFER"))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("build_a")
    ap.add_argument("build_b")
    ap.add_argument("--scene", default="peer", help="peer, or a row of bench_effects.py (all, hard, ...)")
    ap.add_argument("--rounds", type=int, default=6)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--copies", type=int, default=3, help="fresh copies of each build, run in turn")
    ap.add_argument("--simd", default="auto", help="the kernel: auto, avx512, avx2 or portable")
    ap.add_argument("--paired", type=int, default=0, metavar="N",
                    help="both builds in each round's process, N renders of each alternated")
    args = ap.parse_args(argv)
    bench_dir = __file__.rsplit("/", 1)[0] if "/" in __file__ else "."
    builds = (args.build_a, args.build_b)
    cpu = {b: [] for b in builds}
    digest = {}
    with tempfile.TemporaryDirectory(dir=os.path.dirname(os.path.abspath(args.build_a))) as tmp:
        copies = {b: [shutil.copytree(b, os.path.join(tmp, "%d-%d" % (i, k))) for k in range(args.copies)]
                  for i, b in enumerate(builds)}
        if args.paired:
            return paired(args, builds, copies, bench_dir)
        for r in range(args.rounds):
            for b in builds:
                out = subprocess.run([sys.executable, "-c", CHILD, copies[b][r % args.copies], bench_dir, args.scene,
                                      str(args.threads), args.simd], capture_output=True, text=True, check=True).stdout.split()
                cpu[b].append(float(out[0]))
                digest[b] = out[1]
    for b in builds:
        v = cpu[b]
        print("%s: median %.4f s CPU (%.4f-%.4f), passes %s" % (b, statistics.median(v), min(v), max(v), digest[b]))
    print("ratio A/B %.3f (%s scene, %d thread(s), %s kernel, %d rounds)%s" % (
        statistics.median(cpu[builds[0]]) / statistics.median(cpu[builds[1]]), args.scene, args.threads,
        args.simd, args.rounds, "" if digest[builds[0]] == digest[builds[1]] else "; THE PASSES DIFFER"))


if __name__ == "__main__":
    main()
