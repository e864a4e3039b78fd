/* 3-D iterated function systems (section 5.3): a conservative distance bound to the attractor
 * through a hierarchy of bounding balls.
 *
 * If every map w_i(x) = A_i x + t_i sends the ball B = B(c, R) into itself, the attractor
 * A = U w_i(A) lies in B, hence in U w_i(B), and at depth k in the union over words
 * i_1..i_k of w_{i_1} o ... o w_{i_k}(B). Each such image is inside the ball of centre
 * w_word(c) and radius s_word R, s_word = s_{i_1} ... s_{i_k} >= ||A_word|| (s_i the operator
 * norm of A_i). So |p - centre| - radius, minimised over the balls of any cut through the
 * tree, never exceeds the distance from p to A: the bound a ray may step (section 3's
 * unbounding sphere). A child's ball lies inside its parent's (the same inequality one level
 * down), so a child's bound is never below its parent's: that makes the branch-and-bound
 * below exact with respect to the full-depth cut, up to the early settling it allows. */
#include "scene.h"
#include "ubmath.h"

#include <math.h>
#include <string.h>

/* Largest eigenvalue of a symmetric positive semi-definite 3x3 matrix, bounded from above
 * (power iteration gives a lower bound; Gershgorin an upper one): we take the closed form and
 * add a relative margin, since an underestimated norm would make the bound overshoot. */
static double max_eigenvalue_sym3(const double a[3][3])
{
    double lmin, lmax;
    ub_sym3_eigen_range(a, &lmin, &lmax);
    double gersh = 0.0;
    for (int i = 0; i < 3; i++)
        gersh = fmax(gersh, fabs(a[i][0]) + fabs(a[i][1]) + fabs(a[i][2]));
    return fmin(lmax * (1.0 + 1e-9) + 1e-300, gersh);
}

/* Cramer's rule. */
static int solve3(const double m[3][3], const double b[3], double x[3])
{
    double det = ub_det3(m);
    if (!(fabs(det) > 1e-300))
        return -1;
    for (int c = 0; c < 3; c++) {
        double t[3][3];
        memcpy(t, m, sizeof t);
        for (int r = 0; r < 3; r++)
            t[r][c] = b[r];
        x[c] = ub_det3((const double(*)[3])t) / det;
    }
    return 0;
}

static double dist3(const double a[3], const double b[3])
{
    double d0 = a[0] - b[0], d1 = a[1] - b[1], d2 = a[2] - b[2];
    return sqrt(d0 * d0 + d1 * d1 + d2 * d2);
}

static void apply(const double m[3][4], const double p[3], double out[3])
{
    for (int r = 0; r < 3; r++)
        out[r] = m[r][0] * p[0] + m[r][1] * p[1] + m[r][2] * p[2] + m[r][3];
}

/* Whether every map is the same homothety x -> s x + t_i (0 < s < 1, to 1e-12 on the matrices);
 * then *ratio = s and fixed[i] = t_i / (1 - s). The one-path estimates below need it; so that the
 * path's point, which grows as 1 / s per level away from the set, stays far from float overflow
 * (the kernels take points within 1e6 radii of the centre down the path; farther ones settle at
 * the root ball, de_ifs_mirror), steeper systems keep the search. */
static int same_homothety(const ub_object *o, double *ratio, double fixed[][3])
{
    const double s = o->maps[0][0][0];
    if (!(s > 0.0 && s < 1.0) || o->ifs_radius * ub_pow(s, -o->ifs_depth) > 1e12)
        return 0;
    for (int i = 0; i < o->map_count; i++) {
        for (int r = 0; r < 3; r++) {
            for (int c = 0; c < 3; c++)
                if (!(fabs(o->maps[i][r][c] - (r == c ? s : 0.0)) <= 1e-12))
                    return 0;
            fixed[i][r] = o->maps[i][r][3] / (1.0 - s);
        }
    }
    *ratio = s;
    return 1;
}

/* Whether g (a map of the centre's neighbourhood: x -> c + lin (x - c)) permutes the fixed
 * points to within tol: then it permutes the maps (g w_k g^-1 has ratio s and fixed point g(f_k))
 * and keeps the ball B(c, R), so it permutes the leaf balls of every depth. */
static int permutes_fixed_points(const ub_object *o, const double fixed[][3], const double lin[3][3], double tol)
{
    const double *c = o->ifs_center;
    for (int k = 0; k < o->map_count; k++) {
        double g[3];
        for (int r = 0; r < 3; r++)
            g[r] = c[r] + lin[r][0] * (fixed[k][0] - c[0]) + lin[r][1] * (fixed[k][1] - c[1])
                 + lin[r][2] * (fixed[k][2] - c[2]);
        int found = 0;
        for (int l = 0; l < o->map_count && !found; l++)
            found = dist3(g, fixed[l]) <= tol;
        if (!found)
            return 0;
    }
    return 1;
}

