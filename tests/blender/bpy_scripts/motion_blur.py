"""Scripts of test_motion_blur_blender.py (run inside bpy by conftest.run_bpy: see bpy_scripts/__init__.py)."""
import time

import bpy
import numpy as np

FRAME = 1


def keyframed(S, owner, data_path, index, values):
    """Keyframes owner's data_path[index] at frame: value (LINEAR: Cycles' motion steps, three
    transforms per shutter, interpolate a linear motion exactly)."""
    for frame, value in values.items():
        owner.path_resolve(data_path)[index] = value
        owner.keyframe_insert(data_path, index=index, frame=frame)
    for point in S.fcurve(owner, data_path, index).keyframe_points:
        point.interpolation = 'LINEAR'


def shutter_curve(scene, points):
    """The render's shutter curve through `points` (x, y), as a user draws it."""
    mapping = scene.render.motion_blur_shutter_curve
    curve = mapping.curves[0]
    while len(curve.points) > len(points):
        curve.points.remove(curve.points[1])
    while len(curve.points) < len(points):
        curve.points.new(0.5, 0.5)
    for point, location in zip(curve.points, points):
        point.location = location
    mapping.update()


def blurred_ball(S, mod, size, camera, motion, shutter, cycles_samples, unbound_samples):
    """A unit ball (Cycles: a fine UV sphere mesh; Unbound: mu = 0) or the camera keyframed sideways
    (`motion`: 'object' or 'camera', x = -velocity at frame 0 and +velocity at frame 2), rendered at
    FRAME by both engines through Blender's pipeline with the same shutter (`shutter`: position,
    length in frames, curve points or None). Saves both alpha passes; reports render seconds and
    what the frame looks like after the renders (the frame and the ball's place restored)."""
    scene = S.empty_scene(size[0], size[1], "CYCLES")
    cam = S.add_camera(scene, location=camera["location"], lens=camera["lens"])
    scene.render.film_transparent = True
    scene.render.use_motion_blur = True
    scene.render.motion_blur_position = shutter["position"]
    scene.render.motion_blur_shutter = shutter["length"]
    if shutter["curve"]:
        shutter_curve(scene, shutter["curve"])
    # As test_depth_of_field_blender's: only the camera rays' coverage matters.
    S.cycles_cpu(scene, cycles_samples, pixel_filter_type='BOX', filter_width=1.0, max_bounces=0)
    sphere = S.uv_sphere()
    velocity = motion["velocity"]
    moving = sphere if motion["what"] == "object" else cam
    keyframed(S, moving, "location", 0, {0: moving.location.x - velocity, 2: moving.location.x + velocity})
    scene.frame_set(FRAME)
    out, seconds = {}, {}
    start = time.perf_counter()
    out["cycles"] = S.render_to_exr(scene, "cycles.exr")["ViewLayer.Combined.A"]
    seconds["cycles"] = time.perf_counter() - start

    sphere.hide_render = True
    scene.render.engine = 'UNBOUND'
    scene.unbound.samples = unbound_samples
    ball = S.unit_ball()
    if moving is sphere:
        keyframed(S, ball, "location", 0, {0: -velocity, 2: velocity})
        moving = ball
    scene.frame_set(FRAME)
    start = time.perf_counter()
    out["unbound"] = S.render_to_exr(scene, "unbound.exr")["ViewLayer.Combined.A"]
    seconds["unbound"] = time.perf_counter() - start
    stats = dict(mod.engine.LAST_STATS)
    scene.render.use_motion_blur = False
    out["unblurred"] = S.render_to_exr(scene, "unblurred.exr")["ViewLayer.Combined.A"]
    np.savez(S.tmp_dir() / "alpha.npz", **out)
    S.report(seconds=seconds, blur_seconds=stats["motion_blur_seconds"], render_seconds=stats["seconds"],
             after=dict(frame=scene.frame_current, subframe=scene.frame_subframe, x=moving.location.x,
                        evaluated_x=moving.evaluated_get(bpy.context.evaluated_depsgraph_get()).matrix_world[0][3]))


def combined(S, scene, name):
    """The Combined pass (RGBA) of F12."""
    return S.combined(S.render_to_exr(scene, name))


