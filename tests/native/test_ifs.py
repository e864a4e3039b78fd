"""3-D iterated function systems (kind "ifs", section 5.3): the distance bound through the
bounding-ball hierarchy of native/src/ifs.c.

References (reference/families64.py, float64, independent of the native code): attractor points
by the chaos game, the ball hierarchy rebuilt with SVD norms, its leaf balls enumerated, and ray
entries into those balls in closed form."""
import math

import numpy as np
import pytest
import unbound_core as uc

from conftest import HEAVY_SHADING, KERNELS, estimate, make_camera, pixel_rays, render
from reference import families64 as ref


def tetrahedron():
    return [[[0.5, 0, 0, 0.5 * x], [0, 0.5, 0, 0.5 * y], [0, 0, 0.5, 0.5 * z]]
            for x, y, z in ((1, 1, 1), (1, -1, -1), (-1, 1, -1), (-1, -1, 1))]


def menger():
    t = 1.0 / 3.0
    return [[[t, 0, 0, 2 * t * x], [0, t, 0, 2 * t * y], [0, 0, t, 2 * t * z]]
            for x in (-1, 0, 1) for y in (-1, 0, 1) for z in (-1, 0, 1) if abs(x) + abs(y) + abs(z) > 1]


def rotation(axis, angle):
    c, s = math.cos(angle), math.sin(angle)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    r = np.eye(3)
    r[i, i], r[i, j], r[j, i], r[j, j] = c, -s, s, c
    return r


def koch():
    """The add-on's Koch-like set: the Koch curve's maps, the spikes turned a quarter about x."""
    t, rise, spike = 1.0 / 3.0, math.sqrt(3) / 6, math.radians(60)
    maps = []
    for loc, rot in [((-2 * t, 0, 0), np.eye(3)), ((-1 / 6, 0, rise), rotation(1, -spike) @ rotation(0, math.pi / 2)),
                     ((1 / 6, 0, rise), rotation(1, spike) @ rotation(0, math.pi / 2)), ((2 * t, 0, 0), np.eye(3))]:
        a = rot * t
        maps.append(np.column_stack([a, loc]).tolist())
    return maps


def random_affine(seed=4, count=5):
    """General affine maps: rotations, non-uniform scales (one mirrored), shear, spread out."""
    rng = np.random.default_rng(seed)
    maps = []
    for k in range(count):
        q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        a = q @ np.diag(rng.uniform(0.25, 0.55, 3) * (-1 if k == 0 else 1)) @ (np.eye(3) + 0.2 * rng.normal(size=(3, 3)))
        a *= 0.6 / max(0.6, np.linalg.svd(a, compute_uv=False)[0])
        maps.append(np.column_stack([a, rng.uniform(-1, 1, 3)]).tolist())
    return maps


SYSTEMS = {"sierpinski": tetrahedron(), "menger": menger(), "koch": koch(), "random affine": random_affine()}


def query_points(system, rng, count=1000):
    """Points all around the attractor: uniform in its bounding box (grown), and near it."""
    samples = system.chaos_game(count, seed=int(rng.integers(1 << 30)))
    lo, hi = samples.min(0) - 0.5, samples.max(0) + 0.5
    near = samples + rng.normal(size=samples.shape) * rng.uniform(0.001, 0.2, (count, 1))
    return np.concatenate([rng.uniform(lo, hi, (count, 3)), near])


def test_exact_and_bounding_ball():
    d = uc.describe(dict(kind="ifs", maps=menger()))
    assert d["exact"] and d["kind"] == "ifs"
    # The Menger maps fix the cube's corners and edge midpoints; their centroid is 0, and the
    # smallest ball they map into itself is the cube's circumscribed ball.
    np.testing.assert_allclose(d["bound_center"], 0, atol=1e-12)
    assert d["bound_radius"] == pytest.approx(math.sqrt(3), rel=1e-8)


