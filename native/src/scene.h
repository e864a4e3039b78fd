/* Scene description shared by the binding, the set-up code and the SIMD kernels.
 *
 * Everything here is validated and precomputed once per render (in double precision) by
 * scene.c and camera.c, so the kernels only read plain numbers. */
#ifndef UNBOUND_SCENE_H
#define UNBOUND_SCENE_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>

#include "zoom.h"

/* Hard limits: inputs outside them are rejected with a ValueError by the binding. */
#define UB_MAX_IMAGE_SIZE 65536
#define UB_MAX_ITERATIONS 10000
#define UB_MAX_OBJECTS 64
#define UB_MAX_THREADS 1024
#define UB_MAX_BISECTION 64
#define UB_MAX_MARCH_STEPS_LIMIT 1000000
#define UB_MAX_BAILOUT 1.0e6
#define UB_MAX_LIGHTS 64
#define UB_MAX_SAMPLES 4096
#define UB_MAX_REFLECTION_DEPTH 16
#define UB_MAX_AO_SAMPLES 32
#define UB_MAX_WORLD_SAMPLES 64
#define UB_MAX_BOUNCES 1024
#define UB_MAX_RAMP 256
#define UB_MAX_PATH 256        /* points of a Julia stack's c-path */
#define UB_MAX_IFS_MAPS 32
#define UB_MAX_IFS_DEPTH 16
#define UB_MAX_KIFS_PLANES 16    /* fold planes of a kaleidoscopic IFS */
#define UB_MAX_HYBRID_STEPS 8    /* (formula, count) entries of a hybrid */

/* Depth written for background pixels: the value Cycles writes into its Depth pass for a miss. */
#define UB_BACKGROUND_DEPTH 1.0e10f

/* Packet width of the marching kernels: 8 rays (one AVX2 register of floats) unless the kernel's
 * SIMD header set it first (simd_avx512.h: 16). Only the kernels' own headers use it. */
#ifndef UB_LANES
#define UB_LANES 8
#endif
#define UB_ALL_LANES ((1 << UB_LANES) - 1)
#define UB_MAX_LANES 16 /* the widest kernel's UB_LANES */
/* Before a lane loop meant for the vectorizer: not unrolled completely first. GCC unrolls a loop
 * of 8 short trips before it vectorizes, and the straight code it leaves stays scalar (issue 21:
 * 2 % more instructions in the peer render). */
#define UB_VECTOR_LOOP _Pragma("GCC unroll 1")

typedef enum { UB_EPSILON_PIXEL = 0, UB_EPSILON_FIXED = 1 } ub_epsilon_mode;

/* Cycles' panoramic cameras (kernel/camera/projection.h); UB_PANORAMA_NONE: the projection's. */
typedef enum {
    UB_PANORAMA_NONE = 0,
    UB_PANORAMA_EQUIRECTANGULAR,
    UB_PANORAMA_FISHEYE_EQUIDISTANT,
    UB_PANORAMA_FISHEYE_EQUISOLID,
    UB_PANORAMA_MIRRORBALL,
} ub_panorama_type;

/* A clip plane's points as an affine map of the image point (px, py): the homogeneous view-space
 * point (x, y, z, w) of (px, py) on the plane is origin + px per_x + py per_y. */
typedef struct {
    double origin[4], per_x[4], per_y[4];
} ub_clip_plane_map;

