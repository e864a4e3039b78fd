"""Motion blur is Cycles' motion blur (issue 19): Render > Motion Blur's shutter, position and
shutter curve, for object motion, camera motion and keyframed fractal parameters.

Object and camera motion: one bpy process per case renders the same animated scene through
Blender's pipeline at frame 1 with motion blur on: Cycles a fine UV sphere mesh (the unit sphere),
Unbound the unit ball (mu = 0); the ball, or the camera, is keyframed sideways (linear, x from
-v at frame 0 to +v at frame 2), so during the shutter the ball's image sweeps D pixels. The image
is a strip through the ball's centre; its alpha averaged over the strip's rows, as a function of
x, rises at the left edge and falls at the right one, each ramp as wide as the sweep's time
profile (uniform shutter: about 0.8 D between 10 % and 90 %). Both engines use a one-pixel box
filter (Cycles' Box, width 1; Unbound's stratified jitter). Checks, per edge:

* ramp width (10 % -> 90 %): |Unbound - Cycles| <= WIDTH_TOL (5 %) of Cycles';
* the edge's place, the 50 % crossing: within EDGE_TOL pixels (START and END shift both edges by
  D / 2 against CENTER; a shutter curve weighting the shutter's end pulls them toward it);
* the blur's extent, between the outer 5 % crossings: within EXTENT_TOL pixels;
* the ramp is blurred (>= MIN_RAMP pixels), and without blur Unbound's is at most 1.5 pixels.

The estimate's noise (Cycles 512 samples: per-pixel alpha noise <= 0.5 / sqrt(512), averaged over
16 rows, through a ramp of slope 1 / D) moves a crossing by about 0.1 pixel. Measured (printed with
pytest -s): see README, Motion blur.

Keyframed mu: the blurred frame against the mean of renders without blur at the samples' own times
(same times, so only the anti-aliasing differs) and at many sub-frames; the unblurred frame must
differ from both by far more (the comparison can fail).
"""
import numpy as np
import pytest

SIZE = (160, 16)
CAMERA = dict(location=(0.0, -5.0, 0.0), lens=50.0)
WIDTH_TOL = 0.05
EDGE_TOL = 0.25
EXTENT_TOL = 0.4
MIN_RAMP = 6.0
CENTER = dict(position='CENTER', length=0.5, curve=None)

# id: (motion, shutter)
CASES = {
    "object": (dict(what="object", velocity=0.8), CENTER),
    "object_start": (dict(what="object", velocity=0.8), dict(CENTER, position='START')),
    "object_end": (dict(what="object", velocity=0.8), dict(CENTER, position='END')),
    # The camera's motion sweeps the ball the other way: with the shutter opening at the frame,
    # both edges move left (a camera left behind or moved the wrong way fails); a whole frame's shutter.
    "camera": (dict(what="camera", velocity=0.4), dict(CENTER, position='START', length=1.0)),
    # A shutter opening linearly (density ~ t): the ball lingers toward the shutter's end, so both
    # edges move that way and the ramps narrow (the middle 80 % of the time covers less of the sweep).
    "curve_ramp": (dict(what="object", velocity=0.8), dict(CENTER, curve=[(0.0, 0.0), (0.5, 0.5), (1.0, 1.0)])),
}


def row_profile(alpha):
    """Alpha averaged over the strip's rows, and the pixel centres' x."""
    a = alpha.mean(axis=0)
    return np.arange(len(a)) + 0.5, a


def rising(x, a, level):
    """The first x where a(x) rises through `level` (linear between pixels)."""
    i = np.flatnonzero(a >= level)[0]
    assert i > 0, "the profile starts above %g" % level
    return x[i - 1] + (level - a[i - 1]) / (a[i] - a[i - 1]) * (x[i] - x[i - 1])


def falling(x, a, level):
    """The last x where a(x) falls through `level`."""
    i = np.flatnonzero(a >= level)[-1]
    assert i + 1 < len(a), "the profile never falls below %g" % level
    return x[i] + (a[i] - level) / (a[i] - a[i + 1]) * (x[i + 1] - x[i])


def edges(alpha):
    """{left, right}: (ramp width 10 -> 90 %, 50 % crossing); and the extent between the 5 % crossings."""
    x, a = row_profile(alpha)
    left = (rising(x, a, 0.9) - rising(x, a, 0.1), rising(x, a, 0.5))
    right = (falling(x, a, 0.1) - falling(x, a, 0.9), falling(x, a, 0.5))
    return dict(left=left, right=right), falling(x, a, 0.05) - rising(x, a, 0.05)


