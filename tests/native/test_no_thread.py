"""No worker thread (issue 16, defect 5): when no thread can be created (a pids or RLIMIT_NPROC
limit, no address space left for a stack), the render runs on the calling thread, row by row of
each tile, polling between them: progress is reported and a cancel is seen within the budget, and
the image is the same. The thread creation is made to fail by capping the address space of a
subprocess just above what it uses (a thread's stack is an 8 MB mapping)."""
import os
import subprocess
import sys
import textwrap

import pytest

from conftest import EMULATED, ROOT, SANITIZED

pytestmark = pytest.mark.skipif(SANITIZED or EMULATED or not sys.platform.startswith("linux"),
                                reason="RLIMIT_AS under the sanitizers' shadow memory or qemu's guest "
                                       "address space; Linux only")

SCRIPT = textwrap.dedent("""
    import json, resource, sys, time
    sys.path[:0] = [%(tests)r, %(core)r]
    import numpy as np, unbound_core as uc
    from conftest import make_camera, alloc_passes
    cam = make_camera(240, 180)
    obj = dict(mu=(-0.2, 0.8, 0.1, 0.0), max_iterations=300, detail=4.0)
    shading = dict(ao_strength=1.0, ao_samples=8, ambient=(0.3, 0.3, 0.3))
    out = alloc_passes(240, 180, ["combined"])
    heavy = alloc_passes(720, 540, ["combined"])
    calls, state = [], {}
    def progress(f):
        calls.append(f)
        if len(calls) == 3:
            state["t"], state["cpu"] = time.perf_counter(), time.process_time()
        return len(calls) >= 3
    with open("/proc/self/status") as f:
        used = next(int(l.split()[1]) * 1024 for l in f if l.startswith("VmSize:"))
    cap = used + 6 * 2 ** 20  # below one thread stack (8 MB)
    resource.setrlimit(resource.RLIMIT_AS, (cap, resource.RLIM_INFINITY))
    seen = []
    full = uc.render(cam, [obj], out, shading=shading, threads=2, progress=seen.append, poll_interval=0.001)
    # Heavy enough for many polls on a fast core (at 240x180 it took 15 ms on a Zen 5: two polls).
    stats = uc.render(make_camera(720, 540), [obj], heavy, shading=dict(shading, ao_samples=32), threads=2,
                      progress=progress,
                      poll_interval=0.005)
    latency = (time.perf_counter() - state["t"], time.process_time() - state["cpu"]) if state else None
    resource.setrlimit(resource.RLIMIT_AS, (resource.RLIM_INFINITY, resource.RLIM_INFINITY))
    ref = alloc_passes(240, 180, ["combined"])  # after: glibc keeps freed thread stacks for reuse
    uc.render(cam, [obj], ref, shading=shading, threads=2)
    print(json.dumps(dict(threads=full["threads"], progress=len(seen), monotonic=seen == sorted(seen),
                          same=bool(np.array_equal(ref["combined"], out["combined"])),
                          cancelled=stats["cancelled"], latency=latency)))
""")


def test_render_on_the_calling_thread_polls_and_cancels():
    code = SCRIPT % dict(tests=str(ROOT / "tests" / "native"),
                         core=os.environ.get("UNBOUND_CORE_PATH") or str(ROOT / "build" / "wheel"))
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    import json
    r = json.loads(proc.stdout.strip().splitlines()[-1])
    print(r)
    assert r["threads"] == 1, r  # no worker could start: the calling thread rendered
    assert r["same"], r
    assert r["progress"] >= 5 and r["monotonic"], r  # polled while rendering, not only at the end
    assert r["cancelled"] and r["latency"] is not None, r
    wall, cpu = r["latency"]
    assert cpu <= 0.1 and wall <= 1.0, r