typedef struct {
    /* Full image (not the window) in pixels. */
    int width, height;
    int orthographic;
    /* View space -> world: rotation columns and translation (the camera's matrix_world). */
    double cam_to_world[3][4];
    /* The inverse of the projection matrix (Blender's calc_matrix_camera; view space from NDC)
     * on the clip-start (NDC z = -1) and clip-end (z = 1) planes, as maps of the image point:
     * the NDC (2 px / width - 1, 2 py / height - 1) are affine in it, so the maps fold them in
     * and a ray costs no per-pixel NDC (camera_projection.h). */
    ub_clip_plane_map clip_start, clip_end;
    /* A perspective projection whose clip planes are planes of constant view depth (Blender's,
     * lens shift included): every ray from the eye meets them at t_min and t_max in the ratio of
     * their depths, clip end / clip start, the same for every pixel. 0: not such a projection
     * (the clip-end plane gives each ray's t_max). camera_projection.h. */
    double clip_depth_ratio;
    /* Unit vector of the camera's viewing axis in world space (-Z of the camera). */
    double forward[3];
    double position[3];
    /* World-space footprint of one pixel at ray distance t: footprint0 + footprint1 * t. */
    double footprint0, footprint1;
    /* Panoramic cameras: the type, the panorama's (u, v) of the image's edges (left, right,
     * bottom, top), the clip distances along each ray, and the mapping's constants:
     * equirectangular: phi = range[0] u + range[1], theta = range[2] v + range[3] (Cycles'
     * equirectangular_range); equidistant: half the field of view; equisolid: the focal length,
     * the sensor size and the sine of a quarter of the field of view (the lens circle). */
    ub_panorama_type panorama;
    double viewplane[4], near, far;
    double range[4], half_fov, lens, sensor[2], sin_quarter_fov;
    /* Depth of field, Cycles' thin lens: the lens' radius in world units (0: a pinhole), the
     * distance in focus, 1 / the anamorphic ratio; a polygonal aperture's sides (0: a disk), its
     * rotation and the cosine and sine of half a side's angle. Panoramic cameras move the lens
     * across each ray: pano_axis is the panorama's forward axis in camera space (Cycles' x), and
     * the lens' second axis is cross(ray, first axis) times pano_handedness (the determinant of
     * the turn Cycles gives panoramic cameras). */
    double aperture, focus, inv_ratio;
    int blades;
    double blade_rotation, blade_cos, blade_sin;
    double pano_axis[3], pano_handedness;
} ub_camera;

/* The families of section 5 beside the quaternion Julia sets. Julia sets, Mandelbrot slices and
 * IFS have a distance bound that never overshoots (exact); stacks and the cubic locus have no
 * proven one (section 5.1-5.2) and march with an empirical estimate made safe (march.h). */
typedef enum {
    UB_KIND_QUATERNION_JULIA = 0,
    UB_KIND_QUATERNION_MANDELBROT, /* z0 = 0, mu = the slice point */
    UB_KIND_JULIA_STACK,           /* complex Julia sets of z^2 + c(u) stacked along z */
    UB_KIND_CUBIC_LOCUS,           /* z^3 - 3a^2 z + b over the 4-D (a, b) space */
    UB_KIND_IFS,                   /* attractor of 3-D affine maps */
    UB_KIND_MANDELBULB,            /* triplex z^n + c (issue 22; empirical) */
    UB_KIND_MANDELBOX,             /* box fold, sphere fold, scale (issue 22; empirical) */
    UB_KIND_KIFS,                  /* kaleidoscopic IFS: plane folds, rotation, scale (issue 22; exact) */
    UB_KIND_HYBRID,                /* Mandelbulb, Mandelbox and KIFS steps in turn (issue 22; empirical) */
    UB_KIND_COUNT
} ub_fractal_kind;

/* Which critical orbits of the cubic must stay bounded: C+, C-, either, or both (the
 * connectedness locus proper, C+ n C-). */
typedef enum { UB_CUBIC_PLUS = 0, UB_CUBIC_MINUS, UB_CUBIC_UNION, UB_CUBIC_BOTH } ub_cubic_component;

/* Safety of the empirical estimates: their step is scaled by this on top of step_factor, and
 * capped at UB_EMPIRICAL_MAX_STEP of the bounding radius. */
#define UB_EMPIRICAL_SAFETY 0.5
#define UB_EMPIRICAL_MAX_STEP 0.05

/* Normal approximations of section 4.1. */
typedef enum {
    UB_NORMAL_GRADIENT_DISTANCE = 0, /* eq. 15 on the distance estimate d() */
    UB_NORMAL_GRADIENT_POTENTIAL,    /* eq. 15 on the potential G() */
    UB_NORMAL_ZBUFFER,               /* eq. 12-14: neighbouring pixels' hits (camera rays only) */
    UB_NORMAL_ANALYTIC,              /* gradient of |f^n| through the iteration's Jacobian */
} ub_normal_method;

typedef enum { UB_COLOR_BASE = 0, UB_COLOR_ORBIT_TRAP, UB_COLOR_ITERATIONS } ub_color_mode;

/* The fractal's own quantities a material input can be driven by (Blender's Attribute node named
 * unbound_<name>): none (the input's constant), the orbit trap, iterations / max_iterations, the
 * distance estimate at the hit (world units, the Distance pass), the object-space position and the
 * world-space normal (vectors, read as the mean of their components: the Attribute node's Fac). */
typedef enum {
    UB_ATTRIBUTE_NONE = 0,
    UB_ATTRIBUTE_ORBIT_TRAP,
    UB_ATTRIBUTE_ITERATIONS,
    UB_ATTRIBUTE_DISTANCE,
    UB_ATTRIBUTE_POSITION,
    UB_ATTRIBUTE_NORMAL,
} ub_attribute;