/* Whether the hull of piece i, that of the w_i(f_l), lies on the side n.x >= level (to within
 * tol). */
static int piece_on_side(const ub_object *o, const double fixed[][3], int i, const double n[3], double level,
                         double tol)
{
    for (int k = 0; k < o->map_count; k++) {
        double image[3];
        apply(o->maps[i], fixed[k], image);
        if (!(image[0] * n[0] + image[1] * n[1] + image[2] * n[2] - level >= -tol))
            return 0;
    }
    return 1;
}

/* Pieces i and j as mirror images (see detect_mirror_pieces): with P the plane bisecting
 * v_i = w_i(c) and v_j = w_j(c) and n its normal toward v_i,
 *   (1) the reflection g through c with normal n permutes the fixed points (permutes_fixed_points),
 *       so the reflection in P, sigma = w_j g w_i^-1, sends piece i's leaf balls onto piece j's;
 *   (2) the hull of A_i, which holds the centres of piece i's leaf balls (c lies in the hull of
 *       A), lies on v_i's side of P (touching allowed), and that of A_j on v_j's side.
 * Then for p on v_i's side each leaf ball of piece j has its mirror image in piece i with a centre
 * no farther from p, and the other way round. */
static int pieces_are_mirrors(const ub_object *o, const double fixed[][3], int i, int j, double tol)
{
    const double *vi = o->map_center[i], *vj = o->map_center[j];
    double len = dist3(vi, vj), n[3], lin[3][3], level = 0.0;
    if (!(len > tol))
        return 0; /* two maps alike: nothing to choose between, but no plane either */
    for (int r = 0; r < 3; r++) {
        n[r] = (vi[r] - vj[r]) / len;
        level += 0.5 * (vi[r] + vj[r]) * n[r];
    }
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++)
            lin[r][c] = (r == c ? 1.0 : 0.0) - 2.0 * n[r] * n[c];
    double back[3] = {-n[0], -n[1], -n[2]};
    return permutes_fixed_points(o, fixed, lin, tol) && piece_on_side(o, fixed, i, n, level, tol)
        && piece_on_side(o, fixed, j, back, -level, tol);
}

/* What the kernels' descent (estimators.h, de_ifs_mirror) reads, in their precision. */
static void store_path_constants(ub_object *o, double s)
{
    for (int i = 0; i < o->map_count; i++) {
        for (int r = 0; r < 3; r++) {
            o->mirror_center[i][r] = (float)o->map_center[i][r];
            o->mirror_offset[i][r] = (float)o->maps[i][r][3];
        }
    }
    for (int r = 0; r < 3; r++)
        o->mirror_root[r] = (float)o->ifs_center[r];
    o->mirror_radius = (float)o->ifs_radius;
    o->mirror_ratio = (float)s;
    o->mirror_inverse = (float)(1.0 / s);
}

/* Mirror-symmetric pieces (the Sierpinski tetrahedron): when the nearest piece is known without a
 * search. Every map must be the same homothety x -> s x + t_i (0 < s < 1). Then the convex hull of
 * the attractor A is that of the fixed points f_i (its support function h solves
 * h(u) = max_i (t_i.u + s h(u)), so h(u) = max_i f_i.u), and the piece A_i = w_i(A) has the hull
 * of the w_i(f_l). If every pair of pieces are mirror images (pieces_are_mirrors), then for p on
 * v_i's side of the plane bisecting v_i, v_j the nearest leaf ball (in |p - centre| - radius) is
 * not in piece j. Holding for every pair: it lies in the piece whose v_i is nearest p, and so on
 * down one path, whose leaf ball gives exactly the distance to the union of all leaf balls, as the
 * full search would. The tolerances (1e-12 on the matrices, 1e-9 of the radius on positions) admit
 * map sets rounded from exact ones; the estimate is then off by as little. */
static int detect_mirror_pieces(ub_object *o)
{
    double s, fixed[UB_MAX_IFS_MAPS][3];
    const double tol = 1e-9 * o->ifs_radius;
    if (!same_homothety(o, &s, fixed))
        return 0;
    for (int i = 0; i < o->map_count; i++)
        for (int j = i + 1; j < o->map_count; j++)
            if (!pieces_are_mirrors(o, fixed, i, j, tol))
                return 0;
    store_path_constants(o, s);
    return 1;
}

