"""The extension in the real `blender` binary, not bpy from PyPI: Debian trixie's Blender 4.3
(Python 3.13) in the chroot of tools/blender_gui.sh. Validates and installs the built zip with
`blender --command extension`, renders a still in the background, and opens the GUI under Xvfb to
screenshot the Object, Render and View Layer tabs of the Properties editor with Unbound's panels
and the 3D viewport in Rendered shading (saved in build/screenshots/real_blender/ for people to
look at)."""
import json
import os
import pathlib
import shutil
import signal
import subprocess

import numpy as np
import pytest
from exr import extension_zip, read_png

ROOT = pathlib.Path(__file__).resolve().parents[2]
WORK = ROOT / "build" / "real_blender"            # inside the repo: the chroot sees it at /src/build/...
SHOTS = ROOT / "build" / "screenshots" / "real_blender"
SCRIPTS = "tests/blender/real_blender"
MODULE = "bl_ext.user_default.unbound"
SCREEN = (1920, 1080)

pytestmark = pytest.mark.skipif(os.geteuid() != 0, reason="the trixie chroot needs root (CI runs as root)")


def chroot_path(path):
    return "/src/" + str(pathlib.Path(path).relative_to(ROOT))


def tool(*args, timeout=180, env=None):
    """sh tools/blender_gui.sh ARGS -> (rc, stdout+stderr); on timeout the whole process group
    (and with it the chroot's pid namespace) is killed."""
    proc = subprocess.Popen(["sh", "tools/blender_gui.sh", *args], cwd=ROOT, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True, start_new_session=True,
                            env=dict(os.environ, **(env or {})))
    try:
        out, _ = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        out, _ = proc.communicate()
        pytest.fail("timed out after %d s: blender_gui.sh %s\n%s" % (timeout, " ".join(args), out[-4000:]))
    return proc.returncode, out


def results(out, tag):
    return [json.loads(line[len(tag) + 1:]) for line in out.splitlines() if line.startswith(tag + " ")]


@pytest.fixture(scope="module")
def zip_path():
    zip_file = extension_zip()
    rc, out = tool("setup", timeout=900)
    assert rc == 0, out[-4000:]
    return zip_file


@pytest.fixture(scope="module")
def user_dir(zip_path):
    """An isolated BLENDER_USER_RESOURCES with the extension installed (and enabled, in its
    userpref.blend) by Blender's own command line. config/ must exist first, or Blender silently
    uses ~/.config/blender instead."""
    shutil.rmtree(WORK, ignore_errors=True)
    (WORK / "user" / "config").mkdir(parents=True)
    rc, out = tool("run", "env", "BLENDER_USER_RESOURCES=" + chroot_path(WORK / "user"), "blender", "--command",
                   "extension", "install-file", "-r", "user_default", "-e", chroot_path(zip_path))
    assert rc == 0 and 'Installed "unbound"' in out, out[-4000:]
    assert (WORK / "user" / "extensions" / "user_default" / "unbound" / "blender_manifest.toml").exists()
    assert (WORK / "user" / "config" / "userpref.blend").exists()
    return WORK / "user"


def test_extension_validate(zip_path):
    rc, out = tool("run", "blender", "--command", "extension", "validate", chroot_path(zip_path))
    assert rc == 0 and "Success" in out, out[-4000:]


def test_background_render(user_dir):
    still = WORK / "still.png"
    rc, out = tool("run", "env", "BLENDER_USER_RESOURCES=" + chroot_path(user_dir), "blender", "-b",
                   "-setaudio", "None", "--python", SCRIPTS + "/bg_render.py", "--", chroot_path(still))
    assert rc == 0, out[-4000:]
    (r,) = results(out, "UNBOUND_RESULT") or [None]
    assert r, out[-4000:]
    assert r["blender"].startswith("4.") and r["python"].startswith("3.13"), r
    assert r["addon_enabled"] and r["engine"] == "UNBOUND", r
    assert r["add_op"] == ["FINISHED"] and r["fractal"] and r["render_op"] == ["FINISHED"], r
    assert r["stats"]["rays"] == 96 * 72 and not r["stats"]["cancelled"], r
    assert still.stat().st_size > 0
    px = read_png(still)
    assert px.shape == (72, 96, 4)
    coverage = float((px[..., 3] > 0).mean())   # transparent film: alpha marks the fractal
    assert 0.05 < coverage < 0.99, coverage
    assert px[px[..., 3] > 0][:, :3].std() > 5, "object pixels are flat"
    SHOTS.mkdir(parents=True, exist_ok=True)
    shutil.copy(still, SHOTS / "background_render.png")


