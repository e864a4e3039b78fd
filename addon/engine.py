"""Final renders: Blender's depsgraph -> export.py's dicts -> the native core -> render passes.

The RenderEngine class (in __init__.py) only forwards its callbacks here."""
import os
import time
import traceback

import numpy as np

from . import export, passes, utils
from .export import RenderError

# Counters of the most recent render in this process (rays, steps, iterations, seconds, threads,
# simd, cancelled), for scripts and tests.
LAST_STATS = {}


def precision_warning(core, stats):
    """A message when a pixel at the nearest hit covers less than the core's PRECISION_LIMIT of the
    largest fractal's bounding radius (the core measures the ratio: stats['footprint_ratio'])."""
    ratio = stats.get("footprint_ratio")
    if ratio is None or ratio >= core.PRECISION_LIMIT:
        return None
    return ("a pixel covers %.1e of the fractal's size here, finer than single precision resolves "
            "(%.0e): expect steps in depth and shading. Zoom out or move the camera back "
            "(README: Precision)" % (ratio, core.PRECISION_LIMIT))


def update_render_passes(engine, scene, view_layer):
    for p in passes.enabled(view_layer):
        engine.register_pass(scene, view_layer, p.name, p.channels, p.chan_id, p.kind)


def render(engine, depsgraph):
    """RenderEngine.render: one view layer of one frame (every view of it, with stereo 3D).
    Whatever fails ends here, as an error report and error_set: Blender then writes no file for
    the frame (a failed frame is never saved as rendered) and nothing escapes into Blender."""
    try:
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
# the add-on's buffers, in Blender's render result (one per view) and in Blender's copy of it for
# the compositor and the file writer (one per view); and the core's hit buffer (ub_hit: t,
# iterations, distance, steps, object). All passes, one view: 29 channels, 368 bytes per pixel.
HIT_BYTES = 20


def memory_estimate(width, height, wanted, views=1):
    """(bytes, bytes per pixel) that a render of width x height pixels with passes `wanted` needs."""
    channels = sum(p.channels for p in wanted) + (0 if any(p.native == "depth" for p in wanted) else 1)
    per_pixel = 4 * channels * (1 + 2 * views) + HIT_BYTES
    return per_pixel * width * height, per_pixel


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


def memory_preflight(width, height, wanted, views=1):
    """A RenderError before anything is allocated when the render cannot fit in memory: the figure,
    and what to turn off."""
    needed, per_pixel = memory_estimate(width, height, wanted, views)
    available = memory_available()
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


def _render(engine, depsgraph):
    scene = depsgraph.scene
    view_layer = depsgraph.view_layer
    core = utils.native()
    width, height, window = export.image_window(scene)
    objects = export.fractal_objects(depsgraph)
    shading = export.shading_description(depsgraph)
    camera = export.camera_description(engine, depsgraph, width, height)  # checks the camera first
    wanted = passes.enabled(view_layer)
    w, h = window[2], window[3]
    views = [v.name for v in scene.render.views if v.use] if scene.render.use_multiview else [""]
    memory_preflight(w, h, wanted, max(len(views), 1))
    frame = scene.frame_current
    label = "Frame %d | %s" % (frame, view_layer.name)
    engine.update_stats("", "Unbound | %s | %d fractal object%s" % (label, len(objects), "" if len(objects) == 1 else "s"))
    # The result covers the window: Blender places it in the full frame (or crops to it). It holds
    # the passes registered when the render started; a handler may have toggled one since (an
    # animation's frame_change_pre): exactly the result's passes are rendered and written.
    result = engine.begin_result(0, 0, w, h, layer=view_layer.name)
    cancelled = True
    try:
        layer = result.layers[0]
        views = [v.name for v in result.views] or [""]
        names = {p.name for p in layer.passes}
        present = [p for p in passes.PASSES if p.name in names]
        buffers = {p.native: np.empty((h, w, p.channels), np.float32) for p in present}
        # Depth is always rendered: the core's precision check reads it (one float per pixel).
        buffers.setdefault("depth", np.empty((h, w, 1), np.float32))
        started = time.perf_counter()
        stats = None
        for index, view in enumerate(views):
            if len(views) > 1:
                # Stereo 3D / multiview: each view through its own camera (its eye's matrix and
                # shift), as Cycles renders them.
                engine.active_view_set(view)
                camera = export.camera_description(engine, depsgraph, width, height)

            def progress(fraction, index=index):
                engine.update_progress((index + fraction) / len(views))
                return engine.test_break()

            stats = core.render(camera, objects, buffers, window=window, shading=shading, progress=progress,
                                poll_interval=0.02, **export.render_options(scene))
            LAST_STATS.clear()
            LAST_STATS.update(stats)
            if stats["cancelled"]:
                break
            for p in present:
                found = layer.passes.find_by_name(p.name, view)
                if found is None:
                    raise RenderError("Blender's result has no pass %s for view '%s'" % (p.name, view))
                found.rect.foreach_set(buffers[p.native].ravel())
        cancelled = stats["cancelled"]
    finally:
        engine.end_result(result, cancel=cancelled)
    if stats["cancelled"]:
        engine.update_stats("", "Unbound | %s | cancelled" % label)
        return
    warning = precision_warning(core, stats)
    if warning:
        engine.report({'WARNING'}, "Unbound: " + warning)
    elapsed = time.perf_counter() - started
    engine.update_progress(1.0)
    engine.update_stats("", "Unbound | %s | %.2f s | %.1f Mrays/s | %s, %d threads" % (
        label, elapsed, stats["rays"] / max(stats["seconds"], 1e-9) / 1e6, stats["simd"], stats["threads"]))