/* The walls of the cube's fundamental wedge W = {x >= y >= z >= 0} (about the centre): their
 * normals into W. */
static const double wedge_walls[3][3] = {{0.70710678118654752, -0.70710678118654752, 0.0},
                                         {0.0, 0.70710678118654752, -0.70710678118654752},
                                         {0.0, 0.0, 1.0}};

/* Pieces with the cube's symmetry (the Menger sponge and the other sponges cut from a box in a
 * regular grid by a symmetric pattern): when the nearest piece is known after a fold. Every map
 * must be the same homothety, and the 48 signed permutations of the axes about the centre c (the
 * cube's symmetries, the group G) must permute the fixed points, hence the maps and the leaf balls
 * (permutes_fixed_points). Not every pair of pieces is a mirror pair (two opposite corner cubes of
 * the sponge are mirror images only through a plane that is no symmetry of it), but:
 *   (a) G is generated by the reflections in the walls of W, and for p, q in W and any g in G,
 *       |p - q| <= |p - g q| (reflecting q across a wall that separates it from p only brings it
 *       closer; with p on the wall, the reflection fixes p and changes nothing). So for p folded
 *       into W (abs of each coordinate, sorted: exact in float), the nearest leaf ball has a
 *       mirror image, equally a leaf ball, whose centre lies in W too and is no farther.
 *   (b) Every piece whose v_i - c lies outside W (the others are the wedge pieces) has its hull on
 *       the far side of one wall, touching allowed, with v_i strictly beyond it. A leaf ball's
 *       centre is an inner point of its piece's hull (c is inner to the hull of A: the fixed
 *       points are G-symmetric about c, not all at c, so they span the space), hence beyond that
 *       wall, out of W. So the leaf ball of (a) lies in a wedge piece.
 *   (c) Every pair of wedge pieces are mirror images (pieces_are_mirrors): among them the nearest
 *       leaf ball lies in the piece whose v_i is nearest p, as for detect_mirror_pieces.
 * So the estimate folds p into W, goes down the wedge piece whose v_i is nearest (for the Menger
 * sponge, two: the corner cube (1, 1, 1) and the edge cube (1, 1, 0), by z >= 1/3), and repeats in
 * that piece's frame; its leaf ball gives exactly the distance to the union of all leaf balls, as
 * the mirror pieces' path does. Each level folds and compares against the few wedge pieces only,
 * not all m maps. Tolerances: 1e-12 on the matrices, and 1e-7 of the radius on positions, since
 * the add-on stores the maps in float32: its sponge's ratio 1/3 and offsets 2/3 round so that
 * neighbouring pieces overlap by 3e-8 across the plane between them (1.7e-8 of the radius). A
 * leaf ball's centre at most tol across that plane has its mirror image at most 2 tol farther, so
 * each level may overstep the leaf balls' distance by 2 tol of its frame, all levels by at most
 * 2 tol / (1 - s) (3e-7 of the radius for the sponge): less than the float32 rounding of the
 * estimate (tests/native/test_ifs.py allows 2e-6 of the radius; the marcher's threshold is a
 * pixel). */