@pytest.mark.parametrize("name", list(SYSTEMS))
def test_bound_never_exceeds_distance_to_the_attractor(name):
    """The bound at every depth is at most the distance to any attractor point (chaos game,
    20000 points): the unbounding-sphere property that makes the march safe."""
    rng = np.random.default_rng(1)
    system = ref.IFS(SYSTEMS[name])
    attractor = system.chaos_game(20000, seed=2)
    points = np.float32(query_points(system, rng))
    nearest = ref.leaf_distance(points.astype(np.float64), attractor, np.zeros(len(attractor)))
    for depth in (0, 2, 5):
        est, _, _ = estimate(dict(kind="ifs", maps=SYSTEMS[name], ifs_depth=depth), points)
        # float32 rounding of the returned bound: relative 1e-6.
        assert np.all(est <= nearest + 1e-6 * (1 + np.abs(nearest))), \
            f"depth {depth}: bound exceeds the attractor distance by {np.max(est - nearest):.3g}"


@pytest.mark.parametrize("name,depth", [("sierpinski", 4), ("menger", 2), ("koch", 2), ("random affine", 3)])
def test_bound_is_the_leaf_balls_distance(name, depth):
    """Against the enumerated leaf balls of the same depth: inside them the bound is their signed
    distance; outside, the search may settle early (a ball at most a quarter of its distance
    wide: factor 1.5) and settle near-ties (factor 1.25), so it lies within a factor 1.875."""
    rng = np.random.default_rng(3)
    system = ref.IFS(SYSTEMS[name])
    centres, radii = system.leaves(depth)
    est, _, pts = estimate(dict(kind="ifs", maps=SYSTEMS[name], ifs_depth=depth), query_points(system, rng))
    leaf = ref.leaf_distance(pts, centres, radii)
    tol = 1e-5 * (1 + np.abs(leaf))
    assert np.all(est <= leaf + tol)
    outside = leaf > 0
    assert np.all(est[outside] >= leaf[outside] / 1.875 - tol[outside])
    inside = leaf < 0
    assert inside.sum() > 100
    np.testing.assert_allclose(est[inside], leaf[inside], atol=1e-5)


def ray_entry(origin, direction, centres, radii):
    """Closed-form first entry t of each ray into the union of balls (inf: none)."""
    rel = origin[:, None, :] - centres[None]
    b = np.einsum("rkc,rc->rk", rel, direction)
    c = np.einsum("rkc,rkc->rk", rel, rel) - radii[None] ** 2
    disc = b * b - c
    t = np.where(disc >= 0, -b - np.sqrt(np.maximum(disc, 0)), np.inf)
    t = np.where((disc >= 0) & (t < 0) & (-b + np.sqrt(np.maximum(disc, 0)) >= 0), 0.0, t)
    return np.where(t >= 0, t, np.inf).min(axis=1)


@pytest.mark.parametrize("name,depth", [("sierpinski", 4), ("sierpinski", 6), ("menger", 2), ("menger", 3), ("koch", 2),
                                        ("random affine", 3)])
def test_hits_are_the_leaf_balls(name, depth):
    """Rendered with a fixed threshold eps: every ray that enters a leaf ball hits, never beyond
    its entry into the balls, for nearly every ray at its entry into the balls grown by eps
    (bisection refines it; a ray grazing the eps-shell may pass that sliver), and no ray hits that
    stays eps away."""
    eps = 2e-3
    system = ref.IFS(SYSTEMS[name])
    centres, radii = system.leaves(depth)
    # The Koch curve is thin: a closer view.
    eye = (0.3, -2.2, 0.9) if name == "koch" else (-1.8, -3.6, 1.6)
    cam = make_camera(40, 30, eye=eye, target=tuple(system.center), fov_y=0.75)
    obj = dict(kind="ifs", maps=SYSTEMS[name], ifs_depth=depth, threshold_mode="fixed", epsilon=eps)
    passes, _ = render(cam, [obj], ["alpha", "position"])
    origin, direction = (a.reshape(-1, 3) for a in pixel_rays(cam))
    t_set = ray_entry(origin, direction, centres, radii)
    t_shell = ray_entry(origin, direction, centres, radii + eps)
    hit = passes["alpha"].reshape(-1) == 1
    t_hit = np.linalg.norm(passes["position"].reshape(-1, 3) - origin, axis=1)
    assert np.isfinite(t_set).sum() > 100
    assert not np.any(np.isfinite(t_set) & ~hit), "a ray passed through a leaf ball"
    assert not np.any(hit & ~np.isfinite(ray_entry(origin, direction, centres, radii + 1.01 * eps)))
    found = np.isfinite(t_set)
    assert np.all(t_hit[found] <= t_set[found] + 1e-4)
    assert np.mean(np.abs(t_hit[found] - t_shell[found]) < 2e-4) > 0.98


