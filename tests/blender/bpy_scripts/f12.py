"""Scripts of test_f12_blender.py (issue 17, F12 as Cycles users know it): a render of several
samples shows each sample as it finishes (update_result, the stats line's Sample k/N and time
remaining, a moving progress bar), and Esc keeps the samples done, normalised as a render of
that many samples."""
import os
import pathlib

import bpy
import numpy as np

# Passes compared in the cancel test: averaged ones (Combined, AO, Diffuse, Shadow) and ones taken
# from sample 0 (Depth, Normal).
PASS_TOGGLES = ("use_pass_depth", "use_pass_normal", "use_pass_ao", "use_pass_diffuse", "use_pass_shadow")


def scene_with_samples(S, width, height, samples, motion_blur=False):
    """motion_blur: the fractal moves sideways through frame 1 (linear keys), rendered with blur."""
    scene = S.empty_scene(width, height)
    S.add_camera(scene)
    ob = S.add_fractal(max_iterations=12)
    if motion_blur:
        for frame, x in ((0, -0.3), (2, 0.3)):
            ob.location.x = x
            ob.keyframe_insert("location", index=0, frame=frame)
        for point in S.fcurve(ob, "location", 0).keyframe_points:
            point.interpolation = 'LINEAR'
        scene.frame_set(1)
        scene.render.use_motion_blur = True
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", 'SUN'))
    sun.data.angle = 0.3
    sun.rotation_euler = (0.6, 0.3, 0.4)
    scene.collection.objects.link(sun)
    u = scene.unbound
    u.samples = samples
    u.shadows = 'SOFT'
    u.ao_strength = 0.5
    u.ambient = (0.1, 0.1, 0.1)
    vl = scene.view_layers[0]
    for toggle in PASS_TOGGLES:
        setattr(vl.unbound, toggle, True)
    return scene


class Spy:
    """The RenderEngine as engine.py sees it, recording what Blender is told (stats, progress, each
    update_result's Combined pixels) and answering test_break as `cancel(spy)` says."""

    def __init__(self, engine, cancel=None):
        self._engine = engine
        self._cancel = cancel
        self.stats, self.progress, self.updates, self.breaks = [], [], [], 0
        self.results = []  # begin_result's rectangles (x, y, width, height)

    def __getattr__(self, name):
        return getattr(self._engine, name)

    def update_stats(self, stats, info):
        self.stats.append(info)
        self._engine.update_stats(stats, info)

    def update_progress(self, value):
        self.progress.append(value)
        self._engine.update_progress(value)

    def update_result(self, result):
        self._engine.update_result(result)
        rect = result.layers[0].passes.find_by_name("Combined", "").rect
        if len(rect) == 1:  # engine.frame_result's one pixel, which has Blender allocate its passes
            return
        pixels = np.empty(len(rect) * 4, np.float32)
        rect.foreach_get(pixels)
        self.updates.append(dict(progress=self.progress[-1] if self.progress else None,
                                 stats=self.stats[-1] if self.stats else None,
                                 alpha_sum=float(pixels[3::4].sum()), rgb_sum=float(pixels.reshape(-1, 4)[:, :3].sum()),
                                 digest=hash(pixels.tobytes())))

    def begin_result(self, x, y, w, h, **kw):
        self.results.append((x, y, w, h))
        return self._engine.begin_result(x, y, w, h, **kw)

    def test_break(self):
        if self._engine.test_break():
            return True
        if self._cancel is not None and self._cancel(self):
            self.breaks += 1
            return True
        return False


def spied(mod, cancel=None):
    """Route the next renders through a Spy; returns the list that receives the spies."""
    spies = []
    original = mod.engine.render

    def render(engine, depsgraph):
        spy = Spy(engine, cancel)
        spies.append(spy)
        original(spy, depsgraph)

    mod.engine.render = render
    return spies, lambda: setattr(mod.engine, "render", original)


def read_passes(S, scene, name):
    exr = S.render_to_exr(scene, name)
    return {k: np.asarray(v) for k, v in exr.items()}


def samples_shown_as_they_finish(S, mod, samples=8):
    """Every sample shown: the uploads' share of the render time is lifted to 1 (uploads are part
    of the time so far, so the budget always allows one), because how many samples the default
    share lets through depends on the machine's speed against its memory bandwidth."""
    scene = scene_with_samples(S, 240, 180, samples)
    spies, restore = spied(mod)
    share, mod.engine.UPDATE_SHARE = mod.engine.UPDATE_SHARE, 1.0
    mod.engine.UPDATE_IN_BACKGROUND = True  # the bpy module is Blender in the background
    try:
        final = read_passes(S, scene, "progressive.exr")
    finally:
        mod.engine.UPDATE_SHARE = share
        mod.engine.UPDATE_IN_BACKGROUND = False
        restore()
    spy = spies[0]
    S.report(stats=spy.stats, progress=spy.progress, updates=spy.updates,
             final_rgb_sum=float(sum(final["ViewLayer.Combined.%s" % c].sum() for c in "RGB")),
             last=dict(mod.engine.LAST_STATS))


