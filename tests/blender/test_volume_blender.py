"""Convert to Volume through Blender (bpy 4.2, the installed extension) on the unit ball (mu = 0:
the filled Julia set of z^2 is |q| <= 1, so every figure has an analytic reference): the operator,
its file and grid read back by Blender itself, the surface the grid holds, refusals, an unsaved
.blend, a frame range, and Cycles and EEVEE renders of the volume against the ball's disc."""
import math
import os

import numpy as np
import pytest

SCALE, LOCATION = 1.5, (0.3, -0.2, 0.1)


def test_sdf_of_the_unit_ball_beside_the_blend(run_bpy, tmp_path):
    """bpy.ops.object.unbound_convert_to_volume(resolution=64) on the unit ball scaled by 1.5 and
    moved: FINISHED; the new VOLUME object is active and selected, has the fractal's world matrix,
    the fractal is kept (not selected); no temporary mesh, node tree or volume is left. The file
    is beside the saved .blend (a relative '//' path), an OpenVDB level set ('level set' class in
    its metadata), loaded by Blender with one FLOAT grid 'sdf' of voxel size 2 / 64 (the mesh's
    lattice cell: the bounding radius of the ball is 1). Blender's Volume to Mesh on the loaded
    grid at threshold 0 gives vertices whose world radii, over the scale, are 1 within a quarter
    voxel (observed: within 1/70 of a voxel)."""
    r = run_bpy("volume.convert_ball", args=dict(resolution=64, scale=SCALE, location=LOCATION, save_blend=True))
    print({k: v for k, v in r.items() if k != "_output"})
    assert r["result"] == ["FINISHED"], r["_output"][-3000:]
    assert r["active_type"] == "VOLUME" and r["selected"] and not r["fractal_selected"] and r["fractal_kept"], r
    assert r["matrix_equal"], r
    assert r["objects"] == ["Quaternion Julia", "Quaternion Julia Volume"], r["objects"]
    assert (r["meshes"], r["node_groups"], r["volumes"]) == (0, 0, 1), r
    assert r["materials"] == ["Unbound Volume SDF"], r
    assert r["filepath"] == "//Quaternion_Julia.vdb" and r["abspath"] == str(tmp_path / "Quaternion_Julia.vdb"), r
    assert r["file_exists"] and r["file_bytes"] > 1000 and r["level_set_class"], r
    assert r["grids"] == [["sdf", "FLOAT"]] and r["grid_error"] == "", r
    h = 2.0 / 64
    assert r["voxel_size"] == pytest.approx([h] * 3, rel=1e-6), r
    rmin, rmax, count = r["radii"]
    assert count > 1000
    assert abs(rmin / SCALE - 1) < h / 4 and abs(rmax / SCALE - 1) < h / 4, (rmin / SCALE, rmax / SCALE, h)


def test_density_grid_ramps_inside_the_surface(run_bpy):
    """Grid 'Density': a fog volume 'density' (no level set class), 0 outside and rising linearly
    to 1 over Band Width (3) voxels inside: Volume to Mesh at threshold t finds the sphere of radius
    1 - 3 t h, within half a voxel h, for t = 0.1, 0.5, 0.9."""
    thresholds = [0.1, 0.5, 0.9]
    r = run_bpy("volume.density_radii", args=dict(resolution=64, thresholds=thresholds))
    h = r["voxel_size"]
    assert h == pytest.approx(2.0 / 64)
    for t, (rmin, rmax) in zip(thresholds, r["radii"]):
        expected = 1 - 3 * t * h
        print(t, expected, rmin, rmax)
        assert abs(rmin - expected) < h / 2 and abs(rmax - expected) < h / 2, (t, expected, rmin, rmax)


def test_refusals_leave_nothing_behind(run_bpy):
    """Each refusal is an ERROR report (Blender raises it as RuntimeError from bpy.ops) or a failed
    poll, and leaves no object, mesh, node tree, volume or .vdb file: a directory that is a file, a
    fractal with no surface (mu = 2: the Julia set is dust), no active object, a camera active; and
    with UNBOUND_MEMORY_LIMIT=1e6 the memory preflight refuses resolution 512 before OpenVDB
    allocates anything."""
    r = run_bpy("volume.refusals", args=dict(memory_limit_case=False))
    print({k: v for k, v in r.items() if k != "_output"})
    assert "cannot write the .vdb file into" in r["directory_is_a_file"]["message"], r
    assert "no surface" in r["no_surface"]["message"], r
    for case in ("no_active_object", "not_a_fractal"):
        assert "poll() failed" in r[case]["message"], r
    for case in ("directory_is_a_file", "no_surface", "no_active_object", "not_a_fractal"):
        assert r[case]["result"] == ["RuntimeError"] and r[case]["left"] and r[case]["vdb"] == [], (case, r[case])
    m = run_bpy("volume.refusals", args=dict(memory_limit_case=True), env=dict(UNBOUND_MEMORY_LIMIT="1e6"))["memory"]
    assert m["result"] == ["RuntimeError"] and "needs about" in m["message"] and "lower the resolution" in m["message"], m
    assert m["left"] and m["vdb"] == [], m


