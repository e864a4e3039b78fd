"""Benchmark: Convert to Mesh (unbound_core.extract_mesh) on the default quaternion Julia set
(mu = -0.2+0.8i, 16 iterations, bailout 4) at several resolutions, next to a dense grid.

Each run is its own process (so that peak resident memory, ru_maxrss, is that run's alone): wall
time, the core's own timer and phase times, CPU seconds (user + system: the machine may be shared;
cpu / wall tells how much of the 2 cores a run got), peak RSS of the whole process (Python, the
result's numpy arrays included) and the core's own peak bytes, cells, vertices, faces, pieces,
estimate evaluations. With --repeats N each resolution runs N times: medians with min-max.

The dense-grid column is what sampling every lattice point (resolution + 3)^3 would cost: float32
values alone ((N+3)^3 * 4 bytes, before any triangle), and the time of that many evaluations at the
rate measured here for extract_mesh's own evaluations (evaluations / CPU seconds, times the threads).

--check64 SAMPLE checks SAMPLE vertices against the float64 reference (reference/qjulia64.py), after
the timing: the fraction outside the float64 surface {estimate < epsilon}, the fraction with a
point inside within cell / 2^12 along an axis (tests/native/test_mesh.py asserts both are 1), and
|d64 - epsilon| in cells (median, 99%, max: not small, the estimate jumps where the orbit escapes
at the last iteration).

    python bench/bench_mesh.py [--res 256 512 1024 2048] [--repeats 1] [--threads 2] [--check64 0]
                               [--out bench/out/mesh]
"""
import argparse
import json
import os
import pathlib
import resource
import statistics
import subprocess
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]


def check64(m, sample):
    import numpy as np
    sys.path.insert(0, str(ROOT))
    from reference import qjulia64
    eps, h = m.stats["epsilon"], m.stats["cell_size"]
    rng = np.random.default_rng(1)
    v = m.vertices[rng.choice(len(m.vertices), size=min(sample, len(m.vertices)), replace=False)].astype(np.float64)

    def d64(p):
        return qjulia64.distance_estimate(qjulia64.slice_points(p), (-0.2, 0.8, 0.0, 0.0), 16, 4.0)[0]

    at, near = d64(v), np.zeros(len(v), bool)
    for axis in range(3):
        for side in (-1.0, 1.0):
            step = np.zeros(3)
            step[axis] = side * h / 2**12
            near |= d64(v + step) < eps
    q = np.quantile(np.abs(at - eps) / h, [0.5, 0.99, 1.0])
    return dict(sample=len(v), outside=float(np.mean(at >= eps)), inside_within=float(np.mean(near)),
                err_cells_median=float(q[0]), err_cells_99=float(q[1]), err_cells_max=float(q[2]))


def child(res, threads, sample):
    sys.path.insert(0, str(ROOT / "build" / "wheel"))
    import unbound_core as uc
    t0, c0 = time.perf_counter(), time.process_time()
    m = uc.mesh.extract({}, resolution=res, threads=threads)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    out = dict(m.stats, wall=wall, cpu=cpu, peak_rss=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024,
               load=os.getloadavg()[0])
    if sample:
        out["check64"] = check64(m, sample)
    print("RESULT " + json.dumps(out))


def spread(rows, key, scale=1.0, fmt="%.1f"):
    values = [r[key] * scale for r in rows]
    text = fmt % statistics.median(values)
    return text if len(values) == 1 else "%s (%s-%s)" % (text, fmt % min(values), fmt % max(values))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--res", type=int, nargs="+", default=[256, 512, 1024])
    ap.add_argument("--repeats", type=int, default=1)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--check64", type=int, default=0, help="vertices checked against the float64 reference")
    ap.add_argument("--out", default=str(ROOT / "bench" / "out" / "mesh"))
    ap.add_argument("--child", type=int)
    a = ap.parse_args()
    if a.child:
        return child(a.child, a.threads, a.check64)
    summary = []
    for res in a.res:
        runs = []
        for _ in range(a.repeats):
            p = subprocess.run([sys.executable, __file__, "--child", str(res), "--threads", str(a.threads),
                                "--check64", str(a.check64)], capture_output=True, text=True)
            line = [x for x in p.stdout.splitlines() if x.startswith("RESULT ")]
            if not line:
                print(res, "failed", p.stderr[-2000:])
                continue
            r = json.loads(line[-1][7:])
            rate = r["evaluations"] / max(r["cpu"], 1e-9)  # per CPU second
            dense_points = (res + 3) ** 3
            r.update(res=res, dense_bytes=dense_points * 4, dense_seconds=dense_points / rate / a.threads,
                     cpu_per_wall=r["cpu"] / r["wall"])
            runs.append(r)
            print("res %d: wall %.1f s, cpu %.1f s (cpu/wall %.2f, load %.1f), RSS %.0f MB, core %.0f MB, %d vertices, "
                  "%d faces, %d pieces, %d evaluations; dense grid %.2f GB, %.0f s%s" % (
                      res, r["wall"], r["cpu"], r["cpu_per_wall"], r["load"], r["peak_rss"] / 2**20,
                      r["peak_bytes"] / 2**20, r["vertex_count"], r["face_count"], r["pieces"], r["evaluations"],
                      r["dense_bytes"] / 1e9, r["dense_seconds"],
                      "; float64 check %s" % json.dumps(r["check64"]) if "check64" in r else ""), flush=True)
        if runs:
            summary.append(dict(res=res, runs=runs, wall=spread(runs, "wall"), cpu=spread(runs, "cpu"),
                                rss_mb=spread(runs, "peak_rss", 2**-20, "%.0f"),
                                core_mb=spread(runs, "peak_bytes", 2**-20, "%.0f")))
            print("res %d, %d runs: wall %s s, cpu %s s, RSS %s MB, core %s MB" % (
                res, len(runs), summary[-1]["wall"], summary[-1]["cpu"], summary[-1]["rss_mb"], summary[-1]["core_mb"]))
    os.makedirs(a.out, exist_ok=True)
    pathlib.Path(a.out, "results.json").write_text(json.dumps(summary, indent=1))


if __name__ == "__main__":
    main()
