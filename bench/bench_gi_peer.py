"""Benchmark: the peer race with global illumination (issue 19) -- Mandelbulber2's Monte-Carlo GI
against ours at equal error.

The scene is the peer scene of bench_core.py (<shared>/peer/README.md: the quaternion Julia set
mu = -0.2+0.8i, 16 iterations, bailout 4, the peer camera) lit by the peer's sun (its main light,
hard shadows: qjulia_shadows.fract) and a uniform grey sky of radiance SKY, the surface grey of
albedo ALBEDO; global illumination on in both programs, 4 bounces:

  ours         shading use_gi (Cycles' Light Paths, diffuse bounces 4), the sky as the World light
               (world_samples 1), the sun with hard shadows, no axle light;
  Mandelbulber DOF_monte_carlo + DOF_MC_global_illumination (its "Monte Carlo" render with
               "global illumination"), reflections_max 4 (the GI path's bounces), the sky as its
               background colours, DOF_samples N with DOF_max_noise 0 (no adaptive early stop, so
               every pixel takes exactly N samples), a 16-bit PNG.

The two programs' GI estimators differ (Mandelbulber's is not normalised as a radiometric one), so
each is measured against its *own* reference: the same scene at --ref-samples (ours) and
--peer-ref-samples (Mandelbulber) samples per pixel.  Error = RMSE over the object's pixels (the
reference's alpha for ours; for Mandelbulber the alpha side channel of a plain render), relative to the reference's mean over those pixels.  Each program renders a ladder
of sample counts; its CPU seconds (ours: process CPU of the uc.render call; Mandelbulber: the
whole process, start-up and PNG write included, and its marginal CPU per sample from a straight-line
fit) are interpolated log-log to the common relative error --target (default 2 %); where the
ladder does not reach it, the error is extrapolated as c/sqrt(N) (Monte-Carlo) from the ladder's
last rung, the reference's own noise taken out (our reference contains the ladder's samples, so
its error adds as 1/N - 1/N_ref; Mandelbulber's is independent: 1/N + 1/N_ref), on the cost line
CPU = a + b N fitted over the ladder.  The ratio
Mandelbulber / ours at the target is the figure of issue 19 (target >= 10x).

    python bench/bench_gi_peer.py [--res 160x128] [--threads 2] [--target 0.02] [--ref-samples 4096]
                                  [--peer-ref-samples 1024] [--out bench/out/gi_peer]

About 10 minutes on 2 cores at the defaults, most of it the two references.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import time
from pathlib import Path

import numpy as np

import bench_core as bc  # also puts the built wheel (build/wheel) on sys.path
from bench_core import OBJECT, machine, parse_res, read_png, to_u8, write_png
from bench_effects import SUN

uc = bc.uc

SKY = 0.3     # the sky's radiance (grey), both programs
ALBEDO = 0.8  # the surface's grey
SUN_SCALE = 0.7  # the peer's sun dimmed, so that no pixel clips at 1 in Mandelbulber's 16-bit PNG
BOUNCES = 4   # diffuse bounces (ours) = reflections_max (Mandelbulber's GI path length)
OUR_LADDER = (1, 2, 4, 8, 16, 32, 64, 128, 256)
PEER_LADDER = (1, 2, 4, 8, 16, 32, 64)


def hex16(value):
    """Mandelbulber's 16-bit colour component: 0.3 -> '4ccc'."""
    return f"{round(value * 0xFFFF):04x}"


def peer_fract(out):
    """qjulia_shadows.fract with the sky and the albedo written in: Mandelbulber renders its surface
    black when mat1_surface_color comes as an --override (a colour with spaces), so it goes in the file."""
    import peer_mandelbulber as peer
    grey = lambda v: " ".join([hex16(v)] * 3)  # noqa: E731
    lines = {"mat1_surface_color": grey(ALBEDO), "main_light_intensity": SUN_SCALE,
             **{f"background_color_{i}": grey(SKY) for i in (1, 2, 3)}}
    text = (peer.shared_peer_dir() / "qjulia_shadows.fract").read_text()
    for key, value in lines.items():
        start = text.index(f"\n{key} ") + 1
        text = text[:start] + f"{key} {value};" + text[text.index("\n", start):]
    path = out / "qjulia_gi.fract"
    path.write_text(text)
    return path


def peer_overrides(samples):
    """Monte-Carlo GI with exactly `samples` samples per pixel (max noise 0: no early stop)."""
    return {"DOF_monte_carlo": True, "DOF_MC_global_illumination": True, "DOF_samples": samples,
            "DOF_min_samples": 1, "DOF_max_noise": 0, "reflections_max": BOUNCES}


