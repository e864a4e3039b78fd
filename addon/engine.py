"""Final renders: Blender's depsgraph -> export.py's dicts -> the native core -> render passes.

The RenderEngine class (in __init__.py) only forwards its callbacks here."""
import contextlib
import os
import time
import traceback

import bpy
import numpy as np

from . import composite, export, frame_memory, motion_blur, passes, utils
from .export import RenderError

# Counters of the most recent render in this process (rays, steps, iterations, out_of_steps, seconds,
# threads, simd, cancelled, camera_rays), for scripts and tests.
LAST_STATS = {}


def precision_warning(core, stats):
    """A message when a pixel at the nearest hit covers less than the core's PRECISION_LIMIT of the
    largest fractal's bounding radius (the core measures the ratio: stats['footprint_ratio'])."""
    ratio = stats.get("footprint_ratio")
    if ratio is None or ratio >= core.PRECISION_LIMIT:
        return None
    return ("a pixel covers %.1e of the fractal's size here, finer than single precision resolves "
            "(%.0e): expect steps in depth and shading. Zoom out or move the camera back, and fly in "
            "with the fractal's Deep Zoom instead (README: Deep zoom)" % (ratio, core.PRECISION_LIMIT))


# A warning when more than this share of a render's camera rays (every sample, every view) ran out of
# Max Steps: each shows what lies behind it (the background mostly) where the fractal may be. 1e-4 is
# 3 pixels of 200 x 150 and 207 of 1920 x 1080: a few stray rays in a large image are let through.
MAX_STEPS_SHARE = 1e-4


def max_steps_warning(stats, camera_rays):
    """A message when more than MAX_STEPS_SHARE of `camera_rays` ran out of Max Steps before they hit or
    left a fractal (the core counts them: stats['out_of_steps'])."""
    count = stats.get("out_of_steps", 0)
    if camera_rays <= 0 or count <= MAX_STEPS_SHARE * camera_rays:
        return None
    return ("%d of %d camera rays (%.2g%%) ran out of Max Steps before they hit or left the fractal and show "
            "what lies behind it: raise Max Steps or coarsen the threshold (Object Data > Unbound Fractal > "
            "Quality); the Max Steps pass shows where" % (count, camera_rays, 100.0 * count / camera_rays))


def update_render_passes(engine, scene, view_layer):
    for p in passes.enabled(view_layer):
        engine.register_pass(scene, view_layer, p.name, p.channels, p.chan_id, p.kind)


def render(engine, depsgraph):
    """RenderEngine.render: one view layer of one frame (every view of it, with stereo 3D).
    Whatever fails ends here, as an error report and error_set: Blender then writes no file for
    the frame (a failed frame is never saved as rendered) and nothing escapes into Blender."""
    try:
        frame_memory.keep()  # the next frame reuses this one's pages (frame_memory.py)
        _render(engine, depsgraph)
    except (RenderError, ImportError, ValueError, TypeError) as exc:
        # ValueError and TypeError: the core's own messages, which name the object and the key.
        _fail(engine, "Unbound: %s" % exc)
    except MemoryError:
        _fail(engine, "Unbound: out of memory: lower the resolution or turn off passes")
    except Exception as exc:  # noqa: BLE001 - a bug of ours must not save a broken frame either
        traceback.print_exc()
        _fail(engine, "Unbound: internal error (%s: %s); the frame was not rendered" % (type(exc).__name__, exc))


def _fail(engine, message):
    engine.report({'ERROR'}, message)
    engine.error_set(message)


# Bytes per pixel of a final render (issue 16, defect 4): every channel of every pass as float32 in
# Blender's render result and in Blender's copy of it for the compositor and the file writer (each
# one per view). With several samples also the add-on's running sums and the core's hit buffer
# (ub_hit: t, iterations, distance, steps, a 16-bit object and out-of-steps flag) for the whole
# frame; with one sample only a band's (_render_bands: about a sixteenth of the frame, counted as
# an eighth, and a small frame's band as band_rows makes it). All passes, one view: 36 channels,
# 452 bytes per pixel with several samples, 309 with one.
HIT_BYTES = 20