/* A material input driven by an attribute: value = table at clamp(attribute * scale + offset, 0, 1),
 * the table sampled uniformly over [0, 1] (a Color Ramp, or a Map Range's two ends). */
typedef struct {
    ub_attribute source;       /* UB_ATTRIBUTE_NONE: the input's constant */
    int size;                  /* entries of table, >= 2 when driven */
    float scale, offset;
    float table[UB_MAX_RAMP][3]; /* scalar inputs use channel 0 */
} ub_material_map;

/* A Principled BSDF (Cycles 4.x; native/src/bsdf.h) on a fractal: its constant inputs, the derived
 * specular F0 and relative IOR (after Specular IOR Level, as Cycles adjusts them), and the maps of
 * the inputs an attribute drives. enabled 0: the object shades as without a material. */
typedef struct {
    int enabled;
    float base_color[3], metallic, roughness, emission[3], alpha;
    double eta, specular_f0;
    ub_material_map base_color_map, metallic_map, roughness_map;
} ub_material;

typedef struct {
    ub_fractal_kind kind;
    /* Iterated map f(z) = z^2 + mu over the quaternions (eq. 1-4). */
    double mu[4];
    int max_iterations;
    double bailout;            /* effective escape radius: max(user bailout, bounding radius) */
    /* Object-space point p -> quaternion q = slice_origin + slice_basis * p, with the theta
     * rotation of eq. 5-6 already folded in (see scene.c). Columns of slice_basis are orthonormal. */
    double slice_origin[4];
    double slice_basis[4][3];
    /* World -> object (affine 3x4); normals transform with its transpose. */
    double world_to_object[3][4];
    /* Smallest singular value of the object->world linear part: a distance d in object space
     * is at least d * sigma_min in world space, so steps scaled by it never overshoot even
     * under non-uniform scale. */
    double sigma_min;
    double sigma_max;          /* largest singular value: object radius r is at most r sigma_max in the world */
    /* Bounding ball of K_mu cut by the slice, in object space (centre, radius); radius < 0:
     * the slice misses the set entirely. */
    double bound_center[3];
    double bound_radius;
    ub_epsilon_mode epsilon_mode;
    double epsilon;            /* fixed mode: object-space threshold */
    double detail;             /* pixel mode: threshold = pixel footprint / detail */
    double step_factor;        /* multiplies the distance estimate (<= 1 is conservative) */
    double max_step;           /* world-space cap on one step (section 3.4) */
    int max_steps;             /* cap on marching steps per ray */
    int bisection_steps;       /* refinement of the hit between the last two samples */
    float color[3];
    /* Shading (section 4). The gradient step of eq. 15 is alpha * Gamma(t), Gamma(t) = t^delta,
     * t the distance travelled from the eye (Table 1), in world units. */
    ub_normal_method normal_method;
    double normal_alpha, normal_delta;
    float reflectivity;
    ub_color_mode color_mode;
    /* Colour ramp sampled uniformly over [0, 1]; the ramp position is
     * clamp(value * ramp_scale + ramp_offset), value the orbit trap or iterations / max. */
    int ramp_size;
    float ramp[UB_MAX_RAMP][3];
    float ramp_scale, ramp_offset;
    /* Whether the kind's distance estimate is proven never to overshoot (see ub_fractal_kind). */
    int exact;
    /* Julia stack: c(u) piecewise linear through path[0..path_count), u in [0, 1] spanning
     * object z in [-stack_height / 2, stack_height / 2]; x + iy is the complex plane. */
    int path_count;
    double path[UB_MAX_PATH][2];
    double path_speed[UB_MAX_PATH]; /* derived: |dc/dz| along segment i (0 for one point) */
    double stack_height;
    /* Cubic locus: component, and the radius of the 4-D ball it is clipped to (C+ and C- are
     * unbounded; their intersection lies in |a|, |b| <= 2). */
    ub_cubic_component cubic_component;
    double extent;
    /* IFS: x -> A x + t per map (rows of A | t), the recursion depth, and derived: each map's
     * operator norm (upper bound), a ball (ifs_center, ifs_radius) mapped into itself by every
     * map, and each map's image of the centre. ifs_mirror: the maps are homotheties x -> s x + t
     * of one ratio whose pieces are pairwise mirror images (ifs.c, detect_mirror_pieces), so the
     * nearest piece is the one with the nearest image of the centre and the estimate follows one
     * path down the hierarchy (estimators.h, de_ifs_mirror) instead of a search; mirror_*: the
     * centre's images, the offsets t, the centre, radius, s and 1 / s in float. ifs_folded: the
     * same homotheties with the cube's symmetries about the centre (the Menger sponge; ifs.c,
     * detect_folded_pieces), so the point folded into the wedge x >= y >= z >= 0 finds the nearest
     * piece among the fold_count wedge pieces, whose centre's images (minus the centre) are
     * fold_center (estimators.h, de_ifs_folded); it also fills mirror_*, whose path over all maps
     * gives the orbit trap. */
    int map_count, ifs_depth;
    double maps[UB_MAX_IFS_MAPS][3][4];
    double map_norm[UB_MAX_IFS_MAPS];
    double map_center[UB_MAX_IFS_MAPS][3];
    double ifs_center[3], ifs_radius;
    int ifs_mirror;
    float mirror_center[UB_MAX_IFS_MAPS][3], mirror_offset[UB_MAX_IFS_MAPS][3];
    float mirror_root[3], mirror_radius, mirror_ratio, mirror_inverse;
    int ifs_folded, fold_count;
    float fold_center[UB_MAX_IFS_MAPS][3];
    /* Mandelbulb and Mandelbox (formulas.h): Julia mode (c = julia_c, else c = the point), the
     * triplex power, and the Mandelbox's scale, fold limit and sphere-fold radii. */
    int julia_mode;
    double julia_c[3];
    double power;
    double box_scale, box_fold, min_radius, fixed_radius;
    /* KIFS (formulas.h): per step the fold planes in order (unit normal n, offset d: z reflected
     * to n.z >= d), the rotation, then z <- s z - o (s - 1); the final shape (ub_kifs_shape) of
     * size kifs_size; derived: the rotation matrix, rho (a ball |z| <= rho holds every level's
     * set, and an orbit once past it escapes; see kifs_bound in scene.c). */
    int kifs_plane_count;
    double kifs_planes[UB_MAX_KIFS_PLANES][4];
    double kifs_scale, kifs_offset[3], kifs_rotation[3][3];
    int kifs_rotate, kifs_shape;
    double kifs_size, kifs_rho;
    /* Hybrid: entries (formula, count), formula a ub_hybrid_formula, applied in turn, cycling,
     * for max_iterations steps in all; each formula's own parameters above. */
    int hybrid_count;
    int hybrid_formula[UB_MAX_HYBRID_STEPS], hybrid_repeat[UB_MAX_HYBRID_STEPS];
    int hybrid_has_bulb;
    /* Deep zoom (zoom.h): the quaternion kinds' local point u is the fractal's anchor + u 10^-zoom. */
    ub_zoom zoom;
    ub_material material;
} ub_object;

