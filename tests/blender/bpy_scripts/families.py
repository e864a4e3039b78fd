"""Scripts of test_families_blender.py (run inside bpy by conftest.run_bpy: see bpy_scripts/__init__.py)."""
import os

import bpy
import numpy as np
from mathutils import Vector


def every_kind_renders_every_pass(S, mod, kinds):
    out = {}
    for kind in kinds:
        scene = S.empty_scene(48, 36)
        S.add_camera(scene, location=(-2.6, -4.4, 2.4))
        sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", 'SUN'))
        sun.rotation_euler = Vector((0.5, 0.3, -0.8)).to_track_quat('-Z', 'Y').to_euler()
        scene.collection.objects.link(sun)
        bpy.ops.object.unbound_fractal_add(kind=kind, use_cursor=False)
        ob = bpy.context.object
        ob.unbound.reflectivity = 0.2
        s = scene.unbound
        s.samples, s.shadows, s.ao_strength, s.reflection_depth = 2, 'SOFT', 0.5, 1
        s.fog_density, s.glow_strength, s.use_sea, s.sea_height = 0.02, 0.1, True, -1.2
        vl = scene.view_layers[0]
        for p in mod.passes.PASSES:
            if p.toggle:
                setattr(vl.unbound, p.toggle, True)
        scene.render.film_transparent = True
        exr = S.render_to_exr(scene, kind + ".exr")
        finite = all(bool(np.isfinite(v).all()) for v in exr.values())
        obj = exr["ViewLayer.Iterations.X"] > 0
        n = np.stack([exr["ViewLayer.Normal." + c] for c in "XYZ"], -1)
        out[kind] = dict(finite=finite, coverage=float(obj.mean()),
                         normal_error=float(np.abs(np.linalg.norm(n[obj], axis=-1) - 1).max()),
                         passes=len(exr), display=ob.empty_display_size,
                         channels=sum(p.channels for p in mod.passes.PASSES))
    S.report(out=out)


def kind_parameters_are_keyframeable(S, mod):
    changes = {}
    for kind, path, index, a, b in [("JULIA_STACK", "c_start", 1, 0.0, 0.4),
                                    ("CUBIC_LOCUS", "extent", -1, 2.0, 1.2),
                                    ("QUATERNION_MANDELBROT", "slice_offset", -1, 0.0, 0.6),
                                    ("IFS", "ifs_maps[0].location", 0, 0.5, 0.8),
                                    ("IFS", "ifs_depth", -1, 4, 2)]:
        scene = S.empty_scene(40, 30)
        S.add_camera(scene, location=(-2.6, -4.4, 2.4))
        bpy.ops.object.unbound_fractal_add(kind=kind, use_cursor=False)
        ob = bpy.context.object
        owner, prop = (ob.unbound.ifs_maps[0], "location") if "." in path else (ob.unbound, path)

        def set_value(v):
            if index < 0:
                setattr(owner, prop, v)
            else:
                getattr(owner, prop)[index] = v

        set_value(a)
        ob.keyframe_insert("unbound." + path, index=index, frame=1)
        set_value(b)
        ob.keyframe_insert("unbound." + path, index=index, frame=3)
        scene.view_layers[0].unbound.use_pass_depth = True
        depth = []
        for f in (1, 3, 1):
            scene.frame_set(f)
            depth.append(S.render_to_exr(scene, "k%d.exr" % f)["ViewLayer.Depth.Z"])
        changes[kind + "." + path] = [float(np.mean(depth[0] != depth[1])), bool(np.array_equal(depth[0], depth[2]))]
    S.report(changes=changes)