def test_bad_maps_are_rejected():
    expanding = [[[1.2, 0, 0, 0], [0, 0.5, 0, 0], [0, 0, 0.5, 0]]]
    with pytest.raises(ValueError, match="contraction"):
        uc.describe(dict(kind="ifs", maps=expanding))
    with pytest.raises(ValueError, match="1 to 32"):
        uc.describe(dict(kind="ifs", maps=[]))
    with pytest.raises(ValueError, match="1 to 32"):
        uc.describe(dict(kind="ifs", maps=tetrahedron() * 9))
    with pytest.raises(ValueError, match="finite|number"):
        uc.describe(dict(kind="ifs", maps=[[[0.5, 0, 0, float("nan")], [0, 0.5, 0, 0], [0, 0, 0.5, 0]]]))
    with pytest.raises(ValueError):
        uc.describe(dict(kind="ifs", ifs_depth=17))


def test_many_nearly_equal_maps_stay_a_lower_bound():
    """32 nearly equal maps of ratio 0.9 at depth 16 overlap almost completely (the search would
    split nodes without end); the split budget settles them, and the result is still no more
    than the distance to the attractor. A NaN point gives NaN (never a hit)."""
    rng = np.random.default_rng(8)
    maps = [[[0.9 + 1e-3 * rng.normal(), 0, 0, 0.05 * rng.normal()], [0, 0.9, 0, 0.05 * rng.normal()],
             [0, 0, 0.9, 0]] for _ in range(32)]
    system = ref.IFS(maps)
    attractor = system.chaos_game(5000, seed=3)
    pts = np.concatenate([attractor[:200] + 0.01, rng.uniform(-1, 1, (200, 3))])
    est, _, p64 = estimate(dict(kind="ifs", maps=maps, ifs_depth=16), pts)
    nearest = ref.leaf_distance(p64, attractor, np.zeros(len(attractor)))
    assert np.all(est <= nearest + 1e-6)
    est, _, _ = estimate(dict(kind="ifs", ifs_depth=16), [(np.nan, 0, 0), (0.5, 0.5, 0.5)])
    assert np.isnan(est[0]) and np.isfinite(est[1])


def test_nan_points_have_a_defined_escape_count():
    """A NaN point's settled depth is 0 whatever the other lanes of its packet hold (it was left
    unset, and showed the previous lane's count)."""
    sponge = dict(kind="ifs", ifs_depth=8)
    near = [(0.3, 0.2, 0.1)] * 3
    for layout in ([near[0], (np.nan, 0, 0)] * 4, near + [(np.nan, np.nan, np.nan)] * 5):
        est, iters, _ = estimate(sponge, layout)
        nan_rows = np.isnan(np.asarray(layout, float)).any(axis=1)
        assert np.isnan(est[nan_rows]).all() and (iters[~nan_rows] > 0).all()
        assert (iters[nan_rows] == 0).all(), iters


# -- mirror-symmetric pieces: one path down the hierarchy (ifs.c detect_mirror_pieces) ---------------

def moved(maps, rotation_matrix, offset):
    """The same system seen through a rigid motion M x = Q x + o: maps M w M^-1."""
    q, o = np.asarray(rotation_matrix), np.asarray(offset)
    out = []
    for m in np.asarray(maps, float):
        a, t = m[:, :3], m[:, 3]
        a2 = q @ a @ q.T
        out.append(np.column_stack([a2, q @ t + o - a2 @ o]).tolist())
    return out


