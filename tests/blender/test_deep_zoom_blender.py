"""Deep zoom in Blender (issue 18): Object.unbound.zoom (keyframeable) and zoom_anchor reach the core,
and Pick Anchor moves the anchor and the object so that the view does not jump."""
import math


def test_zoom_properties_are_keyframeable_and_exported(run_bpy):
    r = run_bpy("deep_zoom.properties_and_keyframes")
    assert r["zoom_default"] == 0.0 and r["anchor_default"] == "0 0 0"
    assert r["animatable"]
    assert 10.0 < r["mid"] < 20.0  # frame 25 of a 0 -> 30 keyframed fly-in (Bezier ease)
    assert r["exported"][1] == "0 0 0"


def test_pick_anchor_keeps_the_view(run_bpy):
    r = run_bpy("deep_zoom.pick_keeps_the_view")
    for step in r["results"]:
        assert step["result"] == ["FINISHED"], step
        # The centre ray from (0.3, -4, 0.2) toward the origin meets the unit sphere near (0.07, -1, 0.05):
        # the anchor is on the sphere and the object's origin moved there.
        assert abs(math.sqrt(sum(v * v for v in step["anchor"])) - 1.0) < 1e-5, step
        assert step["same_coverage"] and step["hits"] > 100, step
        # The same image: depth within float32's rounding of the moved origin (zoom 0) and of the
        # threshold (1e-5) at depth.
        assert step["depth_change"] < 1e-4, step
    # At zoom 0 the object's origin moved onto the anchor (object and fractal units are one); at
    # zoom 10 the re-pick moved it by the hit's local offset, and the anchor by 10^-10 of that.
    first, second = r["results"]
    assert all(abs(a - b) < 1e-5 for a, b in zip(first["anchor"], first["location"])), first
    moved = [b - a for a, b in zip(first["location"], second["location"])]
    shift = [b - a for a, b in zip(first["anchor"], second["anchor"])]
    assert all(abs(s) <= 1e-10 * abs(m) + 1e-15 for s, m in zip(shift, moved)), (moved, shift)
    # Re-picking at depth refines: the anchor gains digits (zoom + 10 after the point).
    assert len(r["results"][1]["anchor_text"].split()[0]) > 20


def test_rendered_viewport_at_zoom_20(run_bpy):
    """The viewport draws at depth what F12 draws, bit for bit (the same export, the same core)."""
    r = run_bpy("deep_zoom.viewport_at_depth")
    assert r["picks"] == [["FINISHED"]] * 3, r
    assert r["final"] and r["identical"], r
    assert r["coverage"] > 0.5, r  # the surface fills the view


def test_zoomed_mandelbulb_renders_through_f12_and_past_the_limit_says_why(run_bpy):
    """The formula kinds zoom in double (issue 22): Pick Anchor works for them, F12 renders a zoomed
    Mandelbulb, and a zoom past ZOOM_FORMULA_MAX (10) stops the render with the core's message."""
    r = run_bpy("deep_zoom.formula_zoom_f12")
    assert r["picks"] == [["FINISHED"]] * 2, r
    assert r["coverage"] is not None and r["coverage"] > 0.2, r  # the surface at the picked anchor
    assert "zoom to 10 at most" in r["past_limit"] and not r["past_limit_written"], r
