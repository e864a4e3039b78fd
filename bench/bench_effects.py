"""Benchmark: what each shading effect of the native core costs, and hard shadows next to Mandelbulber2's.

The scene is bench_core.py's peer scene (``<shared>/peer/README.md``: quaternion Julia set
mu = -0.2+0.8i, 16 iterations, bailout 4, camera (-2,-2,1) looking at the origin, z up, vertical FOV
53.13 degrees, hit threshold one pixel footprint) with the default shading: the axle light (Lambert,
light at the eye), no other lights. Each row adds one effect to that base (``CASES`` below):

  base, + hard shadows (one sun = Mandelbulber's main light of qjulia_shadows.fract), + soft shadows
  (the same sun with an angular radius of 2 degrees), + AO (strength 1, 5 samples, seen through an
  ambient light of 0.3), + reflections (reflectivity 0.3, depth 2, with the sea on so that they hit
  something), + the sea, + fog, + glow, + 4 AA samples, each other normal method
  (gradient_potential, zbuffer, analytic; the base uses gradient_distance), and everything together
  (soft shadows, AO, reflections, sea, fog, glow, 4 samples).

All rows render at --res with --threads into the same passes (combined, alpha, depth), timed by the
core's own timer (stats["seconds"]). Rows are interleaved round by round (base, hard, soft, ...,
mandelbulber base, mandelbulber shadows, base, hard, ...) after one warm-up round; the table gives
medians over --repeats rounds, the ratio to the base as the median of the per-round ratios (each
round's row time over the same round's base time, which cancels slow drifts of the machine's load),
Mrays/s (primary rays, i.e. pixels x samples, over the median time), marching steps and formula
iterations per primary ray (stats["steps"], stats["iterations"]: primary, shadow and reflection rays;
the DE evaluations of normals and AO are counted in neither).

Mandelbulber2 (unless --no-peer) renders <shared>/peer/qjulia.fract (no shadows) and
qjulia_shadows.fract (hard shadows from its main light) at the same resolution with
limit_CPU_cores=--threads, interleaved with ours; whole-process wall time as in bench_core.py (its
own "total time" line is recorded too). Reported: its shadow cost (shadow/base) next to ours, and the
absolute ratio Mandelbulber2 wall / our hard-shadow core seconds. Then, untimed, both programs'
shadow masks are compared: our core renders the peer's look (white, no axle light, the sun alone at
Mandelbulber's brightness) with and without shadows, and the IoU of the shadowed pixels (lit surface
whose value at least halves when shadows are on) is printed; images go into --out.

    python bench/bench_effects.py [--repeats 3] [--res 640x512] [--threads 2] [--no-peer]
                                  [--out bench/out/effects]
"""
from __future__ import annotations

import argparse
import json
import math
import os
import re
import statistics
import sys
import time
from pathlib import Path

import numpy as np

import bench_core as bc  # also puts the built wheel (build/wheel) and native/ on sys.path
from bench_core import OBJECT, REPO, camera, iou, machine, med, parse_res, read_png, to_u8, write_png

uc = bc.uc

# ------------------------------------------------------------------------------ the peer's light
# qjulia_shadows.fract: main_light_alpha -20; main_light_beta 56; main_light_position_relative
# false; main_light_intensity 1 (white); shadows_enabled true; shadows_cone_angle 0 (hard);
# penetrating_lights false. Mandelbulber2's convention (buddhi1980/mandelbulber2,
# mandelbulber2/src/render_worker.cpp, cRenderWorker::PrepareMainVectors):
#     vector.x = cos(alpha - 0.5 * M_PI) * cos(beta);
#     vector.y = sin(alpha - 0.5 * M_PI) * cos(beta);
#     vector.z = sin(beta);
#     shadowVector = mainLightPositionAsRelative ? mRot.RotateVector(vector) : vector;
# i.e. L = (sin a cos b, -cos a cos b, sin b) in world coordinates (not camera-relative here). L
# points from the surface TOWARD the light: cRenderWorker::MainShading is max(0, n.L) and
# cRenderWorker::MainShadow marches point + L * i. So L = (-0.1913, -0.5255, 0.8290), and our sun,
# whose "direction" is where its rays travel, gets direction = -L.
# Brightness: Mandelbulber's pixel is max(0, n.L) * intensity; our Lambert sun gives
# albedo * E * cos / pi, so E = pi reproduces it.
PEER_ALPHA, PEER_BETA = math.radians(-20.0), math.radians(56.0)
PEER_L = (math.sin(PEER_ALPHA) * math.cos(PEER_BETA), -math.cos(PEER_ALPHA) * math.cos(PEER_BETA),
          math.sin(PEER_BETA))