typedef enum { UB_KIFS_SPHERE = 0, UB_KIFS_BOX, UB_KIFS_TETRAHEDRON, UB_KIFS_OCTAHEDRON } ub_kifs_shape;
typedef enum { UB_HYBRID_MANDELBULB = 0, UB_HYBRID_MANDELBOX, UB_HYBRID_KIFS } ub_hybrid_formula;

typedef enum { UB_LIGHT_POINT = 0, UB_LIGHT_SUN, UB_LIGHT_SPOT, UB_LIGHT_AREA } ub_light_type;

typedef struct {
    ub_light_type type;
    double position[3];
    double direction[3];  /* unit: where the light points (sun, spot, area emit along it) */
    /* Irradiance scale: sun, E = color (W/m^2 per channel); point, spot and area,
     * E = color / r^2 (area: times the emitter's cosine). */
    float color[3];
    double radius;        /* source radius (sun: tangent of the angular radius), soft shadows */
    double spot_cos_outer, spot_cos_inner; /* spot cone: smooth step between these cosines */
    int cast_shadow;
    int soft_falloff;     /* point/spot: Blender's soft falloff, E = color / (r^2 + radius^2) */
} ub_light;

typedef enum { UB_SHADOWS_NONE = 0, UB_SHADOWS_HARD, UB_SHADOWS_SOFT } ub_shadow_mode;

