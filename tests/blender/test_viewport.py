"""The Rendered viewport's scheduler (addon/viewport.py) under the real bpy 4.2: progressive levels,
restart on any change, cancellation of stale work, the time cap, errors, and a final level equal
to a final render (F12, written to EXR) of the same view, bit for bit.

bpy from PyPI has no window, so these tests hand the Session the view a final render uses (the
scene camera at the output resolution); the region's own view (view_part, view_draw) is tested in
the real Blender GUI (test_real_blender.py)."""
import textwrap

# Helpers every script below starts with.
PRELUDE = """
import time
import numpy as np
from bl_ext.user_default.unbound import engine, viewport

def camera_view(scene, window=None):
    dg = bpy.context.evaluated_depsgraph_get()
    r = scene.render
    w, h = r.resolution_x, r.resolution_y
    cam = engine.camera_dict(dg, scene.camera.evaluated_get(dg), scene.camera.matrix_world, w, h)
    return dict(camera=cam, window=window or (0, 0, w, h), error=None)

def current_request(scene, window=None):
    dg = bpy.context.evaluated_depsgraph_get()
    return viewport.request(viewport.scene_part(dg), camera_view(scene, window))

def combined(exr):
    return np.stack([exr["ViewLayer.Combined.%s" % c] for c in "RGBA"], -1)[::-1]
"""


def with_prelude(code):
    return PRELUDE + textwrap.dedent(code)


def test_final_level_equals_a_final_render_of_the_same_view(run_bpy):
    """Levels 1/8, 1/4, 1/2, full, then samples 2 and 3: the last frame is the F12 image's
    Combined pass, bit for bit, with shadows, AO, fog and a reflective sea; perspective and
    orthographic cameras."""
    r = run_bpy(with_prelude("""
        results = {}
        for camera_type in ("PERSP", "ORTHO"):
            scene = S.empty_scene(123, 77)
            S.add_camera(scene, type=camera_type, ortho_scale=3.0)
            S.add_fractal(reflectivity=0.3)
            light = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", 'SUN'))
            scene.collection.objects.link(light)
            light.rotation_euler = (0.6, 0.2, 0.3)
            s = scene.unbound
            s.shadows, s.ao_strength, s.ambient, s.fog_density = 'SOFT', 0.5, (0.2, 0.2, 0.2), 0.05
            s.use_sea, s.reflection_depth = True, 1
            s.samples = s.viewport_samples = 3
            session = viewport.Session()
            session.update(current_request(scene))
            frame = session.wait(120)
            session.stop()
            exr = S.render_to_exr(scene, "final_%s.exr" % camera_type)
            ref = combined(exr)
            results[camera_type] = dict(
                levels=[(d, n) for _, d, n, _, _ in session.log], final=frame.final,
                shape=list(frame.pixels.shape), identical=bool(np.array_equal(frame.pixels, ref)),
                max_diff=float(np.abs(frame.pixels - ref).max()), coverage=float((ref[..., 3] > 0).mean()))
        S.report(**results)
    """))
    for camera_type in ("PERSP", "ORTHO"):
        got = r[camera_type]
        assert got["levels"] == [[8, 1], [4, 1], [2, 1], [1, 1], [1, 2], [1, 3]], got
        assert got["final"] and got["shape"] == [77, 123, 4], got
        assert got["identical"], str(got)
        assert got["coverage"] > 0.05, got


def test_coarse_levels_are_the_final_images_grid_pixels(run_bpy):
    """Each level shows every d-th pixel of every d-th row of the final image (one sample: no
    later samples change them), and full resolution costs one ray per pixel plus the sub-grids'
    one-pixel aprons, not the 1 + 1/4 + 1/16 + 1/64 of re-rendering every level."""
    r = run_bpy(with_prelude("""
        scene = S.empty_scene(160, 90)
        S.add_camera(scene)
        S.add_fractal()
        scene.unbound.viewport_start_divisor = '16'
        frames = []
        session = viewport.Session(redraw=lambda: frames.append(session.frame()))
        session.update(current_request(scene))
        last = session.wait(60)
        session.stop()
        full = last.pixels
        S.report(divisors=[f.divisor for f in frames],
                 grids=[bool(np.array_equal(f.pixels, full[::f.divisor, ::f.divisor])) for f in frames],
                 shapes=[list(f.pixels.shape[:2]) for f in frames], final=[f.final for f in frames])
    """))
    assert r["divisors"] == [16, 8, 4, 2, 1], r
    assert all(r["grids"]), r
    assert r["shapes"] == [[6, 10], [12, 20], [23, 40], [45, 80], [90, 160]], r
    assert r["final"] == [False, False, False, False, True], r