SUN = dict(type="sun", direction=tuple(-c for c in PEER_L), color=(math.pi,) * 3, cast_shadow=True)
SOFT_SUN = dict(SUN, radius=math.tan(math.radians(2.0)))  # sun: radius = tan(angular radius)

# The sea: below the whole object (its lowest visible point is at z ~ -0.92, bound radius 1.54),
# so it hides nothing of the set and the set is mirrored in it.
SEA = dict(use_sea=True, sea_height=-1.0, sea_wavelength=0.25, sea_amplitude=0.01, sea_color=(0.1, 0.25, 0.4),
           sea_reflectivity=0.5)

AMBIENT = (0.3, 0.3, 0.3)

# (key, label, object overrides, shading). shading {} = the defaults: axle light 1, no lights.
CASES = [
    ("base", "base (axle light, no lights)", {}, {}),
    ("hard", "+ hard shadows (peer's sun)", {}, dict(shadows="hard", lights=[SUN])),
    ("soft", "+ soft shadows (sun, 2 deg)", {}, dict(shadows="soft", lights=[SOFT_SUN])),
    # AO only shows through the ambient light (albedo * ambient * AO); the core computes it either way.
    ("ao", "+ AO (strength 1, 5 samples, ambient 0.3)", {},
     dict(ao_strength=1.0, ao_samples=5, ao_distance=0.5, ambient=AMBIENT)),
    ("reflect", "+ reflections 0.3, depth 2 (+ sea)", dict(reflectivity=0.3), dict(reflection_depth=2, **SEA)),
    ("sea", "+ sea", {}, dict(SEA)),
    ("fog", "+ fog (density 0.2)", {}, dict(fog_density=0.2, fog_color=(0.5, 0.55, 0.6))),
    ("glow", "+ glow (strength 0.5)", {}, dict(glow_strength=0.5, glow_color=(1.0, 0.6, 0.3))),
    ("samples4", "+ samples 4", {}, dict(samples=4)),
    ("n_potential", "normals gradient_potential", dict(normal_method="gradient_potential"), {}),
    ("n_zbuffer", "normals zbuffer", dict(normal_method="zbuffer"), {}),
    ("n_analytic", "normals analytic", dict(normal_method="analytic"), {}),
    ("all", "everything (soft, AO, refl+sea, fog, glow, 4 spp)", dict(reflectivity=0.3),
     dict(shadows="soft", lights=[SOFT_SUN], ao_strength=1.0, ao_samples=5, ao_distance=0.5, ambient=AMBIENT,
          reflection_depth=2, **SEA, fog_density=0.2, fog_color=(0.5, 0.55, 0.6), glow_strength=0.5,
          glow_color=(1.0, 0.6, 0.3), samples=4)),
]
PASSES = ("combined", "alpha", "depth")


def run_case(case, width, height, threads, names=PASSES):
    _, _, obj_over, shading = case
    passes = {n: np.zeros((height, width, uc.PASS_CHANNELS[n]), np.float32) for n in names}
    c0 = time.process_time()
    stats = uc.render(camera(width, height), [dict(OBJECT, **obj_over)], passes, threads=threads,
                      shading=dict(shading))
    return dict(stats, cpu_s=time.process_time() - c0), passes