/* Scene-wide shading: lights, the paper's axle light, effects, the sea of Fig. 5, samples. */
typedef struct {
    int samples;               /* anti-aliasing samples per pixel */
    float axle_light;          /* light at the eye: 1 lights a white surface facing the eye to 1 */
    float ambient[3];
    ub_shadow_mode shadows;
    float ao_strength;         /* 0: no ambient occlusion */
    double ao_distance;        /* world distance of the farthest AO sample */
    int ao_samples;
    int reflection_depth;      /* 0: no reflections */
    double fog_density;        /* 1/world units; 0: no fog */
    float fog_color[3];
    float glow_strength;
    float glow_color[3];
    int sea;                   /* the sea of Fig. 5: a plane z = sea_height in world space */
    double sea_height, sea_wavelength, sea_amplitude;
    float sea_color[3];
    float sea_reflectivity;
    int light_count;
    ub_light lights[UB_MAX_LIGHTS];
    int world_samples;         /* world light samples per hit and anti-aliasing sample (each: one
                                  from the map, one from the surface, combined by MIS) */
    int gi;                    /* path tracing: every surface bounces light (kernel.h, gi_bounce) */
    int max_bounces, diffuse_bounces, glossy_bounces; /* Cycles' Light Paths limits */
} ub_shading;

typedef enum {
    UB_PASS_COMBINED = 0, /* RGBA */
    UB_PASS_ALPHA,        /* coverage */
    UB_PASS_DEPTH,        /* distance along the camera's view axis (Blender's Z) */
    UB_PASS_NORMAL,       /* world-space unit normal */
    UB_PASS_POSITION,     /* world-space hit position */
    UB_PASS_ITERATIONS,   /* escape count at the hit */
    UB_PASS_STEPS,        /* marching steps of the ray (every pixel, background included) */
    UB_PASS_DISTANCE,     /* final distance estimate at the hit, world units */
    UB_PASS_AO,           /* ambient occlusion: 1 in the open */
    UB_PASS_SHADOW,       /* fraction of the direct light that is not shadowed */
    UB_PASS_DIFFUSE,      /* direct light (lights and axle light) times colour */
    UB_PASS_AMBIENT,      /* ambient light times colour times AO */
    UB_PASS_REFLECTION,   /* reflected light */
    UB_PASS_ORBIT_TRAP,   /* orbit trap value at the hit: min |z_k| over the orbit */
    UB_PASS_GLOW,         /* glow from the marching steps */
    UB_PASS_MAX_STEPS,    /* 1 where the camera ray ran out of max_steps before it hit or left */
    UB_PASS_DENOISING_ALBEDO, /* surface colour of the first hit, averaged (OpenImageDenoise's albedo) */
    UB_PASS_DENOISING_NORMAL, /* first hit's normal in Cycles' camera space, averaged (OIDN's normal) */
    UB_PASS_COUNT
} ub_pass_id;

extern const char *const ub_pass_names[UB_PASS_COUNT];
extern const int ub_pass_channels[UB_PASS_COUNT];

typedef struct {
    /* Pixels of the full image covered by the buffers: buffer pixel (i, j) is image pixel
     * (x0 + step i, y0 + step j), 0 <= i < w, 0 <= j < h. step 1 is a window of the image;
     * larger steps are the interleaved sub-grids of the viewport's progressive refinement.
     * Buffer row 0 is the bottom row (Blender's render-result order). */
    int x0, y0, w, h, step;
    float *pass[UB_PASS_COUNT]; /* NULL: pass not wanted */
    float background[4];
} ub_film;

typedef struct {
    uint64_t rays, steps, iterations;
    /* Iterations of f in the estimates of the normals' central differences (eq. 15), apart from
     * the march's `iterations`: the same iteration, so a FLOP count of the render counts both
     * (bench/bench_flops.py). */
    uint64_t normal_iterations;
    /* Camera rays of the film (each sample) that ran out of max_steps before they hit or left
     * the fractal: drawn as whatever lies behind, the background mostly (issue 18). */
    uint64_t out_of_steps;
    /* The nearest hit's depth in the depth pass (sample 0), for the precision check's footprint
     * ratio: kept while the passes are written, so that the check needs no pass over the whole
     * frame afterwards (issue 21). The kernels keep it per lane (INFINITY: none yet;
     * ub_counters_start), a vector minimum with no reduction across the lanes; the render's
     * nearest depth is the least of them (ub_counters_nearest_depth). */
    float nearest_lanes[UB_MAX_LANES];
} ub_counters;

/* The nearest depth any lane wrote; INFINITY where none wrote one. */
static inline float ub_counters_nearest_depth(const ub_counters *c)
{
    float nearest = INFINITY;
    for (int l = 0; l < UB_MAX_LANES; l++)
        nearest = fminf(nearest, c->nearest_lanes[l]);
    return nearest;
}

/* What the camera ray of one pixel (one sample) hit: written by the primary phase, read by the
 * shading phase (the Z-buffer normals of eq. 12-14 need the neighbours' hits). */
