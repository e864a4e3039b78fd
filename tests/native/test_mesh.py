"""Convert to Mesh in the core (extract_mesh, native/src/mesh.c): the exact unit ball, every kind,
the default Julia set against the float64 reference, determinism over thread counts, crumbs,
progress and cancel."""
import threading
import time

import numpy as np
import pytest
from conftest import FOREIGN, KIND_OBJECTS, SANITIZED, TIMING_UNRELIABLE, CancelClock, assert_cancel_latencies, uc

from reference import qjulia64

BALL = dict(mu=(0.0, 0.0, 0.0, 0.0), max_iterations=32)


def topology(mesh, pieces=True):
    """Closedness and manifoldness of a triangle mesh: every undirected edge in exactly two faces,
    every directed edge once (consistently oriented), Euler characteristic, pieces (by shared
    vertices), and the enclosed (signed) volume."""
    v, f = mesh.vertices.astype(np.float64), mesh.faces.astype(np.int64)
    directed = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    dkey = directed[:, 0] * (1 << 32) + directed[:, 1]
    und = np.sort(directed, axis=1)
    ukey, counts = np.unique(und[:, 0] * (1 << 32) + und[:, 1], return_counts=True)
    # pieces: label propagation (each vertex takes the least label of its edges' ends) until stable
    edges = np.unique(und, axis=0) if pieces else und[:0]
    label = np.arange(len(v))
    while pieces:
        lo = np.minimum(label[edges[:, 0]], label[edges[:, 1]])
        new = label.copy()
        np.minimum.at(new, edges[:, 0], lo)
        np.minimum.at(new, edges[:, 1], lo)
        new = new[new]
        if np.array_equal(new, label):
            break
        label = new
    used = np.unique(f)
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    volume = np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0
    return dict(edges_in_two_faces=bool((counts == 2).all()), oriented=len(np.unique(dkey)) == len(dkey),
                euler=len(v) - len(ukey) + len(f), pieces=len(np.unique(label[used])),
                all_vertices_used=len(used) == len(v), volume=volume)


def watertight(faces):
    """Lean check for large meshes: the directed edges are all different and each one's reverse is
    among them, i.e. each edge is in exactly two faces, oriented opposite (closed, manifold along
    edges, consistently oriented)."""
    f = faces.astype(np.int64)
    fwd = np.concatenate([f[:, 0] << 32 | f[:, 1], f[:, 1] << 32 | f[:, 2], f[:, 2] << 32 | f[:, 0]])
    rev = np.concatenate([f[:, 1] << 32 | f[:, 0], f[:, 2] << 32 | f[:, 1], f[:, 0] << 32 | f[:, 2]])
    del f
    fwd.sort()
    rev.sort()
    return bool((fwd[1:] != fwd[:-1]).all() and np.array_equal(fwd, rev))


def test_unit_ball_256_is_a_closed_manifold_sphere_on_the_unit_sphere():
    """mu = 0 is exactly the unit ball: at resolution 256 every vertex lies within 1e-3 of radius 1
    (measured 2.5e-4: the surface is estimate = cell / 64, |z| log|z| / 2 = epsilon), each edge
    is in exactly two faces, consistently oriented, Euler characteristic 2, one piece, and the
    enclosed volume is 4 pi / 3 within 0.5% (outward orientation)."""
    m = uc.mesh.extract(BALL, resolution=256)
    r = np.linalg.norm(m.vertices.astype(np.float64), axis=1)
    assert len(r) > 100000
    assert np.abs(r - 1.0).max() < 1e-3
    t = topology(m)
    assert t["edges_in_two_faces"] and t["oriented"] and t["all_vertices_used"], t
    assert watertight(m.faces)
    assert t["euler"] == 2 and t["pieces"] == 1, t
    assert t["volume"] == pytest.approx(4.0 * np.pi / 3.0, rel=5e-3)
    assert m.stats["pieces"] == 1 and not m.stats["cancelled"]
    assert np.all(m.estimate >= m.stats["epsilon"])  # vertices: the bracket's outside end
    assert np.all(m.iterations >= 1) and np.all(np.isfinite(m.trap))


