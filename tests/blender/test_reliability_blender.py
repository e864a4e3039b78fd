"""Issue 16 through Blender (bpy 4.2): any failure inside the engine ends as an error report with no
file written; the memory pre-flight refuses a render that cannot fit, with the figure and what to
turn off; passes toggled during an animation; stereo 3D renders every eye; Set Up Compositing keeps
the user's nodes."""
import pytest


def test_any_failure_is_a_report_and_writes_no_file(run_bpy):
    r = run_bpy("reliability.failures_write_no_file")
    o = r["outcomes"]
    assert o["ok"] == ["ok", True], o
    assert o["key"][1] is False and "internal error (KeyError" in o["key"][0], o
    assert o["runtime"][1] is False and "internal error (RuntimeError: bug)" in o["runtime"][0], o
    assert o["memory"] == ["Error: Unbound: out of memory: lower the resolution or turn off passes", False], o


@pytest.mark.parametrize("how", ["env", "rlimit"])
def test_memory_preflight_refuses_with_the_figure(run_bpy, how):
    if how == "env":
        r = run_bpy("reliability.memory_preflight", env={"UNBOUND_MEMORY_LIMIT": str(8e9)})
    else:
        r = run_bpy("reliability.memory_preflight", args={"limit_gb": 3.0})
    message, written = r["big"]
    assert not written, r
    assert "this render needs about 1327.1 GB of memory (65536 x 65536 pixels at 309 bytes each, 17 passes)" \
        in message, message
    assert "turn off passes (Normal, Position, Diffuse" in message, message
    assert r["small"] == ["ok", True], r
    assert not r["again"][1] and "this render needs about 1327.1 GB" in r["again"][0], r["again"]
    # All passes, 36 channels. One sample (rendered in bands): Blender's result and its copy for
    # the compositor and writer (two float32 copies), and an eighth (rounded up) of the add-on's
    # buffers and the core's 20-byte hit record: 309 bytes per pixel, 1920 x 1080 about 0.64 GB.
    # Several samples: three copies and the whole hit buffer, 452 bytes.
    assert r["per_pixel"] == 36 * 4 * 2 + -(-(36 * 4 + 20) // 8) and r["needed"] == 309 * 1920 * 1080
    assert r["per_pixel_samples"] == 36 * 4 * 3 + 20
    assert "Traceback" not in r["_output"]


def test_passes_toggled_during_an_animation(run_bpy):
    r = run_bpy("reliability.passes_toggled_during_animation")
    assert r["error"] is None, r["error"]
    assert len(r["frames"]) == 4, r
    # The result of a frame holds the passes registered when it was made (before the handler ran for
    # that frame): whichever they are, each written layer holds its rendered values.
    for name, layers in r["frames"].items():
        assert all(layers.values()), (name, layers)
    assert sum(len(layers) for layers in r["frames"].values()) >= 3, r
    assert "KeyError" not in r["_output"] and "Traceback" not in r["_output"]


@pytest.mark.parametrize("mode", ["PARALLEL", "OFFAXIS"])
def test_stereo_renders_each_eye_like_a_mono_render(run_bpy, mode):
    r = run_bpy("reliability.stereo_views_equal_mono_renders", args={"mode": mode})
    assert r["eyes_differ"], r
    for view in ("left", "right"):
        v = r[view]
        assert v["coverage"] > 0.1 and v["max_diff"] is not None, r
        assert v["differing"] < 0.01, r  # at most a silhouette pixel from float32 eye matrices
    print(r)


def test_setup_compositing_keeps_the_users_nodes(run_bpy):
    r = run_bpy("reliability.setup_compositing_keeps_user_nodes")
    assert {"My Blur", "My Colour"} <= set(r["names"]), r
    assert "My Colour>My Blur" in r["links"], r
    ours = [n for n in r["names"] if n.startswith("Unbound ")]
    assert len(ours) == len(set(ours)) and "Unbound Pass Files" in ours and "Unbound Render Layers" in ours, r
    assert len(r["files"]) == 1 and r["files"][0].endswith(".exr"), r