#define UB_HIT_NONE (-1)
#define UB_HIT_SEA (-2)
typedef struct {
    float t;           /* world distance along the ray */
    float iterations, distance, steps;
    /* 16 bits each: the flag fits in the 20 bytes a pixel's hit takes (addon/engine.py's memory
     * estimate counts them); UB_MAX_OBJECTS is far below 2^15. */
    int16_t object;    /* index, UB_HIT_NONE or UB_HIT_SEA */
    int16_t out_of_steps; /* 1: ran out of max_steps in front of what it shows (UB_PASS_MAX_STEPS) */
} ub_hit;

typedef struct {
    /* The film's pixels plus a one-pixel apron (clipped to the image), on the film's grid:
     * buffer pixel (i, j) is image pixel (x0 + step i, y0 + step j). With step 1, normals at a
     * window's edge equal the full render's. Film pixel (x, y) is buffer pixel
     * (x + apron_x, y + apron_y): apron_x is 1 when the buffer has a column left of the film. */
    int x0, y0, w, h, step, apron_x, apron_y;
    ub_hit *hits; /* NULL when the render traces and shades in one phase (its grid is still used) */
} ub_hit_buffer;

/* The World as a light and a background (world.c, world.h): an equirectangular map in the
 * convention of Cycles' Environment Texture, texel (i, j) at u = (i + 0.5) / w, v = (j + 0.5) / h,
 * row 0 the nadir's (Blender's image order); direction (x, y, z) <-> u = atan2(-y, x) / (2 pi) + 0.5,
 * v = atan2(z, hypot(x, y)) / pi + 0.5. Importance sampling by luminance * sin(polar angle), a
 * 2-D piecewise-constant distribution (pbrt-v4's PiecewiseConstant2D): the marginal CDF over the
 * rows, the conditional CDF of each row. */
typedef struct {
    int w, h;
    const float *rgb;      /* h * w * 3 floats, the caller's */
    float *row_cdf;        /* h + 1: marginal CDF over the rows, 0 .. 1 */
    float *col_cdf;        /* h * (w + 1): each row's conditional CDF, 0 .. 1 */
    float *row_sin;        /* h: sin of each row's polar angle (its centre) */
    double sum;            /* sum of luminance * row_sin over the texels; 0: the map sends no light */
} ub_world;

#define UB_MAX_WORLD_TEXELS (4096 * 2048)

/* Rec. 709 luminance, Blender's scene-linear default: the weight of the world map's distribution
 * and of a material's diffuse lobe against its specular one (bsdf.h). */
static inline double ub_luminance(double r, double g, double b)
{
    return 0.2126 * r + 0.7152 * g + 0.0722 * b;
}

/* world.c: the distribution of a map (rgb finite, >= 0); NULL or an error message. */
const char *ub_world_prepare(ub_world *world, const float *rgb, int w, int h);
void ub_world_release(ub_world *world);

/* Issue 21: shared first steps. The full image is cut into UB_CONE_BLOCK x UB_CONE_BLOCK blocks
 * of pixels (absolute image coordinates, so a block is the same whatever window, band or
 * sub-grid is rendered); one cone through the whole area of a block's pixels is marched once
 * per render (kernel cone.h), and every camera ray of the block starts where the cone is
 * certified empty. Block (bx, by) is entry (by - by0) * nbx + (bx - bx0). */
#define UB_CONE_BLOCK 8
typedef struct {
    int bx0, by0, nbx, nby;
    double *start; /* per block: the distance from the camera every ray of the block may start at */
    int *ready;    /* per block, atomic: 1 once start is written (any thread computes the same bits) */
} ub_cone_cache;

typedef struct {
    const ub_camera *camera;
    const ub_object *objects;
    int object_count;
    const ub_film *film;
    const ub_shading *shading;
    ub_hit_buffer *hits;
    /* Set to non-zero from any thread to stop the render. The kernels poll it between bounded
     * pieces of work (a packet, a marching or bisection step, an object's estimate in AO, sea
     * waves and normals, a light, 64 splits of the IFS estimate), so a cancel is seen within a
     * few ms of one thread's work at any setting the parameter table allows. */
    volatile int *cancel;
    const ub_world *world;  /* NULL: no world map (missed rays see the film's background colour) */
    ub_cone_cache *cones;   /* NULL: camera rays start at the clip plane (render.c: which cameras) */
} ub_scene;

/* Sub-pixel offset of anti-aliasing sample s: Halton (2, 3) shifted so sample 0 is the centre. */
void ub_sample_offset(int sample, double *dx, double *dy);
/* Lens sample of anti-aliasing sample s at full-image pixel (px, py), in the unit square. */
void ub_lens_sample(int sample, int px, int py, double uv[2]);

