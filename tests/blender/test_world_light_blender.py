"""The World lights the fractal (issue 19) in real bpy 4.2 with real Cycles: a uniform world on the
unit ball (mu = 0) gives rho L at every pixel; an HDRI world (an Environment Texture of an EXR the
test writes, turned by a Mapping node) baked by Cycles through the panoramic camera lights the ball
as Cycles lights a fine smooth UV sphere; a failed bake fails the frame, no file written."""
import numpy as np

from conftest import erode


def inside(alpha):
    """Pixels fully covered, 2 pixels away from the silhouette."""
    return erode(alpha >= 1.0, 2)


def test_uniform_world_gives_albedo_times_radiance(run_bpy, tmp_path):
    """A Background colour L (no node linked: a 1x1 map, no bake) on albedo rho. Each world-sample
    pair's estimate lies in [0, 2 rho L] (tests/native/test_world_light.py), so by Hoeffding every
    one of n pixels' mean of K = samples * world_samples pairs is within rho L sqrt(2 ln(2 n /
    1e-3) / K) of rho L but with probability 1e-3; the mean over the pixels within 4 rho L / sqrt(K n)."""
    L, rho, samples, world_samples = (1.5, 1.0, 0.5), 0.6, 8, 8
    r = run_bpy("world_light.uniform_world", args=dict(radiance=L, rho=rho, samples=samples,
                                                         world_samples=world_samples))
    assert np.allclose(r["constant_map"], [[list(L)]])
    px = np.load(tmp_path / "uniform.npy")
    ball = inside(px[..., 3])
    got = px[..., :3][ball]
    expected = rho * np.array(L)
    K, n = samples * world_samples, ball.sum()
    assert n > 300
    assert np.all(np.abs(got - expected) <= np.sqrt(2 * np.log(2 * n / 1e-3) / K) * expected)
    assert np.all(np.abs(got.mean(0) - expected) <= 4 * expected / np.sqrt(K * n))
    # A transparent film hides the world from the camera, as in Cycles.
    assert np.all(px[:3, :3] == 0.0)


def test_hdri_world_matches_cycles(run_bpy, tmp_path):
    """Unbound: 16 samples x 4 world-sample pairs; Cycles: 128 samples (each a light and a BSDF
    sample, MIS), max bounces 0 (direct light only, which on a convex ball is all of it). Over the
    ball's covered pixels (2 pixels in from the silhouette, where the mesh's and the set's edges
    differ) the mean difference is held to 2 % of Cycles' mean, and in each quadrant of the ball to
    4 % (the quadrants check the map's orientation and the Mapping's turn). Transparent film in
    both: alpha is the coverage."""
    r = run_bpy("world_light.hdri_world", args=dict(samples=16, world_samples=4, cycles_samples=128,
                                                      rotation_z_deg=40.0), timeout=900)
    print("bake %.2f s, cached %.4f s" % (r["bake_seconds"], r["cached_seconds"]))
    assert r["shape"] == [128, 256, 3]
    assert r["cached_seconds"] < 0.2 * r["bake_seconds"]
    assert r["changed_key"]
    data = np.load(tmp_path / "hdri.npz")
    ours, cycles = data["unbound"], data["cycles"]
    ball = inside(ours[..., 3]) & inside(cycles[..., 3])
    lum = lambda px: px[..., :3] @ np.array([0.2126, 0.7152, 0.0722])  # noqa: E731
    a, b = lum(ours), lum(cycles)
    rel = (a[ball].mean() - b[ball].mean()) / b[ball].mean()
    print("ball: mean difference %.4f of Cycles' mean" % rel)
    assert abs(rel) < 0.02, rel
    ys, xs = np.nonzero(ball)
    cy, cx = ys.mean(), xs.mean()
    for qy in (ys < cy, ys >= cy):
        for qx in (xs < cx, xs >= cx):
            sel = (ys[qy & qx], xs[qy & qx])
            q = (a[sel].mean() - b[sel].mean()) / b[sel].mean()
            print("quadrant: %.4f" % q)
            assert abs(q) < 0.04, q


def test_a_failed_bake_fails_the_frame(run_bpy):
    r = run_bpy("world_light.bake_failure_is_reported")
    assert "baking the World 'Broken' with Cycles failed" in r["outcome"], r["outcome"]
    assert not r["written"]