static int detect_folded_pieces(ub_object *o)
{
    double s, fixed[UB_MAX_IFS_MAPS][3];
    const double tol = 1e-7 * o->ifs_radius;
    if (!same_homothety(o, &s, fixed))
        return 0;
    /* The 48 signed permutations: 6 orders of the axes times 8 sign patterns. */
    static const int orders[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
    for (int k = 0; k < 6; k++) {
        for (int signs = 0; signs < 8; signs++) {
            double lin[3][3] = {{0}};
            for (int r = 0; r < 3; r++)
                lin[r][orders[k][r]] = (signs >> r) & 1 ? -1.0 : 1.0;
            if (!permutes_fixed_points(o, fixed, lin, tol))
                return 0;
        }
    }
    int wedge[UB_MAX_IFS_MAPS], count = 0;
    for (int i = 0; i < o->map_count; i++) {
        double u[3];
        int in_wedge = 1;
        for (int r = 0; r < 3; r++)
            u[r] = o->map_center[i][r] - o->ifs_center[r];
        for (int w = 0; w < 3; w++)
            in_wedge &= u[0] * wedge_walls[w][0] + u[1] * wedge_walls[w][1] + u[2] * wedge_walls[w][2] >= -tol;
        if (in_wedge) {
            wedge[count++] = i;
            continue;
        }
        /* (b): outside W, its hull beyond some wall. */
        int beyond_a_wall = 0;
        for (int w = 0; w < 3 && !beyond_a_wall; w++) {
            double n[3], level = 0.0, h = 0.0;
            for (int r = 0; r < 3; r++) {
                n[r] = -wedge_walls[w][r];
                level += n[r] * o->ifs_center[r];
                h += u[r] * n[r];
            }
            beyond_a_wall = h > tol && piece_on_side(o, fixed, i, n, level, tol);
        }
        if (!beyond_a_wall)
            return 0;
    }
    if (count < 1)
        return 0;
    for (int a = 0; a < count; a++)
        for (int b = a + 1; b < count; b++)
            if (!pieces_are_mirrors(o, fixed, wedge[a], wedge[b], tol))
                return 0; /* (c) */
    store_path_constants(o, s);
    o->fold_count = count;
    for (int a = 0; a < count; a++)
        for (int r = 0; r < 3; r++)
            o->fold_center[a][r] = (float)(o->map_center[wedge[a]][r] - o->ifs_center[r]);
    return 1;
}

const char *ub_ifs_prepare(ub_object *o)
{
    if (o->map_count < 1)
        return "an IFS needs at least one map";
    double fixed_sum[3] = {0, 0, 0};
    for (int i = 0; i < o->map_count; i++) {
        double ata[3][3];
        for (int r = 0; r < 3; r++)
            for (int c = 0; c < 3; c++)
                ata[r][c] = o->maps[i][0][r] * o->maps[i][0][c] + o->maps[i][1][r] * o->maps[i][1][c]
                          + o->maps[i][2][r] * o->maps[i][2][c];
        double s = sqrt(max_eigenvalue_sym3(ata));
        /* A norm near 1 would give an enormous bounding ball and no useful bound. */
        if (!(s < 0.999))
            return "every IFS map must be a contraction (operator norm of its 3x3 part below 0.999)";
        o->map_norm[i] = s;
        double i_minus_a[3][3], t[3], x[3];
        for (int r = 0; r < 3; r++) {
            for (int c = 0; c < 3; c++)
                i_minus_a[r][c] = (r == c ? 1.0 : 0.0) - o->maps[i][r][c];
            t[r] = o->maps[i][r][3];
        }
        if (solve3(i_minus_a, t, x))
            return "an IFS map has no fixed point";
        for (int r = 0; r < 3; r++)
            fixed_sum[r] += x[r];
    }
    /* Centre: the fixed points' centroid. Radius: the smallest R with w_i(B(c, R)) in B(c, R)
     * for every map, |w_i(c) - c| + s_i R <= R. */
    double radius = 0.0;
    for (int r = 0; r < 3; r++)
        o->ifs_center[r] = fixed_sum[r] / o->map_count;
    for (int i = 0; i < o->map_count; i++) {
        apply(o->maps[i], o->ifs_center, o->map_center[i]);
        radius = fmax(radius, dist3(o->map_center[i], o->ifs_center) / (1.0 - o->map_norm[i]));
    }
    /* A single point (all maps constant onto it) still renders as a small ball. */
    o->ifs_radius = fmax(radius * (1.0 + 1e-9), 1e-6);
    if (!isfinite(o->ifs_radius) || o->ifs_radius > 1e6)
        return "the IFS attractor is too large (its bounding ball exceeds 1e6 object units)";
    o->ifs_mirror = detect_mirror_pieces(o);
    o->ifs_folded = !o->ifs_mirror && detect_folded_pieces(o);
    return NULL;
}

/* A node waiting on the stack: its map index under its parent (the parent's composed map is
 * levels[depth - 1] when it is popped: the stack is last-in first-out, so no other node of the
 * parent's depth has been expanded since), its bound and its place in the hierarchy. */
typedef struct {
    double lower;
    double address;
    int map, depth;
} ifs_entry;

/* The composed map w_word of the node last expanded at one depth: x -> lin x + off, s_word. */
typedef struct {
    double lin[3][3], off[3];
    double scale;
} ifs_level;

/* A node is settled, not split further, once its ball is small against its distance: every
 * point of it is then within (1 + 2 UB_IFS_SETTLE) = 1.5 times the bound, which is all the
 * marcher needs far from the surface. Near the surface the bound goes to 0 and nodes are split to the
 * full depth. */
#define UB_IFS_SETTLE 0.25
/* Nodes whose bound is within this factor of the best settled one are settled too, at their own
 * bound, instead of searched: the result stays a lower bound, at most this factor below the
 * exhaustive search's, and near-ties (which overlapping balls make common) cost nothing. */
#define UB_IFS_TIE 1.25
/* At most this many nodes are split per estimate; past it every node still waiting settles at its
 * own bound. The result stays a lower bound; only pathological map sets (many nearly equal maps)
 * get there, and their cost stays bounded. */
#define UB_IFS_MAX_SPLITS 4096
/* The cancel flag is read every this many splits (each costs up to UB_MAX_IFS_MAPS children):
 * a few tens of microseconds of work, where the 4096 splits of one estimate take milliseconds. */
#define UB_IFS_POLL 64

double ub_ifs_distance(const ub_object *o, const double p[3], double *address, int *depth, volatile int *cancel)
{
    const int m = o->map_count, max_depth = o->ifs_depth;
    const double R = o->ifs_radius;
    *address = 0.0;
    *depth = 0;
    double d0 = dist3(p, o->ifs_center);
    if (!isfinite(d0))
        return d0; /* NaN: never a hit, and the marcher's step falls back to its maximum */
    ifs_entry stack[UB_MAX_IFS_DEPTH * (UB_MAX_IFS_MAPS - 1) + 2];
    ifs_level levels[UB_MAX_IFS_DEPTH + 1];
    int sp = 0;
    stack[sp++] = (ifs_entry){d0 - R, 0.0, -1, 0};
    int splits = 0;
    double upper = d0 + R;    /* the attractor has a point within this distance */
    double best = HUGE_VAL;   /* minimum bound over the settled part of the cut */
    double tied = HUGE_VAL;   /* minimum bound of the nodes settled as near-ties */
    double span[UB_MAX_IFS_DEPTH + 1];
    span[0] = 1.0;
    for (int k = 1; k <= max_depth; k++)
        span[k] = span[k - 1] / m;
    while (sp > 0) {
        ifs_entry n = stack[--sp];
        if (n.lower >= best || n.lower > upper)
            continue; /* cannot lower the minimum, or cannot hold the nearest point */
        if (n.lower * UB_IFS_TIE >= best) {
            tied = fmin(tied, n.lower);
            continue;
        }
        /* Compose the node's map from its parent's (the root's is the identity). */
        ifs_level *lv = &levels[n.depth];
        if (n.depth == 0) {
            memset(lv, 0, sizeof *lv);
            for (int r = 0; r < 3; r++)
                lv->lin[r][r] = 1.0;
            lv->scale = 1.0;
        } else {
            const ifs_level *pa = &levels[n.depth - 1];
            const double(*a)[4] = o->maps[n.map];
            for (int r = 0; r < 3; r++) {
                for (int c = 0; c < 3; c++)
                    lv->lin[r][c] = pa->lin[r][0] * a[0][c] + pa->lin[r][1] * a[1][c] + pa->lin[r][2] * a[2][c];
                lv->off[r] = pa->lin[r][0] * a[0][3] + pa->lin[r][1] * a[1][3] + pa->lin[r][2] * a[2][3] + pa->off[r];
            }
            lv->scale = pa->scale * o->map_norm[n.map];
        }
        double radius = lv->scale * R;
        ++splits;
        if (splits > UB_IFS_MAX_SPLITS
            || (splits % UB_IFS_POLL == 0 && cancel && __atomic_load_n(cancel, __ATOMIC_RELAXED))) {
            tied = fmin(tied, n.lower);
            for (int k = 0; k < sp; k++)
                tied = fmin(tied, stack[k].lower);
            break;
        }
        if (n.depth == max_depth || radius <= UB_IFS_SETTLE * n.lower) {
            best = n.lower;
            *address = n.address + 0.5 * span[n.depth];
            *depth = n.depth;
            continue;
        }
        /* Children in order of their bound, nearest pushed last (popped first). */
        double lower[UB_MAX_IFS_MAPS];
        int order[UB_MAX_IFS_MAPS], count = 0;
        for (int i = 0; i < m; i++) {
            double c[3];
            for (int r = 0; r < 3; r++)
                c[r] = lv->lin[r][0] * o->map_center[i][0] + lv->lin[r][1] * o->map_center[i][1]
                     + lv->lin[r][2] * o->map_center[i][2] + lv->off[r];
            double dc = dist3(p, c), rc = radius * o->map_norm[i];
            lower[i] = dc - rc;
            upper = fmin(upper, dc + rc);
            if (lower[i] * UB_IFS_TIE >= best) {
                if (lower[i] < best && lower[i] <= upper)
                    tied = fmin(tied, lower[i]);
                continue;
            }
            int k = count++;
            while (k > 0 && lower[order[k - 1]] < lower[i]) {
                order[k] = order[k - 1];
                k--;
            }
            order[k] = i;
        }
        for (int k = 0; k < count; k++) {
            int i = order[k];
            if (lower[i] > upper)
                continue;
            stack[sp++] = (ifs_entry){lower[i], n.address + i * span[n.depth + 1], i, n.depth + 1};
        }
    }
    return fmin(best, tied);
}