def memory_estimate(width, height, wanted, views=1, samples=1, tile_size=32):
    """(bytes, bytes per pixel) that a render of width x height pixels with passes `wanted` needs."""
    channels = sum(p.channels for p in wanted) + (0 if any(p.native == "depth" for p in wanted) else 1)
    working = 4 * channels + HIT_BYTES   # the add-on's buffers and the core's hit buffer
    per_pixel = 4 * channels * 2 * views + (working if samples > 1 else -(-working // 8))
    needed = per_pixel * width * height
    if samples == 1:  # a small frame's band is more than an eighth of it (band_rows)
        needed += working * max(0, band_rows(width, height, tile_size) * width - width * height // 8)
    return needed, per_pixel


def memory_available():
    """Bytes this process may still allocate: UNBOUND_MEMORY_LIMIT (bytes) when set (tests, farms),
    else the kernel's MemAvailable (else the free physical memory), and no more than the address
    space left under RLIMIT_AS; None if unknown."""
    override = os.environ.get("UNBOUND_MEMORY_LIMIT")
    if override:
        return int(float(override))
    available = None
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    available = int(line.split()[1]) * 1024
    except OSError:
        try:
            available = os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
        except (AttributeError, ValueError, OSError):
            pass
    # An address-space limit (ulimit -v, a farm's cap) binds before the machine's memory does.
    try:
        import resource
        limit = resource.getrlimit(resource.RLIMIT_AS)[0]
        if limit != resource.RLIM_INFINITY:
            with open("/proc/self/status") as f:
                used = next(int(line.split()[1]) * 1024 for line in f if line.startswith("VmSize:"))
            available = max(limit - used, 0) if available is None else min(available, max(limit - used, 0))
    except (ImportError, OSError, ValueError, StopIteration):
        pass
    return available


# The last reading of memory_available(): (perf_counter seconds, bytes). Reading /proc/meminfo each
# frame cost an animation of quick frames 0.15 ms a frame (issue 21), so a reading is used again for
# READING_SECONDS by renders that need at most READING_SHARE of it; a larger render reads afresh.
READING_SECONDS = 1.0
READING_SHARE = 0.25
_last_reading = [None, None]


def memory_preflight(width, height, wanted, views=1, samples=1, tile_size=32):
    """A RenderError before anything is allocated when the render cannot fit in memory: the figure,
    and what to turn off."""
    needed, per_pixel = memory_estimate(width, height, wanted, views, samples, tile_size)
    at, available = _last_reading
    now = time.perf_counter()
    if available is not None and now - at < READING_SECONDS and needed <= READING_SHARE * available \
            and not os.environ.get("UNBOUND_MEMORY_LIMIT"):
        return
    available = memory_available()
    _last_reading[:] = [now, available]
    if available is None or needed <= available:
        return
    optional = sorted((p for p in wanted if p.toggle), key=lambda p: -p.channels)
    advice = "lower the resolution (or its percentage) or render a border"
    if optional:
        advice += ", or turn off passes (%s)" % ", ".join(p.name for p in optional)
    raise RenderError("this render needs about %.1f GB of memory (%d x %d pixels%s at %d bytes each, %d "
                      "pass%s) but about %.1f GB is available: %s" % (
                          needed / 1e9, width, height, " x %d views" % views if views > 1 else "", per_pixel,
                          len(wanted), "" if len(wanted) == 1 else "es", available / 1e9, advice))


# A render of several samples shows each sample in the Image Editor as it finishes
# (RenderEngine.update_result, Blender copying the result for display), as long as those uploads
# take at most this share of the render's time so far: a 1080p render whose samples take longer
# than a few tenths of a second shows every one, and a quick small one is never slowed by them.
UPDATE_SHARE = 0.05
# Blender without a window (blender --background, a farm, the bpy module) shows no image while it
# renders, so there the uploads are skipped, as Cycles skips its display updates in the background;
# True uploads there too (the tests of the uploads, which run in the bpy module).
UPDATE_IN_BACKGROUND = False
# The stats line is refreshed at most this often while a sample renders (seconds).
STATS_INTERVAL = 0.25


def clock(seconds):
    """Seconds as Blender and Cycles print them in the stats line: 00:01.23, 1:02:03.45."""
    minutes, rest = divmod(max(float(seconds), 0.0), 60.0)
    hours, minutes = divmod(int(minutes), 60)
    return "%d:%02d:%05.2f" % (hours, minutes, rest) if hours else "%02d:%05.2f" % (minutes, rest)


class Progress:
    """The progress bar and the stats line of a render of `views` views of `samples` samples:
    Sample k/N, and the time remaining, extrapolated from the fraction done as Cycles does."""

    def __init__(self, engine, label, views, samples):
        self.engine, self.label, self.views, self.samples = engine, label, views, samples
        self.started = time.perf_counter()
        self.shown = -1.0

    def update(self, view, sample, fraction, force=False):
        """`fraction` of sample `sample` (from 0) of view `view` done; True when the user cancelled."""
        done = (view + (sample + fraction) / self.samples) / self.views
        self.engine.update_progress(done)
        now = time.perf_counter()
        if force or now - self.shown >= STATS_INTERVAL:
            self.shown = now
            elapsed = now - self.started
            text = "Unbound | %s | Sample %d/%d" % (self.label, min(sample + 1, self.samples), self.samples)
            if self.views > 1:
                text += " | View %d/%d" % (view + 1, self.views)
            if done > 0.0 and elapsed > 0.0:
                text += " | Remaining %s" % clock(elapsed * (1.0 - done) / done)
            self.engine.update_stats("", text)
        return self.engine.test_break()


def normalised(buffer, native, samples_done):
    """A pass of the running sum as the mean of the samples done: exactly what a render of that
    many samples holds (its last sample multiplies the sum by the float32 1 / count, kernel.h)."""
    if samples_done <= 1 or native in passes.SAMPLE_ZERO:  # (0: a first sample cut short)
        return buffer
    return buffer * (np.float32(1.0) / np.float32(samples_done))


def result_passes(result, layer_name):
    """(layer, view names, passes) of the view layer `layer_name` in a RenderResult (a band holds
    only that layer, Blender's result of the frame every one): exactly the passes it holds
    (registered when the render started; a handler may have toggled one since), in the table's
    order."""
    layer = result.layers[layer_name]
    names = {p.name for p in layer.passes}
    return layer, [v.name for v in result.views] or [""], [p for p in passes.PASSES if p.name in names]


def write_pass(layer, render_pass, view, values):
    found = layer.passes.find_by_name(render_pass.name, view)
    if found is None:
        raise RenderError("Blender's result has no pass %s for view '%s'" % (render_pass.name, view))
    found.rect.foreach_set(values.ravel())


# Every band costs the same whatever its size: Blender's begin_result/end_result merge, one
# foreach_set per pass and the core's per-call setup (about 0.16 ms of CPU a band, measured with
# bench_f12.py --animation at 640x360: 16 bands 1.27x the bare core's CPU, 2 bands 1.15x). So a band
# is a sixteenth of the window (progress to watch, an eighth's memory) but no fewer pixels than this:
# a window of fewer than twice as many is one band (a 640x360 frame: 2 bands cost an animation about
# 1 ms of CPU a frame more than one, bench/README.md).
BAND_MIN_PIXELS = 1 << 17


# Without a window (blender --background, a farm, the bpy module) Blender shows no band and no
# sample as it finishes, so there a window rendered as one band, or as one result of several
# samples, is written straight into Blender's own result of the frame (frame_result), not into a
# band result: Blender allocates and zeroes a band's passes in begin_result and copies them into its
# own in end_result, a third of the CPU an F12 of a small frame spends beyond the core (issue 21:
# the 48-frame 640x360 animation of bench_f12.py --animation, 1.31x -> 1.20x the bare core's CPU,
# both ways alternated in one run), and with several samples a full copy of the passes in memory.
# False: always through bands.
DIRECT_IN_BACKGROUND = True


def direct_in_background(engine):
    """Whether this render writes straight into Blender's result (DIRECT_IN_BACKGROUND)."""
    return DIRECT_IN_BACKGROUND and bpy.app.background and not engine.is_preview


def frame_result(engine, layer_name):
    """Blender's own result of the frame (get_result: every view layer and view), its passes
    allocated: Blender allocates them at a render's first update_result (unconditionally, in 4.2
    as in 5.2), here of a one-pixel band, which end_result(cancel=True) then discards."""
    pixel = engine.begin_result(0, 0, 1, 1, layer=layer_name)
    try:
        engine.update_result(pixel)
    finally:
        engine.end_result(pixel, cancel=True)
    return engine.get_result()


@contextlib.contextmanager
def render_result(engine, layer_name, rect, direct):
    """The RenderResult a render writes its passes into: Blender's own result of the frame when
    `direct` (frame_result), else a band of it at rect = (x, y, w, h) (begin_result), which leaving
    the block ends: merged when the block finished (a cancel too: what was rendered is kept),
    discarded when it raised, so that a failed frame is never shown or saved as rendered (straight
    into Blender's result, render()'s error_set alone sees to that)."""
    if direct:
        yield frame_result(engine, layer_name)
        return
    result = engine.begin_result(*rect, layer=layer_name)
    keep = False
    try:
        yield result
        keep = True
    finally:
        engine.end_result(result, cancel=not keep)


def band_rows(width, height, tile_size):
    """Rows of one band of a one-sample render: the window cut into as many bands of at least
    BAND_MIN_PIXELS pixels as it holds, at most 16, in whole tiles (so the threads share each band's
    tiles), at least one tile."""
    bands = min(max(width * height // BAND_MIN_PIXELS, 1), 16)
    rows = -(-height // bands)
    rows = -(-rows // tile_size) * tile_size
    return max(min(rows, height), 1)


class BandBuffers:
    """The add-on's buffers of one band, kept from one render to the next (issue 21): an animation's
    frames have the same bands, and fresh arrays cost their allocation each frame. At most one
    band's worth is held between renders (what the render needed anyway); a render of another
    band size or other passes replaces it. F12 renders run one at a time (Blender's render job)."""

    _kept = {}

    @classmethod
    def get(cls, wanted, rows, width):
        """{native pass name: float32 (rows, width, channels)} for `wanted` ({name: channels});
        contents undefined: the core writes every pixel (clear_unfinished on a cancel)."""
        buffers = {}
        for name, channels in wanted.items():
            kept = cls._kept.get(name)
            buffers[name] = kept if kept is not None and kept.shape == (rows, width, channels) else \
                utils.native().pass_array(rows, width, channels)
        cls._kept.clear()
        cls._kept.update(buffers)
        return buffers


def _render_bands(engine, depsgraph, core, image, objects, shading, window, label):
    """One sample, rendered band by band straight into Blender's result (begin_result and
    end_result per band, as Cycles' tiles): Blender holds the one full copy of the passes, the
    add-on only a band's, and each band appears in the Image Editor as it finishes. A cancel keeps
    the bands done and the tiles done of the band in flight; a failure discards the band in flight
    and reports (render() above: error_set, so no file is written). `image`: the full image's
    width and height and the camera of the current view. Returns (stats, cancelled)."""
    scene = depsgraph.scene
    width, height, camera = image
    x0, y0, w, h = window
    # clear_unfinished: what a cancel does not reach is transparent black, without a fill beforehand.
    options = dict(shading=shading, poll_interval=0.02, clear_unfinished=True, **export.render_options(scene))
    rows = band_rows(w, h, options["tile_size"])
    bands = -(-h // rows)
    layer_name = depsgraph.view_layer.name
    direct = bands == 1 and direct_in_background(engine)
    progress = Progress(engine, label, 1, 1)
    cameras = {}
    buffers = None
    totals = dict(rays=0, steps=0, iterations=0, out_of_steps=0, seconds=0.0)
    camera_rays = 0  # of the result's pixels, every view rendered
    stats, ratio, cancelled = None, None, False
    for band, top in enumerate(range(0, h, rows)):
        bh = min(rows, h - top)
        with render_result(engine, layer_name, (0, top, w, bh), direct) as result:
            layer, views, present = result_passes(result, layer_name)
            if buffers is None:
                # Depth is always rendered: the core's precision check reads it.
                wanted = dict([("depth", 1)] + [(p.native, p.channels) for p in present])
                buffers = BandBuffers.get(wanted, rows, w)
            band_buffers = {n: b[:bh] for n, b in buffers.items()}
            for index, view in enumerate(views):
                if view not in cameras:
                    if len(views) > 1:
                        engine.active_view_set(view)
                    cameras[view] = camera if len(views) == 1 else \
                        export.camera_description(engine, depsgraph, width, height)
                def poll(fraction, band=band, index=index):
                    return progress.update(0, 0, (band + (index + fraction) / len(views)) / bands)

                stats = core.render(cameras[view], objects, band_buffers, progress=poll,
                                    window=(x0, y0 + top, w, bh), **options)
                for key in totals:
                    totals[key] += stats[key]
                if stats.get("footprint_ratio") is not None:
                    ratio = stats["footprint_ratio"] if ratio is None else min(ratio, stats["footprint_ratio"])
                for p in present:
                    write_pass(layer, p, view, band_buffers[p.native])
                if stats["cancelled"]:
                    cancelled = True
                    break
                camera_rays += w * bh
        # Esc between bands too: a band can end before the core's first poll.
        if cancelled or (top + bh < h and progress.update(0, 0, (band + 1) / bands, force=True)):
            cancelled = True
            break
    stats = dict(stats, cancelled=cancelled, samples_done=0 if cancelled else 1, camera_rays=camera_rays, **totals)
    if ratio is not None:
        stats["footprint_ratio"] = ratio
    LAST_STATS.clear()
    LAST_STATS.update(stats)
    return stats, cancelled


def _render(engine, depsgraph):
    scene = depsgraph.scene
    # Motion blur: each sample at its own time within the shutter (motion_blur.py); the scene is
    # evaluated there and back at the frame's own time afterwards, whatever happened in between.
    times = None
    if motion_blur.blur_enabled(scene, depsgraph.view_layer):
        times = motion_blur.sample_times(scene, max(int(scene.unbound.samples), 1))
    frame, subframe = scene.frame_current, scene.frame_subframe
    try:
        _render_frame(engine, depsgraph, times)
    finally:
        if times is not None:
            engine.frame_set(frame, subframe)


def scene_at(engine, depsgraph, when, width, height, samples):
    """(camera, fractal objects, shading) of the scene evaluated at scene time `when`: one motion-
    blurred sample's, through the same export as the frame's own. The sample count stays the
    frame's (the core divides the sum by it), should it be keyframed too."""
    motion_blur.set_time(engine, when)
    shading = export.shading_description(depsgraph)
    shading["samples"] = samples
    return export.camera_description(engine, depsgraph, width, height), export.fractal_objects(depsgraph), shading


def _render_frame(engine, depsgraph, times):
    """One frame; `times`: each sample's scene time with motion blur, else None."""
    scene = depsgraph.scene
    view_layer = depsgraph.view_layer
    core = utils.native()
    width, height, window = export.image_window(scene)
    frame = scene.frame_current  # the frame's own, before a one-sample render moves to the shutter's middle
    blur_seconds = 0.0  # evaluating and exporting the scene at the samples' times
    if times is not None and len(times) == 1:
        # One sample has one time: the shutter's median (a blurred render's first sample), unblurred.
        engine.report({'WARNING'}, "Unbound: motion blur needs 2 or more samples (Render Properties > Unbound > "
                                   "Samples); this frame was rendered unblurred at the shutter's middle")
        if times[0] != scene.frame_current + scene.frame_subframe:
            motion_blur.set_time(engine, times[0])
    objects = export.fractal_objects(depsgraph)
    shading = export.shading_description(depsgraph)
    camera = export.camera_description(engine, depsgraph, width, height)  # checks the camera first
    wanted = passes.enabled(view_layer)
    w, h = window[2], window[3]
    views = [v.name for v in scene.render.views if v.use] if scene.render.use_multiview else [""]
    samples = int(shading.get("samples", 1))
    memory_preflight(w, h, wanted, max(len(views), 1), samples, scene.unbound.tile_size)
    label = "Frame %d | %s" % (frame, view_layer.name)
    engine.update_stats("", "Unbound | %s | %d fractal object%s" % (label, len(objects), "" if len(objects) == 1 else "s"))
    # Never silent: meshes and other objects only Cycles renders are named once per render.
    unrendered = composite.unrendered_warning(depsgraph)
    if unrendered:
        engine.report({'WARNING'}, "Unbound: " + unrendered)
    unevaluated = export.material_warnings(depsgraph)
    if unevaluated:
        engine.report({'WARNING'}, "Unbound: " + unevaluated)
    if samples == 1:
        started = time.perf_counter()
        stats, cancelled = _render_bands(engine, depsgraph, core, (width, height, camera), objects, shading, window,
                                         label)
        _finish(engine, core, label, stats, cancelled, stats["samples_done"], 1, time.perf_counter() - started)
        return
    # The result covers the window: Blender places it in the full frame (or crops to it). It holds
    # the passes registered when the render started; a handler may have toggled one since (an
    # animation's frame_change_pre): exactly the result's passes are rendered and written.
    shows_samples = UPDATE_IN_BACKGROUND or not bpy.app.background
    direct = not shows_samples and direct_in_background(engine)
    # A failure discards the result (render_result): a failed frame is never shown or saved as
    # rendered. A cancel (Esc) keeps what was rendered, as Cycles does: the samples done, and of a
    # first sample cut short the tiles done (the others transparent black).
    with render_result(engine, view_layer.name, (0, 0, w, h), direct) as result:
        layer, views, present = result_passes(result, view_layer.name)
        # Zeros: what a cancelled first sample did not reach stays transparent black.
        buffers = {p.native: core.pass_array(h, w, p.channels, zero=True) for p in present}
        # Depth is always rendered: the core's precision check reads it (one float per pixel).
        buffers.setdefault("depth", core.pass_array(h, w, 1, zero=True))
        # The sum of the samples done, kept while the next one is added (a cancel mid-sample leaves
        # the buffers half summed): only the averaged passes, only with several samples.
        summed = [n for n in buffers if n not in passes.SAMPLE_ZERO] if samples > 1 else []
        backup = {n: np.empty_like(buffers[n]) for n in summed}
        progress = Progress(engine, label, len(views), samples)
        totals = dict(rays=0, steps=0, iterations=0, out_of_steps=0, seconds=0.0)
        camera_rays = 0  # of the result's pixels, every sample and view rendered
        # A sample a call: the shared first steps are marched by the first and kept for the others
        # (the core marches them again where the camera or the objects move, with motion blur).
        options = dict(window=window, shading=shading, poll_interval=0.02,
                       shared_steps_cache=core.shared_steps_cache(), **export.render_options(scene))
        started = time.perf_counter()
        uploading = 0.0
        stats = None
        cancelled = False

        def write(view, done):
            for p in present:
                # After the last sample the buffers hold the mean already (the core divided).
                write_pass(layer, p, view,
                           buffers[p.native] if done == samples else normalised(buffers[p.native], p.native, done))

        for index, view in enumerate(views):
            if len(views) > 1:
                # Stereo 3D / multiview: each view through its own camera (its eye's matrix and
                # shift), as Cycles renders them.
                engine.active_view_set(view)
                camera = export.camera_description(engine, depsgraph, width, height)
                if index:
                    for b in buffers.values():
                        b.fill(0.0)
            done = 0
            for sample in range(samples):
                if sample:
                    for n in summed:
                        np.copyto(backup[n], buffers[n])
                if times is not None:
                    t0 = time.perf_counter()
                    camera, objects, options["shading"] = scene_at(engine, depsgraph, times[sample], width, height,
                                                                   samples)
                    blur_seconds += time.perf_counter() - t0

                def poll(fraction, index=index, sample=sample):
                    return progress.update(index, sample, fraction)

                stats = core.render(camera, objects, buffers, progress=poll,
                                    sample_range=(sample, 1) if samples > 1 else None, **options)
                for key in totals:
                    totals[key] += stats[key]
                if stats["cancelled"]:
                    cancelled = True
                    # Back to the samples done (a first sample cut short stays as far as it got).
                    for n in summed if sample else ():
                        np.copyto(buffers[n], backup[n])
                    break
                done = sample + 1
                camera_rays += w * h
                # Esc between samples too: a quick sample can end before the core's first poll.
                if progress.update(index, sample + 1 if done < samples else sample, 0.0 if done < samples else 1.0,
                                   force=True) and done < samples:
                    cancelled = True  # the samples done are whole: kept
                    break
                if done < samples and shows_samples and uploading <= UPDATE_SHARE * (time.perf_counter() - started):
                    # The Image Editor shows the samples done while the next ones render.
                    t0 = time.perf_counter()
                    write(view, done)
                    engine.update_result(result)
                    uploading += time.perf_counter() - t0
            write(view, done)
            if cancelled:
                break
        stats = dict(stats, cancelled=cancelled, samples_done=done, camera_rays=camera_rays,
                     motion_blur_seconds=blur_seconds, **totals)
        LAST_STATS.clear()
        LAST_STATS.update(stats)
    _finish(engine, core, label, stats, cancelled, done, samples, time.perf_counter() - started)


def _finish(engine, core, label, stats, cancelled, done, samples, elapsed):
    """The stats line, the progress bar and the precision warning after a render."""
    if cancelled:
        engine.update_stats("", "Unbound | %s | cancelled after %d of %d samples (kept)" % (label, done, samples))
        return
    for warning in (precision_warning(core, stats), max_steps_warning(stats, stats["camera_rays"])):
        if warning:
            engine.report({'WARNING'}, "Unbound: " + warning)
    engine.update_progress(1.0)
    engine.update_stats("", "Unbound | %s | %s | %d sample%s | %.1f Mrays/s | %s, %d threads" % (
        label, clock(elapsed), samples, "" if samples == 1 else "s",
        stats["rays"] / max(stats["seconds"], 1e-9) / 1e6, stats["simd"], stats["threads"]))