def no_uploads_in_the_background(S, mod, samples=8):
    """Blender in the background (the bpy module) shows no image: no sample is uploaded before the
    end, even with the uploads' share lifted to 1; the final passes are those of a render that
    uploads every sample."""
    scene = scene_with_samples(S, 240, 180, samples)
    spies, restore = spied(mod)
    share, mod.engine.UPDATE_SHARE = mod.engine.UPDATE_SHARE, 1.0
    try:
        quiet = read_passes(S, scene, "quiet.exr")
        mod.engine.UPDATE_IN_BACKGROUND = True
        shown = read_passes(S, scene, "shown.exr")
    finally:
        mod.engine.UPDATE_SHARE = share
        mod.engine.UPDATE_IN_BACKGROUND = False
        restore()
    S.report(background=bool(bpy.app.background), updates=[len(spy.updates) for spy in spies],
             identical={k: bool(np.array_equal(quiet[k], shown[k])) for k in shown})


def esc_keeps_the_samples_done(S, mod, samples=8, at=0.5, motion_blur=False):
    """Cancel once the progress passes `at` (within the next sample: the one in flight is dropped),
    then render the same scene with as many samples as were done: every pass equal, bit for bit.
    motion_blur: a moving fractal with blur (a sample's time depends on its index alone)."""
    scene = scene_with_samples(S, 240, 180, samples, motion_blur)
    spies, restore = spied(mod, cancel=lambda spy: bool(spy.progress) and spy.progress[-1] > at)
    cancelled = read_passes(S, scene, "cancelled.exr")
    restore()
    stats = dict(mod.engine.LAST_STATS)
    done = stats["samples_done"]
    scene.unbound.samples = max(done, 1)
    reference = read_passes(S, scene, "reference.exr")
    diffs = {k: float(np.max(np.abs(cancelled[k] - reference[k]))) for k in reference}
    identical = {k: bool(np.array_equal(cancelled[k], reference[k])) for k in reference}
    S.report(stats=stats, done=done, diffs=diffs, identical=identical, breaks=spies[0].breaks,
             spy_stats=spies[0].stats,
             coverage=float((cancelled["ViewLayer.Combined.A"] > 0).mean()),
             channels=sorted(reference), frame=[scene.frame_current, scene.frame_subframe])


def esc_in_the_first_sample_keeps_the_tiles_done(S, mod):
    """One sample, cancelled part of the way (in the middle of its second band of three,
    engine.band_rows): the tiles done are kept (alpha 1 where the fractal is hit), the rest
    transparent black, and the frame is not an empty image."""
    scene = scene_with_samples(S, 640, 480, 1)
    scene.unbound.tile_size = 16
    scene.render.threads_mode = 'FIXED'
    scene.render.threads = 1
    spies, restore = spied(mod, cancel=lambda spy: bool(spy.progress) and spy.progress[-1] > 0.4)
    partial = read_passes(S, scene, "partial.exr")
    restore()
    stats = dict(mod.engine.LAST_STATS)
    full = read_passes(S, scene, "full.exr")
    a, b = partial["ViewLayer.Combined.A"], full["ViewLayer.Combined.A"]
    rendered = a > 0
    S.report(stats=stats, partial_coverage=float(rendered.mean()), full_coverage=float((b > 0).mean()),
             rendered_equal=bool(all(np.array_equal(partial["ViewLayer.Combined.%s" % c][rendered],
                                                    full["ViewLayer.Combined.%s" % c][rendered]) for c in "RGBA")))


def one_sample_bands(S, mod, sizes):
    """One sample at each size: the rectangles the render's bands asked Blender for, and how much
    of the frame the fractal covers. Through bands always, as Blender with a window renders (in the
    background a window of one band goes straight into Blender's result: direct_frame_result)."""
    found = {}
    mod.engine.DIRECT_IN_BACKGROUND = False
    for width, height in sizes:
        scene = scene_with_samples(S, width, height, 1)
        scene.unbound.shadows = 'HARD'
        scene.unbound.ao_strength = 0.0
        spies, restore = spied(mod)
        try:
            px = read_passes(S, scene, "bands_%dx%d.exr" % (width, height))
        finally:
            restore()
        hit = px["ViewLayer.Depth.Z"] < 1e6  # the background's depth is Blender's 1e10
        found["%dx%d" % (width, height)] = dict(results=spies[-1].results, hit=float(hit.mean()),
                                                 hit_rows=int(hit.any(axis=1).sum()),
                                                 rendered=float((px["ViewLayer.Combined.A"] > 0).mean()))
    S.report(found=found)


