"""Issue 17, a beautiful first render (bpy 4.2): Blender's startup scene, Add > Unbound Fractal as
the Add menu does it (framed in the camera, an orbit-trap colour ramp, the soft first look), F12 at
the startup scene's 1920 x 1080."""


def test_startup_scene_add_renders_framed_coloured_and_quick(run_bpy):
    r = run_bpy("first_render.first_render", args={"kind": "QUATERNION_JULIA"}, timeout=600)
    print({k: v for k, v in r.items() if k != "_output"})
    assert r["engine"] == "UNBOUND" and r["samples"] == 4, r
    assert r["size"] == [1080, 1920], r
    # Framed: the default Julia set stands tall, so filling 90 % of the frame's height covers about
    # 23 % of a 16:9 frame (before: 6 %).
    assert r["coverage"] >= 0.20, r
    # Coloured: the object's pixels clearly saturated (before: 0.0001, grey).
    assert r["saturation"] >= 0.25, r
    # 4 samples with ambient occlusion and soft shadows: well under 5 s on 2 cores (CPU seconds / 2).
    assert r["cpu_seconds"] < 8.0, r


def test_frame_in_camera_centres_and_fills(run_bpy):
    r = run_bpy("first_render.frame_in_camera_centres")
    assert r["result"] == ["FINISHED"], r
    x0, y0, x1, y1 = r["after"]
    assert abs((x0 + x1) / 2) < 0.08 and abs((y0 + y1) / 2) < 0.08, r
    assert max(x1 - x0, y1 - y0) > 1.6 and max(abs(x0), abs(x1), abs(y0), abs(y1)) <= 1.0, r
