"""Benchmark: Convert to Volume (addon/convert.py) on the default quaternion Julia set at several
resolutions, in bpy with the built extension installed.

Each resolution runs in its own bpy process. It times the operator's two halves apart first: the
core's extraction, and write_grid (temporary objects, Mesh to SDF Grid, save) with the growth of
peak resident memory over it (Linux: VmHWM, reset through /proc/self/clear_refs before it) against
the band-voxel estimate the operator's memory preflight uses; then the operator as a user calls it
(mesh extraction, the grid by Blender's OpenVDB, the .vdb write, the Volume object). File size; and,
when the Python 3.13 / bpy 5.2 chroot of tools/py313.sh is set up, the files' exact active voxel
counts and grid class read with the OpenVDB Python module bundled with bpy 5.2.

    python bench/bench_volume.py [--res 256 512 1024] [--grid SDF] [--out bench/out/volume]
"""
import argparse
import json
import os
import pathlib
import subprocess
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]


def memory_status(key):
    with open("/proc/self/status") as f:
        return next(int(line.split()[1]) * 1024 for line in f if line.startswith(key + ":"))


def child(res, grid, out):
    from blender_user import private_user_directory
    private_user_directory()  # before bpy starts
    import bpy
    sys.path.insert(0, str(ROOT / "examples"))
    from unbound_extension import ensure_extension, new_scene
    module = ensure_extension(str(ROOT / "dist" / "unbound-0.1.0.zip"))
    convert = sys.modules[module].convert
    new_scene(64, 48, (0.0, 0.0, 0.0))
    bpy.ops.object.unbound_fractal_add(use_cursor=False)
    fractal = bpy.context.object
    fractal.name = "Julia %d" % res  # the file's name: one per resolution
    os.makedirs(out, exist_ok=True)
    bpy.ops.wm.save_as_mainfile(filepath=os.path.join(out, "res%d.blend" % res))
    # the halves apart, first (a fresh process: memory freed by an earlier step is not reused here)
    t0 = time.perf_counter()
    mesh = convert.extract(fractal, bpy.context.evaluated_depsgraph_get(), res, 0)
    extract = time.perf_counter() - t0
    h = mesh.stats["cell_size"]
    estimate = convert.band_voxels(mesh, h, 3)
    with open("/proc/self/clear_refs", "w") as f:
        f.write("5")  # peak RSS := current RSS
    rss0 = memory_status("VmRSS")
    t0 = time.perf_counter()
    convert.write_grid(bpy.context, mesh, grid, h, 3, os.path.join(out, "again.vdb"))
    grid_seconds = time.perf_counter() - t0
    grid_peak = memory_status("VmHWM") - rss0
    del mesh
    # the operator as a user calls it
    t0 = time.perf_counter()
    assert bpy.ops.object.unbound_convert_to_volume(resolution=res, grid=grid) == {'FINISHED'}
    operator = time.perf_counter() - t0
    path = bpy.path.abspath(bpy.context.object.data.filepath)
    print("RESULT " + json.dumps(dict(res=res, grid=grid, operator=operator, extract=extract, write_grid=grid_seconds,
                                      grid_peak=grid_peak, estimate=estimate, voxel_size=h, path=path,
                                      file_bytes=os.path.getsize(path))))
    sys.stdout.flush()
    os.remove(os.path.join(out, "again.vdb"))


OPENVDB_READ = """
import glob, json, os, sys
import bpy
sys.path.append(glob.glob(os.path.join(bpy.utils.system_resource('PYTHON'), 'lib', 'python3*', 'site-packages'))[0])
import openvdb
for path in sys.argv[1:]:
    g = openvdb.read(path, openvdb.readAllGridMetadata(path)[0].name)
    print('VDB ' + json.dumps(dict(path=path, active=g.activeVoxelCount(), grid_class=str(g.gridClass),
                                   mem=g.memUsage() if hasattr(g, 'memUsage') else None)))
"""


def read_with_openvdb(paths):
    """{relative path: (active voxels, class, bytes in memory)} from bpy 5.2's OpenVDB, or {}."""
    if os.geteuid() != 0 or not pathlib.Path("/opt/unbound-py313/opt/venv/bin").is_dir():
        return {}
    script = ROOT / "bench" / "out" / "openvdb_read.py"
    script.write_text(OPENVDB_READ)
    rel = [os.path.relpath(p, ROOT) for p in paths]
    p = subprocess.run(["sh", "tools/py313.sh", "run", "/opt/venv/bin/python", os.path.relpath(script, ROOT)] + rel,
                       cwd=ROOT, capture_output=True, text=True)
    rows = [json.loads(x[4:]) for x in p.stdout.splitlines() if x.startswith("VDB ")]
    if not rows:
        print("openvdb read failed:", p.stdout[-1000:], p.stderr[-1000:])
    return {r["path"]: r for r in rows}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--res", type=int, nargs="+", default=[256, 512, 1024])
    ap.add_argument("--grid", default="SDF", choices=["SDF", "DENSITY"])
    ap.add_argument("--out", default=str(ROOT / "bench" / "out" / "volume"))
    ap.add_argument("--child", type=int)
    a = ap.parse_args()
    if a.child:
        return child(a.child, a.grid, a.out)
    rows = []
    for res in a.res:
        p = subprocess.run([sys.executable, __file__, "--child", str(res), "--grid", a.grid, "--out", a.out],
                           capture_output=True, text=True)
        line = [x for x in p.stdout.splitlines() if x.startswith("RESULT ")]
        if not line:
            print(res, "failed", p.stdout[-2000:], p.stderr[-2000:])
            continue
        rows.append(json.loads(line[-1][7:]))
    exact = read_with_openvdb([r["path"] for r in rows])
    print("%6s %9s %10s %10s %11s %12s %12s %10s %12s %8s" % (
        "res", "voxel", "operator s", "extract s", "write_grid s", "est. voxels", "voxels", "file MB",
        "grid peak MB", "B/voxel"))
    for r in rows:
        e = exact.get(os.path.relpath(r["path"], ROOT), {})
        r.update(active_voxels=e.get("active"), grid_class=e.get("grid_class"), grid_mem=e.get("mem"))
        voxels = r["active_voxels"] or r["estimate"]
        print("%6d %9.5f %10.1f %10.1f %11.1f %12.3g %12s %10.1f %12.0f %8.0f" % (
            r["res"], r["voxel_size"], r["operator"], r["extract"], r["write_grid"], r["estimate"],
            "%.3g" % r["active_voxels"] if r["active_voxels"] else "-", r["file_bytes"] / 1e6,
            r["grid_peak"] / 2**20, r["grid_peak"] / voxels))
    pathlib.Path(a.out, "results.json").write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