def run_gui(user_dir, script, names, timeout, blender_args=(), with_output=False):
    """Blender's GUI (SCREEN, under Xvfb) running SCRIPT with the extension installed; the old
    screenshots `names` removed first. Returns the script's UNBOUND_GUI log (with_output: and
    Blender's output) after checking that Blender exited cleanly without a traceback."""
    SHOTS.mkdir(parents=True, exist_ok=True)
    for name in names:
        (SHOTS / name).unlink(missing_ok=True)
    w, h = SCREEN
    rc, out = tool("gui", "env", "BLENDER_USER_RESOURCES=" + chroot_path(user_dir), "blender",
                   "-p", "0", "0", str(w), str(h), "-setaudio", "None", *blender_args,
                   "--python", SCRIPTS + "/" + script, "--", chroot_path(SHOTS),
                   env={"XVFB_SCREEN": "%dx%dx24" % SCREEN, "BL_TIMEOUT": str(timeout - 30)}, timeout=timeout)
    assert rc == 0, out[-4000:]
    assert "Traceback" not in out, out[-4000:]  # a panel's draw() or a step that fails prints one
    log = results(out, "UNBOUND_GUI")
    assert not [e for e in log if e.get("error") is not None], out[-4000:]
    return (log, out) if with_output else log


def test_gui_panels_screenshots(user_dir):
    names = ["object_tab.png", "object_tab_ifs.png", "render_tab.png", "view_layer_tab.png"]
    log = run_gui(user_dir, "gui_panels.py", names, timeout=180)
    w, h = SCREEN
    ifs = next(e for e in log if e.get("step") == "ifs")
    assert ifs["op"] == ["FINISHED"] and ifs["maps"] == 20, ifs
    setup = next(e for e in log if e.get("step") == "setup")
    assert setup["addon_enabled"] and setup["add_op"] == ["FINISHED"], setup
    assert setup["is_fractal"] and setup["engine"] == "UNBOUND" and setup["window"] == list(SCREEN), setup
    shots = {e["shot"]: e for e in log if "shot" in e}
    assert sorted(shots) == sorted(names), log
    # The fractal's parameters are in the empty's Object Data tab (file names kept).
    expect = {"object_tab.png": ("DATA", {"UNBOUND_PT_fractal", "UNBOUND_PT_fractal_slice", "UNBOUND_PT_fractal_zoom",
                                            "UNBOUND_PT_fractal_quality", "UNBOUND_PT_fractal_shading"}),
              # An IFS has no slice; its panel draws the list of maps (a UIList).
              "object_tab_ifs.png": ("DATA", {"UNBOUND_PT_fractal", "UNBOUND_PT_fractal_quality",
                                              "UNBOUND_PT_fractal_shading"}),
              "render_tab.png": ("RENDER", {"UNBOUND_PT_render", "UNBOUND_PT_render_viewport",
                                            "UNBOUND_PT_render_lighting", "UNBOUND_PT_render_effects",
                                            "UNBOUND_PT_performance", "UNBOUND_PT_performance_threads",
                                            "UNBOUND_PT_performance_kernel",
                                            # opened by the script (closed by default, as in Cycles)
                                            "UNBOUND_PT_motion_blur", "UNBOUND_PT_motion_blur_curve"}),
              # (Sea starts closed)
              "view_layer_tab.png": ("VIEW_LAYER", {"UNBOUND_PT_passes"})}
    for name, (tab, panels) in expect.items():
        e = shots[name]
        assert e["rc"] == 0, e
        assert e["tab"] == tab and set(e["panels"]) == panels, e
        px = read_png(SHOTS / name)
        assert px.shape[:2] == (h, w), px.shape
        assert px[..., :3].std() > 10, "%s is blank" % name
        # The Properties editor (bottom right in the Layout workspace) is not blank either.
        props = px[h * 3 // 10:, w * 5 // 6:, :3]
        assert props.std() > 10 and len(np.unique(props.reshape(-1, 3), axis=0)) > 20, name


def test_gui_rendered_viewport(user_dir):
    """The 3D viewport in Rendered shading (gui_viewport.py): the fractal is drawn, refined from
    1/8 resolution to full, in the user's perspective view, after a change of mu, in the camera
    view inside a render border (with the camera's depth of field), and in an orthographic view. Each time the viewport's request is
    the one built from the region's view and its final frame equals a direct render of it, bit
    for bit. The screenshot without overlays equals the frame passed through Blender's own colour
    management (AgX), so the viewport draws with Blender's display transform."""
    names = ["viewport_rendered.png", "viewport_no_overlays.png", "viewport_camera_border.png", "viewport_ortho.png",
             "viewport_reference.png"]
    log = run_gui(user_dir, "gui_viewport.py", names, timeout=270)
    w, h = SCREEN
    setup = next(e for e in log if e.get("step") == "setup")
    assert setup["add_op"] == ["FINISHED"] and setup["engine"] == "UNBOUND" and setup["is_fractal"], setup
    assert setup["shading"] == "RENDERED" and setup["view_transform"] == "AgX", setup
    steps = {e["step"]: e for e in log if "identical" in e}
    assert sorted(steps) == ["camera_border", "changed_mu", "no_overlays", "ortho", "rendered"], log
    for name, e in steps.items():
        assert e["same_request"] and e["final"] and e["identical"], e
        assert e["levels"] == [[8, 1], [4, 1], [2, 1], [1, 1]], e
    assert steps["changed_mu"]["generation"] > steps["rendered"]["generation"], steps
    # The Object Data tab showed the fractal's parameters while the viewport rendered.
    assert {"UNBOUND_PT_fractal", "UNBOUND_PT_fractal_slice"} <= set(steps["rendered"]["panels"]), steps
    # The camera view renders the render border inside the camera's frame only.
    frame = next(e for e in log if e.get("step") == "camera_frame")["rect"]
    bx, by, bw, bh = steps["camera_border"]["window"]
    fw, fh = frame[2] - frame[0], frame[3] - frame[1]
    assert abs(bx - (frame[0] + 0.2 * fw)) <= 1 and abs(bx + bw - (frame[0] + 0.7 * fw)) <= 1, (frame, bx, bw)
    assert abs(by - (frame[1] + 0.25 * fh)) <= 1 and abs(by + bh - (frame[1] + 0.8 * fh)) <= 1, (frame, by, bh)
    # The camera view shows the camera's depth of field (Cycles' aperture: lens / (2 f-stop)); the
    # user's own views have none, as in Cycles.
    expected = next(e for e in log if e.get("step") == "camera_frame")["aperture"]
    assert steps["camera_border"]["aperture"] == pytest.approx(expected, rel=1e-6), steps["camera_border"]
    assert all(steps[k]["aperture"] == 0.0 for k in ("rendered", "changed_mu", "ortho")), steps
    rx, ry, rw, rh = steps["rendered"]["region"]
    assert steps["rendered"]["window"] == [0, 0, rw, rh], steps["rendered"]
    shots = {e["shot"]: e for e in log if "shot" in e}
    assert all(shots[n]["rc"] == 0 for n in names[:4]), shots
    # Screen (top-down rows) against Blender's colour management of the same frame: 8-bit values
    # equal but for a few pixels at the region's corners (Blender's hidden-region arrows).
    shot = read_png(SHOTS / "viewport_no_overlays.png").astype(int)
    ref = read_png(SHOTS / "viewport_reference.png").astype(int)
    assert ref.shape[:2] == (rh, rw), ref.shape
    crop = shot[h - (ry + rh):h - ry, rx:rx + rw, :3]
    diff = np.abs(crop - ref[..., :3])[24:-24, 24:-24]
    assert ref[..., :3].std() > 10, "the reference frame is flat"
    assert diff.mean() < 0.5 and (diff.max(-1) > 3).mean() < 0.002, (diff.mean(), (diff.max(-1) > 3).mean())
    # The fractal itself is on screen: the pixels where the frame differs from the world colour.
    world = np.median(ref[..., :3].reshape(-1, 3), axis=0)
    fractal = np.abs(ref[..., :3] - world).max(-1) > 10
    assert 0.02 < fractal.mean() < 0.9, fractal.mean()
    assert np.abs(crop[fractal] - world).max(-1).mean() > 20


def test_gui_at_home_in_blender(user_dir):
    """What a Blender user tripped over (issue 17), in the real GUI (gui_ui.py):
    * Add > Unbound Fractal from the menu with Cycles active switches the engine to Unbound;
    * Object Data tab of the fractal: its parameters polled and drawn, no hint panel;
    * Render tab: Blender's Color Management (and sub-panels) and Performance > Threads polled
      true, Threads drawn;
    * World tab: the Surface panel polled and drawn;
    * Light tab: exactly one panel labelled Light polled true (Blender's shader-editor copy shares
      its engine list with the hidden one), and it is drawn;
    * the fractal presets popover opens;
    * a bundled preset applied from the Properties editor with the viewport in Rendered shading:
      a newer generation reaches a final frame without any redraw asked by the test, rendering the
      preset's mu, and the empty's sphere is the new set's bounding sphere;
    * a preset saved under Python 3.13 is a non-empty file that applies; a bundled preset's removal
      is refused and the file stays."""
    names = ["ui_data_tab.png", "ui_render_tab.png", "ui_world_tab.png", "ui_light_tab.png",
             "ui_fractal_presets.png", "ui_preset_applied.png"]
    log = run_gui(user_dir, "gui_ui.py", names, timeout=240)
    steps = {e["step"]: e for e in log if "step" in e}
    add = steps["add"]
    assert add["op"] == ["FINISHED"] and add["engine"] == "UNBOUND" and add["is_fractal"], add

    def names_of(step):
        return {n for n, _ in steps[step]["polled"]}
    data = names_of("data_tab")
    assert {"UNBOUND_PT_fractal", "UNBOUND_PT_fractal_slice", "UNBOUND_PT_fractal_quality"} <= data, data
    assert "UNBOUND_PT_fractal_hint" not in data
    assert "UNBOUND_PT_fractal" in steps["data_tab"]["drawn"], steps["data_tab"]
    render = names_of("render_tab")
    assert {"RENDER_PT_color_management", "RENDER_PT_color_management_curves", "UNBOUND_PT_performance",
            "UNBOUND_PT_performance_threads"} <= render, render
    assert {"UNBOUND_PT_performance_threads", "UNBOUND_PT_render"} <= set(steps["render_tab"]["drawn"])
    assert "UNBOUND_PT_world" in names_of("world_tab") and "UNBOUND_PT_world" in steps["world_tab"]["drawn"]
    lights = [n for n, label in steps["light_tab"]["polled"] if label == "Light"]
    assert lights == ["UNBOUND_PT_light"], steps["light_tab"]["polled"]
    assert "UNBOUND_PT_light" in steps["light_tab"]["drawn"] and "DATA_PT_light" not in steps["light_tab"]["drawn"]
    assert "CANCELLED" not in steps["popover"]["op"], steps["popover"]
    applied = steps["preset_applied"]
    assert steps["apply"]["op"] == ["FINISHED"]
    assert applied["generation"] > applied["before"] and applied["final"], applied
    assert applied["request_mu"] == [pytest.approx(applied["mu"])], applied
    assert applied["size_after"] == pytest.approx(applied["expected_size"]), applied
    assert applied["size_after"] != pytest.approx(applied["size_before"]), applied
    saved = steps["save"]
    assert saved["python"].startswith("3.13"), saved
    assert saved["op"] == ["FINISHED"] and saved["size"] > 100, saved
    assert saved["run"] == ["FINISHED"] and saved["mu"] == pytest.approx(saved["saved_mu"]), saved
    assert saved["remove_bundled"] == ["CANCELLED"] and saved["bundled_kept"], saved
    for name in names:
        px = read_png(SHOTS / name)
        assert px[..., :3].std() > 10, "%s is blank" % name


def test_gui_convert_to_volume_undo_and_redo(user_dir):
    """Convert to Volume in the real GUI (gui_volume.py) on the unit ball of a saved .blend: the
    Volume object is active, its .vdb beside the .blend, no temporary left; Edit > Undo (Blender's
    undo stack, which background bpy lacks) removes it and makes the fractal active again, Redo
    brings it back. Screenshots for people: Solid shading (Blender draws the SDF's values as
    density: a faint shell), Rendered by EEVEE, the Object > Convert menu."""
    names = ["volume_solid.png", "volume_eevee.png", "volume_convert_menu.png"]
    log = run_gui(user_dir, "gui_volume.py", names, timeout=300)
    steps = {e["step"]: e for e in log if "step" in e}
    c = steps["convert"]
    assert c["op"] == ["FINISHED"] and c["after"]["active_type"] == "VOLUME", c
    assert c["filepath"] == "//Quaternion_Julia.vdb" and c["file_exists"], c
    assert c["after"]["volumes"] == 1 and c["after"]["meshes"] == c["before"]["meshes"], c
    assert c["after"]["node_groups"] == c["before"]["node_groups"] == 0, c
    u = steps["undo"]
    assert u["undo"] == ["FINISHED"] and u["undone"] == c["before"], u
    assert u["redo"] == ["FINISHED"] and u["redone"] == c["after"], u
    for name in names:
        assert (SHOTS / name).exists(), name


def test_ctrl_c_cancels_a_1080p_render_within_100ms(user_dir):
    """`blender -b` turns Ctrl-C (SIGINT) into its break flag, which RenderEngine.test_break()
    reads: the engine polls it every 20 ms during the native render. A 1920x1080 frame with soft
    shadows and reflections (seconds of work) is interrupted one second in; the render operator
    must return within 100 ms of the signal, the frame marked cancelled, Blender still running."""
    rc, out = tool("run", "env", "BLENDER_USER_RESOURCES=" + chroot_path(user_dir), "python3",
                   SCRIPTS + "/cancel_driver.py", "1.0", "--", "blender", "-b", "-setaudio", "None",
                   "--python", SCRIPTS + "/cancel_render.py", timeout=300)
    assert rc == 0, out[-4000:]
    (r,) = results(out, "UNBOUND_CANCEL") or [None]
    assert r, out[-4000:]
    assert r["stats"] and r["stats"]["cancelled"] is True, r
    assert 0 < r["stats"]["rays"] <= 1920 * 1080, r
    assert r["latency"] is not None, out[-4000:]
    print("Ctrl-C to render return: %.1f ms" % (r["latency"] * 1000))
    assert 0 < r["latency"] < 0.1, r
    assert "Sent an internal break event" in out and "Blender quit" in out, out[-4000:]
    # Blender ran its script to the end and quit by itself: status 1 after a break (its own
    # convention in background mode), never a signal.
    assert "UNBOUND_CANCEL_RC 1" in out or "UNBOUND_CANCEL_RC 0" in out, out[-4000:]


# Issue 17 in one GUI session (gui_proxy_f12.py): the Solid-mode proxy and F12's progress ---------

PROXY_SHOTS = ["proxy_off.png", "proxy_solid.png", "proxy_julia.png", "proxy_wire.png", "proxy_wire_off.png",
               "proxy_material.png", "f12_window.png"]


@pytest.fixture(scope="module")
def proxy_f12_log(user_dir):
    return run_gui(user_dir, "gui_proxy_f12.py", PROXY_SHOTS, timeout=300)


def region_crop(name, rect):
    """The 3D view's region (x, y, w, h, bottom-left origin) of screenshot `name`, as int RGB."""
    x, y, w, h = rect
    px = read_png(SHOTS / name).astype(int)
    return px[SCREEN[1] - (y + h):SCREEN[1] - y, x:x + w, :3]


def changed(a, b, rect):
    """Pixels of the region that differ between screenshots a and b by more than 8 in a channel."""
    return np.abs(region_crop(a, rect) - region_crop(b, rect)).max(-1) > 8


def disk_distance(shape, centre, radius):
    """Per pixel of a region (rows top-down): distance of its centre from the projected ball's
    centre, in units of the ball's projected radius."""
    h, w = shape
    cols, rows = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
    return np.hypot(cols - centre[0], (h - rows) - centre[1]) / radius


def test_gui_solid_proxy_shows_the_fractal(proxy_f12_log):
    """Solid shading, front orthographic view of mu = 0 (the unit ball) behind a small cube: the
    pixels the proxy changes (screenshots with it off and on) are the projected unit ball, less
    the cube in front of it (depth-tested). A changed mu changes them; Wireframe shading draws
    lines inside the ball; Material Preview draws it, Rendered shading does not."""
    steps = {e["step"]: e for e in proxy_f12_log if "step" in e}
    setup, on = steps["setup"], steps["proxy_solid"]
    assert setup["add_op"] == ["FINISHED"] and setup["is_fractal"] and setup["shading"] == "SOLID", setup
    assert on["shader_ok"] and on["faces"] > 1000, on
    assert on["region"] == steps["proxy_off"]["region"] and on["centre"] == steps["proxy_off"]["centre"], steps
    rect, centre = on["region"], on["centre"]
    rx, ry = on["radius"]
    assert rx > 50 and abs(rx - ry) < 0.5, on["radius"]   # orthographic: a circle, large enough to judge
    drawn = changed("proxy_off.png", "proxy_solid.png", rect)
    d = disk_distance(drawn.shape, centre, rx)
    h = drawn.shape[0]
    cols, rows = np.meshgrid(np.arange(drawn.shape[1]) + 0.5, h - (np.arange(h) + 0.5))
    x0, y0, x1, y1 = on["cube"]
    in_cube = (cols > x0 + 2) & (cols < x1 - 2) & (rows > y0 + 2) & (rows < y1 - 2)
    assert in_cube.sum() > 400, on["cube"]
    # The proxy's vertices lie within a cell of the sphere; 3 pixels more for the overlay's circle.
    margin = on["cell"] + 3.0 / rx
    inside, outside = (d < 1 - margin) & ~in_cube, d > 1 + margin
    print("proxy: %d faces in %.3f s; ball radius %.1f px; changed inside %.4f, outside %.5f, behind the cube %.4f"
          % (on["faces"], on["seconds"], rx, drawn[inside].mean(), drawn[outside].mean(), drawn[in_cube].mean()))
    assert drawn[inside].mean() > 0.99, drawn[inside].mean()
    assert drawn[outside].mean() < 0.001, drawn[outside].mean()
    assert drawn[in_cube].mean() < 0.01, drawn[in_cube].mean()      # the cube in front hides it
    # mu = -0.2+0.8i: another shape.
    julia = changed("proxy_off.png", "proxy_julia.png", rect)
    assert julia.mean() > 0.01 and (julia & drawn).sum() / (julia | drawn).sum() < 0.8
    # Wireframe: lines over the ball, nothing outside it.
    wire = changed("proxy_wire_off.png", "proxy_wire.png", rect)
    assert wire[inside].mean() > 0.05 and wire[outside].mean() < 0.001, (wire[inside].mean(), wire[outside].mean())
    assert steps["material"]["drawn"] >= 1, steps["material"]
    assert steps["rendered"]["drawn"] == 0 and steps["rendered"]["sessions"] == 1, steps["rendered"]


def test_gui_f12_result_changes_during_the_render(proxy_f12_log):
    """F12 (render.render INVOKE_DEFAULT into the render window's Image Editor) of 192 samples (one
    render thread) with every sample uploaded, the window filmed by ffmpeg 5 times a second: the image area shows at
    least two pictures that are neither the empty window before F12 nor the finished render (so
    they were shown while it rendered), the film ends on the finished picture, and the Render
    Result then equals a blocking render of the same scene, bit for bit."""
    f12 = next(e for e in proxy_f12_log if e.get("step") == "f12")
    invoked = next(e for e in proxy_f12_log if e.get("step") == "f12_invoked")
    assert invoked["op"] == ["RUNNING_MODAL"] and invoked["windows"] == 2, invoked
    assert f12["samples_done"] == f12["sample_count"] and f12["cancelled"] is False, f12
    assert f12["ffmpeg_rc"] == 0, f12
    frames = sorted((SHOTS / f12["frames"]).glob("*.png"))
    assert len(frames) >= 10, len(frames)
    # The image area: the window less its header (top) and a margin.
    images = [read_png(f)[40:-20, 20:-20, :3] for f in frames]
    empty, final = images[0], images[-1]
    assert np.array_equal(images[-2], final), "the film ends before the window settled"
    shown = []
    for img in images[1:-1]:
        if not np.array_equal(img, empty) and not np.array_equal(img, final):
            if not any(np.array_equal(img, s) for s in shown):
                shown.append(img)
    first_change = next(i for i, img in enumerate(images) if not np.array_equal(img, empty))
    print("F12: %.2f s render; %d frames at %d fps; %d pictures shown before the end; first change at frame %d; "
          "blocking reference %.2f s" % (f12["render_seconds"], len(frames), f12["fps"], len(shown), first_change,
                                         f12["reference_seconds"]))
    assert len(shown) >= 2, (len(shown), f12)
    # Each picture shows something over the empty window (the fractal's pixels, not the header).
    assert all((np.abs(img.astype(int) - empty).max(-1) > 20).mean() > 0.005 for img in shown)
    assert f12["shown_after_end"]["digest"] == f12["reference"]["digest"], f12
    assert f12["reference"]["coverage"] > 0.02 and f12["reference_op"] == ["FINISHED"], f12


# Issue 20: Convert to Mesh from the UI runs modal, with its progress in the status bar; Esc cancels

def status_bar_left(name):
    """The left third of the status bar (the bottom rows) of screenshot `name`: where Blender shows
    the keymap hints or an operator's status text (reports show in its middle)."""
    px = read_png(SHOTS / name).astype(int)
    return px[-22:, :SCREEN[0] // 3, :3]


def test_gui_convert_to_mesh_esc_cancels_and_completes_like_a_script(user_dir):
    """Convert to Mesh as a user starts it (gui_convert_modal.py: INVOKE_DEFAULT, the dialog's
    Enter, simulated through Blender's event queue) on the default Julia set:
    * at resolution 1024, Esc one second in: the operator ends within 1 s of the Esc (the core
      stops within 100 ms; the rest is Blender's event loop and the 50 ms timer), nothing is
      made (objects, meshes, materials and the frame as before), and the status bar's text, shown during the conversion, is Blender's own again within 2 s;
    * at a low resolution without Esc: it completes, and the new active mesh is the one a
      script's EXEC_DEFAULT makes, bit for bit (positions, triangles, trap)."""
    afters = ["convert_status_after.png"] + ["convert_status_after_%d.png" % k for k in (1, 2, 3)]
    names = ["convert_status_before.png", "convert_status_during.png"] + afters
    log, out = run_gui(user_dir, "gui_convert_modal.py", names, timeout=240,
                       blender_args=("--enable-event-simulate",), with_output=True)
    steps = {e["step"]: e for e in log if "step" in e}
    assert steps["setup"]["add_op"] == ["FINISHED"] and steps["setup"]["is_fractal"], steps["setup"]
    c = steps["cancel"]
    print("Esc to the end of Convert to Mesh: %.1f ms (after %.2f s of conversion)" % (1000 * c["esc_to_end"], c["ran"]))
    assert c["invoke_op"] == ["RUNNING_MODAL"] and c["was_running"], c
    assert c["after"] == c["before"], c
    assert c["esc_to_end"] <= 1.0, c
    before, during = (status_bar_left(n) for n in names[:2])
    assert (np.abs(during - before).max(-1) > 30).mean() > 0.01, "no status text during the conversion"
    # Within 2 s of the end (shots 0.5 s apart: a loaded machine may redraw the bar late).
    assert any(np.array_equal(status_bar_left(n), before) for n in afters), \
        "the status bar did not get its own text back"
    done = steps["complete"]
    assert done["exec_op"] == ["FINISHED"], done
    modal, script = done["modal"], done["exec"]
    assert modal["type"] == "MESH" and modal["vertices"] > 1000, modal
    assert set(done["after_modal"]["objects"]) - set(done["before"]["objects"]) == {modal["name"]}, done
    assert script["name"] != modal["name"], done
    for key in ("vertices", "faces", "co", "loops", "trap"):
        assert modal[key] == script[key], (key, modal, script)