def peer_total_time(stdout):
    """Mandelbulber's own render time from its 'total time: 1.9s' progress line (0.1 s steps)."""
    m = re.findall(r"total time:\s*([0-9.]+)s", stdout)
    return float(m[-1]) if m else None


def shadow_masks(base_u8, shadow_u8, lit_min=13):
    """Lit surface (value >= lit_min/255, i.e. n.L >= ~0.05) and, of it, the shadowed pixels (the
    shadowed image keeps less than half the unshadowed value). Same rule for both programs."""
    b, s = base_u8.astype(np.int32), shadow_u8.astype(np.int32)
    lit = b >= lit_min
    return lit, lit & (2 * s < b)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--res", default="640x512")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--no-peer", action="store_true", help="skip Mandelbulber2")
    ap.add_argument("--out", default=str(REPO / "bench" / "out" / "effects"))
    args = ap.parse_args(argv)
    W, H = parse_res(args.res, ap)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    mach = machine()
    load0 = os.getloadavg()
    print(f"machine: nproc {mach['nproc']}, {mach['cpu']}, AVX2+FMA {mach['simd_avx2_fma']}; "
          f"python {mach['python']}, numpy {mach['numpy']}")
    print(f"scene: peer qjulia {W}x{H}, {args.threads} threads, {len(CASES)} shading cases; {args.repeats} "
          f"interleaved rounds after one warm-up; load average {os.getloadavg()[0]:.2f}")

    peer = None
    if not args.no_peer:
        import peer_mandelbulber as peer
        peer.ensure_installed()
        pdir = peer.shared_peer_dir()
        peer_files = {"base": pdir / "qjulia.fract", "shadows": pdir / "qjulia_shadows.fract"}
        for p in peer_files.values():
            if not p.is_file():
                raise SystemExit(f"missing peer settings file {p}")

    # Warm-up round (not counted); its images are written out.
    for case in CASES:
        _, img = run_case(case, W, H, args.threads)
        write_png(out / f"native_{case[0]}.png", to_u8(img["combined"][::-1, :, :3]))
    if peer:
        for key, fract in peer_files.items():
            peer.render(fract, W, H, args.threads, out / f"peer_{key}.png")

    T = {c[0]: [] for c in CASES}
    P = {"base": [], "shadows": []}
    for i in range(args.repeats):
        for case in CASES:
            T[case[0]].append(run_case(case, W, H, args.threads)[0])
        if peer:
            for key, fract in peer_files.items():
                r = peer.render(fract, W, H, args.threads, out / f"peer_{key}.png")
                P[key].append(dict(wall_s=r["wall_s"], cpu_s=r["cpu_s"], render_s=peer_total_time(r["stdout"])))
        line = " ".join(f"{k} {T[k][-1]['seconds']:.3f}" for k in ("base", "hard", "soft", "all"))
        if peer:
            line += f"; mandelbulber2 base {P['base'][-1]['wall_s']:.2f} shadows {P['shadows'][-1]['wall_s']:.2f}"
        print(f"  round {i + 1}: {line} s", flush=True)

    rep = dict(machine=mach, date=time.strftime("%Y-%m-%d %H:%M %Z"), res=[W, H], threads=args.threads,
               repeats=args.repeats, loadavg_start=load0, cases={})
    base_sec = [t["seconds"] for t in T["base"]]
    print(f"\nnative core {W}x{H}, {T['base'][0]['threads']} threads, simd {T['base'][0]['simd']}; "
          f"x base = median of per-round ratios")
    hdr = f"{'case':52s} {'seconds median (min-max)':>26s} {'x base':>7s} {'Mrays/s':>8s} {'steps/ray':>9s} " \
          f"{'iter/ray':>8s} {'cpu/wall':>8s}"
    print(hdr)
    print("-" * len(hdr))
    rows = {}
    for key, label, obj_over, shading in CASES:
        runs = T[key]
        sec = [t["seconds"] for t in runs]
        ms = statistics.median(sec)
        ratio = statistics.median([s / b for s, b in zip(sec, base_sec)])
        r0 = runs[0]
        cpu_wall = statistics.median([t["cpu_s"] / t["seconds"] for t in runs])
        row = dict(label=label, seconds=sec, median_s=ms, ratio_to_base=ratio, rays=r0["rays"],
                   steps=r0["steps"], iterations=r0["iterations"], mrays_per_s=r0["rays"] / ms / 1e6,
                   steps_per_ray=r0["steps"] / r0["rays"], iterations_per_ray=r0["iterations"] / r0["rays"],
                   cpu_over_wall=cpu_wall, object=obj_over, shading=json.loads(json.dumps(shading)))
        rows[key] = row
        print(f"{label:52s} {med(sec):>26s} {ratio:7.2f} {row['mrays_per_s']:8.2f} {row['steps_per_ray']:9.2f} "
              f"{row['iterations_per_ray']:8.1f} {cpu_wall:8.2f}")
    rep["cases"] = rows
    refl_over_sea = statistics.median([a["seconds"] / b["seconds"] for a, b in zip(T["reflect"], T["sea"])])
    print(f"reflections over the sea alone: {refl_over_sea:.2f}x; soft over hard shadows: "
          f"{statistics.median([a['seconds'] / b['seconds'] for a, b in zip(T['soft'], T['hard'])]):.2f}x")
    rep["reflections_over_sea"] = refl_over_sea

    if peer:
        pb = [p["wall_s"] for p in P["base"]]
        ps = [p["wall_s"] for p in P["shadows"]]
        peer_cost = statistics.median([s / b for s, b in zip(ps, pb)])
        ours_cost = rows["hard"]["ratio_to_base"]
        hard_sec = [t["seconds"] for t in T["hard"]]
        speed = statistics.median(ps) / statistics.median(hard_sec)
        speed_base = statistics.median(pb) / statistics.median(base_sec)
        rtime = {k: [p["render_s"] for p in P[k] if p["render_s"] is not None] for k in P}
        print(f"\nMandelbulber2 {W}x{H}, limit_CPU_cores={args.threads}, whole process (its own 'total time'):")
        print(f"  base    (qjulia.fract)         wall {med(pb)} s, cpu {med([p['cpu_s'] for p in P['base']])} s"
              + (f" (render {statistics.median(rtime['base']):.2f} s)" if rtime["base"] else ""))
        print(f"  shadows (qjulia_shadows.fract) wall {med(ps)} s, cpu {med([p['cpu_s'] for p in P['shadows']])} s"
              + (f" (render {statistics.median(rtime['shadows']):.2f} s)" if rtime["shadows"] else ""))
        peer_cost_cpu = statistics.median([s["cpu_s"] / b["cpu_s"] for s, b in zip(P["shadows"], P["base"])])
        ours_cost_cpu = statistics.median([s["cpu_s"] / b["cpu_s"] for s, b in zip(T["hard"], T["base"])])
        print(f"  hard-shadow cost shadow/base: Mandelbulber2 {peer_cost:.2f}x, Unbound {ours_cost:.2f}x "
              f"(by CPU seconds, less sensitive to other jobs: {peer_cost_cpu:.2f}x and {ours_cost_cpu:.2f}x)")
        peer_extra = statistics.median([s - b for s, b in zip(ps, pb)])
        ours_extra = statistics.median([s - b for s, b in zip(hard_sec, base_sec)])
        print(f"  hard-shadow cost in seconds (median of per-round shadow - base): Mandelbulber2 {peer_extra:+.3f} s, "
              f"Unbound {ours_extra:+.4f} s")
        print(f"  Mandelbulber2 wall / Unbound core seconds: shadows {speed:.0f}x, base {speed_base:.0f}x")
        rep["mandelbulber2"] = dict(base_wall_s=pb, shadows_wall_s=ps,
                                    base_cpu_s=[p["cpu_s"] for p in P["base"]],
                                    shadows_cpu_s=[p["cpu_s"] for p in P["shadows"]],
                                    base_render_s=rtime["base"], shadows_render_s=rtime["shadows"],
                                    shadow_cost=peer_cost, unbound_shadow_cost=ours_cost,
                                    shadow_cost_cpu=peer_cost_cpu, unbound_shadow_cost_cpu=ours_cost_cpu,
                                    shadow_extra_s=peer_extra, unbound_shadow_extra_s=ours_extra,
                                    speedup_shadows=speed, speedup_base=speed_base)

        # Untimed: our core with the peer's look (sun alone at the peer's brightness), with and without
        # shadows, against the peer's last images; shadowed-region IoU.
        look = dict(axle_light=0.0, lights=[SUN])
        ours = {}
        for key, mode in (("base", "none"), ("shadows", "hard")):
            case = (key, key, dict(color=(1.0, 1.0, 1.0)), dict(look, shadows=mode))  # white, as the peer's
            _, img = run_case(case, W, H, args.threads, names=("combined", "alpha", "shadow"))
            ours[key] = to_u8(img["combined"][::-1, :, 0])
            write_png(out / f"native_peerlook_{key}.png", to_u8(img["combined"][::-1, :, :3]))
        theirs = {k: read_png(out / f"peer_{k}.png")[..., 0] for k in P}
        lit_o, sh_o = shadow_masks(ours["base"], ours["shadows"])
        lit_p, sh_p = shadow_masks(theirs["base"], theirs["shadows"])
        siou, liou = iou(sh_o, sh_p), iou(lit_o, lit_p)
        hits = (ours["base"] > 0) | (theirs["base"] > 0)
        mean_abs = float(np.mean(np.abs(ours["shadows"].astype(np.int32) - theirs["shadows"].astype(np.int32))[hits]))
        print(f"  shadowed-region IoU (same rule on both programs' images): {siou:.3f}; lit-surface IoU {liou:.3f}; "
              f"shadowed fraction of the lit surface: Unbound {sh_o.sum() / max(lit_o.sum(), 1):.3f}, "
              f"Mandelbulber2 {sh_p.sum() / max(lit_p.sum(), 1):.3f}; mean |difference| of the shadow images "
              f"where either lights the surface {mean_abs:.1f}/255")
        rep["mandelbulber2"].update(shadow_iou=siou, lit_iou=liou, shadow_image_mean_abs_diff=mean_abs,
                                    shadowed_fraction_unbound=float(sh_o.sum() / max(lit_o.sum(), 1)),
                                    shadowed_fraction_peer=float(sh_p.sum() / max(lit_p.sum(), 1)))
        rgb = lambda a: np.repeat(a[..., None], 3, axis=2)  # noqa: E731
        write_png(out / "shadows_side_by_side.png", np.concatenate([rgb(ours["shadows"]), rgb(theirs["shadows"])], 1))
        diff = np.zeros((H, W, 3), np.uint8)
        diff[lit_o | lit_p] = 60
        diff[sh_o & sh_p] = 255
        diff[sh_o & ~sh_p] = (255, 0, 0)
        diff[sh_p & ~sh_o] = (0, 255, 0)
        write_png(out / "shadow_mask_diff.png", diff)

    load = os.getloadavg()
    rep["loadavg_end"] = load
    (out / "results.json").write_text(json.dumps(rep, indent=1))
    print(f"\nload average at the end {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} (other jobs on the machine skew all "
          f"timings; cpu/wall near {args.threads} means the core's threads really ran in parallel)")
    print(f"images and results.json in {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
