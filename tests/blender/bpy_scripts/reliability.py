"""Scripts of test_reliability_blender.py (issue 16): failures end as a report with no file written,
the memory pre-flight, passes toggled during an animation, stereo 3D, Set Up Compositing."""
import os
import pathlib

import bpy
import numpy as np


def failures_write_no_file(S, mod):
    """Any exception inside the engine: an error report, no traceback escaping, no file."""
    scene = S.empty_scene(32, 24)
    S.add_camera(scene)
    S.add_fractal()
    outcomes = {}
    original = mod.export.fractal_objects
    for name, exc in [("key", KeyError("boom")), ("memory", MemoryError()), ("runtime", RuntimeError("bug"))]:
        def failing(depsgraph, exc=exc):
            raise exc
        mod.export.fractal_objects = failing
        outcomes[name] = S.attempt(scene, name + ".png")
    mod.export.fractal_objects = original
    outcomes["ok"] = S.attempt(scene, "ok.png")
    S.report(outcomes=outcomes)


def memory_preflight(S, mod, limit_gb=None):
    """65536 x 65536 with every pass: refused before anything is allocated, with the figure and the
    passes to turn off; the engine's estimate of a small render; a small render still works. With
    limit_gb, the address space is capped (ulimit -v) instead of UNBOUND_MEMORY_LIMIT."""
    if limit_gb:
        import resource
        with open("/proc/self/status") as f:
            used = next(int(line.split()[1]) * 1024 for line in f if line.startswith("VmSize:"))
        cap = used + int(limit_gb * 1e9)
        resource.setrlimit(resource.RLIMIT_AS, (cap, cap))
    scene = S.empty_scene(65536, 65536)
    S.add_camera(scene)
    S.add_fractal()
    vl = scene.view_layers[0]
    for p in mod.passes.PASSES:
        if p.toggle:
            setattr(vl.unbound, p.toggle, True)
    big = S.attempt(scene, "big.png")
    needed, per_pixel = mod.engine.memory_estimate(1920, 1080, mod.passes.enabled(vl))
    _, per_pixel_samples = mod.engine.memory_estimate(1920, 1080, mod.passes.enabled(vl), samples=8)
    scene.render.resolution_x, scene.render.resolution_y = 32, 24
    small = S.attempt(scene, "small.png")
    # At once after the small render (whose memory reading a quick next frame may use again): the
    # big one still reads afresh and is refused (engine.READING_SHARE).
    scene.render.resolution_x, scene.render.resolution_y = 65536, 65536
    again = S.attempt(scene, "again.png")
    S.report(big=big, small=small, again=again, per_pixel=per_pixel, needed=needed,
             per_pixel_samples=per_pixel_samples)


def passes_toggled_during_animation(S, mod):
    """A frame_change_pre handler toggles Normal and Glow every frame of an animation: every EXR
    holds the result's passes, each with its rendered values (no KeyError, no all-zero layer)."""
    scene = S.empty_scene(40, 30)
    S.add_camera(scene)
    S.add_fractal()
    scene.unbound.glow_strength = 0.8
    vl = scene.view_layers[0]

    def toggle(scene, *args):
        on = scene.frame_current % 2 == 0
        vl.unbound.use_pass_normal = on
        vl.unbound.use_pass_glow = not on

    bpy.app.handlers.frame_change_pre.append(toggle)
    S.exr_output(scene)
    out = pathlib.Path(os.environ["UNBOUND_TEST_TMP"]) / "anim"
    scene.render.filepath = str(out) + "/f_####"
    scene.frame_start, scene.frame_end = 1, 4
    try:
        bpy.ops.render.render(animation=True)
        error = None
    except RuntimeError as exc:
        error = str(exc)
    frames = {}
    for path in sorted(out.glob("*.exr")):
        exr = S.read_exr(path)
        layers = {}
        for name in ("Normal", "Glow"):
            chans = [k for k in exr if ".%s." % name in k]
            if chans:
                layers[name] = bool(any(np.abs(exr[k]).max() > 0 for k in chans))
        frames[path.name] = layers
    bpy.app.handlers.frame_change_pre.remove(toggle)
    S.report(error=error, frames=frames)
    S.exit_without_finalizing()  # bpy 4.2 may crash at exit after a Python handler ran