def test_any_change_restarts_and_stale_work_is_cancelled_at_once(run_bpy):
    """A heavy view (640x360, 400 iterations, soft shadows, 8 samples) is changed while it
    refines: by a parameter (mu), by the frame (keyframed theta), by the camera (moved) and by a
    setting (samples). Each change restarts at the coarsest level; the stale step stops within
    50 ms; no frame of stale work is published after the change; the last frame equals a fresh
    session's image of the final request. Equal requests (a redraw, a selection) restart nothing."""
    r = run_bpy(with_prelude("""
        scene = S.empty_scene(640, 360)
        S.add_camera(scene)
        ob = S.add_fractal(max_iterations=400)
        light = bpy.data.objects.new("Point", bpy.data.lights.new("Point", 'POINT'))
        scene.collection.objects.link(light)
        light.location = (2, -2, 3)
        light.data.shadow_soft_size = 0.5
        scene.unbound.shadows = 'SOFT'
        scene.unbound.viewport_samples = 8
        ob.unbound.theta = 0.0
        ob.unbound.keyframe_insert("theta", frame=1)
        ob.unbound.theta = 0.3
        ob.unbound.keyframe_insert("theta", frame=10)
        scene.frame_set(1)
        session = viewport.Session()
        restarted = [session.update(current_request(scene))]

        def until_refining():
            # wait for the first frame of the latest generation, then change something
            t = time.perf_counter()
            while time.perf_counter() - t < 30:
                f = session.frame()
                if f is not None and f.generation == session._generation:
                    return f.divisor
                time.sleep(0.002)
            raise RuntimeError("no frame")

        changes = []
        def change(label, fn):
            changes.append((label, until_refining()))
            fn()
            restarted.append(session.update(current_request(scene)))

        change("mu", lambda: setattr(ob.unbound, "mu", (-0.3, 0.7, 0.1, 0.0)))
        change("frame", lambda: scene.frame_set(4))
        change("camera", lambda: setattr(scene.camera, "location", (0.5, -3.2, 1.0)))
        change("samples", lambda: setattr(scene.unbound, "viewport_samples", 2))
        # Not changes: the same request again, and a selection change with a depsgraph update.
        same = [session.update(current_request(scene))]
        ob.select_set(not ob.select_get())
        bpy.context.view_layer.update()
        same.append(session.update(current_request(scene)))
        last = session.wait(120)
        log = list(session.log)
        cancellations = list(session.cancellations)
        session.stop()
        fresh = viewport.Session()
        fresh.update(current_request(scene))
        expected = fresh.wait(120)
        fresh.stop()
        S.report(restarted=restarted, same=same, changes=changes, log=log, cancellations=cancellations,
                 generation=last.generation, final=last.final, samples=last.samples_done,
                 identical=bool(np.array_equal(last.pixels, expected.pixels)))
    """), timeout=600)
    assert r["restarted"] == [True] * 5 and r["same"] == [False, False], r
    assert r["generation"] == 5 and r["final"] and r["samples"] == 2, r
    assert r["identical"], r
    # Every change came while its predecessor was refining, and cancelled it promptly.
    assert {c[0] for c in r["cancellations"]} == {1, 2, 3, 4}, r["cancellations"]
    assert max(c[1] for c in r["cancellations"]) < 0.05, r["cancellations"]
    # Each generation starts at 1/8; once a newer one has published, no older one publishes.
    log = r["log"]
    for g in range(1, 6):
        mine = [e for e in log if e[0] == g]
        assert mine and mine[0][1] == 8, (g, mine)
        if g < 5:
            assert not any(e[4] for e in mine), "a stale generation finished: %s" % mine
    generations = [e[0] for e in log]
    assert generations == sorted(generations), generations