def curve_path(S, mod):
    scene = S.empty_scene(40, 30)
    S.add_camera(scene, location=(-2.6, -4.4, 2.4))
    bpy.ops.object.unbound_fractal_add(kind='JULIA_STACK', use_cursor=False)
    ob = bpy.context.object
    ob.unbound.c_start, ob.unbound.c_end = (-1.2, 0.1), (0.2, 0.3)
    line = S.render_to_exr(scene, "line.exr")["ViewLayer.Combined.R"]
    curve = bpy.data.curves.new("Path", 'CURVE')
    spline = curve.splines.new('POLY')
    spline.points.add(1)
    spline.points[0].co = (-1.2, 0.1, 0.0, 1.0)
    spline.points[1].co = (0.2, 0.3, 0.0, 1.0)
    path_ob = bpy.data.objects.new("Path", curve)
    scene.collection.objects.link(path_ob)
    ob.unbound.path_mode = 'CURVE'
    ob.unbound.path_curve = path_ob
    poly = S.render_to_exr(scene, "poly.exr")["ViewLayer.Combined.R"]
    dg = bpy.context.evaluated_depsgraph_get()
    from bl_ext.user_default.unbound import export
    bez = bpy.data.curves.new("Bez", 'CURVE')
    bs = bez.splines.new('BEZIER')
    bs.bezier_points.add(1)
    for p, co in zip(bs.bezier_points, [(-1.2, 0.1, 0.0), (0.2, 0.3, 0.0)]):
        p.co = co
        p.handle_left_type = p.handle_right_type = 'AUTO'
    bez_ob = bpy.data.objects.new("Bez", bez)
    scene.collection.objects.link(bez_ob)
    ob.unbound.path_curve = bez_ob
    dg = bpy.context.evaluated_depsgraph_get()
    bez_path = export.c_path(ob.unbound, dg)
    bezier = S.render_to_exr(scene, "bez.exr")["ViewLayer.Combined.R"]
    errors = []
    for target in (None, scene.camera):
        ob.unbound.path_curve = target
        try:
            bpy.ops.render.render()
            errors.append("finished")
        except RuntimeError as exc:
            errors.append(str(exc))
    S.report(same=bool(np.array_equal(line, poly)), coverage=float((line > 0).mean()),
             bez_points=len(bez_path), bez_ends=[bez_path[0], bez_path[-1]],
             bez_differs=bool(not np.array_equal(line, bezier)), errors=errors)


def ifs_map_operators_presets_and_errors(S, mod):
    scene = S.empty_scene(32, 24)
    S.add_camera(scene, location=(-2.6, -4.4, 2.4))
    bpy.ops.object.unbound_fractal_add(kind='IFS', use_cursor=False)
    u = bpy.context.object.unbound

    def evaluated_maps():
        """The maps F12 and the Rendered viewport read: the depsgraph's copy of the object."""
        ob = bpy.context.object
        return len(ob.evaluated_get(bpy.context.evaluated_depsgraph_get()).unbound.ifs_maps)

    counts = [len(u.ifs_maps)]
    evaluated = [evaluated_maps()]
    bpy.ops.object.unbound_ifs_shape(shape='MENGER')
    counts.append(len(u.ifs_maps))
    evaluated.append(evaluated_maps())
    bpy.ops.object.unbound_ifs_map_add()
    counts.append(len(u.ifs_maps))
    evaluated.append(evaluated_maps())
    u.ifs_maps[-1].location = (0.1, 0.2, 0.3)
    u.ifs_maps[-1].scale = (0.2, 0.25, -0.3)
    saved = [tuple(m.location) + tuple(m.rotation) + tuple(m.scale) for m in u.ifs_maps]
    status = bpy.ops.unbound.fractal_preset_add(name="My IFS")
    folder = bpy.utils.preset_paths("unbound/fractal")[-1]
    bpy.ops.object.unbound_fractal_add(kind='IFS', use_cursor=False)
    v = bpy.context.object.unbound
    run = bpy.ops.script.execute_preset(filepath=os.path.join(folder, "My_IFS.py"),
                                        menu_idname="UNBOUND_MT_fractal_presets")
    restored = [tuple(m.location) + tuple(m.rotation) + tuple(m.scale) for m in v.ifs_maps]
    bpy.ops.object.unbound_ifs_map_remove()
    bpy.ops.object.unbound_ifs_shape(shape='KOCH')
    counts.append(len(v.ifs_maps))
    evaluated.append(evaluated_maps())
    while len(v.ifs_maps):
        bpy.ops.object.unbound_ifs_map_remove()
    try:
        bpy.ops.render.render()
        outcome = "finished"
    except RuntimeError as exc:
        outcome = str(exc)
    S.report(counts=counts, evaluated=evaluated, outcome=outcome, saved=saved, restored=restored, ops=sorted(status) + sorted(run))