def stereo_views_equal_mono_renders(S, mod, mode="PARALLEL"):
    """Stereo 3D (multiview): each eye's image equals a mono render through a camera placed at that
    eye (translated by half the interocular distance; off-axis: shifted as Blender shifts it)."""
    from mathutils import Matrix
    scene = S.empty_scene(48, 36)
    cam = S.add_camera(scene, location=(0.3, -2.8, 0.6))
    S.add_fractal()
    stereo = cam.data.stereo
    stereo.convergence_mode = mode
    stereo.pivot = 'CENTER'  # the eyes at -/+ half the interocular distance (Blender's default: LEFT)
    stereo.interocular_distance = 0.4
    stereo.convergence_distance = 3.0
    scene.render.use_multiview = True
    scene.render.views_format = 'STEREO_3D'
    S.exr_output(scene)
    scene.render.image_settings.views_format = 'MULTIVIEW'
    exr = S.render_to_exr(scene, "stereo.exr")
    names = sorted(k for k in exr if "Combined" in k)
    views = {}
    for view in ("left", "right"):
        chans = {k.rsplit(".", 1)[-1]: exr[k] for k in names if view in k.split(".")}
        views[view] = np.stack([chans[c] for c in "RGBA"], -1) if set("RGBA") <= set(chans) else None
    # Mono references, one per eye.
    scene.render.use_multiview = False
    base = cam.matrix_world.copy()
    shift0, lens, sensor = cam.data.shift_x, cam.data.lens, cam.data.sensor_width
    result = dict(channels=names)
    for view, sign in (("left", -1.0), ("right", 1.0)):
        cam.matrix_world = base @ Matrix.Translation((sign * stereo.interocular_distance / 2, 0.0, 0.0))
        cam.data.shift_x = shift0
        if mode == "OFFAXIS":
            cam.data.shift_x = shift0 - sign * 0.5 * (stereo.interocular_distance / sensor) * (
                lens / stereo.convergence_distance)
        mono = S.render_to_exr(scene, "mono_%s.exr" % view)
        ref = np.stack([mono["ViewLayer.Combined.%s" % c] for c in "RGBA"], -1)
        got = views[view]
        diff = np.abs(got - ref).max(-1) if got is not None and got.shape == ref.shape else None
        result[view] = dict(max_diff=None if diff is None else float(diff.max()),
                            differing=None if diff is None else float((diff > 1e-4).mean()),
                            coverage=float((ref[..., 3] > 0).mean()),
                            got_coverage=None if got is None else float((got[..., 3] > 0).mean()))
        result[view]["vs_other"] = {v: None if g is None else float((np.abs(g - ref).max(-1) > 1e-4).mean())
                                    for v, g in views.items()}
        cam.matrix_world = base
    cam.data.shift_x = shift0
    centre = S.render_to_exr(scene, "mono_centre.exr")
    ref = np.stack([centre["ViewLayer.Combined.%s" % c] for c in "RGBA"], -1)
    result["centre_vs"] = {v: None if g is None else float((np.abs(g - ref).max(-1) > 1e-4).mean())
                           for v, g in views.items()}
    lv, rv = views["left"], views["right"]
    result["eyes_differ"] = bool(lv is not None and rv is not None and np.abs(lv - rv).max() > 1e-3)
    S.report(**result)


def setup_compositing_keeps_user_nodes(S, mod):
    scene = S.empty_scene(32, 24)
    S.add_camera(scene)
    S.add_fractal()
    vl = scene.view_layers[0]
    vl.unbound.use_pass_depth = True
    tree = mod.utils.compositor_tree(scene, create=True)
    blur = tree.nodes.new("CompositorNodeBlur")
    blur.name = "My Blur"
    rgb = tree.nodes.new("CompositorNodeRGB")
    rgb.name = "My Colour"
    tree.links.new(rgb.outputs[0], blur.inputs[0])
    out = os.path.join(os.environ["UNBOUND_TEST_TMP"], "comp") + "/"
    bpy.ops.scene.unbound_setup_compositing(directory=out)
    bpy.ops.scene.unbound_setup_compositing(directory=out)  # a second run replaces only its own nodes
    names = sorted(n.name for n in tree.nodes)
    links = sorted("%s>%s" % (l.from_node.name, l.to_node.name) for l in tree.links)
    scene.render.filepath = os.path.join(os.environ["UNBOUND_TEST_TMP"], "still.png")
    bpy.ops.render.render(write_still=True)
    S.report(names=names, links=links, files=sorted(os.listdir(out)))
