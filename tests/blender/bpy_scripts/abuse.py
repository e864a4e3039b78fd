"""Scripts of test_abuse_blender.py (run inside bpy by conftest.run_bpy: see bpy_scripts/__init__.py)."""
import gc
import glob
import math
import os

import addon_utils
import bpy


def every_property_at_and_beyond_its_limits(S, mod):
    scene = S.empty_scene(16, 12)
    S.add_camera(scene)
    ob = S.add_fractal()
    skip = {"ifs_active_map"}  # a list index, not a render parameter
    rows = []
    for owner in (ob.unbound, scene.unbound):
        for p in owner.bl_rna.properties:
            if p.type not in ('FLOAT', 'INT') or p.identifier in skip:
                continue
            name = p.identifier
            saved = getattr(owner, name)
            saved = tuple(saved) if p.array_length else saved
            big = math.inf if p.type == 'FLOAT' else 2 ** 31 - 1
            values = [("hard_min", p.hard_min), ("hard_max", p.hard_max), ("soft_min", p.soft_min),
                      ("soft_max", p.soft_max), ("below", -big), ("above", big)]
            if p.type == 'FLOAT':
                values.append(("nan", math.nan))
            for label, value in values:
                try:
                    setattr(owner, name, [value] * p.array_length if p.array_length else value)
                    stored = getattr(owner, name)
                    stored = list(stored) if p.array_length else [stored]
                except (ValueError, TypeError, OverflowError) as exc:
                    rows.append([name, label, "set refused: %s" % exc, False, None, True])
                    continue
                within = all(p.hard_min <= v <= p.hard_max for v in stored if v == v)
                outcome, written = S.attempt(scene)
                rows.append([name, label, outcome, written, repr(stored[0]), within])
            setattr(owner, name, saved)
    S.report(rows=rows, name=ob.name)


def nan_drivers_and_wild_keyframes_over_an_animation(S, mod):
    scene = S.empty_scene(16, 12)
    S.add_camera(scene)
    ob = S.add_fractal()
    # A Python driver that turns NaN from frame 2 on (Blender substitutes 0 for a NaN driver).
    fc = ob.driver_add("unbound.mu", 1)
    fc.driver.type = 'SCRIPTED'
    fc.driver.expression = "float('nan') if frame >= 2 else 0.8"
    # Keyframes that go wild: huge, NaN, -inf, then sane again; linear extrapolation.
    for frame, value in ((1, 0.0), (2, 1e30), (3, 0.0), (4, 0.0), (5, 0.0), (6, 0.5)):
        ob.unbound.theta = value
        ob.keyframe_insert("unbound.theta", frame=frame)
    curve = S.fcurve(ob, "unbound.theta")
    curve.keyframe_points[2].co[1] = math.nan
    curve.keyframe_points[3].co[1] = -math.inf
    curve.extrapolation = 'LINEAR'
    frames = []
    for f in range(1, 8):
        scene.frame_set(f)
        outcome, written = S.attempt(scene)
        frames.append([f, outcome, written, ob.unbound.theta if ob.unbound.theta == ob.unbound.theta else "nan",
                       ob.unbound.mu[1]])
    # The same range as one animation render: it stops at the first bad frame, with a report.
    scene.frame_start, scene.frame_end = 1, 7
    scene.render.filepath = os.path.join(os.environ["UNBOUND_TEST_TMP"], "anim_")
    try:
        bpy.ops.render.render(animation=True)
        anim = "ok"
    except RuntimeError as exc:
        anim = str(exc).strip()
    files = sorted(n for n in os.listdir(os.environ["UNBOUND_TEST_TMP"]) if n.startswith("anim_"))
    S.report(frames=frames, anim=anim, files=files, name=ob.name)
    S.exit_without_finalizing()  # bpy 4.2's own exit crash after Python drivers (see there)


