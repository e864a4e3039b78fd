"""Global illumination (issue 19) in real bpy 4.2 against real Cycles: the red unit ball (mu = 0)
over a white diffuse floor (Unbound's flat sea, reflectivity 0; in Cycles a plane), a sun and a
uniform world, Scene.unbound.use_gi with Cycles' bounce limits. Held: the image's, the ball's and
the floor's mean colours within 3 % of Cycles' (Cycles: 256 samples, no clamping; Unbound: 64
samples), and colour bleeding: the floor just in front of the ball turns red as in Cycles (its red
over green within 3 % of Cycles'), and redder than without GI."""
import numpy as np

from conftest import erode

SETUP = dict(size=(96, 72), ball_color=(0.8, 0.05, 0.05), floor_color=(0.8, 0.8, 0.8),
             world_color=(0.25, 0.3, 0.35), sun_toward=(0.25, -0.6, 0.75), sun_energy=3.0, bounces=(8, 4, 4),
             samples=64, world_samples=1, cycles_samples=256)


def regions(ball_alpha):
    """Ball (2 pixels in from the silhouette), floor (3 pixels off the ball, below the horizon
    row of the camera's view: rows under the ball's top), and the floor right in front of the
    ball: the 8 rows under its lowest covered row, within its columns."""
    ball = erode(ball_alpha >= 1.0, 2)
    outside = erode(ball_alpha <= 0.0, 3)
    ys, xs = np.nonzero(ball_alpha > 0.0)
    # Row 0 is the top of the image (bpy_session.read_exr).
    bottom = ys.max()
    near = np.zeros_like(ball)
    near[bottom + 2:bottom + 10, xs.min() + 4:xs.max() - 3] = True
    floor = outside.copy()
    floor[:ys.min()] = False
    return ball, floor, near & outside


def test_ball_over_floor_matches_cycles_with_colour_bleeding(run_bpy, tmp_path):
    assert run_bpy("gi.ball_over_floor", args=SETUP, timeout=900).get("done")
    data = np.load(tmp_path / "gi.npz")
    gi, direct, cycles = data["gi"][..., :3], data["direct"][..., :3], data["cycles"][..., :3]
    ball, floor, near = regions(data["ball"][..., 3])
    assert ball.sum() > 500 and floor.sum() > 1000 and near.sum() > 100, (ball.sum(), floor.sum(), near.sum())
    for name, mask in (("image", np.ones_like(ball)), ("ball", ball), ("floor", floor), ("near", near)):
        ours, theirs = gi[mask].mean(0), cycles[mask].mean(0)
        rel = (ours - theirs) / theirs
        print("%-5s unbound %s cycles %s difference %s" % (name, ours, theirs, rel))
        assert np.all(np.abs(rel) < 0.03), (name, rel)
    # Colour bleeding: red over green on the floor in front of the ball.
    ratio = lambda px: px[near][:, 0].sum() / px[near][:, 1].sum()  # noqa: E731
    print("near floor R/G: unbound GI %.4f, Cycles %.4f, no GI %.4f" % (ratio(gi), ratio(cycles), ratio(direct)))
    assert ratio(cycles) > 1.05
    assert abs(ratio(gi) / ratio(cycles) - 1) < 0.03
    assert ratio(gi) > 1.05 * ratio(direct)


def test_glossy_ball_over_floor_matches_cycles(run_bpy, tmp_path):
    """The ball with a Principled BSDF (metallic 0.5, roughness 0.35) instead of Lambert: its
    bounces draw from the diffuse or the GGX lobe (visible normals), the floor sees the ball's
    glossy reflection of itself and the ball the floor's. Means within 3 % of Cycles' over the
    image, the ball and the floor."""
    args = dict(SETUP, principled=(0.5, 0.35))
    assert run_bpy("gi.ball_over_floor", args=args, timeout=900).get("done")
    data = np.load(tmp_path / "gi.npz")
    gi, cycles = data["gi"][..., :3], data["cycles"][..., :3]
    ball, floor, near = regions(data["ball"][..., 3])
    for name, mask in (("image", np.ones_like(ball)), ("ball", ball), ("floor", floor), ("near", near)):
        ours, theirs = gi[mask].mean(0), cycles[mask].mean(0)
        rel = (ours - theirs) / theirs
        print("%-5s unbound %s cycles %s difference %s" % (name, ours, theirs, rel))
        assert np.all(np.abs(rel) < 0.03), (name, rel)


def test_light_paths_panel_and_export(run_bpy):
    """Render tab > Light Paths (a sub-panel of Unbound's, closed by default like Cycles'), GI off
    by default with Cycles' default limits 12 / 4 / 4, and the settings reach the shading dict
    that F12 and the viewport share (export.shading_description)."""
    r = run_bpy("gi.light_paths_panel_and_export")
    assert r["panel"] == dict(label="Light Paths", parent="UNBOUND_PT_render", context="render", closed=True,
                              registered=True), r["panel"]
    assert r["defaults"] == dict(use_gi=False, max_bounces=12, diffuse_bounces=4, glossy_bounces=4)
    assert r["exported"] == dict(use_gi=True, max_bounces=7, diffuse_bounces=3, glossy_bounces=2)