/* One rectangle rendered by one thread, in packets of UB_LANES pixels along rows.
 * Phase 0 traces camera rays of `sample` into the hit buffer (coordinates relative to it);
 * phase 1 shades them and accumulates the film (coordinates relative to the film window).
 * Where no pixel reads its neighbours' hits (no Z-buffer normals), UB_PHASE_TRACE_AND_SHADE
 * does both, packet by packet, over the film (the hit buffer's grid then), without the buffer. */
enum { UB_PHASE_TRACE = 0, UB_PHASE_SHADE = 1, UB_PHASE_TRACE_AND_SHADE = 2 };
typedef void (*ub_tile_kernel)(const ub_scene *scene, int phase, int sample, int tx0, int ty0, int tx1, int ty1,
                               ub_counters *counters);

void ub_render_tile_avx512(const ub_scene *, int, int, int, int, int, int, ub_counters *);
void ub_render_tile_avx2(const ub_scene *, int, int, int, int, int, int, ub_counters *);
void ub_render_tile_portable(const ub_scene *, int, int, int, int, int, int, ub_counters *);

/* Normals at object-space points with the object's own method (the Z-buffer method falls back
 * to the distance gradient), for tests: n points xyz, path lengths t (for alpha * t^delta),
 * writes object-space unit normals. */
void ub_normals_avx512(const ub_object *, const float *, const float *, size_t, float *);
void ub_normals_avx2(const ub_object *, const float *, const float *, size_t, float *);
void ub_normals_portable(const ub_object *, const float *, const float *, size_t, float *);

/* Distance estimate and escape count at object-space points (the kernels' own arithmetic),
 * for tests: n points, xyz interleaved; writes estimate (object units) and iterations. */
void ub_estimate_avx512(const ub_object *, const float *, size_t, float *, float *);
void ub_estimate_avx2(const ub_object *, const float *, size_t, float *, float *);
void ub_estimate_portable(const ub_object *, const float *, size_t, float *, float *);
/* Deep zoom test hook (module.c's _zoom_probe): the estimate of a zoomed object by `path` at n
 * object-space points, lane-parallel as the kernels run it or (scalar) by ub_zoom_estimate, per
 * point UB_ZOOM_PROBE_VALUES doubles: distance, iterations, trap, potential, normal (3), rebases. */
#define UB_ZOOM_PROBE_VALUES 8
void ub_zoom_probe_avx512(const ub_object *, int path, int want, int scalar, const float *, size_t, double *);
void ub_zoom_probe_avx2(const ub_object *, int path, int want, int scalar, const float *, size_t, double *);
void ub_zoom_probe_portable(const ub_object *, int path, int want, int scalar, const float *, size_t, double *);

int ub_cpu_has_avx2_fma(void);
int ub_cpu_has_avx512(void);

/* What the estimators compute besides the distance estimate (de_ext's `want`). */
enum { UB_WANT_TRAP = 1, UB_WANT_POTENTIAL = 2, UB_WANT_JACOBIAN = 4 };

/* zoom.c: the deep zoom's set-up (after ub_object_prepare: the slice and the bound are read) and
 * its scalar estimate, shared by both kernels. */
const char *ub_zoom_prepare(ub_object *obj, double zoom, const char *anchor_text);
/* The path for a hit threshold of eps_local object units (OFF for an object without zoom). */
ub_zoom_path ub_zoom_choose_path(const ub_object *o, double eps_local);
typedef struct {
    double dist;          /* object (local) units */
    int iterations;
    double trap, potential;
    double normal[3];     /* with UB_WANT_JACOBIAN: the gradient of |z_n| along the object's axes */
    int rebases;          /* glitches: how often the point moved onto the critical orbit */
} ub_zoom_result;
/* The estimate at the kernels' quaternion B u (u local) by `path`, with the extras of `want`:
 * the scalar reference, ub_zoom_start, ub_zoom_iterate and ub_zoom_finish in a row. The kernels
 * run all three lane-parallel (zoom_lanes.h), with the same bits. */
