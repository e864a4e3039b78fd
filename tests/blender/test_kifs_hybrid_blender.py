"""KIFS and HYBRID inside Blender (bpy): every pass and shading option through the render engine,
added by bpy.ops.object.unbound_fractal_add ready to render, their parameters (the fold planes'
and hybrid entries' included) keyframed. (Their bundled presets are rendered by
test_shading_blender.py.)"""

KINDS = ["KIFS", "HYBRID"]


def test_every_kind_renders_every_pass(run_bpy):
    r = run_bpy("families.every_kind_renders_every_pass", args=dict(kinds=KINDS), timeout=600)
    assert sorted(r["out"]) == sorted(KINDS)
    for kind, v in r["out"].items():
        assert v["finite"], kind
        assert 0.02 < v["coverage"] < 0.9, (kind, v)
        assert v["normal_error"] < 1e-3, (kind, v)
        assert v["display"] > 0.5, (kind, v)
        assert v["passes"] >= v["channels"], (kind, v)


def test_added_ready_to_render(run_bpy):
    r = run_bpy("kifs_hybrid.added_ready_to_render", timeout=300)
    out = r["out"]
    assert out["KIFS"]["exact"] and not out["HYBRID"]["exact"]  # the panel says which
    assert out["KIFS"]["planes"] == 7 and out["HYBRID"]["steps"] == 2  # Menger sponge; bulb then box
    for kind, v in out.items():
        assert 0.05 < v["coverage"] < 0.9, (kind, v)
        assert 0.9 < v["display"] < 2.0, (kind, v)


def test_parameters_are_keyframeable(run_bpy):
    """A keyframe on each parameter (frames 1 and 3) reaches the core's dict at frame 3 and changes
    the depth; frame 1 again gives the same dict and the same pixels."""
    r = run_bpy("kifs_hybrid.kind_parameters_are_keyframeable", timeout=600)
    assert len(r["changes"]) == 8
    for name, (changed, same, exported) in r["changes"].items():
        assert exported[0] == exported[2] != exported[1], name
        assert changed > 0.01, name
        assert same, name


def test_fold_plane_and_hybrid_entry_lists(run_bpy):
    r = run_bpy("kifs_hybrid.list_operators")
    assert r["copied"] == [True, 0.25], r
    assert "at most 16 fold planes" in r["over"], r
    assert r["planes"][1:] == [15, 14], r
    n = r["steps"][0]
    assert r["steps"][1] == [n + 1, True, True] and r["steps"][2] == [n, 0], r