def camera_and_fractal_deleted_between_frames(S, mod):
    scene = S.empty_scene(16, 12)
    S.add_camera(scene)
    ob = S.add_fractal()
    ob.keyframe_insert("unbound.mu", frame=1)
    steps = []
    scene.frame_set(1)
    steps.append(S.attempt(scene))
    bpy.data.objects.remove(scene.camera)
    scene.frame_set(2)
    steps.append(S.attempt(scene))
    S.add_camera(scene)
    bpy.data.objects.remove(ob)
    scene.frame_set(3)
    steps.append(S.attempt(scene))
    # Deleted from a frame-change handler in the middle of an animation render.
    name = S.add_fractal().name
    scene.render.film_transparent = True

    def delete_fractal(scene, *args):
        if scene.frame_current == 3 and name in bpy.data.objects:
            bpy.data.objects.remove(bpy.data.objects[name])

    bpy.app.handlers.frame_change_pre.append(delete_fractal)
    scene.frame_start, scene.frame_end = 1, 4
    scene.render.filepath = os.path.join(os.environ["UNBOUND_TEST_TMP"], "anim_")
    bpy.ops.render.render(animation=True)
    bpy.app.handlers.frame_change_pre.remove(delete_fractal)
    S.report(steps=steps, fractals=[o.name for o in bpy.data.objects if o.type == 'EMPTY'])


def disable_reenable_and_reload(S, mod):
    scene = S.empty_scene(16, 12)
    S.add_camera(scene)
    ob = S.add_fractal(mu=(-0.4, 0.6, 0.0, 0.0))
    ob.unbound.theta = 0.7
    seen = {}
    seen["first"] = S.attempt(scene)

    # Disabled and enabled again: the object keeps its settings, the render still works.
    addon_utils.disable(S.MODULE, default_set=True)
    addon_utils.enable(S.MODULE, default_set=True)
    seen["reenabled"] = [S.MODULE in bpy.context.preferences.addons, tuple(round(v, 6) for v in ob.unbound.mu),
                         round(ob.unbound.theta, 6)]
    seen["after_reenable"] = S.attempt(scene)

    # Reload Scripts (F3 > Reload Scripts): the add-on re-registers.
    seen["reload"] = sorted(bpy.ops.script.reload())
    seen["after_reload"] = S.attempt(scene)

    S.report(**seen)
    S.exit_without_finalizing()  # bpy 4.2's own exit crash after Reload Scripts (see there)


def native_module_missing(S, mod):
    user = os.environ["BLENDER_USER_RESOURCES"]
    libs = glob.glob(os.path.join(user, "extensions", ".local", "lib", "python*", "site-packages",
                                  "unbound_core", "_native*"))
    for path in libs:
        with open(path, "wb") as f:
            f.write(b"not a shared library")
    addon_utils.enable(S.MODULE, default_set=True)
    seen = dict(libs_damaged=len(libs), enabled=S.MODULE in bpy.context.preferences.addons)
    scene = S.empty_scene(16, 12)
    S.add_camera(scene)
    seen["add"] = sorted(bpy.ops.object.unbound_fractal_add(use_cursor=False))
    scene.frame_set(2)  # depsgraph handlers run
    seen["render"] = S.attempt(scene)
    S.report(**seen)


def thousand_renders_through_blender_with_flat_memory(S, mod):
    scene = S.empty_scene(32, 24)
    S.add_camera(scene)
    ob = S.add_fractal()
    scene.unbound.shadows = 'SOFT'
    scene.unbound.reflection_depth = 1
    scene.view_layers[0].unbound.use_pass_depth = True

    def resident():
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * 4096

    samples = []
    for i in range(1000):
        ob.unbound.theta = 0.001 * i  # a changed parameter each time: a real re-render
        bpy.ops.render.render()
        if i % 100 == 99:
            gc.collect()
            samples.append(resident())
    S.report(samples=samples, rays=mod.engine.LAST_STATS["rays"])


def zoom_beyond_single_precision_warns(S, mod):
    scene = S.empty_scene(32, 24)
    S.add_fractal(mu=(0.0, 0.0, 0.0, 0.0))
    S.add_camera(scene, location=(0.0, -3.0, 0.0), clip_start=1e-6)
    print("FAR_START")
    far = S.attempt(scene)
    print("FAR_END")
    S.add_camera(scene, location=(0.0, -1.0 - 1e-5, 0.0), clip_start=1e-6)
    near = S.attempt(scene)
    S.report(far=far, near=near)