def run_ours(samples, width, height, threads):
    """(image, alpha, CPU seconds, wall seconds) of one GI render of ours."""
    cam = bc.camera(width, height)
    passes = {"combined": np.zeros((height, width, 4), np.float32)}
    sun = dict(SUN, color=tuple(SUN_SCALE * c for c in SUN["color"]))
    shading = dict(axle_light=0.0, shadows="hard", lights=[sun], world_samples=1, samples=samples, use_gi=True,
                   diffuse_bounces=BOUNCES)
    world = np.full((1, 1, 3), SKY, np.float32)
    c0, t0 = time.process_time(), time.perf_counter()
    uc.render(cam, [dict(OBJECT, color=(ALBEDO,) * 3)], passes, threads=threads, world=world, shading=shading)
    cpu, wall = time.process_time() - c0, time.perf_counter() - t0
    combined = passes["combined"]
    return combined[..., :3], combined[..., 3], cpu, wall


def run_peer(peer, fract, samples, width, height, threads, out):
    png = out / f"peer_{samples}.png"
    r = peer.render(fract, width, height, threads, png, overrides=peer_overrides(samples), image_format="png16",
                    timeout=1800)
    return read_png(png, as_float=True)[..., :3], r["cpu_s"], r["wall_s"]


def peer_silhouette(peer, fract, width, height, threads, out):
    """Mandelbulber's object mask: its alpha side channel of a plain (one-sample) render."""
    png = out / "peer_silhouette.png"
    peer.render(fract, width, height, threads, png, overrides=peer.SILHOUETTE_OVERRIDES)
    return read_png(png.with_name("peer_silhouette_alpha.png"), as_float=True)[..., 0] > 0.5


def relative_rmse(image, reference, mask):
    """RMSE over the masked pixels (all channels), relative to the reference's mean there."""
    diff = (image - reference)[mask]
    return float(np.sqrt(np.mean(diff * diff)) / np.mean(reference[mask]))


def noise_basis(n, n_ref, nested):
    """error^2 / c^2 of an n-sample image against an n_ref-sample reference: 1/n - 1/n_ref when the
    reference contains the image's samples (ours: the same sample sequence), else 1/n + 1/n_ref."""
    return 1.0 / n + (-1.0 if nested else 1.0) / n_ref


def time_line(samples, cpu):
    """Least-squares cpu = a + b N: (fixed cost a, marginal cost per sample b)."""
    b, a = np.polyfit(np.asarray(samples, float), np.asarray(cpu, float), 1)
    return float(a), float(b)


def fits(stats):
    """The Monte-Carlo constant c (error = c sqrt(basis)) of the ladder's last rung, the one nearest
    the target, with the reference's noise taken out; and the cost line over the whole ladder."""
    last = stats["rows"][-1]
    c = last["rel_rmse"] / math.sqrt(noise_basis(last["samples"], stats["n_ref"], stats["nested"]))
    a, b = time_line([r["samples"] for r in stats["rows"]], [r["cpu_s"] for r in stats["rows"]])
    return dict(c=c, fixed_cpu_s=a, cpu_per_sample_s=b)


def cpu_at(target, stats):
    """CPU seconds to reach `target`: log-log interpolation on the ladder where it brackets the target,
    else c/sqrt(N) from the last rung on the cost line.  Returns (seconds, samples, how)."""
    pts = [(r["rel_rmse"], r["cpu_s"], r["samples"]) for r in stats["rows"]]
    for (e0, t0, n0), (e1, t1, n1) in zip(pts, pts[1:]):
        if e0 >= target >= e1 and e0 > e1:
            f = math.log(e0 / target) / math.log(e0 / e1)
            return (math.exp(math.log(t0) + f * math.log(t1 / t0)), math.exp(math.log(n0) + f * math.log(n1 / n0)),
                    "interpolated")
    fit = fits(stats)
    n = (fit["c"] / target) ** 2
    return fit["fixed_cpu_s"] + fit["cpu_per_sample_s"] * n, n, f"extrapolated from {pts[-1][2]} by c/sqrt(N)"


