"""Unbound at home in Blender's UI (issue 17), in bpy 4.2: the panels Unbound gets in the Render,
Object Data, World and Light tabs; fractal and look presets saved in full, applied, split, and
bundled ones refused removal; a preset tags the depsgraph; the Add operator's engine switch and
rotation. (tests/blender/test_real_blender.py drives the same in the real Blender GUI.)"""
import pytest


def test_panels_for_unbound(run_bpy):
    """Render tab: Blender's Color Management panel and its sub-panels, and a Performance panel with
    Threads (Cycles' layout), Motion Blur with its Shutter Curve; Light tab (Properties, data): one panel labelled Light; World tab: a
    Surface panel editing the Background node whose Color x Strength the engine reads; the
    fractal's parameters in the empty's Object Data tab; the camera's Depth of Field panels; mu's drag step 10 (0.001 per pixel)."""
    r = run_bpy("ui.panels_for_unbound")
    render = {name for name, _, _ in r["render"]}
    assert {"RENDER_PT_color_management", "RENDER_PT_color_management_curves"} <= render, sorted(render)
    assert {"UNBOUND_PT_performance", "UNBOUND_PT_performance_threads"} <= render, sorted(render)
    # Motion Blur: Blender's shutter settings and curve (issue 19), not EEVEE's panel of its own options.
    assert {"UNBOUND_PT_motion_blur", "UNBOUND_PT_motion_blur_curve"} <= render, sorted(render)
    assert not any("eevee" in name for name in render), sorted(render)
    lights = [name for name, label, _ in r["data"] if label == "Light"]
    assert lights == ["UNBOUND_PT_light"], r["data"]
    assert "UNBOUND_PT_world" in {name for name, _, _ in r["world"]}, r["world"]
    assert r["world_color"] == pytest.approx([0.1, 0.2, 0.3], abs=1e-6)
    assert r["fractal_context"] == "data"
    assert "UNBOUND_PT_fractal" in {name for name, _, _ in r["data"]}
    # The camera's Depth of Field panel and its Aperture sub-panel (read as Cycles reads them).
    assert {"DATA_PT_camera_dof", "DATA_PT_camera_dof_aperture"} <= {name for name, _, _ in r["data"]}, r["data"]
    assert r["mu_step"] == 10 and r["add_mu_step"] == 10


def test_presets_split_save_apply_remove(run_bpy):
    """A fractal preset saved from an object (mu, theta, iterations, colour) holds the object's
    parameters only, written in full (no exec of preset_defines, which Python 3.13 breaks); applied
    to another fractal it restores them and leaves the scene's shading alone. A look preset holds
    the scene's shading only and leaves the object alone. No bundled fractal preset changes the
    scene, no bundled look the object. Removing a bundled preset is refused with a warning and
    the file stays; the user's own is removed."""
    r = run_bpy("ui.presets_split_save_apply_remove")
    assert r["save_fractal"] == r["save_look"] == ["FINISHED"]
    assert "ob.unbound.mu = (0.1, -0.6, 0.2, 0.05)" in r["fractal_text"], r["fractal_text"]
    assert "scene" not in r["fractal_text"].replace("bpy.context.scene", "")
    assert "scene.unbound.glow_strength = 0.3" in r["look_text"] and "ob." not in r["look_text"]
    assert r["apply_fractal"] == ["FINISHED"]
    assert r["b"]["mu"] == pytest.approx([0.1, -0.6, 0.2, 0.05], abs=1e-6)
    assert r["b"]["theta"] == pytest.approx(0.7, abs=1e-6) and r["b"]["max_iterations"] == 33
    assert r["b"]["color"] == pytest.approx([0.3, 0.2, 0.1], abs=1e-6)
    assert r["scene_after_fractal"] == {"glow": 0.0, "sea": False}
    assert r["apply_look"] == ["FINISHED"]
    assert r["scene_after_look"]["glow"] == pytest.approx(0.3) and r["scene_after_look"]["sea"] is True
    assert r["b_mu_after_look"] == pytest.approx([0.5, 0.5, 0.5, 0.5])
    assert r["bundled_fractal_changed_scene"] == []
    assert len(r["bundled_looks"]) >= 4 and r["bundled_look_changed_object"] == []
    assert r["remove_bundled"] == ["CANCELLED"] and r["bundled_still_there"]
    assert "is a bundled preset and cannot be removed" in r["_output"]
    assert r["remove_own"] == ["FINISHED"] and r["own_gone"]


def test_preset_apply_tags_the_depsgraph(run_bpy):
    """Applying a fractal preset tags the object: the depsgraph reports it updated (so the
    Rendered viewport and the bounding-sphere handler see the change without an orbit), and the
    empty's sphere is the new set's bounding sphere at once."""
    r = run_bpy("ui.preset_apply_tags_the_depsgraph")
    assert r["status"] == ["FINISHED"]
    assert r["name"] in r["seen"], r
    assert r["size_after"] == pytest.approx(r["expected"]) and r["size_after"] != pytest.approx(r["size_before"])


def test_add_operator_keeps_engine_and_rotates(run_bpy):
    """A script's Add (EXEC) keeps the scene's engine and places the fractal at Location with
    Rotation. (The Add menu's, INVOKE, switches the engine: test_real_blender's GUI test.)"""
    r = run_bpy("ui.add_operator_keeps_engine_and_rotates")
    assert r["exec_engine"] == "CYCLES"
    assert r["location"] == pytest.approx([1.0, 2.0, 3.0])
    assert r["rotation"] == pytest.approx(r["wanted_rotation"], abs=1e-6)