void ub_zoom_estimate(const ub_object *o, int path, const double u_q[4], int want, ub_zoom_result *res);
/* One point's iteration state between the start and the finish. */
typedef struct {
    double z[4];          /* the point's orbit z_n */
    double delta[4];      /* z_n - Z_index of the reference it follows (z_n itself when direct) */
    double dc[4];         /* what each step adds on top of the reference's own step */
    double c_full[4];     /* the c of direct iteration (mu, or the Mandelbrot point) */
    double r2, dr2, dm;   /* |z_n|^2; the Julia |f'|^2 or the Mandelbrot |f'| */
    double trap, gscale;  /* min |z_k|^2; 2^-n */
    double add_scale;     /* the Mandelbrot Jacobian's dmu/dx, rescaled with it */
    double j[3][4];       /* with UB_WANT_JACOBIAN: dz_n/dx along the three object axes */
    int n;                /* iterations done (skipped ones included) */
    int direct;           /* no reference: the double path, or past the reference's end */
    int on_crit;          /* following the critical orbit (after a glitch) rather than the anchor's */
    int index, length;    /* the reference entry Z_index, of `length` stored */
    int rebases;
} ub_zoom_state;
/* The point's start: z0 = Q + 10^-zoom B u, the reference, the skip table's linear start. */
void ub_zoom_start(const ub_object *o, int path, const double u_q[4], int want, ub_zoom_state *s);
/* The iterations, from s->n on to the escape or max_iterations (scalar). */
void ub_zoom_iterate(const ub_object *o, ub_zoom_state *s, int want);
/* The estimate and its extras from the state after the last iteration. */
void ub_zoom_finish(const ub_object *o, const ub_zoom_state *s, int want, ub_zoom_result *res);
/* The anchor moved by the local offset u, as text: anchor + u 10^-zoom with `digits` digits after
 * the point (the fixed point's exact sum); NULL or a message. */
const char *ub_zoom_anchor_move(const char *anchor_text, double zoom, const double u[3], int digits, char *out,
                                int size);

/* zoom_formulas.c: the formula kinds' deep zoom in double (zoom.h: UB_ZOOM_FORMULA_MAX). */
static inline int ub_kind_is_formula(ub_fractal_kind kind)
{
    return kind == UB_KIND_MANDELBULB || kind == UB_KIND_MANDELBOX || kind == UB_KIND_KIFS || kind == UB_KIND_HYBRID;
}
/* Called by ub_zoom_prepare for these kinds with the parsed anchor; NULL or a message. */
const char *ub_zoom_formula_prepare(ub_object *obj, double zoom, const ub_fixed anchor[3]);
/* The estimate at the local point u (object units around the anchor), in local units. */
void ub_zoom_formula_estimate(const ub_object *o, const double u[3], ub_zoom_result *res);
/* zoom.c: the set's bounding ball in local units, cut to UB_ZOOM_VIEW_RADIUS around the anchor. */
void ub_zoom_view_ball(ub_object *obj, const ub_fixed anchor[3]);

/* scene.c / camera.c: derive the precomputed fields; return NULL or an error message. */
const char *ub_object_prepare(ub_object *obj, double theta, const double slice_basis[4][3],
                              const double slice_origin[4], const double object_to_world[4][4]);
double ub_det3(const double m[3][3]);
/* Smallest and largest eigenvalue of a symmetric 3x3 matrix. */
void ub_sym3_eigen_range(const double a[3][3], double *lmin, double *lmax);
/* ifs.c: validate the maps and derive the bounding ball; NULL or an error message. */
const char *ub_ifs_prepare(ub_object *obj);
/* Lower bound on the distance from object-space point p to the IFS attractor (the union of the
 * leaf balls at ifs_depth); *address: where in the map hierarchy the nearest leaf lies, in
 * [0, 1); *depth: the depth at which the bound was settled. Scalar double precision, shared by
 * both kernels so they agree bit for bit. With `cancel` (may be NULL) set, the search stops
 * within UB_IFS_POLL splits and returns a lower bound all the same (the bound of every node still
 * waiting). */
double ub_ifs_distance(const ub_object *o, const double p[3], double *address, int *depth,
                       volatile int *cancel);
const char *ub_camera_prepare(ub_camera *cam, const double cam_to_world[4][4],
                              const double projection[4][4]);
/* World-space width of one pixel at ray distance t (the smaller side of a non-square pixel). */
double ub_pixel_footprint(const ub_camera *cam, double t);
/* Ray through full-image point (px, py) (a pixel's centre is at +0.5): world origin, unit
 * direction, t range. `lens`: a point of the unit square that picks the ray's point on the
 * aperture (ub_lens_sample); NULL, or a camera without depth of field: the pinhole's ray.
 * Returns 0 where a panoramic camera sees nothing (outside a fisheye's or the mirror ball's
 * circle: Cycles traces no ray there), with a zero direction and t range. */
int ub_camera_ray(const ub_camera *cam, double px, double py, const double lens[2], double origin[3],
                  double dir[3], double *t_min, double *t_max);

#endif
