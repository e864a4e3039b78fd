"""Composite with Cycles (issue 20, "in the same picture as Blender's meshes"): the meshes rendered by
Cycles in the linked copy "<scene> Cycles", combined with Unbound's fractal by depth in the Unbound
scene's compositor, against Cycles rendering the whole scene with a mesh sphere in the fractal's place.

Scene (160 x 120, camera at (0, -4, 0.6)): the unit ball (mu = 0, K_0 is the unit ball), a cube of
edge 0.8 in front of it and one of edge 1.4 behind it, each overlapping the ball in the image, a sun.
Cycles: CPU, 16 samples, its default 1.5-pixel filter (anti-aliased edges), no denoising.
Reference: the same scene rendered by Cycles alone, the ball a smooth 256 x 128 UV sphere of radius
1 (its faces lie inside the sphere by at most 1.5e-4, about 0.01 pixel here).

Edges: a pixel is "within a pixel of an edge" when its 3 x 3 neighbourhood in the reference's Object
Index pass (which surface the first sample saw: background, ball, front cube, back cube) holds more
than one surface. Cycles' filter spreads an edge over +-0.75 pixel, so elsewhere every sample of a
pixel sees the same surface. Measured (bpy 4.2 and 5.2 alike, the same figures): 1089 of the 19200
pixels are edge pixels; coverage (alpha > 0.5) disagrees in 7 pixels, all of them edge pixels; the
Depth of the Z Combine agrees with the reference's to at most 1.86e-4 relative (median 2.9e-6) on
the 7846 covered non-edge pixels: exactly (0) on the cubes, the mesh sphere's polygonal error on the
ball; the background is 1e10 in both. The front cube hides the ball in 659 non-edge pixels and the
ball hides the back cube in 941. Each render pair (Composite with Cycles + the reference) takes
about 5 s here.

Not compared: shading (Cycles' and Unbound's lights differ) and shadows of one on the other, which
the set-up does not give (README: Composite with Cycles).
"""
import numpy as np

COVERAGE = 0.5          # alpha above which a pixel counts as covered
DEPTH_REL_TOL = 1e-3    # |composite - reference| / reference on covered non-edge pixels
BACKGROUND_DEPTH = 1e10
BALL, FRONT, BACK = 1, 2, 3  # the reference's object indices (bpy_scripts/composite.py)


def near_edges(labels):
    """Pixels whose 3 x 3 neighbourhood holds more than one label."""
    h, w = labels.shape
    padded = np.pad(labels, 1, mode="edge")
    mixed = np.zeros(labels.shape, bool)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            mixed |= padded[1 + dy:1 + dy + h, 1 + dx:1 + dx + w] != labels
    return mixed


def test_composite_with_cycles_matches_cycles_alone(run_bpy, tmp_path):
    r = run_bpy("composite.composite_matches_cycles", timeout=600)
    assert r["done"]
    print("F12 of both scenes %.2f s, the reference %.2f s" % (r["composite_seconds"], r["reference_seconds"]))
    px = dict(np.load(tmp_path / "renders.npz"))
    labels = px["reference_index"]
    edges = near_edges(labels)
    composite = px["composite_rgba"][..., 3] > COVERAGE
    reference = px["reference_rgba"][..., 3] > COVERAGE
    fractal = px["unbound_rgba"][..., 3] > COVERAGE
    meshes = px["cycles_rgba"][..., 3] > COVERAGE
    inner = ~edges

    # The scene is what it claims: the front cube hides part of the ball, the ball part of the back cube.
    front_over_ball = inner & (labels == FRONT) & fractal
    ball_over_back = inner & (labels == BALL) & meshes & (px["cycles_depth"] > px["unbound_depth"])
    assert front_over_ball.sum() > 100 and ball_over_back.sum() > 100, (front_over_ball.sum(), ball_over_back.sum())
    assert set(np.unique(labels)) == {0, BALL, FRONT, BACK}

    # Coverage: the composite covers exactly the reference's pixels away from edges.
    differ = composite != reference
    print("front cube over the ball: %d pixels, ball over the back cube: %d"
          % (front_over_ball.sum(), ball_over_back.sum()))
    print("coverage: %d pixels differ, %d outside the %d edge pixels (of %d)"
          % (differ.sum(), (differ & inner).sum(), edges.sum(), edges.size))
    assert not (differ & inner).any(), np.argwhere(differ & inner)[:8].tolist()
    assert edges.sum() < 0.1 * edges.size

    # Depth: the Z Combine's Depth where both hit, away from edges; the background where neither does.
    z, z_ref = px["composite_depth"], px["reference_depth"]
    hit = composite & reference & inner
    rel = np.abs(z - z_ref)[hit] / z_ref[hit]
    print("depth: %d pixels, relative error max %.2e median %.2e" % (hit.sum(), rel.max(), np.median(rel)))
    assert rel.max() <= DEPTH_REL_TOL
    for label in (FRONT, BACK):  # the cubes are the same mesh in both renders: the same float32 Depth
        on = hit & (labels == label)
        assert on.sum() > 100 and np.array_equal(z[on], z_ref[on]), label
    empty = ~composite & ~reference & inner
    assert empty.any() and (z[empty] == BACKGROUND_DEPTH).all() and (z_ref[empty] == BACKGROUND_DEPTH).all()
    # The Z Combine's Depth is the nearer of the two renders' (Unbound's background moved behind
    # Cycles' changes nothing).
    assert np.array_equal(z, np.minimum(px["cycles_depth"], px["unbound_depth"]))


