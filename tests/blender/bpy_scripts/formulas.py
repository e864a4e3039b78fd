"""Scripts of test_formulas_blender.py (run inside bpy by conftest.run_bpy: see bpy_scripts/__init__.py)."""
import bpy
import numpy as np


def kind_parameters_are_keyframeable(S, mod):
    changes = {}
    for kind, path, index, a, b in [("MANDELBULB", "power", -1, 8.0, 6.5),
                                    ("MANDELBULB", "julia_c", 0, 0.3, 0.6),
                                    ("MANDELBOX", "box_scale", -1, 2.0, 2.4),
                                    ("MANDELBOX", "box_fold", -1, 1.0 / 6.0, 0.14),
                                    ("MANDELBOX", "min_radius", -1, 1.0 / 12.0, 0.04),
                                    ("MANDELBOX", "fixed_radius", -1, 1.0 / 6.0, 0.12)]:
        scene = S.empty_scene(40, 30)
        S.add_camera(scene, location=(-2.6, -4.4, 2.4))
        bpy.ops.object.unbound_fractal_add(kind=kind, use_cursor=False)
        ob = bpy.context.object
        if path == "julia_c":
            ob.unbound.julia_mode = True

        def set_value(v):
            if index < 0:
                setattr(ob.unbound, path, v)
            else:
                getattr(ob.unbound, path)[index] = v

        set_value(a)
        ob.keyframe_insert("unbound." + path, index=index, frame=1)
        set_value(b)
        ob.keyframe_insert("unbound." + path, index=index, frame=3)
        scene.view_layers[0].unbound.use_pass_depth = True
        depth, exported = [], []
        for f in (1, 3, 1):
            scene.frame_set(f)
            depth.append(S.render_to_exr(scene, "k%d.exr" % f)["ViewLayer.Depth.Z"])
            value = mod.export.object_parameters(ob)[path]
            exported.append(float(value if index < 0 else value[index]))
        changes[kind + "." + path] = [float(np.mean(depth[0] != depth[1])), bool(np.array_equal(depth[0], depth[2])),
                                      exported]
    S.report(changes=changes)


def added_ready_to_render(S, mod):
    """Each new kind from the Add operator alone, under Blender's default camera placement."""
    out = {}
    for kind in ("MANDELBULB", "MANDELBOX"):
        scene = S.empty_scene(48, 36)
        S.add_camera(scene, location=(0.8, -5.0, 1.6))
        bpy.ops.object.unbound_fractal_add(kind=kind, use_cursor=False)
        ob = bpy.context.object
        scene.render.film_transparent = True
        exr = S.render_to_exr(scene, kind + ".exr")
        alpha = exr["ViewLayer.Combined.A"]
        out[kind] = dict(coverage=float((alpha > 0.5).mean()), display=ob.empty_display_size,
                         exact=bool(mod.properties.EXACT_KINDS.__contains__(kind)))
    S.report(out=out)