@pytest.mark.parametrize("kind", sorted(KIND_OBJECTS))
def test_every_kind_gives_a_closed_oriented_manifold(kind):
    obj = KIND_OBJECTS[kind]
    m = uc.mesh.extract(obj, resolution=48)
    assert m.stats["face_count"] > 100, (kind, m.stats)
    t = topology(m)
    assert t["edges_in_two_faces"] and t["oriented"] and t["all_vertices_used"], (kind, t)
    assert t["volume"] > 0, (kind, t)
    # every closed orientable piece has an even Euler characteristic
    assert t["euler"] % 2 == 0, (kind, t)
    assert np.isfinite(m.vertices).all() and np.isfinite(m.trap).all()
    d = uc.describe(obj)
    rel = m.vertices.astype(np.float64) - np.array(d["bound_center"])
    assert np.linalg.norm(rel, axis=1).max() <= d["bound_radius"] * (1 + 1e-6) + m.stats["cell_size"]


def test_same_bytes_for_any_thread_count():
    obj = KIND_OBJECTS["quaternion_julia"]
    runs = [uc.extract_mesh(obj, resolution=96, threads=t) for t in (1, 2, 7)]
    for key in ("vertices", "faces", "trap", "iterations", "estimate"):
        assert runs[0][key] == runs[1][key] == runs[2][key], key
    # and the portable kernel gives the AVX2 kernel's bytes where there is one
    if uc.cpu_info()["avx2_fma"]:
        portable = uc.extract_mesh(obj, resolution=96, simd="portable")
        assert all(portable[k] == runs[0][k] for k in ("vertices", "faces", "trap", "iterations"))


DEFAULT_MU = (-0.2, 0.8, 0.0, 0.0)  # the default Julia set: 16 iterations, bailout 4


def assert_on_the_float64_surface(m, sample, seed=1):
    """The quaternion kinds' vertices lie on the float64 surface (issue 20): a sample of vertices,
    each outside by the float64 reference estimate (reference/qjulia64.py, numpy, independent of
    the core) and each with a point inside (estimate < epsilon) within delta = cell / 2^12 along
    one of the three axes, i.e. within four bisection brackets (cell / 2^14) of the boundary of
    {estimate < epsilon}. Returns |d64 - epsilon| / cell at the sample.

    Why not |d64 - epsilon| itself: with 16 iterations most of that boundary (72% of the vertices
    at 256 cells) is where the orbit escapes at the 16th and last iteration, and the estimate
    jumps there from 0 (no escape) to well above epsilon (up to 50 epsilon measured): the vertex
    is at the jump, d64 - epsilon is what the jump leaves over, not a distance. The float32
    mesher (before) left 1.8% of the vertices inside the float64 surface at 256 cells."""
    eps, h = m.stats["epsilon"], m.stats["cell_size"]
    rng = np.random.default_rng(seed)
    v = m.vertices[rng.choice(len(m.vertices), size=min(sample, len(m.vertices)), replace=False)].astype(np.float64)

    def d64(points):
        return qjulia64.distance_estimate(qjulia64.slice_points(points), DEFAULT_MU, 16, 4.0)[0]

    at = d64(v)
    inside_near = np.zeros(len(v), bool)
    for axis in range(3):
        for side in (-1.0, 1.0):
            step = np.zeros(3)
            step[axis] = side * h / 2**12
            inside_near |= d64(v + step) < eps
    assert (at >= eps).all(), ("vertices inside the float64 surface", np.mean(at < eps))
    assert inside_near.all(), ("vertices farther than cell / 2^12 from the float64 surface", np.mean(~inside_near))
    return np.abs(at - eps) / h


def test_default_julia_vertices_on_the_float64_surface():
    """At 256 cells (20 000 vertices checked): see assert_on_the_float64_surface."""
    m = uc.mesh.extract({}, resolution=256)
    assert_on_the_float64_surface(m, 20000)
    assert watertight(m.faces)


@pytest.mark.skipif(SANITIZED or FOREIGN, reason="20 M vertices: native Linux only (the mesher's bits are "
                                                "the same everywhere)")
def test_default_julia_1024_on_the_float64_surface_and_watertight():
    """The default Julia set (mu = (-0.2, 0.8, 0, 0), 16 iterations) at 1024 cells across: closed
    and oriented manifold (watertight), and 200 000 vertices on the float64 surface
    (assert_on_the_float64_surface: outside it, and within cell / 2^12 of a point inside)."""
    m = uc.mesh.extract({}, resolution=1024)
    assert watertight(m.faces)
    assert_on_the_float64_surface(m, 200000)


