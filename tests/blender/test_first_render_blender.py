"""Issue 17, a beautiful first render (bpy 4.2): Blender's startup scene, Add > Unbound Fractal as
the Add menu does it (framed in the camera, an orbit-trap colour ramp, the soft first look), F12 at
the startup scene's 1920 x 1080."""
import pytest


def test_startup_scene_add_renders_framed_coloured_and_quick(run_bpy):
    r = run_bpy("first_render.first_render", args={"kind": "QUATERNION_JULIA"}, timeout=600)
    print({k: v for k, v in r.items() if k != "_output"})
    assert r["engine"] == "UNBOUND" and r["samples"] == 4, r
    assert r["size"] == [1080, 1920], r
    # Framed: the default Julia set stands tall, so it is turned to lie across the 16:9 frame
    # (Turn to Fit) and scaled to fill 90 % of the limiting side: about 35 % of the frame (before:
    # 6 %; framed standing up: 23 %). The issue asks for at least 30 %.
    assert r["coverage"] >= 0.30, r
    assert r["turned"], r
    # Coloured: the object's pixels clearly saturated (before: 0.0001, grey).
    assert r["saturation"] >= 0.25, r
    # 4 samples with ambient occlusion and soft shadows: well under 5 s on 2 cores (CPU seconds / 2).
    assert r["cpu_seconds"] < 8.0, r


def test_startup_scene_add_ifs_renders_as_quick(run_bpy):
    """The default IFS (the Sierpinski tetrahedron at depth 7) the same way: framed, coloured by its
    maps, and as quick as the Julia set (issue 21: 24 s of CPU before its one-path estimate, 2.7 s
    after, bench/bench_first_look.py)."""
    r = run_bpy("first_render.first_render", args={"kind": "IFS"}, timeout=600)
    print({k: v for k, v in r.items() if k != "_output"})
    assert r["engine"] == "UNBOUND" and r["samples"] == 4 and r["size"] == [1080, 1920], r
    # Framed: the tetrahedron fills the frame's height, its holes leave about 13 % of the frame covered.
    assert r["coverage"] >= 0.10 and r["saturation"] >= 0.25, r
    assert r["cpu_seconds"] < 8.0, r


def test_frame_in_camera_centres_and_fills(run_bpy):
    r = run_bpy("first_render.frame_in_camera_centres")
    assert r["result"] == ["FINISHED"], r
    x0, y0, x1, y1 = r["after"]
    assert abs((x0 + x1) / 2) < 0.08 and abs((y0 + y1) / 2) < 0.08, r
    assert max(x1 - x0, y1 - y0) > 1.6 and max(abs(x0), abs(x1), abs(y0), abs(y1)) <= 1.0, r


def test_turn_to_fit_lays_a_tall_set_across_a_wide_frame(run_bpy):
    """Frame in Camera with Turn to Fit: the default Julia set, standing tall in the 16:9 frame, is
    turned a quarter about the view axis (its silhouette's width and height swap, within the
    silhouette mask's pixel) and fills more of the frame; in a tall (9:16) frame it is left standing."""
    r = run_bpy("first_render.turn_to_fit")
    wide, tall = r["wide"], r["tall"]
    assert wide["result"] == tall["result"] == ["FINISHED"], r
    (w0, h0), (w1, h1) = wide["before_size"], wide["after_size"]
    assert h0 > 1.15 * w0 and w1 > h1, r     # stood across the long side; now lies along it
    assert wide["angle"] == pytest.approx(90.0, abs=1e-3), r
    assert wide["after_area"] > 1.3 * wide["before_area"], r
    assert tall["angle"] == pytest.approx(0.0, abs=1e-3), r
