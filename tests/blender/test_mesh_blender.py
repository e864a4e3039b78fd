"""Convert to Mesh through Blender (bpy 4.2, the installed extension): the operator on the active
fractal, the new mesh active and selected, its attributes, menus; STL and glTF round trips; and
the mesh rendered by Cycles against Unbound's render of the fractal from the same camera."""
import numpy as np


def test_convert_to_mesh_operator_and_stl_gltf_round_trips(run_bpy):
    """bpy.ops.object.unbound_convert_to_mesh on the active fractal (resolution 64): FINISHED, the
    new MESH object is active and selected (the fractal not), it carries unbound_trap and
    unbound_iterations, Blender counts Euler characteristic V - E + F even and every edge in two
    faces (E = 3F/2); exported by Blender's STL (binary) and glTF (GLB) exporters and imported
    again, the triangles (float32 coordinates, orientation kept) are identical."""
    r = run_bpy("mesh.convert_and_export", args=dict(resolution=64), timeout=300)
    assert r["result"] == ["FINISHED"], r
    assert r["active_type"] == "MESH" and r["selected"] and not r["fractal_selected"], r
    assert {"unbound_trap", "unbound_iterations"} <= set(r["attributes"]), r
    assert r["object_menu_has_entry"], r
    assert 2 * r["edges"] == 3 * r["faces"] and r["euler"] % 2 == 0, r
    assert r["trap_max"] > r["trap_min"] >= 0.0
    assert r["stl_faces"] == r["faces"] and r["stl_identical"], r
    assert r["gltf_faces"] == r["faces"] and r["gltf_identical"], r


def test_cycles_silhouette_of_the_mesh_matches_unbound(run_bpy, tmp_path):
    """IoU of the coverage (alpha > 0.5) of Cycles' render of the mesh (resolution 512 here; 1024 in
    bench/bench_mesh.py's report) and Unbound's render of the fractal, 320 x 240, >= 0.99."""
    run_bpy("mesh.silhouette_cycles_vs_unbound", args=dict(resolution=512, width=320, height=240), timeout=600)
    a = dict(np.load(tmp_path / "alpha.npz"))
    u, c = a["unbound"] > 0.5, a["cycles"] > 0.5
    iou = (u & c).sum() / (u | c).sum()
    print("IoU", iou, u.sum(), c.sum())
    assert u.sum() > 0.05 * u.size
    assert iou >= 0.99, iou
