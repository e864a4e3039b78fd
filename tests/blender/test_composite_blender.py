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

Not compared here: shading (Cycles' and Unbound's lights differ). The fractal's shadow on the
meshes (Fractal Shadows: a stand-in mesh in the Cycles scene) is tested below against the same UV
sphere; the meshes' shadow on the fractal is not available (Unbound does not trace meshes).
"""
import numpy as np
import pytest

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
    assert r["objects"] == ["Back", "Camera", "Front", "Late", "Quaternion Julia", "Quaternion Julia Shadow",
                            "Sun"], r["objects"]
    assert r["props_excluded"]


# Fractal Shadows (bpy_scripts/composite.fractal_shadow): the unit ball (mu = 0) 1.5 above a matte plane
# (z = -1.5), a sun with angle 0 (a hard shadow), Cycles direct light only (max bounces 0), 4
# samples, 120 x 90. A lit diffuse plane is then uniform and a shadowed one black, so the analytic
# shadow is the plane's points within 1 of the line through the ball's centre along the light:
# inside 0.9 every pixel must be black, beyond 1.1 lit. Measured (bpy 4.2): 864 pixels inside, 9479
# beyond; the stand-in (128 cells, 461904 faces, vertices at radius 1.0002: the surface at the
# render's epsilon 1e-4) gives the UV sphere's image exactly on every pixel farther than 1.5
# pixel footprints (the distance to the neighbouring pixels' points on the plane) from the
# outline, and 1068 against 1067 shadowed pixels (darker than half the lit plane) in all; 16
# samples: 1075 against 1072. Each render 0.5 s, each run of the operator 0.6 s here.
SHADOW_INSIDE, SHADOW_OUTSIDE = 0.9, 1.1  # distances from the shadow's axis, in ball radii
BLACK, LIT = 0.01, 0.99                    # fractions of the lit plane's luminance
OUTLINE_FOOTPRINTS = 1.5                   # pixels this near the outline (in footprints) may differ
MATCH_TOL = 0.01                           # |stand-in - UV sphere| / lit elsewhere
SHADOWED_COUNT_TOL = 0.01                  # relative difference of the shadowed pixel counts
PLANE_Z = -1.5


def luminance(rgba):
    return rgba[..., :3] @ np.array([0.2126, 0.7152, 0.0722])


def shadow_geometry(position, light_travel):
    """Per pixel: the distance of the plane point it shows from the shadow's axis (the line through
    the ball's centre along the light), and its footprint (the largest distance to the next
    pixel's point, across and down)."""
    d = np.asarray(light_travel) / np.linalg.norm(light_travel)
    along = position @ d
    axis_distance = np.linalg.norm(position - along[..., None] * d, axis=-1)
    footprint = np.zeros(position.shape[:2])
    across = np.linalg.norm(position[:, 1:] - position[:, :-1], axis=-1)
    down = np.linalg.norm(position[1:] - position[:-1], axis=-1)
    footprint[:, :-1] = np.maximum(footprint[:, :-1], across)
    footprint[:, 1:] = np.maximum(footprint[:, 1:], across)
    footprint[:-1] = np.maximum(footprint[:-1], down)
    footprint[1:] = np.maximum(footprint[1:], down)
    return axis_distance, footprint


@pytest.fixture
def fractal_shadow(run_bpy, tmp_path):
    r = run_bpy("composite.fractal_shadow", timeout=300)
    print("operator %.2f s, render %.2f s" % (r["operator_seconds"], r["render_seconds"]))
    return r, dict(np.load(tmp_path / "shadow.npz"))