def test_unsaved_blend_writes_to_the_system_temporary_folder(run_bpy, tmp_path):
    """An unsaved .blend: the file goes to the system's temporary folder ($TMPDIR here), not to
    bpy.app.tempdir (Blender's session folder, deleted when it quits), as an absolute path, and the
    operator warns how to keep it (save and convert again, or pack)."""
    r = run_bpy("volume.unsaved", env=dict(TMPDIR=str(tmp_path)))
    assert r["result"] == ["FINISHED"] and r["exists"], r
    assert r["filepath"] == str(tmp_path / "Quaternion_Julia.vdb"), r
    assert not r["filepath"].startswith(r["tempdir"]), r
    assert "the .blend is unsaved" in r["_output"] and "Pack Resources" in r["_output"]


def test_frame_range_is_a_volume_sequence(run_bpy):
    """Frame Range, frames 1-3 of a fractal keyframed from the unit ball to mu = -0.5: three files
    _0001 to _0003 beside the .blend, one Volume object (a sequence) reading file N on frame N and
    nothing on frame 4; the frame the user was on (2) is set again; on frame 1 the grid is the
    unit ball (radii within a quarter voxel of 1)."""
    r = run_bpy("volume.frame_range", args=dict(resolution=32))
    assert r["result"] == ["FINISHED"] and r["frame_after"] == 2 and r["is_sequence"], r
    assert r["files"] == ["Quaternion_Julia_000%d.vdb" % f for f in (1, 2, 3)], r
    assert r["objects"] == ["Quaternion Julia", "Quaternion Julia Volume"], r
    for f in (1, 2, 3):
        assert r["frames"][str(f)] == dict(file="Quaternion_Julia_000%d.vdb" % f, grids=1), r["frames"]
    assert r["frames"]["4"]["grids"] == 0, r["frames"]
    h = 2.0 / 32
    assert all(abs(x - 1) < h / 4 for x in r["radii_frame1"]), r


def disc_iou(alpha, lens=50.0, sensor=36.0, distance=4.0):
    """IoU of coverage (alpha > 0.5) with the unit ball's silhouette seen from `distance` on its
    axis: a disc of radius f tan(asin(1 / distance)) pixels at the image centre (f in pixels)."""
    h, w = alpha.shape
    radius = lens / sensor * w * math.tan(math.asin(1.0 / distance))
    y, x = np.mgrid[0:h, 0:w] + 0.5
    disc = (x - w / 2) ** 2 + (y - h / 2) ** 2 <= radius ** 2
    covered = alpha > 0.5
    return (disc & covered).sum() / (disc | covered).sum(), disc.sum(), covered.sum()


@pytest.mark.parametrize("engine,grid", [("CYCLES", "SDF"), ("CYCLES", "DENSITY"), ("EEVEE", "SDF")])
def test_render_of_the_volume_is_the_ball(run_bpy, tmp_path, engine, grid):
    """The converted unit ball (resolution 64, the operator's volume material) rendered at 96 x 72,
    transparent film, the fractal hidden: Cycles (CPU, 16 samples, no bounces) and EEVEE (4 samples,
    software GL here): the coverage's IoU with the analytic disc >= 0.95 for Cycles (observed
    1.00 for the SDF, 0.99 for the density, whose edge is soft) and >= 0.88 for EEVEE (observed 0.92: it
    samples volumes on a froxel grid coarser than the pixels, which spreads the edge outward)."""
    r = run_bpy("volume.render_ball", args=dict(resolution=64, grid=grid, width=96, height=72, engine=engine,
                                                 samples=16 if engine == "CYCLES" else 4), timeout=600)
    alpha = np.load(tmp_path / "alpha.npy")
    iou, disc, covered = disc_iou(alpha)
    print(engine, grid, "IoU", iou, disc, covered, "render s", r["seconds"])
    assert iou >= (0.95 if engine == "CYCLES" else 0.88), (iou, disc, covered)
