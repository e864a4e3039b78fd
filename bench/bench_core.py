"""Benchmark: Unbound's native core against a float64 numpy reference and against Mandelbulber2.

The scene is the peer scene of ``<shared>/peer/README.md``: quaternion Julia set mu = -0.2+0.8i,
16 iterations, bailout 4, camera at (-2,-2,1) looking at the origin (z up), vertical FOV 53.13
degrees, hit threshold one pixel footprint, Lambert. In one run, interleaved (A B C A B C ...):

  A  native core (``unbound_core.render``) at --res with --threads: the core's own timer
     (stats["seconds"]) and the whole call wall time including allocating the passes;
  B  the numpy reference (``reference.qjulia64.render``) at the small --ref-res, single-threaded;
  C  Mandelbulber2 at --res with limit_CPU_cores=--threads: whole-process wall time (start-up,
     render, PNG write: what the peer costs a user) and its CPU seconds.

Then it checks that both programs draw the same object: IoU of Mandelbulber's silhouette mask
(SILHOUETTE_OVERRIDES) with the native alpha pass, and writes the images into --out.

    python bench/bench_core.py [--repeats 3] [--res 1280x1024] [--threads 2]
                               [--ref-res 160x128] [--no-peer] [--out bench/out]

Target: the native core at least 10x faster than Mandelbulber2.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import platform
import statistics
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
# The wheel `make wheel` built and unpacked; an in-place build of native/ as a fallback.
sys.path.insert(0, str(REPO / "native"))
sys.path.insert(0, str(REPO / "build" / "wheel"))
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "bench"))

import unbound_core as uc  # noqa: E402
from reference import qjulia64  # noqa: E402

import OpenImageIO as oiio  # noqa: E402  (requirements-dev.txt)

OBJECT = dict(mu=(-0.2, 0.8, 0.0, 0.0), max_iterations=16, bailout=4.0)
EYE, TARGET, UP = (-2.0, -2.0, 1.0), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0)
FOV_Y = 2.0 * math.atan(0.5)  # 53.13 degrees, Mandelbulber's fov 1
TARGET_SPEEDUP = 10.0


def camera(width, height):
    return dict(matrix=uc.look_at(EYE, TARGET, UP), projection=uc.perspective(FOV_Y, width / height, 0.1, 100.0),
                width=width, height=height)


# ------------------------------------------------------------------------------------- PNG I/O

def write_png(path, img):
    """img: uint8 (H, W) or (H, W, C), row 0 = top."""
    img = np.ascontiguousarray(img)
    if img.ndim == 2:
        img = img[:, :, None]
    h, w, c = img.shape
    out = oiio.ImageOutput.create(str(path))
    out.open(str(path), oiio.ImageSpec(w, h, c, "uint8"))
    out.write_image(img)
    out.close()


def read_png(path, as_float=False):
    """8-bit PNG -> uint8 (H, W, C); as_float: a PNG of any bit depth -> float32 in [0, 1]. Row 0 = top."""
    buf = oiio.ImageBuf(str(path))
    pixels = buf.get_pixels(oiio.FLOAT if as_float else oiio.UINT8)
    if pixels is None or buf.has_error:
        raise RuntimeError(f"cannot read {path}: {buf.geterror()}")
    return np.asarray(pixels, np.float32) if as_float else np.asarray(pixels)


def iou(a, b):
    """Intersection over union of two boolean masks (1 when both are empty)."""
    union = np.sum(a | b)
    return float(np.sum(a & b) / union) if union else 1.0


def to_u8(linear):
    """Linear [0, 1] -> 8 bit with no transfer function (Mandelbulber's gamma 1 too)."""
    return (np.clip(linear, 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)


# ---------------------------------------------------------------------------------- the runs

def run_native(width, height, threads, names=("combined", "alpha", "depth")):
    cam = camera(width, height)
    c0, t0 = time.process_time(), time.perf_counter()
    passes = {n: uc.pass_array(height, width, uc.PASS_CHANNELS[n], zero=True) for n in names}
    stats = uc.render(cam, [OBJECT], passes, threads=threads)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    return dict(stats, wall_s=wall, cpu_s=cpu), passes


def run_reference(width, height):
    t0 = time.perf_counter()
    res = qjulia64.render(camera(width, height), OBJECT, width, height)
    return dict(seconds=time.perf_counter() - t0, rays=res["rays"], steps=res["steps"],
                iterations=res["iterations"]), res


def machine():
    model = "?"
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return dict(nproc=os.cpu_count(), cpu=model, python=platform.python_version(), numpy=np.__version__,
                simd_avx2_fma=uc.cpu_info()["avx2_fma"])


def med(values):
    return f"{statistics.median(values):.4g} ({min(values):.4g}-{max(values):.4g})"


def parse_res(text, ap):
    try:
        w, h = (int(v) for v in text.lower().split("x"))
        return w, h
    except ValueError:
        ap.error(f"bad resolution {text!r}, want WIDTHxHEIGHT")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--res", default="1280x1024")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--ref-res", default="160x128")
    ap.add_argument("--no-peer", action="store_true", help="skip Mandelbulber2")
    ap.add_argument("--out", default=str(REPO / "bench" / "out"))
    args = ap.parse_args(argv)
    W, H = parse_res(args.res, ap)
    RW, RH = parse_res(args.ref_res, ap)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    mach = machine()
    print(f"machine: nproc {mach['nproc']}, {mach['cpu']}, AVX2+FMA {mach['simd_avx2_fma']}; "
          f"python {mach['python']}, numpy {mach['numpy']}")
    print(f"scene: peer qjulia, native/peer {W}x{H} with {args.threads} threads, numpy reference {RW}x{RH}; "
          f"{args.repeats} interleaved repeats after one warm-up; load average {os.getloadavg()[0]:.2f}")

    peer = None
    if not args.no_peer:
        import peer_mandelbulber as peer
        peer.ensure_installed()
        fract = peer.shared_peer_dir() / "qjulia.fract"

    # Warm-up (not counted); the peer's silhouette render doubles as its warm-up.
    _, native_img = run_native(W, H, args.threads)
    ref_stats, ref_img = run_reference(RW, RH)
    _, native_small = run_native(RW, RH, args.threads)
    if peer:
        sil = peer.render(fract, W, H, args.threads, out / "peer_silhouette.png", overrides=peer.SILHOUETTE_OVERRIDES)

    A, B, C = [], [], []
    for i in range(args.repeats):
        A.append(run_native(W, H, args.threads)[0])
        B.append(run_reference(RW, RH)[0])
        if peer:
            r = peer.render(fract, W, H, args.threads, out / "peer.png")
            C.append(dict(wall_s=r["wall_s"], cpu_s=r["cpu_s"]))
        line = f"  round {i + 1}: native {A[-1]['seconds']:.4f} s (wall {A[-1]['wall_s']:.4f} s), " \
               f"numpy {B[-1]['seconds']:.3f} s"
        print(line + (f", mandelbulber2 {C[-1]['wall_s']:.2f} s" if peer else ""), flush=True)

    rep = dict(machine=mach, date=time.strftime("%Y-%m-%d %H:%M %Z"), res=[W, H], ref_res=[RW, RH],
               threads=args.threads, repeats=args.repeats)
    n_sec = [a["seconds"] for a in A]
    n_wall = [a["wall_s"] for a in A]
    a0 = A[0]
    rays, steps, iters = a0["rays"], a0["steps"], a0["iterations"]
    print(f"\nA native core {W}x{H}, {a0['threads']} threads, simd {a0['simd']}:")
    n_cpu = [a["cpu_s"] for a in A]
    print(f"  core seconds {med(n_sec)} s, whole call incl. passes {med(n_wall)} s, cpu {med(n_cpu)} s "
          f"(cpu/wall {statistics.median(n_cpu) / statistics.median(n_wall):.2f})")
    ns = statistics.median(n_sec)
    print(f"  {rays / ns / 1e6:.2f} Mrays/s, {iters / ns / 1e6:.1f} M iterations/s; per ray: "
          f"{steps / rays:.2f} steps, {iters / rays:.1f} iterations")
    rep["native"] = dict(seconds=n_sec, wall_s=n_wall, cpu_s=n_cpu, rays=rays, steps=steps,
                         iterations=iters, simd=a0["simd"], threads=a0["threads"])

    b_sec = [b["seconds"] for b in B]
    bs = statistics.median(b_sec)
    b0 = B[0]
    print(f"B numpy float64 reference {RW}x{RH}, 1 thread:")
    print(f"  {med(b_sec)} s, {b0['rays'] / bs / 1e3:.1f} krays/s, {b0['iterations'] / bs / 1e6:.2f} M iterations/s; "
          f"per ray: {b0['steps'] / b0['rays']:.2f} steps, {b0['iterations'] / b0['rays']:.1f} iterations")
    ratio_ray = (bs / b0["rays"]) / (ns / rays)
    ratio_it = (bs / b0["iterations"]) / (ns / iters)
    agree = float(np.mean((native_small["alpha"][..., 0] > 0.5) == ref_img["alpha"]))
    print(f"  numpy per-ray time / native per-ray time: {ratio_ray:.0f}x (per iteration {ratio_it:.0f}x); "
          f"native and numpy agree on {100 * agree:.2f}% of the {RW}x{RH} pixels")
    rep["numpy"] = dict(seconds=b_sec, rays=b0["rays"], steps=b0["steps"], iterations=b0["iterations"],
                        ratio_per_ray=ratio_ray, ratio_per_iteration=ratio_it, alpha_agreement=agree)

    # Images: native combined (flip rows: row 0 is the bottom), its mask, the numpy one.
    write_png(out / "native.png", to_u8(native_img["combined"][::-1, :, :3]))
    write_png(out / "native_alpha.png", to_u8(native_img["alpha"][::-1, :, 0]))
    write_png(out / "numpy_reference.png", to_u8(ref_img["combined"][::-1]))

    if peer:
        c_wall = [c["wall_s"] for c in C]
        cw = statistics.median(c_wall)
        print(f"C Mandelbulber2 {W}x{H}, limit_CPU_cores={args.threads}, whole process:")
        print(f"  wall {med(c_wall)} s, cpu {med([c['cpu_s'] for c in C])} s")
        speed = cw / ns
        print(f"  Mandelbulber2 wall / native core seconds: {speed:.0f}x; / native whole call: "
              f"{cw / statistics.median(n_wall):.0f}x  (target >= {TARGET_SPEEDUP:.0f}x: "
              f"{'met' if speed >= TARGET_SPEEDUP else 'NOT met'})")
        peer_mask = read_png(Path(sil["png"]).with_name(Path(sil["png"]).stem + "_alpha.png"))[..., 0] > 127
        ours = native_img["alpha"][::-1, :, 0] > 0.5
        sil_iou = iou(peer_mask, ours)
        print(f"  silhouette IoU (Mandelbulber2 alpha vs native alpha): {sil_iou:.4f}; coverage native "
              f"{ours.mean():.3f}, peer {peer_mask.mean():.3f}; only native {np.sum(ours & ~peer_mask)} px, "
              f"only peer {np.sum(peer_mask & ~ours)} px")
        rep["mandelbulber2"] = dict(wall_s=c_wall, cpu_s=[c["cpu_s"] for c in C], speedup_vs_core=speed,
                                    iou=sil_iou, coverage_native=float(ours.mean()), coverage_peer=float(peer_mask.mean()))
        # Side by side: native | peer, and a mask difference (white both, red native only, green peer only).
        peer_rgb = read_png(out / "peer.png")[..., :3]
        write_png(out / "side_by_side.png", np.concatenate([to_u8(native_img["combined"][::-1, :, :3]), peer_rgb], 1))
        diff = np.zeros((H, W, 3), np.uint8)
        diff[ours & peer_mask] = 255
        diff[ours & ~peer_mask] = (255, 0, 0)
        diff[peer_mask & ~ours] = (0, 255, 0)
        write_png(out / "mask_diff.png", diff)

    load = os.getloadavg()
    rep["loadavg_end"] = load
    (out / "results.json").write_text(json.dumps(rep, indent=1))
    print(f"\nload average at the end {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} (other jobs on the machine skew all "
          f"timings; native cpu/wall near {args.threads} means its threads really ran in parallel)")
    print(f"images and results.json in {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