def cantor_pair():
    """Two maps of ratio 0.3 on a line: the pieces are mirror images in the plane between them."""
    return [[[0.3, 0, 0, -0.7], [0, 0.3, 0, 0.2], [0, 0, 0.3, 0.1]], [[0.3, 0, 0, 0.7], [0, 0.3, 0, 0.2], [0, 0, 0.3, 0.1]]]


MIRROR = {"sierpinski": tetrahedron(),
          "sierpinski moved": moved(tetrahedron(), rotation(2, 0.7) @ rotation(0, -0.4), (0.3, -0.2, 0.5)),
          "cantor pair": cantor_pair()}


def test_mirror_pieces_are_detected_only_where_they_hold():
    """The one-path estimate applies to homotheties of one ratio whose pieces are pairwise mirror
    images (the Sierpinski tetrahedron, also turned and moved; two maps); not where some pair is not
    (the Menger sponge: two corner cubes are mirror images only through a plane that is no symmetry
    of the sponge), nor to pieces that overlap, rotations, unequal or mirrored ratios, a vertex
    moved."""
    for name, maps in MIRROR.items():
        assert uc.describe(dict(kind="ifs", maps=maps))["ifs_mirror"], name
    skewed = tetrahedron()
    skewed[3][0][3] = 0.4
    unequal = tetrahedron()
    unequal[0] = [[0.4, 0, 0, 0.6], [0, 0.4, 0, 0.6], [0, 0, 0.4, 0.6]]
    flipped = [[[-0.5, 0, 0, x], [0, -0.5, 0, y], [0, 0, -0.5, z]] for x, y, z in ((1, 1, 1), (1, -1, -1), (-1, 1, -1), (-1, -1, 1))]
    stretched = tetrahedron()
    stretched[1][2][2] = 0.45
    # Ratio 0.6: the pieces overlap across the bisecting planes (mirror images, but not each on its
    # own side), so the nearest v_i no longer marks the nearest piece.
    overlapping = [[[0.6, 0, 0, 0.4 * x], [0, 0.6, 0, 0.4 * y], [0, 0, 0.6, 0.4 * z]]
                   for x, y, z in ((1, 1, 1), (1, -1, -1), (-1, 1, -1), (-1, -1, 1))]
    for name, maps in [("overlapping", overlapping), ("menger", menger()), ("koch", koch()), ("random affine", random_affine()), ("skewed", skewed),
                       ("unequal ratios", unequal), ("ratio -1/2", flipped), ("stretched", stretched)]:
        assert not uc.describe(dict(kind="ifs", maps=maps))["ifs_mirror"], name
    assert not uc.describe(dict(kind="quaternion_julia"))["ifs_mirror"]
    # Ratio 1/20: mirror pieces, but at depth 16 the path's point would grow by 20^16 (float
    # overflow): the search. At depth 5, one path.
    steep = [[[0.05, 0, 0, x], [0, 0.05, 0, y], [0, 0, 0.05, z]] for x, y, z in ((1, 1, 1), (1, -1, -1), (-1, 1, -1), (-1, -1, 1))]
    assert not uc.describe(dict(kind="ifs", maps=steep, ifs_depth=16))["ifs_mirror"]
    assert uc.describe(dict(kind="ifs", maps=steep, ifs_depth=5))["ifs_mirror"]
    # Far points (beyond 1e6 radii) settle at the root ball: finite, within float rounding.
    far = np.array([[3e8, 1.0, 2.0], [-1e7, 0.0, 0.0]])
    est, _, pts = estimate(dict(kind="ifs", maps=tetrahedron(), ifs_depth=16), far)
    np.testing.assert_allclose(est, np.linalg.norm(pts, axis=1) - math.sqrt(3), rtol=1e-6)


