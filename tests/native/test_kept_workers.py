"""The render's worker threads kept from one render to the next (issue 21, render.c ub_crew):
starting and joining a render's threads cost 0.1-0.2 ms of CPU a thread and call, so one crew of
workers is kept and sleeps between renders. What must hold: no thread is started or ended by the
next render with as many threads; the kept workers take no CPU between renders; any thread
count, in any order, and renders at the same time give the same bytes; a child of fork(), which
has none of the parent's threads, renders too."""
import json
import os
import subprocess
import sys
import textwrap
import threading
import time

import numpy as np
import pytest

import unbound_core as uc
from conftest import EMULATED, KIND_OBJECTS, ROOT, alloc_passes, make_camera

JULIA = KIND_OBJECTS["quaternion_julia"]
SHADING = dict(samples=2, ao_strength=0.5, ao_samples=2)
linux_only = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc/self/task")


def render(threads, camera=None):
    camera = camera or make_camera(160, 120)
    passes = alloc_passes(camera["width"], camera["height"], ["combined", "depth", "normal"])
    stats = uc.render(camera, [JULIA], passes, shading=SHADING, threads=threads)
    return passes, stats


def tasks():
    return set(os.listdir("/proc/self/task"))


def cpu_ns(task):
    try:
        with open("/proc/self/task/%s/schedstat" % task) as f:
            return int(f.read().split()[0])
    except OSError:
        return 0


SAME_WORKERS = textwrap.dedent("""
    import json, os, sys, threading
    sys.path[:0] = [%(tests)r, %(core)r]
    import unbound_core as uc
    from conftest import KIND_OBJECTS, make_camera, alloc_passes
    def workers_seen():
        seen = set()
        def progress(fraction):
            seen.update(os.listdir("/proc/self/task"))
            return False
        passes = alloc_passes(320, 240, ["combined"])
        stats = uc.render(make_camera(320, 240), [KIND_OBJECTS["quaternion_julia"]], passes, threads=2,
                          shading=dict(samples=2, ao_strength=0.5, ao_samples=2), progress=progress,
                          poll_interval=0.0005)
        return sorted(seen - {str(threading.get_native_id())}), stats["threads"]
    print(json.dumps([workers_seen() for _ in range(5)]))
""")


# The subprocess tests: under qemu-user (tests/platforms) the interpreter cannot start another.
no_child_under_qemu = pytest.mark.skipif(EMULATED, reason="qemu-user runs no child interpreter here")


@linux_only
@no_child_under_qemu
def test_the_next_render_starts_no_thread():
    """The same workers (thread ids) in every render of a process: none started, none ended
    (in a process of its own: threads of other tests come and go)."""
    code = SAME_WORKERS % dict(tests=str(ROOT / "tests" / "native"),
                               core=os.environ.get("UNBOUND_CORE_PATH") or str(ROOT / "build" / "wheel"))
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    renders = json.loads(proc.stdout.splitlines()[-1])
    assert all(threads == 2 for _, threads in renders), renders
    assert len(renders[0][0]) >= 2 and all(seen == renders[0][0] for seen, _ in renders), renders


@linux_only
@pytest.mark.skipif(EMULATED, reason="qemu-user's own threads")
def test_kept_workers_sleep_between_renders():
    render(2)
    workers = tasks() - {str(threading.get_native_id())}
    start = {t: cpu_ns(t) for t in workers}
    time.sleep(0.5)
    used = sum(cpu_ns(t) - start[t] for t in workers)
    assert used < 2e6, used  # ns over 0.5 s: nothing but a stray wake-up (measured 0)


def test_any_thread_count_in_any_order_gives_the_same_bytes():
    reference, _ = render(1)
    for threads in (3, 2, 1, 4, 2):
        passes, stats = render(threads)
        assert stats["threads"] == threads
        assert all(np.array_equal(reference[n], passes[n]) for n in reference), threads


def test_renders_at_the_same_time_get_their_own_workers():
    cameras = [make_camera(160, 120), make_camera(160, 120, eye=(0.5, -2.9, 1.0))]
    references = [render(1, c)[0] for c in cameras]
    results, errors = [], []

    def run(i, threads):
        try:
            passes, stats = render(threads, cameras[i])
            results.append(stats["threads"] == threads and
                           all(np.array_equal(references[i][n], passes[n]) for n in passes))
        except Exception as exc:  # noqa: BLE001 - reported below
            errors.append(exc)

    runs = [threading.Thread(target=run, args=(i % 2, 1 + i % 3)) for i in range(8)]
    for t in runs:
        t.start()
    for t in runs:
        t.join()
    assert not errors and len(results) == 8 and all(results), (errors, results)


CHILD = textwrap.dedent("""
    import os, signal, sys
    sys.path[:0] = [%(tests)r, %(core)r]
    import numpy as np, unbound_core as uc
    from conftest import KIND_OBJECTS, make_camera, alloc_passes
    def render():
        passes = alloc_passes(160, 120, ["combined"])
        uc.render(make_camera(160, 120), [KIND_OBJECTS["quaternion_julia"]], passes, threads=2)
        return passes["combined"]
    parent = render()  # the parent's crew is kept now
    pid = os.fork()
    if pid == 0:
        signal.alarm(60)  # a child waiting on workers it does not have would hang
        os._exit(0 if np.array_equal(render(), parent) else 3)
    _, status = os.waitpid(pid, 0)
    print("child", os.waitstatus_to_exitcode(status), "parent", int(np.array_equal(render(), parent)))
""")


@pytest.mark.skipif(not hasattr(os, "fork"), reason="no fork()")
@no_child_under_qemu
def test_a_child_of_fork_renders():
    code = CHILD % dict(tests=str(ROOT / "tests" / "native"),
                        core=os.environ.get("UNBOUND_CORE_PATH") or str(ROOT / "build" / "wheel"))
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert proc.stdout.split()[-4:] == ["child", "0", "parent", "1"], proc.stdout