def test_composite_colour_is_premultiplied_over(run_bpy, tmp_path):
    """The combined colour is the nearer render laid over the farther one (premultiplied "over",
    Cycles in front on ties) in every pixel but within a pixel of where the depth order changes
    (Z Combine's Anti-Alias blends the two orders there). Without the Alpha Convert nodes, a
    Cycles edge over Unbound's transparent background came out darkened by its own alpha (309
    partly covered pixels here, by up to 0.15), and with Unbound's background on top of Cycles'
    on a tie (5.2) brightened by 1/alpha."""
    assert run_bpy("composite.composite_matches_cycles", timeout=600)["done"]
    px = dict(np.load(tmp_path / "renders.npz"))
    cycles, unbound = px["cycles_rgba"], px["unbound_rgba"]
    cycles_front = px["cycles_depth"] <= px["unbound_depth"]
    front = np.where(cycles_front[..., None], cycles, unbound)
    back = np.where(cycles_front[..., None], unbound, cycles)
    over = front + (1.0 - front[..., 3:4]) * back
    error = np.abs(px["composite_rgba"] - over).max(axis=-1)
    partial = (cycles[..., 3] > 0.0) & (cycles[..., 3] < 1.0) & (unbound[..., 3] == 0.0)
    assert partial.sum() > 50  # anti-aliased mesh edges over the empty background are checked
    order_changes = near_edges(cycles_front)
    wrong = (error > 1e-4) & ~order_changes
    print("colour: %d pixels differ from 'over' by > 1e-4, all within a pixel of a depth-order change (%d)"
          % ((error > 1e-4).sum(), order_changes.sum()))
    assert not wrong.any(), np.argwhere(wrong)[:8].tolist()


def warnings_of(r):
    return [line for line in r["_output"].splitlines() if line.startswith("Warning: Unbound:")
            and "not rendered" in line]


def test_meshes_without_the_set_up_are_reported(run_bpy):
    r = run_bpy("composite.unrendered_warning", args=dict(set_up=False))
    assert r["outcome"] == "ok" and r["written"]
    assert warnings_of(r) == ["Warning: Unbound: 2 objects (Back, Front) are not rendered: Unbound renders only "
                              "fractals. Render > Unbound > Composite with Cycles renders them with Cycles and "
                              "combines them by depth"], warnings_of(r)


def test_no_warning_with_the_set_up(run_bpy):
    r = run_bpy("composite.unrendered_warning", args=dict(set_up=True))
    assert r["outcome"] == "ok" and r["written"]
    assert warnings_of(r) == [], warnings_of(r)
    assert "Scene Cycles" in r["_output"]  # F12 rendered the Cycles copy too


def test_object_missing_from_the_cycles_copy_is_reported(run_bpy):
    """An object added to the Scene Collection after the set-up is in no composited scene."""
    r = run_bpy("composite.unrendered_warning", args=dict(set_up=True, add_to_scene_collection=True))
    assert warnings_of(r) == ["Warning: Unbound: 1 object (Late) is in no composited scene and is not rendered: "
                              "run Render > Unbound > Composite with Cycles again"], warnings_of(r)


def test_a_second_run_refreshes_the_copy_and_replaces_only_its_nodes(run_bpy):
    """Run, Set Up Compositing, a user's node, a new object and an excluded collection, run again:
    the same nodes (not twice), the user's and Set Up Compositing's kept, the output fed by the Z
    Combine, the copy (Cycles, transparent film, Depth pass, the same camera) holding the new object
    and the collection, excluded as in the Unbound scene's view layer; one copy, not two."""
    r = run_bpy("composite.refresh")
    # The output is the tree's own where it has one (4.x makes a Composite node), else ours (5.x).
    expected = {"Unbound+Cycles " + n for n in ("Cycles", "Straight Cycles", "Straight Unbound", "Unbound",
                                                "Unbound Background", "Unbound Background Behind", "Viewer", "Z Combine")}
    assert r["first"] == r["second"] and set(r["first"]) - {"Unbound+Cycles Output"} == expected, r["first"]
    assert "Mine" in r["all_nodes"] and "Unbound Render Layers" in r["all_nodes"]
    assert r["output_fed_by"] == ["Unbound+Cycles Z Combine"], r["output_fed_by"]
    assert r["scenes"] == ["Scene", "Scene Cycles"]
    assert r["engine"] == "CYCLES" and r["transparent"] and not r["unbound_transparent"]
    assert r["camera"] == "Camera" and r["z_pass"] and r["depth_pass"]
    assert r["objects"] == ["Back", "Camera", "Front", "Late", "Quaternion Julia", "Sun"], r["objects"]
    assert r["props_excluded"]