def test_fractal_shadow_stand_in(fractal_shadow):
    """One stand-in, in the Cycles scene only, invisible to the camera but casting shadows and seen
    in reflections, on the fractal (its world matrix; moved with it), its vertices on the unit
    sphere; a second run replaces it; with Fractal Shadows off it is gone with its collection."""
    r, _ = fractal_shadow
    (proxy,) = r["first"]
    assert proxy["name"] == "Quaternion Julia Shadow" and proxy["in_copy"] and not proxy["in_unbound_scene"]
    assert not proxy["camera"] and proxy["shadow"] and proxy["diffuse"] and proxy["glossy"]
    assert proxy["follows"] == ["Quaternion Julia"] and proxy["world_is_fractal"]
    assert abs(proxy["radius_min"] - 1.0) < 1e-3 and abs(proxy["radius_max"] - 1.0) < 1e-3, proxy
    assert r["second"] == r["first"] and r["meshes_after_two_runs"] == r["meshes_after_one_run"]
    assert r["moved_with"] == pytest.approx([0.3, -0.2, 0.1], abs=1e-6)
    assert r["off_facts"] == [] and r["collections_off"] == []
    assert r["meshes_off"] == r["meshes_after_one_run"] - 1


def test_fractal_shadow_on_the_plane_matches_a_mesh_sphere(fractal_shadow):
    r, px = fractal_shadow
    position = px["on_position"]
    plane = (px["on_rgba"][..., 3] > 0.999) & (np.abs(position[..., 2] - PLANE_Z) < 1e-3)
    axis_distance, footprint = shadow_geometry(position, r["light_travel"])
    inside, outside = plane & (axis_distance < SHADOW_INSIDE), plane & (axis_distance > SHADOW_OUTSIDE)
    assert inside.sum() > 500 and outside.sum() > 5000, (inside.sum(), outside.sum())
    on, off, sphere = (luminance(px[k + "_rgba"]) for k in ("on", "off", "sphere"))
    lit = np.median(off[plane])
    assert lit > 0.1

    # Invisible to the camera: the camera rays hit what they hit without it.
    for key in ("off", "sphere"):
        assert np.array_equal(px[key + "_position"], position) and np.array_equal(px[key + "_rgba"][..., 3],
                                                                                 px["on_rgba"][..., 3])
    # Off: no shadow at all. On: the analytic shadow, black inside and lit outside.
    assert (off[plane] >= LIT * lit).all()
    print("on: inside max %.4f, outside min %.4f of the lit plane" % (on[inside].max() / lit, on[outside].min() / lit))
    assert (on[inside] <= BLACK * lit).all() and (on[outside] >= LIT * lit).all()

    # The stand-in's shadow is the UV sphere's, but within a pixel or so of the outline.
    away = plane & (np.abs(axis_distance - 1.0) > OUTLINE_FOOTPRINTS * footprint)
    difference = np.abs(on - sphere) / lit
    shadowed_on, shadowed_sphere = (plane & (on < 0.5 * lit)).sum(), (plane & (sphere < 0.5 * lit)).sum()
    print("stand-in vs UV sphere: max difference %.4f on %d pixels away from the outline, %.4f near it; "
          "shadowed pixels %d vs %d" % (difference[away].max(), away.sum(), difference[plane & ~away].max(),
                                         shadowed_on, shadowed_sphere))
    assert difference[away].max() <= MATCH_TOL
    assert abs(shadowed_on - shadowed_sphere) <= SHADOWED_COUNT_TOL * shadowed_sphere


def test_fractal_shadow_reports(run_bpy):
    """The info message says what is made and what is not (a mesh's shadow on the fractal); a
    keyframed fractal's shadow is named as the current frame's shape; a fractal the core refuses
    is a clear error and leaves no stand-in behind."""
    r = run_bpy("composite.shadow_reports")
    infos = [line for line in r["_output"].splitlines() if line.startswith("Info: Unbound:")]
    assert infos == ["Info: Unbound: scene 'Scene Cycles' renders 2 objects with Cycles and the shadows of 1 fractal "
                     "(each a mesh of 32 cells, invisible to the camera); keyframed (Quaternion Julia): the shadow "
                     "keeps frame 4's shape, run again on another frame; F12 here combines them with the fractal by "
                     "depth. Meshes cast no shadow on the fractal: Unbound does not trace meshes"], infos
    assert r["keyframed"] == ["Quaternion Julia Shadow"]
    assert r["error"] == ("Error: Unbound: fractal 'Quaternion Julia': an IFS needs at least one map: add one, or "
                          "pick a preset"), r["error"]
    assert r["left"] == [] and r["meshes"] == ["Cube", "Cube.001"], (r["left"], r["meshes"])
