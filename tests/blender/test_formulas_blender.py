"""The community formulas of issue 22 inside Blender (bpy): MANDELBULB and MANDELBOX through the
render engine with every pass and shading option, added by bpy.ops.object.unbound_fractal_add ready
to render, their parameters keyframed. (Their bundled presets are rendered by
test_shading_blender.py.)"""

KINDS = ["MANDELBULB", "MANDELBOX"]


def test_every_formula_renders_every_pass(run_bpy):
    r = run_bpy("families.every_kind_renders_every_pass", args=dict(kinds=KINDS), timeout=600)
    assert sorted(r["out"]) == sorted(KINDS)
    for kind, v in r["out"].items():
        assert v["finite"], kind
        assert 0.02 < v["coverage"] < 0.9, (kind, v)
        assert v["normal_error"] < 1e-3, (kind, v)
        assert v["display"] > 0.5, (kind, v)
        assert v["passes"] >= v["channels"], (kind, v)


def test_added_ready_to_render(run_bpy):
    r = run_bpy("formulas.added_ready_to_render", timeout=300)
    for kind, v in r["out"].items():
        assert 0.05 < v["coverage"] < 0.9, (kind, v)
        assert 0.9 < v["display"] < 2.0, (kind, v)  # the bounding sphere, about the other kinds' size
        assert not v["exact"], kind  # empirical, and the panel says so


def test_formula_parameters_are_keyframeable(run_bpy):
    """A keyframe on each new parameter reaches the core's dict between the keys (2 at frame 3:
    the value at 3) and changes the depth (but the sphere-fold radii, which shape the holes and the
    inside of the Mandelbox, not its outer faces: test_formulas.py shows they reach the kernel);
    re-rendering a frame gives the same pixels."""
    r = run_bpy("formulas.kind_parameters_are_keyframeable", timeout=600)
    assert len(r["changes"]) == 6
    for name, (changed, same, exported) in r["changes"].items():
        assert exported[0] == exported[2] != exported[1], (name, exported)
        if name not in {"MANDELBOX.min_radius", "MANDELBOX.fixed_radius"}:
            assert changed > 0.01, name
        assert same, name