@pytest.mark.parametrize("name", list(MIRROR))
def test_mirror_estimate_is_the_leaf_balls_distance_everywhere(name):
    """Mirror pieces: for a point on v_i's side of the plane bisecting v_i, v_j, every leaf ball
    of piece j has its mirror image in piece i with a centre no farther, so the nearest leaf ball
    lies down the path of the nearest v's, and the one-path estimate is the signed distance to the
    union of all leaf balls, min |p - c| - r over the m^depth balls (float64, enumerated), not only
    inside them (the search settles early outside): equal up to float32 rounding, at every depth
    up to the add-on's 7, all around the set and far from it. And never more than the distance to
    the attractor (chaos game, 20000 points)."""
    rng = np.random.default_rng(11)
    system = ref.IFS(MIRROR[name])
    attractor = system.chaos_game(5000, seed=5)
    points = np.concatenate([query_points(system, rng, 500),
                             system.center + rng.normal(size=(100, 3)) * 20.0])
    for depth in range(8):
        centres, radii = system.leaves(depth)
        est, iters, pts = estimate(dict(kind="ifs", maps=MIRROR[name], ifs_depth=depth), points)
        leaf = ref.leaf_distance(pts, centres, radii, chunk=256)
        # float32: the point as read and about 10 roundings of the path, relative to the ball's size.
        np.testing.assert_allclose(est, leaf, rtol=2e-6, atol=2e-6 * system.radius, err_msg=f"depth {depth}")
        assert (iters == depth).all()
    nearest = ref.leaf_distance(pts, attractor, np.zeros(len(attractor)), chunk=256)
    assert np.all(est <= nearest + 2e-6 * (system.radius + np.abs(nearest)))


def test_mirror_estimate_against_the_general_search():
    """The same Sierpinski tetrahedron with one map's matrix off by 1e-10 (not a homothety: the
    general branch and bound): the search's bound lies within its factor 1.875 below the leaf-ball
    distance, so below the one-path estimate and within that factor of it."""
    near_copy = tetrahedron()
    near_copy[0][0][1] = 1e-10
    assert not uc.describe(dict(kind="ifs", maps=near_copy))["ifs_mirror"]
    search_below_one_path(tetrahedron(), near_copy, (3, 7), seed=12)


def search_below_one_path(maps, near_copy, depths, seed):
    """At 2000 points near the attractor of `maps`, per depth: the general search's bound (on
    near_copy, which takes the search) lies below the one-path estimate of `maps`, within the
    search's factor 1.875 of it outside the balls and equal to it inside. Returns (one path,
    search, tolerance) per depth."""
    points = query_points(ref.IFS(maps), np.random.default_rng(seed), 2000)
    results = []
    for depth in depths:
        one_path, _, _ = estimate(dict(kind="ifs", maps=maps, ifs_depth=depth), points)
        search, _, _ = estimate(dict(kind="ifs", maps=near_copy, ifs_depth=depth), points)
        tol = 2e-5 * (1 + np.abs(one_path))
        assert np.all(search <= one_path + tol)
        outside = one_path > 0
        assert np.all(search[outside] >= one_path[outside] / 1.875 - tol[outside])
        np.testing.assert_allclose(search[~outside], one_path[~outside], atol=2e-5)
        results.append((one_path, search, tol))
    return results


# -- the cube's symmetries: one path after a fold (ifs.c detect_folded_pieces) ---------------------

def grid_sponge(cells, k):
    """Maps of ratio 1/k onto the cells (integer grid indices, centred: -(k-1)/2 .. (k-1)/2 in
    steps of 1) of the cube [-1, 1]^3 cut into k^3."""
    s = 1.0 / k
    return [[[s, 0, 0, 2 * s * a], [0, s, 0, 2 * s * b], [0, 0, s, 2 * s * c]] for a, b, c in cells]


def cube_cells(k, keep):
    """The cells of a k-grid kept by keep(sorted |indices|, descending): a pattern with the cube's
    48 symmetries."""
    half = (k - 1) / 2
    axis = [i - half for i in range(k)]
    return [(a, b, c) for a in axis for b in axis for c in axis
            if keep(sorted((abs(a), abs(b), abs(c)), reverse=True))]