def measure(name, ladder, n_ref, render, nested, mask_of, out):
    """Render the reference and the ladder; print and return the rows."""
    t0 = time.perf_counter()
    ref = render(n_ref)
    print(f"{name}: reference {n_ref} samples, {ref[-2]:.1f} s CPU, {ref[-1]:.1f} s wall "
          f"(run {time.perf_counter() - t0:.0f} s)", flush=True)
    mask = mask_of(ref)
    write_png(out / f"{name}_reference.png", to_u8(ref[0] / max(1e-6, float(ref[0][mask].max()))))
    rows = []
    for n in ladder:
        image, *_rest, cpu, wall = render(n)
        err = relative_rmse(image, ref[0], mask)
        rows.append(dict(samples=n, cpu_s=cpu, wall_s=wall, rel_rmse=err))
        print(f"  {n:4d} samples: relative RMSE {100 * err:6.2f} %, CPU {cpu:8.3f} s, wall {wall:7.3f} s", flush=True)
    return dict(rows=rows, n_ref=n_ref, nested=nested, ref_cpu_s=ref[-2], ref_wall_s=ref[-1],
                object_pixels=int(mask.sum()), ref_mean=float(np.mean(ref[0][mask])))


def summarise(report):
    """Print the fits and the race at report["target"]; adds them to the report."""
    target = report["target"]
    for name in ("ours", "mandelbulber"):
        stats = report[name]
        stats.update(fits(stats))
        stats["at_target"] = dict(zip(("cpu_s", "samples", "how"), cpu_at(target, stats)))
        print(f"{name}: one sample's relative error c = {stats['c']:.3f} (from {stats['rows'][-1]['samples']} "
              f"samples); CPU = {stats['fixed_cpu_s']:.3f} s + {stats['cpu_per_sample_s']:.4f} s x samples; "
              f"object pixels {stats['object_pixels']}, reference mean {stats['ref_mean']:.4f}")
    ours, theirs = report["ours"], report["mandelbulber"]
    report["ratio_whole_process"] = theirs["at_target"]["cpu_s"] / ours["at_target"]["cpu_s"]
    report["ratio_marginal"] = (theirs["cpu_per_sample_s"] * theirs["c"] ** 2) / (ours["cpu_per_sample_s"] * ours["c"] ** 2)
    print(f"\nat {100 * target:.1f} % relative RMSE:")
    for label, stats in (("ours        ", ours), ("Mandelbulber", theirs)):
        at = stats["at_target"]
        print(f"  {label} {at['samples']:8.1f} samples, {at['cpu_s']:8.3f} s CPU ({at['how']})")
    print(f"  time ratio Mandelbulber / ours: {report['ratio_whole_process']:.1f}x (Mandelbulber's whole process); "
          f"{report['ratio_marginal']:.1f}x from the marginal CPU per sample x c^2 (start-up left out)")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--res", default="160x128")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--target", type=float, default=0.02, help="relative RMSE to reach (default 0.02)")
    ap.add_argument("--ref-samples", type=int, default=4096, help="our reference's samples")
    ap.add_argument("--peer-ref-samples", type=int, default=1024, help="Mandelbulber's reference's samples")
    ap.add_argument("--out", default=str(bc.REPO / "bench" / "out" / "gi_peer"))
    ap.add_argument("--report", default=None, help="analyse this report.json of an earlier run; render nothing")
    args = ap.parse_args(argv)
    if args.report:
        report = json.loads(Path(args.report).read_text())
        report["target"] = args.target
        summarise(report)
        return
    W, H = parse_res(args.res, ap)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    import peer_mandelbulber as peer
    peer.ensure_installed()
    fract = peer_fract(out)

    mach = machine()
    load0 = os.getloadavg()
    print(f"machine: nproc {mach['nproc']}, {mach['cpu']}; {W}x{H}, {args.threads} threads; "
          f"load average at start {load0[0]:.2f} {load0[1]:.2f} {load0[2]:.2f}")
    run_ours(1, W, H, args.threads)  # warm-up
    ours = measure("ours", OUR_LADDER, args.ref_samples, lambda n: run_ours(n, W, H, args.threads),
                   True, lambda ref: ref[1] > 0.5, out)
    theirs = measure("mandelbulber", PEER_LADDER, args.peer_ref_samples,
                     lambda n: run_peer(peer, fract, n, W, H, args.threads, out), False,
                     lambda ref: peer_silhouette(peer, fract, W, H, args.threads, out), out)
    load1 = os.getloadavg()
    report = dict(machine=mach, res=[W, H], threads=args.threads, target=args.target, ours=ours,
                  mandelbulber=theirs, load_start=load0, load_end=load1, date=time.strftime("%Y-%m-%d %H:%M %Z"))
    summarise(report)
    print(f"load average at end {load1[0]:.2f} {load1[1]:.2f} {load1[2]:.2f}")
    (out / "report.json").write_text(json.dumps(report, indent=1))


if __name__ == "__main__":
    main()
