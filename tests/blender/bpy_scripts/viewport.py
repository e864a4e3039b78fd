"""Scripts of test_viewport.py (run inside bpy by conftest.run_bpy: see bpy_scripts/__init__.py).
The add-on's modules are imported inside the functions: the extension is installed first."""
import os
import time

import bpy
import numpy as np


def camera_view(scene, window=None):
    from bl_ext.user_default.unbound import export
    dg = bpy.context.evaluated_depsgraph_get()
    r = scene.render
    w, h = r.resolution_x, r.resolution_y
    cam = export.camera_dict(dg, scene.camera.evaluated_get(dg), scene.camera.matrix_world, w, h)
    return dict(camera=cam, window=window or (0, 0, w, h), error=None)


def current_request(scene, window=None):
    from bl_ext.user_default.unbound import viewport
    dg = bpy.context.evaluated_depsgraph_get()
    return viewport.request(viewport.scene_part(dg), camera_view(scene, window))


def combined(exr):
    return np.stack([exr["ViewLayer.Combined.%s" % c] for c in "RGBA"], -1)[::-1]


def final_level_equals_a_final_render_of_the_same_view(S, mod):
    from bl_ext.user_default.unbound import viewport
    results = {}
    for camera_type in ("PERSP", "ORTHO", "PANO", "PERSP_DOF"):
        scene = S.empty_scene(123, 77)
        pano = dict(panorama_type='FISHEYE_EQUIDISTANT', fisheye_fov=3.5) if camera_type == 'PANO' else {}
        cam = S.add_camera(scene, type=camera_type.split("_")[0], ortho_scale=3.0, **pano)
        if camera_type == "PERSP_DOF":
            dof = cam.data.dof
            dof.use_dof, dof.focus_distance, dof.aperture_fstop, dof.aperture_blades = True, 2.0, 0.4, 6
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


def coarse_levels_are_the_final_images_grid_pixels(S, mod):
    from bl_ext.user_default.unbound import viewport
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


def any_change_restarts_and_stale_work_is_cancelled_at_once(S, mod):
    from bl_ext.user_default.unbound import viewport
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


def time_cap_and_errors(S, mod):
    from bl_ext.user_default.unbound import viewport
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


def viewport_settings_are_scene_properties(S, mod):
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


def heavy_ifs_viewport_closes_promptly(S, mod):
    """Issue 16's worst case: an IFS of 32 maps at depth 16 with 32 AO samples at distance 1e-4,
    8 instances, in the Rendered viewport; closing it (Session.stop) while it refines."""
    from bl_ext.user_default.unbound import viewport
    scene = S.empty_scene(640, 360)
    S.add_camera(scene)
    bpy.ops.object.unbound_fractal_add(kind='IFS', use_cursor=False)
    ob = bpy.context.object
    maps = ob.unbound.ifs_maps
    maps.clear()
    rng = np.random.default_rng(1)
    for i in range(32):  # nearly coincident contractions: the IFS search cannot prune
        m = maps.add()
        m.location = tuple(rng.uniform(-0.1, 0.1, 3))
        m.scale = (0.8, 0.8, 0.8)
    ob.unbound.ifs_depth = 16
    for k in range(7):  # 8 instances: linked duplicates share the fractal's settings
        dup = ob.copy()
        dup.location = (0.3 * (k - 3), 0.0, 0.0)
        scene.collection.objects.link(dup)
    ob.location = (0.3 * 4, 0.0, 0.0)
    scene.unbound.ao_strength = 1.0
    scene.unbound.ao_samples = 32
    scene.unbound.ao_distance = 1e-4
    scene.unbound.viewport_samples = 16
    session = viewport.Session()
    session.update(current_request(scene))
    time.sleep(0.5)  # well into the refinement: the first levels of this scene take seconds
    refining = session._finished != session._generation
    t = time.perf_counter()
    session.stop()
    stop_s = time.perf_counter() - t
    S.report(stop_s=stop_s, refining=refining, alive=session._thread.is_alive(), maps=len(maps))