FOLDED = {
    "menger": menger(),
    # The same sponge in another order of the maps, moved and grown (x -> 2.5 x + o).
    "menger moved": [[[t[0][0], 0, 0, 2.5 * t[0][3] + 0.3 * (1 - t[0][0])],
                      [0, t[1][1], 0, 2.5 * t[1][3] - 1.1 * (1 - t[0][0])],
                      [0, 0, t[2][2], 2.5 * t[2][3] + 0.7 * (1 - t[0][0])]] for t in menger()[::-1]],
    # As the add-on stores it: in float32 (ratio 0.33333334, offsets 0.6666667), so that the pieces
    # overlap by 3e-8 across the planes between them (detect_folded_pieces' tolerance).
    "menger float32": np.float64(np.float32(menger())).tolist(),
    # Edges and face centres of the 3-grid (no corners): wedge pieces (1, 1, 0) and (1, 0, 0).
    "edges and faces": grid_sponge(cube_cells(3, lambda u: u[1] == 1 or (u[0] == 1 and u[1] == 0)), 3),
    # The frame of a 4-grid (cells with two indices at the edge): wedge pieces (3/2, 3/2, 3/2),
    # (3/2, 3/2, 1/2).
    "4-grid frame": grid_sponge(cube_cells(4, lambda u: u[1] == 1.5), 4),
    # All 8 cells of a 2-grid (the solid cube): one wedge piece.
    "2-grid cube": grid_sponge(cube_cells(2, lambda u: True), 2),
}


def test_folded_pieces_are_detected_only_where_they_hold():
    """The folded estimate applies to homotheties of one ratio whose fixed points have the cube's 48
    symmetries about their centre, where the pieces outside the wedge x >= y >= z >= 0 lie beyond
    one of its walls and the wedge's pieces are pairwise mirror images: the Menger sponge (also
    moved, grown, its maps in another order, in float32 as the add-on stores it) and other
    patterns of a grid. Not: the corners with the body centre (wedge pieces (1, 1, 1) and
    (0, 0, 0) are mirror images only through a plane that is no symmetry), a map missing or
    moved, a matrix off by 1e-10, pieces overlapping by 2e-5 (ratio 0.33334; the float32 sponge's
    overlap by 3e-8 is admitted), the sponge turned (the fold is along the axes: the search), nor
    where the mirror path holds (the tetrahedron, whose path takes precedence)."""
    for name, maps in FOLDED.items():
        d = uc.describe(dict(kind="ifs", maps=maps))
        assert d["ifs_folded"] and not d["ifs_mirror"], name
    corners_and_body = grid_sponge(cube_cells(3, lambda u: u[2] == 1 or u[0] == 0), 3)
    missing = menger()[1:]
    moved_map = menger()
    moved_map[5][1][3] += 1e-4
    near_copy = menger()
    near_copy[0][0][1] = 1e-10
    turned = moved(menger(), rotation(2, 0.3), (0, 0, 0))
    # Ratio 0.33334: neighbouring pieces overlap by 2e-5, beyond the tolerance for float32 maps.
    grown = [[[0.33334 if r == c else 0.0 for c in range(3)] + [m[r][3]] for r in range(3)] for m in menger()]
    for name, maps in [("corners and body", corners_and_body), ("a map missing", missing), ("a map moved", moved_map),
                       ("a matrix off", near_copy), ("turned", turned), ("pieces overlapping", grown), ("koch", koch()),
                       ("sierpinski", tetrahedron())]:
        assert not uc.describe(dict(kind="ifs", maps=maps))["ifs_folded"], name
    # Far points settle at the root ball: finite, within float rounding.
    far = np.array([[3e8, 1.0, 2.0], [-1e7, 0.0, 0.0]])
    est, _, pts = estimate(dict(kind="ifs", maps=menger(), ifs_depth=4), far)
    np.testing.assert_allclose(est, np.linalg.norm(pts, axis=1) - math.sqrt(3), rtol=1e-6)


