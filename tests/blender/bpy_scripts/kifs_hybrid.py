"""Scripts of test_kifs_hybrid_blender.py (run inside bpy by conftest.run_bpy)."""
import bpy
import numpy as np


def kind_parameters_are_keyframeable(S, mod):
    changes = {}
    # (kind, data path, index, value at frame 1, at frame 3): the KIFS's own keys, a fold plane's
    # offset and normal inside the collection, the hybrid's Mandelbulb power and an entry's count.
    for kind, path, index, a, b in [("KIFS", "kifs_scale", -1, 3.0, 2.6),
                                    ("KIFS", "kifs_offset", 0, 1.0, 0.8),
                                    ("KIFS", "kifs_rotation", 2, 0.0, 0.3),
                                    ("KIFS", "kifs_size", -1, 1.0, 0.8),
                                    ("KIFS", "kifs_planes[6].offset", -1, 1.0 / 3.0, 0.2),
                                    ("KIFS", "kifs_planes[3].normal", 1, -1.0, -0.7),
                                    ("HYBRID", "power", -1, 8.0, 6.0),
                                    ("HYBRID", "hybrid_steps[0].count", -1, 1, 3)]:
        scene = S.empty_scene(40, 30)
        S.add_camera(scene, location=(-2.6, -4.4, 2.4))
        bpy.ops.object.unbound_fractal_add(kind=kind, use_cursor=False)
        ob = bpy.context.object
        if path == "kifs_size":
            # The last level's boxes are 3^-6 of the sponge: at one level their size moves its faces.
            ob.unbound.max_iterations = 1
        owner_path, _, name = ("unbound." + path).rpartition(".")
        owner = ob.path_resolve(owner_path)

        def set_value(v):
            if index < 0:
                setattr(owner, name, v)
            else:
                getattr(owner, name)[index] = v

        set_value(a)
        ob.keyframe_insert("unbound." + path, index=index, frame=1)
        set_value(b)
        ob.keyframe_insert("unbound." + path, index=index, frame=3)
        scene.view_layers[0].unbound.use_pass_depth = True
        depth, exported = [], []
        for f in (1, 3, 1):
            scene.frame_set(f)
            depth.append(S.render_to_exr(scene, "k%d.exr" % f)["ViewLayer.Depth.Z"])
            exported.append(repr(mod.export.object_parameters(ob)))
        changes[kind + "." + path] = [float(np.mean(depth[0] != depth[1])), bool(np.array_equal(depth[0], depth[2])),
                                      exported]
    S.report(changes=changes)


def added_ready_to_render(S, mod):
    """Each new kind from the Add operator alone, under Blender's default camera placement; then
    each bundled KIFS and hybrid preset applied to it."""
    out = {}
    for kind in ("KIFS", "HYBRID"):
        scene = S.empty_scene(48, 36)
        S.add_camera(scene, location=(0.8, -5.0, 1.6))
        bpy.ops.object.unbound_fractal_add(kind=kind, use_cursor=False)
        ob = bpy.context.object
        scene.render.film_transparent = True
        exr = S.render_to_exr(scene, kind + ".exr")
        alpha = exr["ViewLayer.Combined.A"]
        out[kind] = dict(coverage=float((alpha > 0.5).mean()), display=ob.empty_display_size,
                         exact=kind in mod.properties.EXACT_KINDS, planes=len(ob.unbound.kifs_planes),
                         steps=len(ob.unbound.hybrid_steps))
    S.report(out=out)


def list_operators(S, mod):
    """The KIFS fold-plane and hybrid-entry lists: add copies the active item, stops at the limit
    with a report, remove keeps a valid active index."""
    S.empty_scene(32, 24)
    bpy.ops.object.unbound_fractal_add(kind='KIFS', use_cursor=False)
    u = bpy.context.object.unbound
    planes = [len(u.kifs_planes)]
    u.kifs_active_plane = 0
    u.kifs_planes[0].offset = 0.25
    bpy.ops.object.unbound_kifs_plane_add()
    copied = (u.kifs_active_plane == len(u.kifs_planes) - 1, u.kifs_planes[-1].offset)
    while len(u.kifs_planes) < 16:
        bpy.ops.object.unbound_kifs_plane_add()
    try:
        bpy.ops.object.unbound_kifs_plane_add()
        over = "finished"
    except RuntimeError as exc:
        over = str(exc)
    u.kifs_active_plane = 15
    bpy.ops.object.unbound_kifs_plane_remove()
    planes += [len(u.kifs_planes), u.kifs_active_plane]
    bpy.ops.object.unbound_fractal_add(kind='HYBRID', use_cursor=False)
    h = bpy.context.object.unbound
    steps = [len(h.hybrid_steps)]
    h.hybrid_active_step = 0
    bpy.ops.object.unbound_hybrid_step_add()
    steps.append((len(h.hybrid_steps), h.hybrid_steps[-1].formula == h.hybrid_steps[0].formula,
                  h.hybrid_steps[-1].count == h.hybrid_steps[0].count))
    h.hybrid_active_step = 0
    bpy.ops.object.unbound_hybrid_step_remove()
    steps.append((len(h.hybrid_steps), h.hybrid_active_step))
    S.report(planes=planes, copied=list(copied), over=over, steps=steps)
