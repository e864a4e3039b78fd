"""Scripts of test_mesh_blender.py (run inside bpy by conftest.run_bpy: see bpy_scripts/__init__.py)."""
import os
import pathlib

import bpy
import numpy as np


def _mesh_arrays(ob):
    me = ob.data
    v = np.empty(3 * len(me.vertices), np.float32)
    me.vertices.foreach_get("co", v)
    f = np.empty(3 * len(me.polygons), np.int32)
    me.polygons.foreach_get("vertices", f)
    return v.reshape(-1, 3), f.reshape(-1, 3)


def _triangles(ob):
    """Each triangle as its 9 float32 coordinates, rotated so its smallest vertex comes first
    (orientation kept), sorted: a vertex numbering-free description of the surface."""
    v, f = _mesh_arrays(ob)
    tri = v[f]  # (m, 3, 3)
    # rotation: index of the lexicographically smallest vertex per triangle
    order = np.zeros(len(tri), np.int64)
    for j in (1, 2):
        a, b = tri[np.arange(len(tri)), order], tri[:, j]
        less = (b[:, 0] < a[:, 0]) | ((b[:, 0] == a[:, 0]) & ((b[:, 1] < a[:, 1]) | ((b[:, 1] == a[:, 1]) & (b[:, 2] < a[:, 2]))))
        order = np.where(less, j, order)
    idx = (order[:, None] + np.arange(3)[None, :]) % 3
    rot = tri[np.arange(len(tri))[:, None], idx].reshape(-1, 9)
    rot = rot[np.lexsort(rot.T[::-1])]
    return rot


def convert_and_export(S, mod, resolution):
    """Convert to Mesh on the active fractal; the new mesh is active; STL and glTF round trips."""
    tmp = pathlib.Path(os.environ["UNBOUND_TEST_TMP"])
    scene = S.empty_scene(64, 48)
    fractal = S.add_fractal()
    assert bpy.context.view_layer.objects.active == fractal
    result = bpy.ops.object.unbound_convert_to_mesh(resolution=resolution)
    new = bpy.context.view_layer.objects.active
    out = dict(result=sorted(result), active_type=new.type, active_name=new.name, selected=new.select_get(),
               fractal_selected=fractal.select_get(), vertices=len(new.data.vertices), faces=len(new.data.polygons),
               attributes=sorted(a.name for a in new.data.attributes))
    # the menus draw the operator (a menu function registered on the Object menu)
    out["object_menu_has_entry"] = any(getattr(f, "__name__", "") == "menu_convert"
                                       for f in getattr(bpy.types.VIEW3D_MT_object.draw, "_draw_funcs", []))
    trap = np.empty(len(new.data.vertices), np.float32)
    new.data.attributes["unbound_trap"].data.foreach_get("value", trap)
    out["trap_min"], out["trap_max"] = float(trap.min()), float(trap.max())
    # manifold by Blender's own count: each edge in two faces
    me = new.data
    ek = np.empty(2 * len(me.edges), np.int32)
    me.edges.foreach_get("vertices", ek)
    out["edges"] = len(me.edges)
    out["euler"] = len(me.vertices) - len(me.edges) + len(me.polygons)
    original = _triangles(new)
    for o in list(bpy.context.view_layer.objects):
        o.select_set(o == new)
    # STL
    stl = tmp / "mesh.stl"
    if hasattr(bpy.ops.wm, "stl_export"):
        bpy.ops.wm.stl_export(filepath=str(stl), export_selected_objects=True, ascii_format=False,
                              apply_modifiers=False, global_scale=1.0)
        bpy.ops.wm.stl_import(filepath=str(stl))
    else:
        bpy.ops.export_mesh.stl(filepath=str(stl), use_selection=True)
        bpy.ops.import_mesh.stl(filepath=str(stl))
    stl_ob = bpy.context.selected_objects[0]
    out["stl_identical"] = bool(np.array_equal(_triangles(stl_ob), original))
    out["stl_faces"] = len(stl_ob.data.polygons)
    # glTF
    import addon_utils
    addon_utils.enable("io_scene_gltf2", default_set=True)
    for o in list(bpy.context.view_layer.objects):
        o.select_set(o == new)
    bpy.context.view_layer.objects.active = new
    glb = tmp / "mesh.glb"
    bpy.ops.export_scene.gltf(filepath=str(glb), use_selection=True, export_format='GLB',
                              export_normals=False, export_texcoords=False, export_materials='NONE',
                              export_attributes=False)
    before = set(bpy.data.objects)
    bpy.ops.import_scene.gltf(filepath=str(glb))
    gl_ob = [o for o in bpy.data.objects if o not in before and o.type == 'MESH'][0]
    gl_ob.data.transform(gl_ob.matrix_world)
    out["gltf_identical"] = bool(np.array_equal(_triangles(gl_ob), original))
    out["gltf_faces"] = len(gl_ob.data.polygons)
    S.report(**out)
    # bpy 4.2 from PyPI crashes at exit after the glTF add-on was enabled (as after a reload)
    S.exit_without_finalizing()


def silhouette_cycles_vs_unbound(S, mod, resolution, width, height):
    """Unbound's render of the default fractal and Cycles' render of its mesh, same camera,
    transparent film: both alpha channels saved."""
    scene = S.empty_scene(width, height)
    scene.render.film_transparent = True
    S.add_camera(scene, location=(0.4, -3.0, 0.9))
    # the fixed threshold: the render and the mesh show the same surface {estimate = epsilon}
    fractal = S.add_fractal(threshold_mode='FIXED', epsilon=1e-4)
    scene.unbound.samples = 1
    unbound = S.render_to_exr(scene, "unbound.exr")
    bpy.context.view_layer.objects.active = fractal
    assert bpy.ops.object.unbound_convert_to_mesh(resolution=resolution, use_material=False) == {'FINISHED'}
    mesh_ob = bpy.context.view_layer.objects.active
    scene.render.engine = 'CYCLES'
    c = scene.cycles
    c.device = 'CPU'
    c.samples = 16
    c.use_adaptive_sampling = False
    c.use_denoising = False
    c.filter_width = 0.01
    c.max_bounces = 0
    cycles = S.render_to_exr(scene, "cycles.exr")
    np.savez(pathlib.Path(os.environ["UNBOUND_TEST_TMP"]) / "alpha.npz",
             unbound=unbound["ViewLayer.Combined.A"], cycles=cycles["ViewLayer.Combined.A"])
    S.report(faces=len(mesh_ob.data.polygons))