@pytest.mark.parametrize("name", list(FOLDED))
def test_folded_estimate_is_the_leaf_balls_distance_everywhere(name):
    """The folded path is the signed distance to the union of all leaf balls, min |p - c| - r over
    the m^depth balls (float64, enumerated: 160 000 for the sponge at the add-on's depth 4), not
    only inside them (the search settles early outside, within its factor 1.875): equal up to
    float32 rounding at every depth up to 4 (3 for the other patterns, up to 32 maps), all around
    the set, near it and far from it. And never more than the distance to the attractor (chaos
    game, 5000 points)."""
    rng = np.random.default_rng(21)
    system = ref.IFS(FOLDED[name])
    attractor = system.chaos_game(5000, seed=6)
    points = np.concatenate([query_points(system, rng, 300),
                             system.center + rng.normal(size=(60, 3)) * 20.0])
    assert uc.describe(dict(kind="ifs", maps=FOLDED[name], ifs_depth=4))["ifs_folded"]
    deepest = 4 if name.startswith("menger") else 3
    for depth in range(deepest + 1):
        centres, radii = system.leaves(depth)
        est, iters, pts = estimate(dict(kind="ifs", maps=FOLDED[name], ifs_depth=depth), points)
        leaf = ref.leaf_distance(pts, centres, radii, chunk=16)
        np.testing.assert_allclose(est, leaf, rtol=2e-6, atol=2e-6 * system.radius, err_msg=f"depth {depth}")
        assert (iters == depth).all()
        # Outside the balls the search's settled bound is below this by up to its factor 1.875;
        # points within that margin make the test able to tell the two apart.
        if depth == deepest:
            assert np.mean((leaf > 0.01) & (leaf < 0.3)) > 0.1
    nearest = ref.leaf_distance(pts, attractor, np.zeros(len(attractor)), chunk=256)
    assert np.all(est <= nearest + 2e-6 * (system.radius + np.abs(nearest)))


def test_folded_estimate_against_the_general_search():
    """The Menger sponge with one map's matrix off by 1e-10 (the general branch and bound) against
    the folded path at the add-on's depth 4: the search's bound lies below the folded estimate
    (both bound the same leaf balls, the search from below), within its factor 1.875 of it outside
    the balls and equal inside; the folded one is strictly larger at many points outside (the
    search settles early), so the two differ and the folded path is the one the sponge takes."""
    near_copy = menger()
    near_copy[0][0][1] = 1e-10
    assert not uc.describe(dict(kind="ifs", maps=near_copy))["ifs_folded"]
    for folded, search, tol in search_below_one_path(menger(), near_copy, (2, 4), seed=22):
        outside = folded > 0
        assert np.mean(folded[outside] > 1.1 * search[outside] + tol[outside]) > 0.05


@pytest.mark.parametrize("name", ["sierpinski", "menger"])
def test_one_path_estimates_are_bit_identical_for_threads_tiles_and_simd(name):
    """The one-path estimates run in the kernels' vectors: every kernel and any thread count or
    tile size give the same bytes, with every effect (shadows, AO, reflections, sea, fog, glow) and
    the orbit trap (the path over all maps, for the sponge too)."""
    cam = make_camera(53, 37, eye=(-1.8, -3.6, 1.6))
    obj = dict(kind="ifs", maps=SYSTEMS[name], ifs_depth=6 if name == "sierpinski" else 4,
               color_mode="orbit_trap", reflectivity=0.3)
    ref_passes, ref_stats = render(cam, [obj], threads=1, tile_size=32, shading=HEAVY_SHADING)
    for threads, tile, simd in [(2, 13, KERNELS[-1]), (7, 1, "portable"), (3, 64, KERNELS[0]), (1, 32, KERNELS[1 % len(KERNELS)]),
                                (2, 32, KERNELS[-1])]:
        out, stats = render(cam, [obj], threads=threads, tile_size=tile, simd=simd, shading=HEAVY_SHADING)
        for k in ref_passes:
            assert ref_passes[k].tobytes() == out[k].tobytes(), (k, threads, tile, simd)
        assert stats["iterations"] == ref_stats["iterations"]
    assert (ref_passes["alpha"] > 0).mean() > 0.1
