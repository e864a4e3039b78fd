"""1000 calls in one process with flat memory: resident set size (C allocations, threads) and
tracemalloc's count of Python allocations (objects, numpy buffers) stop growing after warm-up.
Leaks of the C core that are too small for RSS are LeakSanitizer's job (tools/sanitize.sh test)."""
import gc
import tracemalloc

import numpy as np
import pytest
import unbound_core as uc

from conftest import EMULATED, SANITIZED, alloc_passes, make_camera

pytestmark = pytest.mark.skipif(SANITIZED, reason="ASan's allocator keeps freed memory in quarantine")

RENDERS = 1000
WARM_UP = 100
SHADING = dict(shadows="soft", reflection_depth=1, ao_strength=0.5, ao_samples=2, samples=1,
               lights=[dict(type="point", position=(2.0, -2.0, 2.0))])
OBJECTS = [dict(mu=(-0.2, 0.8, 0.1, 0.0), max_iterations=12),
           dict(kind="ifs", ifs_depth=3, matrix=[[1, 0, 0, 1.5], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]],
                maps=[[[0.5, 0, 0, x], [0, 0.5, 0, 0], [0, 0, 0.5, 0.4]] for x in (-0.5, 0.5)]),
           dict(kind="julia_stack", path=[(-0.1, 0.65), (-0.8, 0.15)], matrix=[[1, 0, 0, -1.5], [0, 1, 0, 0],
                                                                               [0, 0, 1, 0], [0, 0, 0, 1]])]


def resident_bytes():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * 4096


def one_round(cam, passes, points, est, its, i):
    stats = uc.render(cam, OBJECTS, passes, shading=SHADING, threads=2, progress=lambda f: False)
    assert not stats["cancelled"]
    uc.estimate(OBJECTS[i % 3], points, est, its)
    uc.describe(OBJECTS[i % 3])
    # The error paths allocate and must free too.
    with pytest.raises(ValueError):
        uc.render(cam, [dict(OBJECTS[0], mu=(float("nan"), 0, 0, 0))], passes)
    with pytest.raises(ValueError):
        uc.render(cam, OBJECTS, passes, shading=dict(SHADING, lights=[dict(type="laser")]))
    # A cancelled render (by the callback, at its first poll).
    uc.render(cam, OBJECTS, passes, shading=SHADING, progress=lambda f: True, poll_interval=1e-4)


def test_thousand_renders_with_flat_memory():
    cam = make_camera(48, 36)
    passes = alloc_passes(48, 36)
    rng = np.random.default_rng(6)
    points = rng.uniform(-1.5, 1.5, (256, 3)).astype(np.float32)
    est = np.empty(256, np.float32)
    its = np.empty(256, np.float32)
    for i in range(WARM_UP):
        one_round(cam, passes, points, est, its, i)
    gc.collect()
    tracemalloc.start()
    traced_start = tracemalloc.get_traced_memory()[0]
    rss_start = resident_bytes()
    for i in range(WARM_UP, RENDERS):
        one_round(cam, passes, points, est, its, i)
    gc.collect()
    traced_growth = tracemalloc.get_traced_memory()[0] - traced_start
    tracemalloc.stop()
    rss_growth = resident_bytes() - rss_start
    print("after %d more rounds: RSS %+d bytes, traced Python allocations %+d bytes"
          % (RENDERS - WARM_UP, rss_growth, traced_growth))
    # 900 rounds of 4 calls: a leak of one 48x36 pass (27 KB) per round would be 24 MB.
    # qemu-user keeps ~290 KB of its own per guest thread ever started (measured with plain Python
    # threads: +516 MB over 1800), so under emulation only the traced allocations say something.
    if not EMULATED:
        assert rss_growth < 2 * 2 ** 20, rss_growth
    # Less than 16 bytes per round: not one leaked Python object per call.
    assert traced_growth < 16 * (RENDERS - WARM_UP), traced_growth