def test_time_cap_and_errors(run_bpy):
    """The time cap ends refinement early (the frame reached is final); a NaN parameter shows
    as an error frame naming the object, and fixing it renders again; a NaN setting is one error,
    not endless restarts; equal clip distances are a message; stop() mid-render returns promptly
    and ends the worker."""
    r = run_bpy(with_prelude("""
        scene = S.empty_scene(480, 270)
        S.add_camera(scene)
        ob = S.add_fractal(max_iterations=300)
        scene.unbound.viewport_samples = 64
        scene.unbound.viewport_time_limit = 0.15
        session = viewport.Session()
        t = time.perf_counter()
        session.update(current_request(scene))
        capped = session.wait(60)
        capped_s = time.perf_counter() - t
        ob.unbound.theta = float("nan")
        session.update(current_request(scene))
        error = session.wait(60)
        ob.unbound.theta = 0.0
        scene.unbound.viewport_time_limit = 0.0
        scene.unbound.viewport_samples = 1
        session.update(current_request(scene))
        ok = session.wait(60)
        # A NaN that reaches the request (a scene setting, which the core refuses) gives one
        # error frame; the redraw it asks for builds the same request, which restarts nothing.
        scene.unbound.fog_density = float("nan")
        session.update(current_request(scene))
        nan_frame = session.wait(60)
        nan_again = session.update(current_request(scene))
        scene.unbound.fog_density = 0.0
        # Equal clip distances: a message, in the viewport and for F12 alike.
        scene.camera.data.clip_start = scene.camera.data.clip_end = 5.0
        clip_outcome = S.attempt(scene)
        scene.camera.data.clip_start, scene.camera.data.clip_end = 0.1, 100.0
        # stop() in the middle of a long refinement
        scene.unbound.viewport_samples = 64
        session.update(current_request(scene))
        time.sleep(0.2)
        t = time.perf_counter()
        session.stop()
        stop_s = time.perf_counter() - t
        S.report(nan=[nan_frame.error, nan_again], clip=list(clip_outcome),
                 capped=[capped.final, capped.samples_done, capped_s], error=error.error,
                 error_final=error.final, ok=[ok.final, ok.error, ok.divisor], stop_s=stop_s,
                 alive=session._thread.is_alive())
    """))
    final, samples_done, seconds = r["capped"]
    assert final and samples_done < 64 and seconds < 1.5, r
    assert r["error"] == "fractal 'Quaternion Julia': theta must be finite (check its keyframes and drivers)", r
    assert r["error_final"], r
    assert r["ok"] == [True, None, 1], r
    assert "fog_density" in r["nan"][0] and r["nan"][1] is False, r
    assert r["clip"] == ["Error: Unbound: The clip start (5) must be less than the clip end (5)", False], r
    assert r["stop_s"] < 0.2 and not r["alive"], r


def test_viewport_settings_are_scene_properties(run_bpy):
    """Scene.unbound holds the viewport's start resolution, samples and time cap, keyframeable and
    saved with the file; the Render tab's Viewport panel draws them."""
    r = run_bpy("""
        scene = S.empty_scene()
        s = scene.unbound
        defaults = [s.viewport_start_divisor, s.viewport_samples, s.viewport_time_limit]
        s.viewport_start_divisor, s.viewport_samples, s.viewport_time_limit = '32', 16, 2.5
        items = [(i.identifier, i.value) for i in s.bl_rna.properties["viewport_start_divisor"].enum_items]
        path = os.path.join(os.environ["UNBOUND_TEST_TMP"], "settings.blend")
        bpy.ops.wm.save_as_mainfile(filepath=path)
        bpy.ops.wm.read_homefile(use_empty=True)
        bpy.ops.wm.open_mainfile(filepath=path)
        s = bpy.context.scene.unbound
        S.report(defaults=defaults, items=items, loaded=[s.viewport_start_divisor, s.viewport_samples,
                                                         s.viewport_time_limit],
                 panel=hasattr(bpy.types, "UNBOUND_PT_render_viewport"))
    """)
    assert r["defaults"] == ["8", 1, 0.0], r
    assert r["items"] == [[str(d), d] for d in (1, 2, 4, 8, 16, 32, 64)], r
    assert r["loaded"] == ["32", 16, 2.5] and r["panel"], r
