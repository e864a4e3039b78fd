"""Depth of field is Cycles' depth of field (issue 19).

One bpy process per case renders the same scene through Blender's pipeline twice, with the
camera's depth of field on: Cycles renders a fine UV sphere mesh (the unit sphere), Unbound the
unit ball (mu = 0). The camera looks at the ball's centre, so its silhouette is a circle; out of
focus, the edge is blurred by the aperture's image, and the alpha across the edge ramps from 1 to
0. If Unbound's thin lens is Cycles' (aperture radius from focal length and f-stop, the plane in
focus at the focus distance or the focus object's distance along the view axis, the aperture's
polygon, rotation and anamorphic ratio), the two ramps have the same width.

Measured: alpha as a function of the distance r from the ball's image centre, averaged over the
pixels of an angular sector (the whole circle for a disk aperture; eight 45-degree sectors for
the polygonal, anamorphic one, whose blur differs by direction), in bins of BIN pixels; the
ramp's width is the distance between its 90 % and 10 % crossings (linear interpolation between
bins). Both engines use a one-pixel box filter (Cycles' Box, width 1; Unbound's stratified
jitter). Checks, per profile:

* ramp width: |Unbound - Cycles| <= WIDTH_TOL (5 %) of Cycles';
* the edge's place, the 50 % crossing: within EDGE_TOL pixels (a polygon's corners push it out
  and its sides pull it in, so this sees the polygon's turn);
* the ramp is wide enough (>= MIN_RAMP pixels) for the 5 % to mean something: a pinhole's ramp
  is about one pixel.

The noise of the estimate (per-pixel alpha noise ~ 0.5 / sqrt(samples), averaged over the
sector's pixels in a bin) moves a crossing by a few hundredths of a pixel at these sample counts
(Cycles 512, Unbound 256). Measured (printed with pytest -s): ramp widths 11.72 vs Cycles' 11.71 px
(focus distance), 9.95 vs 9.94 (focus object), 6.78-12.64 vs 6.79-12.58 over the eight sectors of
the anamorphic pentagon (at most 0.8 % apart), 9.92-10.24 vs 9.91-10.25 for the triangle (0.6 %);
the 50 % edges within 0.05 px. A disk instead of the pentagon measured 14-17 % wider, a ratio of
1 instead of 2 up to 89 %, and the triangle turned the other way moves edges by up to 1 px.
Renders: Unbound 2.5-4 s, Cycles 6-13 s (bpy 4.2, 2 shared cores).
"""
import math

import numpy as np
import pytest

SIZE = (160, 120)
CAMERA = dict(location=(0.0, -5.0, 0.0), lens=50.0)
BIN = 0.5
WIDTH_TOL = 0.05
EDGE_TOL = 0.15
MIN_RAMP = 4.0

# id: (depth-of-field settings, focus object location or None, angular sectors)
CASES = {
    # In focus at 2.5 (the ball's silhouette is at about 4.8 along the view axis).
    "focus_distance": (dict(focus_distance=2.5, aperture_fstop=0.125), None, 1),
    # The focus object's distance along the view axis is 3.2 (its offset across the axis must not count).
    "focus_object": (dict(focus_distance=50.0, aperture_fstop=0.08), (0.4, -1.8, -0.3), 1),
    # Five blades turned by 0.4 rad, the aperture's width halved by the anamorphic ratio 2.
    "blades_rotation_ratio": (dict(focus_distance=2.5, aperture_fstop=0.1, aperture_blades=5,
                                   aperture_rotation=0.4, aperture_ratio=2.0), None, 8),
    # A pentagon's blur hardly depends on its turn; a triangle's does: its corners push the 50 %
    # edge out by about 0.5 pixel against its sides, so a turn the wrong way moves it by 1 pixel.
    "triangle_rotation": (dict(focus_distance=2.5, aperture_fstop=0.1, aperture_blades=3, aperture_rotation=0.4),
                          None, 8),
}


def radial_profiles(alpha, sectors):
    """Per sector: (bin centres, mean alpha) over the pixels whose direction from the image centre
    lies in it (sector k centred on angle 2 pi k / sectors)."""
    h, w = alpha.shape
    ys, xs = np.mgrid[0:h, 0:w]
    dx, dy = xs + 0.5 - w / 2, ys + 0.5 - h / 2
    r, angle = np.hypot(dx, dy), np.arctan2(dy, dx)
    bins = np.floor(r / BIN).astype(int)
    profiles = []
    for k in range(sectors):
        centre = 2 * math.pi * k / sectors
        inside = np.abs((angle - centre + math.pi) % (2 * math.pi) - math.pi) <= math.pi / sectors
        count = np.bincount(bins[inside], minlength=bins.max() + 1)
        total = np.bincount(bins[inside], weights=alpha[inside], minlength=bins.max() + 1)
        used = count > 0
        profiles.append(((np.arange(len(count))[used] + 0.5) * BIN, total[used] / count[used]))
    return profiles


def crossing(r, a, level):
    """The outermost r where the profile a(r) (1 inside, 0 outside) falls through `level`."""
    above = np.flatnonzero(a >= level)
    i = above[-1]
    assert i + 1 < len(a), "the profile never falls below %g" % level
    return r[i] + (a[i] - level) / (a[i] - a[i + 1]) * (r[i + 1] - r[i])


def ramp(r, a):
    """(width of the 90 % -> 10 % ramp, place of the 50 % crossing), pixels."""
    return crossing(r, a, 0.1) - crossing(r, a, 0.9), crossing(r, a, 0.5)


@pytest.mark.parametrize("case", CASES, ids=list(CASES))
def test_blurred_silhouette_matches_cycles(run_bpy, tmp_path, case):
    dof, focus_object, sectors = CASES[case]
    r = run_bpy("depth_of_field.blurred_ball", args=dict(size=SIZE, camera=CAMERA, dof=dof, focus_object=focus_object,
                                                         cycles_samples=512, unbound_samples=256), timeout=600)
    alpha = {k: v for k, v in np.load(tmp_path / "alpha.npz").items()}
    lines = []
    failures = []
    for k, (cyc, unb) in enumerate(zip(radial_profiles(alpha["cycles"], sectors),
                                       radial_profiles(alpha["unbound"], sectors))):
        (w_c, e_c), (w_u, e_u) = ramp(*cyc), ramp(*unb)
        lines.append("sector %d: ramp width Cycles %.2f px, Unbound %.2f px (%+.1f %%); 50 %% edge %.2f / %.2f px"
                     % (k, w_c, w_u, 100 * (w_u / w_c - 1), e_c, e_u))
        if not (w_c >= MIN_RAMP and abs(w_u - w_c) <= WIDTH_TOL * w_c and abs(e_u - e_c) <= EDGE_TOL):
            failures.append(lines[-1])
    print("%s: %s; render seconds %s\n  %s" % (case, r["camera"], r["seconds"], "\n  ".join(lines)))
    assert not failures, failures