@pytest.mark.parametrize("case", CASES, ids=list(CASES))
def test_blur_profile_matches_cycles(run_bpy, tmp_path, case):
    motion, shutter = CASES[case]
    r = run_bpy("motion_blur.blurred_ball", args=dict(size=SIZE, camera=CAMERA, motion=motion, shutter=shutter,
                                                      cycles_samples=512, unbound_samples=256), timeout=600)
    alpha = dict(np.load(tmp_path / "alpha.npz"))
    (cyc, extent_c), (unb, extent_u) = edges(alpha["cycles"]), edges(alpha["unbound"])
    lines, failures = [], []
    for side in ("left", "right"):
        (w_c, e_c), (w_u, e_u) = cyc[side], unb[side]
        lines.append("%s edge: ramp Cycles %.2f px, Unbound %.2f px (%+.1f %%); 50 %% at %.2f / %.2f px"
                     % (side, w_c, w_u, 100 * (w_u / w_c - 1), e_c, e_u))
        if not (w_c >= MIN_RAMP and abs(w_u - w_c) <= WIDTH_TOL * w_c and abs(e_u - e_c) <= EDGE_TOL):
            failures.append(lines[-1])
    lines.append("extent (5 %% crossings): Cycles %.2f px, Unbound %.2f px" % (extent_c, extent_u))
    if abs(extent_u - extent_c) > EXTENT_TOL:
        failures.append(lines[-1])
    sharp = edges(alpha["unblurred"])[0]
    lines.append("unblurred ramps %.2f / %.2f px" % (sharp["left"][0], sharp["right"][0]))
    print("%s: seconds %s (Unbound's scene evaluation at the samples' times %.3f s, its rendering %.3f s)\n  %s"
          % (case, r["seconds"], r["blur_seconds"], r["render_seconds"], "\n  ".join(lines)))
    assert not failures, failures
    assert max(sharp["left"][0], sharp["right"][0]) <= 1.5, sharp
    # Blender is back at the frame after the render: frame, subframe and the evaluated motion.
    after = r["after"]
    assert (after["frame"], after["subframe"]) == (1, 0.0), after
    assert after["evaluated_x"] == pytest.approx(after["x"], abs=1e-6), after


# Keyframed mu[1]: 0.4 at frame 0, 1.2 at frame 2; a whole frame's shutter (mu 0.6 ... 1.0).
MU_KEYS = {"0": 0.4, "2": 1.2}
MU_SIZE = (64, 48)
MU_SAMPLES = 64
# Mean |difference| of RGBA over the image, and its 99.5th percentile: the blurred frame against
# the mean at the sample times (the same times: only the anti-aliasing pattern differs) and at 48
# sub-frames (4 samples each: time sampled differently too).
MU_TOL = {"at_sample_times": (0.004, 0.045), "at_subframes": (0.009, 0.09)}
# The unblurred frame is at least this many times further from either mean (mean |difference|).
MU_SENSITIVITY = 4.0


def test_keyframed_mu_is_blurred_over_the_shutter(run_bpy, tmp_path):
    r = run_bpy("motion_blur.keyframed_mu", args=dict(size=MU_SIZE, samples=MU_SAMPLES,
                                                      shutter=dict(position='CENTER', length=1.0), mu_keys=MU_KEYS,
                                                      subframes=48), timeout=600)
    c = dict(np.load(tmp_path / "combined.npz"))
    times = r["times"]
    assert len(times) == MU_SAMPLES and min(times) >= 0.5 and max(times) <= 1.5, times
    failures = []
    for reference, (mean_tol, tail_tol) in MU_TOL.items():
        diff = np.abs(c["blurred"] - c[reference])
        unblurred = float(np.abs(c["unblurred"] - c[reference]).mean())
        mean, tail = float(diff.mean()), float(np.percentile(diff, 99.5))
        line = ("%s: mean |diff| %.4f (tolerance %.4f), 99.5th percentile %.4f (%.3f); unblurred frame %.4f"
                % (reference, mean, mean_tol, tail, tail_tol, unblurred))
        print(line)
        if not (mean <= mean_tol and tail <= tail_tol and unblurred >= MU_SENSITIVITY * mean):
            failures.append(line)
    print("scene evaluation at the samples' times %.3f s, rendering %.3f s" % (r["blur_seconds"], r["render_seconds"]))
    assert not failures, failures
    assert r["after"] == dict(frame=1, subframe=0.0, mu=pytest.approx(0.8)), r["after"]


def test_same_bits_without_motion_and_one_sample(run_bpy):
    """Blur on with nothing moving is the render without blur, bit for bit; one sample renders
    the shutter's middle (START: a quarter frame on) unblurred, and says that blur needs samples."""
    r = run_bpy("motion_blur.same_bits_without_motion", args=dict(size=(64, 48), samples=4))
    assert r["channels"] >= 10 and all(r["identical"].values()), r["identical"]
    assert r["one_sample_at_middle"] and not r["one_sample_at_frame"]
    assert "Warning: Unbound: motion blur needs 2 or more samples" in r["_output"]


def test_esc_keeps_the_blurred_samples_done(run_bpy):
    """Esc during a blurred render (a moving fractal, 8 samples): the samples done equal a blurred
    render of that many samples, bit for bit (each sample's time is a function of its index alone,
    not of the sample count), and the frame is restored."""
    r = run_bpy("f12.esc_keeps_the_samples_done", args={"samples": 8, "at": 0.5, "motion_blur": True})
    assert r["stats"]["cancelled"] and r["breaks"] >= 1 and 3 <= r["done"] <= 5, r["stats"]
    assert len(r["channels"]) >= 12 and all(r["identical"].values()), r["diffs"]
    assert r["frame"] == [1, 0.0], r["frame"]


def test_zero_shutter_curve_refused_and_stereo_blurred(run_bpy):
    """A shutter curve at zero everywhere lets no light in: F12 fails with a message saying where
    to fix it, and no file is written. Stereo 3D with blur: each eye blurred (differs from its
    unblurred render), the eyes differ, the frame restored."""
    r = run_bpy("motion_blur.refusals_and_stereo")
    assert r["zero_curve"] == ["Error: Unbound: the motion blur's shutter curve is zero everywhere: no light reaches "
                               "the film (Render Properties > Motion Blur > Shutter Curve)", False], r["zero_curve"]
    assert r["views_differ"] and r["blur_changes"] == [True, True], r
    assert r["frame"] == [1, 0.0], r["frame"]
