"""Benchmark: Convert to Mesh (unbound_core.extract_mesh) on the default quaternion Julia set
(mu = -0.2+0.8i, 16 iterations, bailout 4) at several resolutions, next to a dense grid.

Each resolution runs in its own process (so that peak resident memory, ru_maxrss, is that run's
alone): wall time, the core's own timer and phase times, CPU seconds (user + system: the machine
may be shared), peak RSS of the whole process (Python, numpy arrays of the result included) and the
core's own peak bytes, cells, vertices, faces, pieces, estimate evaluations.

The dense-grid column is what sampling every lattice point (resolution + 3)^3 would cost: float32
values alone ((N+3)^3 * 4 bytes, before any triangle), and the time of that many evaluations at the
rate measured here for extract_mesh's own evaluations (evaluations / CPU seconds, times the threads).

    python bench/bench_mesh.py [--res 256 512 1024 2048] [--threads 2] [--out bench/out/mesh]
"""
import argparse
import json
import os
import pathlib
import resource
import subprocess
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]


def child(res, threads):
    sys.path.insert(0, str(ROOT / "build" / "wheel"))
    import unbound_core as uc
    t0, c0 = time.perf_counter(), time.process_time()
    m = uc.mesh.extract({}, resolution=res, threads=threads)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    out = dict(m.stats, wall=wall, cpu=cpu, peak_rss=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024)
    print("RESULT " + json.dumps(out))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--res", type=int, nargs="+", default=[256, 512, 1024])
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--out", default=str(ROOT / "bench" / "out" / "mesh"))
    ap.add_argument("--child", type=int)
    a = ap.parse_args()
    if a.child:
        return child(a.child, a.threads)
    rows = []
    print("%6s %8s %8s %9s %9s %10s %10s %7s %12s %12s %12s" % (
        "res", "wall s", "cpu s", "RSS MB", "core MB", "vertices", "faces", "pieces", "evals", "dense GB",
        "dense s"))
    for res in a.res:
        p = subprocess.run([sys.executable, __file__, "--child", str(res), "--threads", str(a.threads)],
                           capture_output=True, text=True)
        line = [x for x in p.stdout.splitlines() if x.startswith("RESULT ")]
        if not line:
            print(res, "failed", p.stderr[-2000:])
            continue
        r = json.loads(line[-1][7:])
        rate = r["evaluations"] / max(r["cpu"], 1e-9)  # per CPU second
        dense_points = (res + 3) ** 3
        r.update(res=res, dense_bytes=dense_points * 4, dense_seconds=dense_points / rate / a.threads)
        rows.append(r)
        print("%6d %8.1f %8.1f %9.0f %9.0f %10d %10d %7d %12d %12.1f %12.0f" % (
            res, r["wall"], r["cpu"], r["peak_rss"] / 2**20, r["peak_bytes"] / 2**20, r["vertex_count"],
            r["face_count"], r["pieces"], r["evaluations"], r["dense_bytes"] / 1e9, r["dense_seconds"]))
    os.makedirs(a.out, exist_ok=True)
    pathlib.Path(a.out, "results.json").write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
