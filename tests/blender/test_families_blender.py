"""Section 5's families inside Blender (bpy): every kind through the render engine with every pass
and shading option, keyframed kind parameters, the c-path from a curve object, the IFS maps'
operators, and errors reported. (Every bundled preset, these kinds' included, is rendered by
test_shading_blender.py.)"""
import numpy as np

KINDS = ["QUATERNION_JULIA", "QUATERNION_MANDELBROT", "JULIA_STACK", "CUBIC_LOCUS", "IFS"]


def test_every_kind_renders_every_pass(run_bpy):
    """Each kind with soft shadows from a sun, AO, reflections on the sea, fog, glow and 2 samples:
    every pass is finite, the object is there, normals are unit vectors on it."""
    r = run_bpy("families.every_kind_renders_every_pass", args=dict(kinds=KINDS), timeout=600)
    for kind, v in r["out"].items():
        assert v["finite"], kind
        assert 0.02 < v["coverage"] < 0.9, (kind, v)
        assert v["normal_error"] < 1e-3, (kind, v)
        assert v["display"] > 0.5, (kind, v)
        assert v["passes"] >= v["channels"], (kind, v)  # every pass reached the EXR


def test_kind_parameters_are_keyframeable(run_bpy):
    """A keyframe on each kind's own parameters changes the frame between the keys, and
    re-rendering a frame gives the same pixels."""
    r = run_bpy("families.kind_parameters_are_keyframeable", timeout=600)
    for name, (changed, same) in r["changes"].items():
        assert changed > 0.01, name
        assert same, name


def test_curve_path(run_bpy):
    """A two-point poly curve gives the same c-path, and so the same pixels, as the line; a Bezier
    curve is followed as Blender tessellates it; a missing or wrong path object is reported."""
    r = run_bpy("families.curve_path")
    assert r["same"] and r["coverage"] > 0.05
    assert r["bez_points"] > 2
    np.testing.assert_allclose(r["bez_ends"], [(-1.2, 0.1), (0.2, 0.3)], atol=1e-6)
    assert "no curve object is set" in r["errors"][0] and "fractal '" in r["errors"][0]
    assert "is not a curve" in r["errors"][1]
    assert "Traceback" not in r["_output"]


def test_ifs_map_operators_presets_and_errors(run_bpy):
    """The shape, add and remove operators edit the maps, and the depsgraph's copy (what F12 and the
    Rendered viewport read) follows at once; a saved preset restores the maps (a collection) on
    another IFS; an IFS without maps is reported, not raised."""
    r = run_bpy("families.ifs_map_operators_presets_and_errors")
    assert r["counts"] == [4, 20, 21, 4]
    assert r["evaluated"] == r["counts"]
    assert r["ops"] == ["FINISHED", "FINISHED"]
    np.testing.assert_allclose(r["restored"], r["saved"], atol=1e-6)
    assert "an IFS needs at least one map" in r["outcome"] and "fractal '" in r["outcome"]
    assert "Traceback" not in r["_output"]
