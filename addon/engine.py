"""Final renders: Blender's depsgraph -> export.py's dicts -> the native core -> render passes.

The RenderEngine class (in __init__.py) only forwards its callbacks here."""
import time

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
    """RenderEngine.render: one view layer of one frame."""
    try:
        _render(engine, depsgraph)
    except (RenderError, ImportError, ValueError, TypeError) as exc:
        # ValueError and TypeError: the core's own messages, which name the object and the key.
        message = "Unbound: %s" % exc
        engine.report({'ERROR'}, message)
        engine.error_set(message)


def _render(engine, depsgraph):
    scene = depsgraph.scene
    view_layer = depsgraph.view_layer
    core = utils.native()
    width, height, window = export.image_window(scene)
    camera = export.camera_description(engine, depsgraph, width, height)
    objects = export.fractal_objects(depsgraph)
    shading = export.shading_description(depsgraph)
    wanted = passes.enabled(view_layer)
    w, h = window[2], window[3]
    buffers = {p.native: np.empty((h, w, p.channels), np.float32) for p in wanted}
    # Depth is always rendered: the core's precision check reads it (one float per pixel).
    buffers.setdefault("depth", np.empty((h, w, 1), np.float32))
    frame = scene.frame_current
    label = "Frame %d | %s" % (frame, view_layer.name)
    engine.update_stats("", "Unbound | %s | %d fractal object%s" % (label, len(objects), "" if len(objects) == 1 else "s"))

    def progress(fraction):
        engine.update_progress(fraction)
        return engine.test_break()

    started = time.perf_counter()
    stats = core.render(camera, objects, buffers, window=window, shading=shading, progress=progress,
                        poll_interval=0.02, **export.render_options(scene))
    LAST_STATS.clear()
    LAST_STATS.update(stats)
    # The result covers the window: Blender places it in the full frame (or crops to it).
    result = engine.begin_result(0, 0, w, h, layer=view_layer.name)
    try:
        layer = result.layers[0]
        for p in wanted:
            layer.passes[p.name].rect.foreach_set(buffers[p.native].ravel())
    finally:
        engine.end_result(result, cancel=stats["cancelled"])
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