def keyframed_mu(S, mod, size, samples, shutter, mu_keys, subframes):
    """A Julia set whose mu[1] is keyframed (linear), rendered at FRAME with motion blur; then
    without blur at each sample's time (the engine's own motion_blur.sample_times, each render of
    `samples` samples) and at `subframes` evenly spaced times of the open shutter, with 4 samples
    each. Saves the four Combined passes (blurred, the two means, the unblurred frame)."""
    scene = S.empty_scene(size[0], size[1])
    S.add_camera(scene)
    scene.render.film_transparent = True
    ob = S.add_fractal(mu=(-0.2, 0.8, 0.0, 0.0), max_iterations=12)
    keyframed(S, ob, "unbound.mu", 1, {int(k): v for k, v in mu_keys.items()})
    scene.render.use_motion_blur = True
    scene.render.motion_blur_position = shutter["position"]
    scene.render.motion_blur_shutter = shutter["length"]
    scene.unbound.samples = samples
    scene.frame_set(FRAME)
    out = {"blurred": combined(S, scene, "blurred.exr")}
    blur_stats = dict(mod.engine.LAST_STATS)
    after = dict(frame=scene.frame_current, subframe=scene.frame_subframe, mu=ob.unbound.mu[1])
    times = mod.motion_blur.sample_times(scene, samples)
    scene.render.use_motion_blur = False
    out["unblurred"] = combined(S, scene, "unblurred.exr")

    def mean_over(when, count):
        total = 0.0
        scene.unbound.samples = count
        for t in when:
            frame = int(np.floor(t))
            scene.frame_set(frame, subframe=t - frame)
            total = total + combined(S, scene, "subframe.exr")
        scene.frame_set(FRAME)
        return total / len(when)

    out["at_sample_times"] = mean_over(times, samples)
    opening, length = mod.motion_blur.shutter_interval(scene.render, FRAME)
    out["at_subframes"] = mean_over([opening + length * (k + 0.5) / subframes for k in range(subframes)], 4)
    np.savez(S.tmp_dir() / "combined.npz", **out)
    S.report(times=times, after=after, blur_seconds=blur_stats["motion_blur_seconds"],
             render_seconds=blur_stats["seconds"])


def same_bits_without_motion(S, mod, size, samples):
    """Motion blur on for a scene where nothing moves: every sample exports the same scene, so the
    render equals the render without blur bit for bit (every pass). Then one sample with the shutter
    at START: the frame rendered unblurred at the shutter's middle, a quarter frame on, equal to a
    render without blur at that subframe, with the warning."""
    scene = S.empty_scene(size[0], size[1])
    S.add_camera(scene)
    ob = S.add_fractal(max_iterations=12)
    vl = scene.view_layers[0]
    for toggle in ("use_pass_depth", "use_pass_normal", "use_pass_ao", "use_pass_iterations"):
        setattr(vl.unbound, toggle, True)
    scene.unbound.samples = samples
    scene.unbound.ao_strength = 0.5
    scene.frame_set(FRAME)
    exr = S.render_to_exr
    plain = exr(scene, "plain.exr")
    scene.render.use_motion_blur = True
    blurred = exr(scene, "blurred.exr")
    identical = {k: bool(np.array_equal(plain[k], blurred[k])) for k in plain}

    keyframed(S, ob, "location", 0, {0: -0.4, 2: 0.4})
    scene.frame_set(FRAME)
    scene.unbound.samples = 1
    scene.render.motion_blur_position = 'START'
    one_sample = exr(scene, "one_sample.exr")
    scene.render.use_motion_blur = False
    scene.frame_set(FRAME, subframe=0.25)
    at_middle = exr(scene, "middle.exr")
    scene.frame_set(FRAME)
    at_frame = exr(scene, "frame.exr")
    S.report(identical=identical, channels=len(plain),
             one_sample_at_middle=all(np.array_equal(one_sample[k], at_middle[k]) for k in one_sample),
             one_sample_at_frame=all(np.array_equal(one_sample[k], at_frame[k]) for k in one_sample))


def refusals_and_stereo(S, mod):
    """A shutter curve that is zero everywhere: F12 fails with the message and writes no file.
    Stereo 3D with blur (a moving fractal, 4 samples): both views render, each differs from its
    unblurred self, and the frame is restored."""
    scene = S.empty_scene(64, 48)
    S.add_camera(scene)
    ob = S.add_fractal(max_iterations=12)
    keyframed(S, ob, "location", 0, {0: -0.4, 2: 0.4})
    scene.frame_set(FRAME)
    scene.unbound.samples = 4
    scene.render.use_motion_blur = True
    shutter_curve(scene, [(0.0, 0.0), (0.5, 0.0), (1.0, 0.0)])
    zero_curve = S.attempt(scene, "zero_curve.png")
    shutter_curve(scene, [(0.0, 1.0), (0.5, 1.0), (1.0, 1.0)])
    scene.render.use_multiview = True
    scene.render.views_format = 'STEREO_3D'
    scene.render.film_transparent = True
    scene.camera.data.stereo.interocular_distance = 0.2
    # One file per eye (the _L and _R suffixes): 5.x writes a multi-view EXR as parts whose
    # channels do not name the view.
    S.exr_output(scene)
    scene.render.image_settings.views_format = 'INDIVIDUAL'

    def eyes(name):
        folder = S.tmp_dir()
        scene.render.filepath = str(folder / (name + ".exr"))
        bpy.ops.render.render(write_still=True)  # Blender writes NAME_L.exr and NAME_R.exr
        return [S.read_exr(folder / ("%s_%s.exr" % (name, eye)))["ViewLayer.Combined.A"] for eye in "LR"]

    blurred = eyes("stereo_blurred")
    scene.render.use_motion_blur = False
    sharp = eyes("stereo_sharp")
    S.report(zero_curve=zero_curve, frame=[scene.frame_current, scene.frame_subframe],
             views_differ=bool(not np.array_equal(*blurred)),
             blur_changes=[bool(not np.array_equal(b, s)) for b, s in zip(blurred, sharp)])