def direct_frame_result(S, mod, width, height, samples=1):
    """A window of one band (one sample) or of several samples, in the background: written straight
    into Blender's result of the frame (engine.frame_result), and the same scene through a band
    result (DIRECT_IN_BACKGROUND off). Two view layers (the second without the sun's collection,
    and with other passes) and two stereo views, so that a pass written into the wrong layer or
    view shows. Every channel of the EXRs, and the rectangles begin_result was asked for (per view
    layer)."""
    scene = scene_with_samples(S, width, height, samples)
    sun = bpy.data.objects["Sun"]
    lights = bpy.data.collections.new("Lights")
    scene.collection.children.link(lights)
    lights.objects.link(sun)
    scene.collection.objects.unlink(sun)
    second = scene.view_layers.new("Second")
    second.layer_collection.children["Lights"].exclude = True
    second.unbound.use_pass_position = True
    scene.render.use_multiview = True
    scene.render.views_format = 'STEREO_3D'
    scene.camera.data.stereo.interocular_distance = 0.3
    S.exr_output(scene)
    scene.render.image_settings.views_format = 'MULTIVIEW'
    found = {}
    for direct in (True, False):
        mod.engine.DIRECT_IN_BACKGROUND = direct
        spies, restore = spied(mod)
        try:
            found[direct] = (read_passes(S, scene, "direct_%d.exr" % direct), [spy.results for spy in spies])
        finally:
            restore()
            mod.engine.DIRECT_IN_BACKGROUND = True
    (a, rects_direct), (b, rects_bands) = found[True], found[False]
    combined = {(layer, view): np.stack([a["%s.Combined.%s.%s" % (layer, view, c)] for c in "RGBA"], -1)
                for layer in ("ViewLayer", "Second") for view in ("left", "right")}
    S.report(channels=sorted(a), channels_bands=sorted(b),
             unequal=sorted(k for k in a if k in b and not np.array_equal(a[k], b[k])),
             rects_direct=rects_direct, rects_bands=rects_bands,
             layers_differ=not np.array_equal(combined["ViewLayer", "left"], combined["Second", "left"]),
             views_differ=not np.array_equal(combined["ViewLayer", "left"], combined["ViewLayer", "right"]),
             hit=float((a["ViewLayer.Depth.left.Z"] < 1e6).mean()))  # the background's depth is 1e10


def direct_failure_writes_no_file(S, mod):
    """A core failure in a window of one band written straight into Blender's result (background):
    an error report and no file, as through bands."""
    scene = scene_with_samples(S, 96, 64, 1)
    original = mod.utils.native

    class Core:
        def __getattr__(self, name):
            return getattr(original(), name)

        def render(self, *args, **kw):
            raise MemoryError()

    spies, restore = spied(mod)
    mod.utils.native = lambda: Core()
    try:
        outcome = S.attempt(scene, "direct_failed.png")
    finally:
        mod.utils.native = original
        restore()
    S.report(outcome=outcome, rects=spies[0].results)


def failure_mid_render_writes_no_file(S, mod, samples=4):
    """A failure after some samples were shown: still an error report and no file (issue 16)."""
    scene = scene_with_samples(S, 120, 90, samples)
    calls = []
    original = mod.utils.native

    class Core:
        def __getattr__(self, name):
            return getattr(original(), name)

        def render(self, *args, **kw):
            calls.append(kw.get("sample_range"))
            if len(calls) == 3:
                raise MemoryError()
            return original().render(*args, **kw)

    mod.utils.native = lambda: Core()
    outcome = S.attempt(scene, "failed.png")
    mod.utils.native = original
    S.report(outcome=outcome, calls=calls)



def frame_memory_kept(S, mod, width, height, renders, direct=True):
    """Page faults per F12 of a scene of seven passes, after a first render (issue 21,
    addon/frame_memory.py): whether the add-on kept the frame's memory, and which environments
    it would keep it in. direct: DIRECT_IN_BACKGROUND (False: through a band, as with a window)."""
    import resource
    mod.engine.DIRECT_IN_BACKGROUND = direct
    scene = S.empty_scene(width, height)
    S.add_camera(scene)
    S.add_fractal(max_iterations=8)
    vl = scene.view_layers[0]
    vl.use_pass_z = vl.use_pass_normal = vl.use_pass_position = True
    for toggle in ("use_pass_iterations", "use_pass_steps", "use_pass_distance"):
        setattr(vl.unbound, toggle, True)
    finished = [bpy.ops.render.render() == {'FINISHED'}]
    before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    for _ in range(renders):
        finished.append(bpy.ops.render.render() == {'FINISHED'})
    faults = (resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before) / renders
    memory = __import__(mod.__name__ + ".frame_memory", fromlist=["keep"])
    wanted = {}
    for name, value in (("default", None), ("UNBOUND_KEEP_FRAME_MEMORY", "0"),
                        ("MALLOC_TRIM_THRESHOLD_", "1000000")):
        saved = {k: os.environ.pop(k, None) for k in ("UNBOUND_KEEP_FRAME_MEMORY", "MALLOC_TRIM_THRESHOLD_")}
        if value is not None:
            os.environ[name] = value
        wanted[name] = memory.wanted()
        for k, v in saved.items():
            os.environ.pop(k, None)
            if v is not None:
                os.environ[k] = v
    S.report(faults=faults, kept=memory.keep(), wanted=wanted, finished=all(finished),
             pages_per_frame=width * height * 4 * 14 / 4096)
