"""Mandelbulb and Mandelbox side by side with Mandelbulber2 (issue 22): silhouette IoU and the
CPU-time ratio, same scenes, same camera, 2 threads, interleaved runs.

    python bench/bench_formulas_peer.py [--res 640x480] [--threads 2] [--repeats 3] [--out bench/out/formulas]

Scenes. The peer's settings are its quaternion scene (<shared>/peer/qjulia.fract: camera, fov 1,
Lambert light, no effects) with the formula swapped:
* Mandelbulb power 8, Mandelbrot form, 12 iterations, bailout 4. Mandelbulber's formula 2 measures
  the latitude (asin z/r) where ours (White-Nylander) measures theta from +z (acos): its direction
  is (cos n t', ..., sin n t'), t' = n (lat + beta). With beta_angle_offset = 90/n - 90 degrees
  (-78.75 for n = 8), n (lat + beta) = pi/2 - n theta, so cos and sin of it are sin n theta and
  cos n theta: the very same map (and the same running derivative), no parameter of ours needed.
* Mandelbox scale 2, fold limit 1, radii 0.5 / 1 (both programs' defaults), Mandelbrot form,
  14 iterations, bailout sqrt(3) 10 (ours: the proven escape radius, scene.c), camera 8x farther.
Our core renders combined + alpha + depth; the peer figures are its whole process (start-up, render,
PNG write: what it costs a user). CPU time is quoted next to wall time: on this shared machine
wall time depends on other jobs."""
from __future__ import annotations

import argparse
import json
import math
import statistics
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "build" / "wheel"))
sys.path.insert(0, str(REPO / "bench"))

import unbound_core as uc  # noqa: E402

import bench_core as bc  # noqa: E402
import peer_mandelbulber as peer  # noqa: E402

DIRECTION = np.array([-2.0, -2.0, 1.0]) / 3.0  # the peer scene's camera direction (camera_rotation)
SCENES = {
    "mandelbulb": dict(obj=dict(kind="mandelbulb", power=8.0, max_iterations=12, bailout=4.0), distance=3.0,
                       peer={"formula_1": 2, "N": 12, "bailout": 4, "julia_mode": "false"},
                       fractal={"power": 8, "beta_angle_offset": 90.0 / 8 - 90.0}),
    "mandelbox": dict(obj=dict(kind="mandelbox", box_scale=2.0, max_iterations=14), distance=24.0,
                      peer={"formula_1": 8, "N": 14, "bailout": math.sqrt(3) * 10, "julia_mode": "false"},
                      fractal={"mandelbox_scale": 2, "mandelbox_folding_limit": 1, "mandelbox_folding_value": 2,
                               "mandelbox_folding_min_radius": 0.5, "mandelbox_folding_fixed_radius": 1}),
}


def fract_text(base, scene):
    """The peer scene's file with the formula, iterations, camera distance and fractal_1 keys replaced."""
    s = SCENES[scene]
    eye = DIRECTION * s["distance"]
    keys = dict(s["peer"], camera="%g %g %g" % tuple(eye), camera_distance_to_target=s["distance"])
    lines = []
    for line in base.splitlines():
        key = line.split(" ", 1)[0]
        if key in keys:
            continue
        lines.append(line)
        if line.startswith("[main_parameters]"):
            lines += ["%s %s;" % (k, v) for k, v in keys.items()]
        if line.startswith("[fractal_1]"):
            lines += ["%s %s;" % (k, v) for k, v in s["fractal"].items()]
    return "\n".join(lines) + "\n"


def run_native(scene, width, height, threads):
    s = SCENES[scene]
    eye = tuple(DIRECTION * s["distance"])
    cam = dict(matrix=uc.look_at(eye, (0, 0, 0), (0, 0, 1)),
               projection=uc.perspective(bc.FOV_Y, width / height, 0.1, 100.0), width=width, height=height)
    passes = {n: np.zeros((height, width, uc.PASS_CHANNELS[n]), np.float32) for n in ("combined", "alpha", "depth")}
    c0, t0 = time.process_time(), time.perf_counter()
    stats = uc.render(cam, [s["obj"]], passes, threads=threads)
    return dict(stats, wall_s=time.perf_counter() - t0, cpu_s=time.process_time() - c0), passes


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--res", default="640x480")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--out", default=str(REPO / "bench" / "out" / "formulas"))
    args = ap.parse_args(argv)
    W, H = bc.parse_res(args.res, ap)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    peer.ensure_installed()
    base = (peer.shared_peer_dir() / "qjulia.fract").read_text()
    report = dict(machine=bc.machine(), date=time.strftime("%Y-%m-%d %H:%M %Z"), res=[W, H], threads=args.threads)
    for scene in SCENES:
        fract = out / (scene + ".fract")
        fract.write_text(fract_text(base, scene))
        _, img = run_native(scene, W, H, args.threads)  # warm-up
        sil = peer.render(fract, W, H, args.threads, out / (scene + "_peer_silhouette.png"),
                          overrides=peer.SILHOUETTE_OVERRIDES)
        A, C = [], []
        for _ in range(args.repeats):
            A.append(run_native(scene, W, H, args.threads)[0])
            r = peer.render(fract, W, H, args.threads, out / (scene + "_peer.png"))
            C.append(dict(wall_s=r["wall_s"], cpu_s=r["cpu_s"]))
        ours = img["alpha"][::-1, :, 0] > 0.5
        theirs = bc.read_png(Path(sil["png"]).with_name(Path(sil["png"]).stem + "_alpha.png"))[..., 0] > 127
        iou = bc.iou(ours, theirs)
        bc.write_png(out / (scene + "_native.png"), bc.to_u8(img["combined"][::-1, :, :3]))
        diff = np.zeros(ours.shape + (3,), np.uint8)
        diff[ours & theirs] = 255
        diff[ours & ~theirs] = (255, 0, 0)
        diff[theirs & ~ours] = (0, 255, 0)
        bc.write_png(out / (scene + "_silhouette_diff.png"), diff)
        nw, nc = [a["wall_s"] for a in A], [a["cpu_s"] for a in A]
        pw, pc = [c["wall_s"] for c in C], [c["cpu_s"] for c in C]
        ratio_cpu = statistics.median(pc) / statistics.median(nc)
        ratio_wall = statistics.median(pw) / statistics.median(nw)
        print(f"{scene} {W}x{H}, {args.threads} threads, {args.repeats} interleaved runs (median (min-max)):")
        print(f"  unbound      cpu {bc.med(nc)} s, wall {bc.med(nw)} s")
        print(f"  mandelbulber cpu {bc.med(pc)} s, wall {bc.med(pw)} s (whole process)")
        print(f"  CPU-time ratio {ratio_cpu:.1f}x (wall {ratio_wall:.1f}x); silhouette IoU {iou:.4f} "
              f"(coverage ours {ours.mean():.3f}, peer {theirs.mean():.3f})", flush=True)
        report[scene] = dict(native_cpu_s=nc, native_wall_s=nw, peer_cpu_s=pc, peer_wall_s=pw, cpu_ratio=ratio_cpu,
                             wall_ratio=ratio_wall, iou=iou, coverage_native=float(ours.mean()),
                             coverage_peer=float(theirs.mean()))
    (out / "report.json").write_text(json.dumps(report, indent=1))


if __name__ == "__main__":
    main()