def test_crumbs_are_removed_below_min_faces():
    obj = KIND_OBJECTS["quaternion_julia"]
    all_pieces = uc.mesh.extract(obj, resolution=128)
    assert all_pieces.stats["pieces"] > 1
    kept = uc.mesh.extract(obj, resolution=128, min_faces=1000)
    assert kept.stats["pieces_removed"] > 0
    t = topology(kept)
    assert t["pieces"] == kept.stats["pieces"] - kept.stats["pieces_removed"], t
    assert t["edges_in_two_faces"] and t["all_vertices_used"], t
    assert len(kept.faces) < len(all_pieces.faces)


def test_progress_and_cancel():
    fractions = []
    m = uc.mesh.extract({}, resolution=192, progress=lambda f: fractions.append(f) and False, poll_interval=0.001)
    assert not m.stats["cancelled"] and fractions and all(0.0 <= f <= 1.0 for f in fractions)
    assert fractions == sorted(fractions)
    stopped = uc.mesh.extract({}, resolution=512, progress=lambda f: True, poll_interval=0.001)
    assert stopped.stats["cancelled"] and len(stopped.vertices) == 0
    ev = threading.Event()
    ev.set()
    assert uc.mesh.extract({}, resolution=512, cancel=ev, poll_interval=0.001).stats["cancelled"]
    with pytest.raises(ZeroDivisionError):
        uc.mesh.extract({}, resolution=128, progress=lambda f: 1 / 0, poll_interval=0.001)


def test_bad_arguments():
    with pytest.raises(ValueError):
        uc.extract_mesh({}, resolution=1)
    with pytest.raises(TypeError):
        uc.extract_mesh({}, resolution=2.5)
    with pytest.raises(ValueError):
        uc.extract_mesh({"mu": (float("nan"), 0, 0, 0)})
    with pytest.raises(TypeError):
        uc.extract_mesh({}, progress=3)


# Where a 1024-cell extraction of the default Julia set is cancelled: (phase, the progress fraction
# whose first report starts a timer, the timer's seconds). What the polls report: the seeds < 0.15
# <= the tracking waves < 0.6, the sort 0.61, triangles and vertex bisection 0.62 - 0.95, the
# crumbs 0.955, the vertex attributes 0.96 - 1 (and then the output, without a copy).
CANCEL_MOMENTS = (("seeding", 0.0, 0.05), ("tracking, first waves", 0.15, 0.0), ("tracking, later waves", 0.35, 0.0),
                  ("sort", 0.61, 0.0), ("triangles and bisection", 0.7, 0.0), ("crumbs", 0.955, 0.0),
                  ("attributes and output", 0.99, 0.0))


@pytest.mark.skipif(TIMING_UNRELIABLE or FOREIGN, reason="timing: the sanitizers or an emulated CPU slow the core "
                                                        "several-fold")
@pytest.mark.parametrize("phase,fraction,delay", CANCEL_MOMENTS, ids=[m[0] for m in CANCEL_MOMENTS])
def test_cancel_1024_returns_within_100_ms_in_every_phase(phase, fraction, delay):
    """Issue 20: a cancel stops a 1024-cell extraction within 100 ms whatever it is doing (polls
    in every serial stretch: hash-map growth, the wave bookkeeping, the sort, the crumbs; big
    buffers freed after the return). The cancel comes from another thread (a timer setting the
    threading.Event, as the operator's modal loop does), so the wait for the next poll counts.
    Held to conftest's budget: process CPU time from the cancel to the return <= 100 ms
    (measured 0.2 - 8 ms), wall <= 1 s (the margin for a loaded 2-core machine)."""
    cancel, clock, started = threading.Event(), CancelClock(), []

    def fire():
        clock.mark()
        cancel.set()

    def progress(f):
        if not started and f >= fraction:
            started.append(threading.Timer(delay, fire))
            started[0].start()
        return False

    m = uc.mesh.extract({}, resolution=1024, threads=2, progress=progress, cancel=cancel, poll_interval=0.002)
    latency = clock.latency() if clock.marked else None
    for timer in started:
        timer.join()
    assert latency is not None, "the extraction ended before the cancel (%s)" % phase
    assert m.stats["cancelled"] and len(m.vertices) == 0, m.stats
    assert_cancel_latencies([latency], "extract_mesh 1024, %s" % phase)
