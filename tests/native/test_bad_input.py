"""Every bad input is a ValueError/TypeError naming the parameter, never a crash."""
import math

import numpy as np
import pytest
import unbound_core as uc

from conftest import alloc_passes, make_camera

W, H = 16, 12


def call(camera=None, objects=None, passes=None, **kw):
    camera = make_camera(W, H) if camera is None else camera
    objects = [dict(max_iterations=8)] if objects is None else objects
    passes = alloc_passes(W, H, ["combined", "depth"]) if passes is None else passes
    return uc.render(camera, objects, passes, **kw)


def cam_with(**changes):
    c = make_camera(W, H)
    c.update(changes)
    return c


NAN, INF = math.nan, math.inf
OBJECT_CASES = [
    (dict(mu=(NAN, 0, 0, 0)), ValueError, r"objects\[0\]\.mu\[0\] must be finite"),
    (dict(mu=(0, INF, 0, 0)), ValueError, r"objects\[0\]\.mu\[1\] must be finite"),
    (dict(mu=(0, 0, 0)), ValueError, r"objects\[0\]\.mu must have 4 components"),
    (dict(mu="abcd"), TypeError, r"objects\[0\]\.mu must be a sequence"),
    (dict(mu=(1e9, 0, 0, 0)), ValueError, r"objects\[0\]\.mu\[0\] must be in \[-1000, 1000\], got 1e\+09"),
    (dict(slice_origin=(0, 0, 0, -2e3)), ValueError, r"objects\[0\]\.slice_origin\[3\] must be in \[-1000, 1000\]"),
    (dict(color=(0.5, 2e6, 0.5)), ValueError, r"objects\[0\]\.color\[1\] must be in \[0, 1e\+06\]"),
    (dict(name="Ghost", theta=NAN), ValueError,
     r"^fractal 'Ghost': theta must be finite \(check its keyframes and drivers\)$"),
    (dict(name="Ghost", mu=(0, 0, NAN, 0)), ValueError, r"^fractal 'Ghost': mu\[2\] must be finite \(check"),
    (dict(name="Ghost", matrix=[[0, 0, 0, 0]] * 3 + [[0, 0, 0, 1]]), ValueError,
     r"^fractal 'Ghost': object_to_world must be invertible"),
    (dict(name=3), TypeError, r"objects\[0\]\.name must be a string"),
    (dict(name="x" * 64), ValueError, r"objects\[0\]\.name must be a string of at most 63 bytes"),
    (dict(theta=NAN), ValueError, r"objects\[0\]\.theta must be finite"),
    (dict(max_iterations=0), ValueError, r"objects\[0\]\.max_iterations must be in \[1, 10000\]"),
    (dict(max_iterations=-5), ValueError, r"max_iterations"),
    (dict(max_iterations=10 ** 12), ValueError, r"max_iterations"),
    (dict(max_iterations=10 ** 40), ValueError, r"max_iterations"),
    (dict(max_iterations=3.5), TypeError, r"max_iterations must be an integer"),
    (dict(bailout=NAN), ValueError, r"bailout must be finite"),
    (dict(bailout=0.5), ValueError, r"bailout must be in"),
    (dict(bailout=INF), ValueError, r"bailout must be finite"),
    (dict(epsilon=0.0), ValueError, r"epsilon must be in"),
    (dict(epsilon=-1e-3), ValueError, r"epsilon must be in"),
    (dict(detail=NAN), ValueError, r"detail must be finite"),
    (dict(step_factor=2.0), ValueError, r"step_factor must be in"),
    (dict(max_step=0.0), ValueError, r"max_step must be in"),
    (dict(max_step=NAN), ValueError, r"max_step must be finite"),
    (dict(max_steps=0), ValueError, r"max_steps"),
    (dict(bisection_steps=-1), ValueError, r"bisection_steps"),
    (dict(threshold_mode="tiny"), ValueError, r"threshold_mode must be one of"),
    (dict(kind="buddhabrot"), ValueError, r"kind must be one of"),
    (dict(color=(1, 1)), ValueError, r"color must have 3 components"),
    (dict(slice_basis=[[1, 0, 0], [0, 1, 0], [0, 0, 2], [0, 0, 0]]), ValueError, r"orthonormal"),
    (dict(slice_basis=[[1, 0], [0, 1]]), ValueError, r"slice_basis must be a 4x3 matrix"),
    (dict(matrix=[[0, 0, 0, 0]] * 3 + [[0, 0, 0, 1]]), ValueError, r"objects\[0\]: object_to_world must be invertible"),
    (dict(matrix=[[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [1, 0, 0, 1]]), ValueError, r"affine"),
    (dict(matrix=[[1, 0, 0, NAN], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]), ValueError, r"matrix\[0\]\[3\] must be finite"),
    (dict(colour=(1, 0, 0)), ValueError, r"unknown key 'colour'"),
]


@pytest.mark.parametrize("change,exc,message", OBJECT_CASES)
def test_bad_object_parameters(change, exc, message):
    with pytest.raises(exc, match=message):
        call(objects=[dict(dict(max_iterations=8), **change)])


@pytest.mark.parametrize("camera,exc,message", [
    (cam_with(width=0), ValueError, r"camera\.width must be in \[1, 65536\]"),
    (cam_with(height=-3), ValueError, r"camera\.height must be in"),
    (cam_with(width=10 ** 6), ValueError, r"camera\.width"),
    (cam_with(width=1.5), TypeError, r"camera\.width must be an integer"),
    (cam_with(projection=[[0] * 4] * 4), ValueError, r"camera\.projection must be invertible"),
    (cam_with(projection=[[NAN] * 4] * 4), ValueError, r"camera\.projection\[0\]\[0\] must be finite"),
    (cam_with(matrix=[[0] * 4] * 4), ValueError, r"camera\.matrix must have a non-degenerate rotation"),
    (cam_with(matrix=[[1, 0, 0]] * 4), ValueError, r"camera\.matrix\[0\] must have 4 components"),
    ({"matrix": np.eye(4).tolist(), "width": 4, "height": 4}, ValueError, r"camera needs"),
    ("camera", TypeError, r"camera must be a dict"),
])
def test_bad_camera(camera, exc, message):
    with pytest.raises(exc, match=message):
        call(camera=camera)


def test_bad_passes():
    with pytest.raises(ValueError, match=r"passes\['combined'\] must have shape \(12, 16, 4\)"):
        call(passes={"combined": np.zeros((12, 16, 3), np.float32)})
    with pytest.raises(TypeError, match=r"passes\['depth'\] must have dtype float32"):
        call(passes={"depth": np.zeros((12, 16), np.float64)})
    with pytest.raises(ValueError, match=r"passes\['depth'\] must be C-contiguous"):
        call(passes={"depth": np.zeros((16, 12), np.float32).T})
    with pytest.raises(TypeError, match=r"passes\['depth'\] must be a writable buffer"):
        ro = np.zeros((12, 16), np.float32)
        ro.flags.writeable = False
        call(passes={"depth": ro})
    with pytest.raises(TypeError, match=r"passes\['depth'\] must be a writable buffer"):
        call(passes={"depth": [0.0] * (12 * 16)})
    with pytest.raises(ValueError, match=r"passes: unknown pass 'Depth'"):
        call(passes={"Depth": np.zeros((12, 16), np.float32)})
    with pytest.raises(ValueError, match=r"passes\['depth'\] must have shape"):
        call(passes={"depth": np.zeros((0, 0), np.float32)})


@pytest.mark.parametrize("window,message", [
    ((0, 0, 17, 12), r"window .* must lie inside the 16x12 image"),
    ((-1, 0, 4, 4), r"window"),
    ((0, 0, 0, 4), r"window"),
    ((2, 2, 14, 11), r"window"),
    ((0.5, 0, 4, 4), r"window must be 4 integers"),
    ((NAN, 0, 4, 4), r"window\[0\] must be finite"),
])
def test_bad_window(window, message):
    with pytest.raises(ValueError, match=message):
        call(window=window)


def test_bad_options():
    with pytest.raises(ValueError, match=r"threads must be in \[0, 1024\]"):
        call(threads=-1)
    with pytest.raises(ValueError, match=r"threads must be in"):
        call(threads=100000)
    with pytest.raises(ValueError, match=r"tile_size must be in"):
        call(tile_size=0)
    with pytest.raises(ValueError, match=r"simd must be one of"):
        call(simd="sse9")
    with pytest.raises(TypeError, match=r"progress must be callable"):
        call(progress=3)
    with pytest.raises(TypeError, match=r"cancel must have an is_set"):
        call(cancel=object())
    with pytest.raises(ValueError, match=r"background\[3\] must be finite"):
        call(background=(0, 0, 0, NAN))
    with pytest.raises(ValueError, match=r"objects: at most 64"):
        call(objects=[dict()] * 65)
    with pytest.raises(TypeError, match=r"objects must be a list"):
        call(objects=dict())


def test_empty_object_list_renders_background():
    passes = alloc_passes(W, H, ["combined", "depth", "alpha"])
    stats = uc.render(make_camera(W, H), [], passes, background=(0.1, 0.2, 0.3, 1.0))
    assert stats["rays"] == W * H
    assert np.all(passes["depth"] == np.float32(1e10))
    assert np.allclose(passes["combined"], np.array([0.1, 0.2, 0.3, 1.0], np.float32))
    assert np.all(passes["alpha"] == 0)


def test_estimate_bad_input():
    with pytest.raises(ValueError, match=r"points must be a C-contiguous float32 array of shape \(n, 3\)"):
        uc.estimate({}, np.zeros((4, 2), np.float32), np.zeros(4, np.float32), np.zeros(4, np.float32))
    with pytest.raises(ValueError, match=r"estimate must have shape \(4,\)"):
        uc.estimate({}, np.zeros((4, 3), np.float32), np.zeros(3, np.float32), np.zeros(4, np.float32))


def test_one_dimensional_outputs_reject_empty_columns():
    """A (n, 0) float32 array holds no bytes: estimate/iterations/t buffers of that shape were
    once accepted as (n,) and written/read 4n bytes out of bounds (a crash at n = 4e6)."""
    pts = np.zeros((1000, 3), np.float32)
    empty = np.zeros((1000, 0), np.float32)
    full = np.zeros(1000, np.float32)
    with pytest.raises(ValueError, match=r"estimate must have shape \(1000,\)"):
        uc.estimate({}, pts, empty, full)
    with pytest.raises(ValueError, match=r"iterations must have shape \(1000,\)"):
        uc.estimate({}, pts, full, empty)
    with pytest.raises(ValueError, match=r"t must have shape \(1000,\)"):
        uc.normals({}, pts, empty, np.zeros((1000, 3), np.float32))


class Hostile:
    """A number whose conversion runs arbitrary Python: it empties or changes the container it
    was read from (issue 16, defect 1: the parser once kept borrowed references across it)."""

    def __init__(self, victim, value=0.5):
        self.victim, self.value = victim, value

    def __float__(self):
        if isinstance(self.victim, dict):
            self.victim.clear()
        else:
            del self.victim[:]
        import gc
        gc.collect()
        return self.value


def test_camera_ray_coordinates_are_checked(camera):
    """Found by the table-driven fuzzer: a huge int raised OverflowError, not a named error."""
    with pytest.raises(TypeError, match=r"^x must be a number"):
        uc.camera_ray(camera, 10 ** 400, 0)
    with pytest.raises(ValueError, match=r"^y must be finite"):
        uc.camera_ray(camera, 0.5, math.nan)


def test_values_that_mutate_their_containers_are_read_safely(camera):
    obj = dict(mu=[-0.2, 0.8, 0.0, 0.0], theta=0.0)
    obj["theta"] = Hostile(obj)  # clears the object dict while its keys are being read
    uc.describe(obj)
    cam = dict(camera)
    cam["matrix"] = [list(row) for row in cam["matrix"]]
    cam["matrix"][0][0] = Hostile(cam)  # clears the camera dict while its matrix is read
    passes = {"depth": np.zeros((48, 64, 1), np.float32)}
    uc.render(cam, [dict(mu=(0.0, 0.0, 0.0, 0.0))], passes)
    row = [0.0, 0.0, 1.0]
    row[1] = Hostile(row, 0.0)  # empties the sequence being read
    basis = [[1, 0, 0], [0, 1, 0], row, [0, 0, 0]]
    uc.describe(dict(slice_basis=basis))
    shading = dict(samples=1, lights=[dict(type="sun", direction=(0, 0, -1))])
    shading["ambient"] = (Hostile(shading, 0.1), 0.1, 0.1)  # clears the shading dict
    uc.render(camera, [dict(mu=(0.0, 0.0, 0.0, 0.0))], passes, shading=shading)
    assert cam == {} and shading == {}  # the conversions did run


def test_table_defaults_are_the_defaults_the_core_uses(camera):
    """An object, shading and keywords spelt out with PARAMETERS' defaults render the same bytes as
    the empty dicts: the table is what the parser applies."""
    def defaults(section, skip=()):
        return {k: v["default"] for k, v in uc.PARAMETERS[section].items()
                if k not in skip and v["type"] != "custom" and v["default"] is not None}
    obj = defaults("object", skip=("name",))
    shading = defaults("shading")
    shading["lights"] = [defaults("light")]
    keywords = defaults("render")
    plain = {n: np.zeros((48, 64, uc.PASS_CHANNELS[n]), np.float32) for n in uc.PASSES}
    spelt = {n: np.zeros_like(a) for n, a in plain.items()}
    uc.render(camera, [{}], plain, shading=dict(lights=[{}]))
    uc.render(camera, [obj], spelt, shading=shading, **keywords)
    for n in plain:
        assert plain[n].tobytes() == spelt[n].tobytes(), n


def test_parameters_table_is_complete_and_read_only():
    import types
    assert isinstance(uc.PARAMETERS, types.MappingProxyType)
    assert set(uc.PARAMETERS) == {"object", "camera", "shading", "light", "render"}
    for section, rows in uc.PARAMETERS.items():
        assert isinstance(rows, types.MappingProxyType)
        for key, row in rows.items():
            assert row["description"], (section, key)
            assert row["type"] in {"float", "int", "bool", "choice", "string", "list", "custom"}
            if row["type"] == "choice":
                assert row["default"] in row["choices"], (section, key)
            if row["type"] in {"float", "int"} and isinstance(row["default"], (int, float)):
                assert row["min"] <= row["default"] <= row["max"], (section, key)
    with pytest.raises(TypeError):
        uc.PARAMETERS["object"]["mu"] = {}


# Issue 16, smaller defects: a key with an embedded NUL read as its prefix in C (so "mu\0junk" was
# accepted and ignored, "alpha\0x" wrote the alpha pass), and two passes sharing one array were
# accepted, each then holding the other's values.
@pytest.mark.parametrize("where", ["object", "shading", "light", "camera", "pass", "choice"])
def test_keys_with_an_embedded_nul_are_refused(where):
    cam, objects, shading, passes = make_camera(W, H), [dict(max_iterations=8)], {}, None
    if where == "object":
        objects = [{"max_iterations": 8, "mu\0junk": (0.0, 0.0, 0.0, 0.0)}]
    elif where == "shading":
        shading = {"samples\0": 2}
    elif where == "light":
        shading = dict(lights=[{"type": "sun", "color\0x": (1.0, 1.0, 1.0)}])
    elif where == "camera":
        cam["width\0x"] = 3
    elif where == "pass":
        passes = {"depth": np.zeros((H, W), np.float32), "alpha\0x": np.zeros((H, W), np.float32)}
    elif where == "choice":
        objects = [dict(kind="ifs\0junk")]
    with pytest.raises(ValueError, match="must not contain NUL characters"):
        call(cam, objects, passes, shading=shading)


def test_aliased_pass_buffers_are_refused():
    a = np.zeros((H, W), np.float32)
    with pytest.raises(ValueError, match=r"passes\['alpha'\] and passes\['depth'\] share memory"):
        call(passes={"alpha": a, "depth": a})
    rgba = np.zeros((H, W, 4), np.float32)
    with pytest.raises(ValueError, match="share memory"):  # overlapping views of one array
        call(passes={"combined": rgba, "alpha": rgba[..., 3:4].copy(), "depth": rgba.reshape(-1)[:H * W].reshape(H, W)})
    # Distinct arrays (and None) are fine.
    call(passes={"alpha": a, "depth": a.copy(), "normal": None})


@pytest.mark.skipif(__import__("sys").version_info < (3, 12),
                    reason="__buffer__ (PEP 688) needs Python >= 3.12: run under tools/py313.sh")
def test_pass_whose_buffer_rewrites_the_passes_dict():
    """Issue 16, defect 9: a pass object whose __buffer__ rewrites the passes dict during render().
    The core reads a snapshot of the dict, so every pass given is rendered, and every buffer it
    acquired is released (a leaked export keeps the bytearray from being resized)."""
    storage = {name: bytearray(H * W * 4) for name in ("alpha", "depth", "steps")}
    released = []

    class Rewriting:
        def __init__(self, name, passes):
            self.name, self.passes = name, passes

        def __buffer__(self, flags):
            self.passes.clear()
            self.passes["steps"] = np.zeros((H, W), np.float32)
            return memoryview(storage[self.name]).cast("f", (H, W))

        def __release_buffer__(self, view):
            released.append(self.name)
            view.release()

    passes = {}
    passes.update(alpha=Rewriting("alpha", passes), depth=Rewriting("depth", passes),
                  steps=memoryview(storage["steps"]).cast("f", (H, W)))
    call(passes=passes)
    assert sorted(released) == ["alpha", "depth"]
    for name, data in storage.items():
        data.extend(b"\0\0\0\0")  # BufferError if an export leaked
        values = np.frombuffer(bytes(data[:H * W * 4]), np.float32)
        assert np.isfinite(values).all() and values.any(), name  # rendered, not skipped
