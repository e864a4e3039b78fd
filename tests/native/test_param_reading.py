"""Issue 21: the core reads the common values (floats, tuples and lists of floats, matrices of them,
ints, bools) without formatting their names, and formats a name only for a value it must look at
closer (module.c, quick_value). Both ways must read the same numbers, and a bad value given the
quick way must still be named exactly in its message."""
import math

import numpy as np
import pytest
import unbound_core as uc

from conftest import make_camera

W, H = 24, 18

JULIA = dict(kind="quaternion_julia", mu=(-0.2, 0.8, 0.1, -0.05), theta=0.3, max_iterations=12, bailout=4.0,
             detail=1.5, step_factor=0.9, color=(0.8, 0.5, 0.3), reflectivity=0.2,
             matrix=[[0.9, 0.1, 0.0, 0.1], [-0.1, 0.9, 0.0, 0.0], [0.0, 0.0, 1.1, 0.05], [0.0, 0.0, 0.0, 1.0]],
             slice_basis=((1.0, 0.0, 0.0), (0.0, 0.6, 0.0), (0.0, 0.0, 1.0), (0.0, 0.8, 0.0)),
             slice_origin=(0.0, 0.0, 0.0, 0.1), color_mode="orbit_trap",
             color_ramp=[(0.1, 0.2, 0.3), (0.9, 0.5, 0.1), (0.2, 0.8, 0.4)])
IFS = dict(kind="ifs", ifs_depth=5, max_iterations=8,
           maps=[[[0.5, 0.0, 0.0, 0.5], [0.0, 0.5, 0.0, 0.0], [0.0, 0.0, 0.5, 0.0]],
                 [[0.5, 0.0, 0.0, -0.5], [0.0, 0.5, 0.0, 0.0], [0.0, 0.0, 0.5, 0.0]],
                 [[0.5, 0.0, 0.0, 0.0], [0.0, 0.5, 0.0, 0.5], [0.0, 0.0, 0.5, 0.3]]])


def the_named_way(value):
    """The same numbers in forms the quick path does not take: numpy arrays for sequences, and
    np.float32 scalars (no Python float: read through __float__) for floats that float32 holds."""
    if isinstance(value, float):
        return np.float32(value) if float(np.float32(value)) == value else value
    if isinstance(value, (list, tuple)) and value and isinstance(value[0], (float, list, tuple)):
        return np.array(value, np.float64)
    return value


def named(obj):
    return {k: the_named_way(v) for k, v in obj.items()}


@pytest.mark.parametrize("obj", [JULIA, IFS], ids=["julia", "ifs"])
def test_quick_and_named_readings_are_the_same(obj):
    quick, slow = uc.describe(obj), uc.describe(named(obj))
    assert quick == slow
    camera = make_camera(W, H)
    out = []
    for o in (obj, named(obj)):
        passes = {n: np.full((H, W, uc.PASS_CHANNELS[n]), np.nan, np.float32) for n in ("combined", "depth", "normal")}
        uc.render(camera, [o], passes, threads=1)
        out.append({n: p.tobytes() for n, p in passes.items()})
    assert out[0] == out[1]
    # Not a render of nothing: the fractal is in view.
    assert np.isfinite(np.frombuffer(out[0]["depth"], np.float32)).any()


def test_each_quick_value_lands_in_its_own_field():
    """A value read the quick way changes what describe() reports, field by field (a row or
    offset mixed up in the quick path would leave one of them at its default)."""
    base = uc.describe(JULIA)
    for key, value, field in (("bailout", 6.0, "bailout"), ("step_factor", 0.5, "step_factor"),
                              ("matrix", [[2.0, 0.0, 0.0, 0.0], [0.0, 2.0, 0.0, 0.0], [0.0, 0.0, 2.0, 0.0],
                                          [0.0, 0.0, 0.0, 1.0]], "sigma_max"),
                              ("slice_origin", (0.0, 0.0, 0.0, 0.3), "slice_origin"),
                              ("max_iterations", 20, "max_iterations")):
        changed = uc.describe(dict(JULIA, **{key: value}))
        assert changed[field] != base[field], key
        assert changed == uc.describe(named(dict(JULIA, **{key: value}))), key


NAN, INF = math.nan, math.inf


@pytest.mark.parametrize("change,exc,message", [
    (dict(mu=(0.0, INF, 0.0, 0.0)), ValueError, r"^objects\[0\]\.mu\[1\] must be finite$"),
    (dict(mu=(0.0, 0.0, 2e3, 0.0)), ValueError, r"^objects\[0\]\.mu\[2\] must be in \[-1000, 1000\], got 2000$"),
    (dict(mu=[0.0, 0.0, 0.0]), ValueError, r"^objects\[0\]\.mu must have 4 components, got 3$"),
    (dict(bailout=NAN), ValueError, r"^objects\[0\]\.bailout must be finite$"),
    (dict(matrix=[[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, NAN, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]]),
     ValueError, r"^objects\[0\]\.matrix\[1\]\[2\] must be finite$"),
    (dict(matrix=[[1.0, 0.0, 0.0, 0.0]] * 3), ValueError, r"^objects\[0\]\.matrix must be a 4x4 matrix, got 3 rows$"),
    (dict(max_iterations=10 ** 6), ValueError, r"^objects\[0\]\.max_iterations must be in \[1, 10000\]$"),
    (dict(max_iterations=True), None, None),  # a bool is an int to the named reader too
    (dict(name="Ghost", color=(0.5, -1.0, 0.5)), ValueError, r"^fractal 'Ghost': color\[1\] must be in \[0, 1e\+06\], got -1$"),
    (dict(color_ramp=[(0.1, 0.2, 0.3), (0.1, INF, 0.3)]), ValueError,
     r"^objects\[0\]\.color_ramp\[1\]\[1\] must be finite$"),
])
def test_bad_values_given_the_quick_way_are_named(change, exc, message):
    camera = make_camera(W, H)
    passes = {"combined": np.zeros((H, W, 4), np.float32)}
    obj = dict(dict(max_iterations=8), **change)
    if exc is None:
        uc.render(camera, [obj], passes, threads=1)
        return
    with pytest.raises(exc, match=message):
        uc.render(camera, [obj], passes, threads=1)
