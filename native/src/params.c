/* The parameter table (see params.h): one row per key, in the order the caller meets them. */
#include "params.h"

#include <math.h>

#include "render.h"

#define ROWS(table) (table), (int)(sizeof(table) / sizeof((table)[0]))
/* A row's default values, written in the row (NULL: zeros). */
#define D(...) ((const double[]){__VA_ARGS__})

/* Row builders: key, record field, shape, range, defaults, description. */
#define FIELD_OF(record, field) offsetof(record, field)
#define SCALAR(rec, key, type, lo, hi, def, flags, text) \
    {#key, type, FIELD_OF(rec, key), 1, 1, lo, hi, def, NULL, flags, text, 0, 0, 0, 0, 0, NULL}
#define REAL(rec, key, lo, hi, def, text) SCALAR(rec, key, UB_PARAM_FLOAT, lo, hi, def, 0, text)
#define INTEGER(rec, key, lo, hi, def, text) SCALAR(rec, key, UB_PARAM_INT, lo, hi, def, 0, text)
#define FLAG(rec, key, def, text) SCALAR(rec, key, UB_PARAM_BOOL, 0, 1, def, 0, text)
#define VECTOR(rec, key, n, lo, hi, def, flags, text) \
    {#key, UB_PARAM_FLOAT, FIELD_OF(rec, key), 1, n, lo, hi, def, NULL, flags, text, 0, 0, 0, 0, 0, NULL}
#define MATRIX(rec, key, r, c, lo, hi, def, flags, text) \
    {#key, UB_PARAM_FLOAT, FIELD_OF(rec, key), r, c, lo, hi, def, NULL, flags, text, 0, 0, 0, 0, 0, NULL}
#define CHOICE(rec, key, names, def, text) \
    {#key, UB_PARAM_CHOICE, FIELD_OF(rec, key), 1, 1, 0, 0, def, names, 0, text, 0, 0, 0, 0, 0, NULL}
#define LIST(rec, key, r, c, lo, hi, nmin, nmax, def, ndef, flags, text)                                     \
    {#key, UB_PARAM_LIST, FIELD_OF(rec, key), r, c, lo, hi, def, NULL, flags, text, nmin, nmax, ndef,         \
     FIELD_OF(rec, key##_count), sizeof(((rec *)0)->key[0]), NULL}


const char *const ub_kind_names[] = {"quaternion_julia", "quaternion_mandelbrot", "julia_stack", "cubic_locus",
                                     "ifs", "mandelbulb", "mandelbox", "kifs", "hybrid", NULL};
const char *const ub_isa_names[] = {"auto", "avx2", "portable", "avx512", NULL};
static const char *const threshold_modes[] = {"pixel", "fixed", NULL};
static const char *const normal_methods[] = {"gradient_distance", "gradient_potential", "zbuffer", "analytic",
                                             NULL};
static const char *const color_modes[] = {"base", "orbit_trap", "iterations", NULL};
static const char *const attributes[] = {"none", "orbit_trap", "iterations", "distance", "position", "normal", NULL};
static const char *const cubic_components[] = {"plus", "minus", "union", "both", NULL};
static const char *const light_types[] = {"point", "sun", "spot", "area", NULL};
static const char *const shadow_modes[] = {"none", "hard", "soft", NULL};
static const char *const panorama_types[] = {"none", "equirectangular", "fisheye_equidistant", "fisheye_equisolid",
                                             "mirrorball", NULL};
static const char *const kifs_shapes[] = {"sphere", "box", "tetrahedron", "octahedron", NULL};

/* ------------------------------------------------------------------ object */

/* Defaults: the paper's dendrite-like mu of the benchmark, the 1-i-j slice at k = 0, identity
 * placement; for section 5, Fig. 4's stack of real c, the connectedness locus proper and the
 * Sierpinski tetrahedron (these maps). */
static const double default_maps[48] = {
    0.5, 0, 0, 0.5,  0, 0.5, 0, 0.5,   0, 0, 0.5, 0.5,
    0.5, 0, 0, 0.5,  0, 0.5, 0, -0.5,  0, 0, 0.5, -0.5,
    0.5, 0, 0, -0.5, 0, 0.5, 0, 0.5,   0, 0, 0.5, -0.5,
    0.5, 0, 0, -0.5, 0, 0.5, 0, -0.5,  0, 0, 0.5, 0.5,
};

/* KIFS: the Sierpinski tetrahedron's three folds (Knighty's x + y >= 0, x + z >= 0, y + z >= 0);
 * hybrid: one Mandelbulb step, one Mandelbox step. */
static const double default_kifs_planes[12] = {1, 1, 0, 0, 1, 0, 1, 0, 0, 1, 1, 0};
static const double default_hybrid_steps[4] = {0, 1, 1, 1};

/* The four rows of a material input an attribute can drive (scene.h ub_material_map). */
#define MATERIAL_MAP(input, channels, label)                                                                 \
    CHOICE(OBJ, material_##input##_source, attributes, NULL,                                                 \
           "material: the attribute driving " label " (none: its constant)"),                             \
    LIST(OBJ, material_##input##_ramp, 1, channels, -1e6, 1e6, 2, UB_MAX_RAMP, NULL, 0, UB_PARAM_NONE_OK,     \
         "material: " label " over the attribute, uniformly spaced over [0, 1] (a Color Ramp or Map Range)"),  \
    REAL(OBJ, material_##input##_scale, -1e12, 1e12, D(1.0),                                                 \
         "material: " label " ramp position = clamp(attribute * scale + offset, 0, 1)"),                   \
    REAL(OBJ, material_##input##_offset, -1e12, 1e12, NULL,                                                  \
         "material: " label " ramp position = clamp(attribute * scale + offset, 0, 1)")

#define OBJ ub_object_input
static const ub_param object_rows[] = {
    {"name", UB_PARAM_STRING, FIELD_OF(OBJ, name), 1, 1, 0, UB_MAX_NAME - 1, NULL, NULL, 0,
     "the caller's name of the object, used in messages instead of objects[i]", 0, 0, 0, 0, 0, NULL},
    CHOICE(OBJ, kind, ub_kind_names, NULL, "family of fractal (section 5)"),
    VECTOR(OBJ, mu, 4, -1e3, 1e3, D(-0.2, 0.8, 0.0, 0.0), 0,
           "constant mu of f(z) = z^2 + mu (components 1, i, j, k)"),
    REAL(OBJ, theta, -1e6, 1e6, NULL, "rotation of the Julia set before it is lifted to 4-D (eq. 5-6), radians"),
    MATRIX(OBJ, slice_basis, 4, 3, -HUGE_VAL, HUGE_VAL, D(1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0), 0,
           "object-space axes in the quaternions (4x3, orthonormal columns): the 3-D slice"),
    VECTOR(OBJ, slice_origin, 4, -1e3, 1e3, NULL, 0, "quaternion at the object's origin"),
    MATRIX(OBJ, matrix, 4, 4, -1e9, 1e9, D(1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1), 0,
           "object -> world, affine 4x4 (Blender's matrix_world)"),
    INTEGER(OBJ, max_iterations, 1, UB_MAX_ITERATIONS, D(16), "iterations of f per point"),
    REAL(OBJ, bailout, 1.0, UB_MAX_BAILOUT, D(4.0), "escape radius; never below the set's bound"),
    CHOICE(OBJ, threshold_mode, threshold_modes, NULL,
           "hit threshold: the pixel footprint at each depth / detail, or a fixed epsilon"),
    REAL(OBJ, epsilon, 1e-7, 1.0, D(1e-3), "fixed threshold mode: hit threshold in object units"),
    REAL(OBJ, detail, 1e-3, 1e3, D(1.0), "pixel threshold mode: threshold = pixel footprint / detail"),
    REAL(OBJ, step_factor, 0.01, 1.0, D(1.0), "fraction of the distance estimate taken per step"),
    REAL(OBJ, max_step, 1e-6, 1e6, D(10.0), "longest step along a ray, world units (section 3.4)"),
    INTEGER(OBJ, max_steps, 1, UB_MAX_MARCH_STEPS_LIMIT, D(2000), "most marching steps per ray"),
    INTEGER(OBJ, bisection_steps, 0, UB_MAX_BISECTION, D(10), "bisection steps refining each hit"),
    VECTOR(OBJ, color, 3, 0.0, 1e6, D(0.8, 0.8, 0.8), 0, "surface colour, scene-linear RGB"),
    CHOICE(OBJ, normal_method, normal_methods, NULL, "normal approximation (section 4.1)"),
    REAL(OBJ, normal_alpha, 1e-9, 1e3, D(1e-3), "gradient step scale alpha of eq. 15"),
    REAL(OBJ, normal_delta, 0.0, 4.0, D(1.0), "depth exponent delta of the gradient step (Table 1)"),
    REAL(OBJ, reflectivity, 0.0, 1.0, NULL, "fraction of light the surface mirrors"),
    CHOICE(OBJ, color_mode, color_modes, NULL, "surface colour: base colour, or the ramp over a quantity"),
    LIST(OBJ, color_ramp, 1, 3, 0.0, 1e6, 2, UB_MAX_RAMP, NULL, 0, UB_PARAM_NONE_OK,
         "colour ramp: RGB colours uniformly spaced over [0, 1]; None: no ramp"),
    REAL(OBJ, ramp_scale, -1e6, 1e6, D(1.0), "ramp position = value * ramp_scale + ramp_offset"),
    REAL(OBJ, ramp_offset, -1e6, 1e6, NULL, "ramp position = value * ramp_scale + ramp_offset"),
    LIST(OBJ, path, 1, 2, -1e3, 1e3, 1, UB_MAX_PATH, D(-1.5, 0.0, 0.25, 0.0), 2, 0,
         "Julia stack: (Re c, Im c) points of the c-path, bottom to top"),
    REAL(OBJ, stack_height, 1e-6, 1e6, D(2.0), "Julia stack: height along object z"),
    CHOICE(OBJ, cubic_component, cubic_components, D(UB_CUBIC_BOTH),
           "cubic locus: which critical orbits must stay bounded"),
    REAL(OBJ, extent, 1e-6, 1e3, D(2.0), "cubic locus: radius of the 4-D ball it is cut to"),
    LIST(OBJ, maps, 3, 4, -1e6, 1e6, 1, UB_MAX_IFS_MAPS, default_maps, 4, 0,
         "IFS: affine maps x -> A x + t as 3x4 rows [A | t], each contracting"),
    INTEGER(OBJ, ifs_depth, 0, UB_MAX_IFS_DEPTH, D(6), "IFS: levels of the map hierarchy"),
    FLAG(OBJ, julia_mode, NULL, "Mandelbulb, Mandelbox: Julia mode, c = julia_c (else c = the point)"),
    VECTOR(OBJ, julia_c, 3, -1e3, 1e3, NULL, 0, "Mandelbulb, Mandelbox: the constant c of Julia mode"),
    REAL(OBJ, power, 2.0, 32.0, D(8.0), "Mandelbulb: triplex power n of z^n + c"),
    REAL(OBJ, box_scale, -10.0, 10.0, D(2.0), "Mandelbox: scale s of z <- s fold(z) + c, |s| > 1"),
    REAL(OBJ, box_fold, 1e-3, 100.0, D(1.0), "Mandelbox: box fold limit L (coordinates beyond +-L are reflected)"),
    REAL(OBJ, min_radius, 1e-3, 100.0, D(0.5), "Mandelbox: sphere fold minimum radius (linear scale inside)"),
    REAL(OBJ, fixed_radius, 1e-3, 100.0, D(1.0), "Mandelbox: sphere fold fixed radius (inversion inside), >= min_radius"),
    LIST(OBJ, kifs_planes, 1, 4, -1e3, 1e3, 0, UB_MAX_KIFS_PLANES, default_kifs_planes, 3, 0,
         "KIFS: fold planes (nx, ny, nz, d) in order, each reflecting z to n.z >= d (n normalised)"),
    REAL(OBJ, kifs_scale, 1.0, 10.0, D(2.0), "KIFS: scale s of z <- s R fold(z) - o (s - 1), s > 1"),
    VECTOR(OBJ, kifs_offset, 3, -1e3, 1e3, D(1.0, 1.0, 1.0), 0, "KIFS: offset o, the fixed point of the scaling"),
    VECTOR(OBJ, kifs_rotation, 3, -1e6, 1e6, NULL, 0, "KIFS: rotation R after the folds, XYZ Euler angles, radians"),
    CHOICE(OBJ, kifs_shape, kifs_shapes, D(UB_KIFS_TETRAHEDRON), "KIFS: the shape the last level is drawn as"),
    REAL(OBJ, kifs_size, 1e-3, 1e3, D(1.0), "KIFS: radius (sphere, octahedron) or half-width (box, tetrahedron) of the shape"),
    LIST(OBJ, hybrid_steps, 1, 2, 0.0, 10000.0, 1, UB_MAX_HYBRID_STEPS, default_hybrid_steps, 2, 0,
         "hybrid: (formula, count) entries applied in turn, formula 0 Mandelbulb, 1 Mandelbox, 2 KIFS"),
    REAL(OBJ, zoom, 0.0, UB_MAX_ZOOM, NULL,
         "quaternion kinds (to 60) and Mandelbulb, Mandelbox, KIFS, hybrid (to 10, double precision): log10 of the "
         "magnification; the object's point u is the fractal's anchor + u 10^-zoom"),
    {"zoom_anchor", UB_PARAM_STRING, FIELD_OF(OBJ, zoom_anchor), 1, 1, 0, UB_MAX_ANCHOR - 1, NULL, NULL, 0,
     "zoomed kinds: the fractal's object-space point at the object's origin, three decimal numbers 'x y z' "
     "with as many digits as the zoom needs", 0, 0, 0, 0, 0, NULL, "0 0 0"},
    FLAG(OBJ, use_material, NULL, "a Principled BSDF material (the material_* keys) instead of colour and Lambertian shading"),
    VECTOR(OBJ, material_base_color, 3, 0.0, 1e6, D(0.8, 0.8, 0.8), 0, "material: Base Color, scene-linear RGB"),
    REAL(OBJ, material_metallic, 0.0, 1.0, NULL, "material: Metallic"),
    REAL(OBJ, material_roughness, 0.0, 1.0, D(0.5), "material: Roughness (GGX alpha = roughness^2)"),
    REAL(OBJ, material_ior, 0.0, 1e3, D(1.5), "material: IOR of the dielectric specular layer"),
    REAL(OBJ, material_specular_ior_level, 0.0, 1e6, D(0.5),
         "material: Specular IOR Level (0.5: the IOR's own reflectance; F0 scales by 2 level)"),
    VECTOR(OBJ, material_emission, 3, 0.0, 1e12, NULL, 0, "material: Emission Color times Emission Strength"),
    REAL(OBJ, material_alpha, 0.0, 1.0, D(1.0), "material: Alpha, the surface's coverage"),
    MATERIAL_MAP(base_color, 3, "Base Color"),
    MATERIAL_MAP(metallic, 1, "Metallic"),
    MATERIAL_MAP(roughness, 1, "Roughness"),
};
#undef OBJ
const ub_param_section ub_object_section = {"object", ROWS(object_rows), sizeof(ub_object_input)};

/* ------------------------------------------------------------------ camera */

#define CAM ub_camera_input
static const ub_param camera_rows[] = {
    MATRIX(CAM, matrix, 4, 4, -HUGE_VAL, HUGE_VAL, NULL, UB_PARAM_REQUIRED,
           "camera -> world (Blender's matrix_world; scale is ignored)"),
    MATRIX(CAM, projection, 4, 4, -HUGE_VAL, HUGE_VAL, NULL, UB_PARAM_REQUIRED,
           "projection matrix (Blender's calc_matrix_camera), perspective or orthographic"),
    SCALAR(CAM, width, UB_PARAM_INT, 1, UB_MAX_IMAGE_SIZE, NULL, UB_PARAM_REQUIRED, "image width in pixels"),
    SCALAR(CAM, height, UB_PARAM_INT, 1, UB_MAX_IMAGE_SIZE, NULL, UB_PARAM_REQUIRED, "image height in pixels"),
    CHOICE(CAM, panorama_type, panorama_types, NULL,
           "none: the projection's camera; else Cycles' panoramic camera of that type (the projection then "
           "gives only the clip start and end, as distances along each ray)"),
    REAL(CAM, fisheye_fov, 1e-3, 10.0 * M_PI, D(M_PI),
         "fisheye: field of view, radians (equidistant: of the image's inscribed ellipse; equisolid: its limit)"),
    REAL(CAM, fisheye_lens, 1e-3, 1e6, D(10.5), "equisolid fisheye: focal length, mm"),
    REAL(CAM, sensor_width, 1e-3, 1e6, D(36.0), "equisolid fisheye: sensor width, mm, after Blender's sensor fit"),
    REAL(CAM, sensor_height, 1e-3, 1e6, D(24.0), "equisolid fisheye: sensor height, mm, after Blender's sensor fit"),
    /* +-1.5707964: Blender's limit is pi / 2 in float32, a little above the double's. */
    REAL(CAM, latitude_min, -1.5707964, 1.5707964, D(-M_PI / 2), "equirectangular: latitude of the bottom edge, radians"),
    REAL(CAM, latitude_max, -1.5707964, 1.5707964, D(M_PI / 2), "equirectangular: latitude of the top edge, radians"),
    REAL(CAM, longitude_min, -1e6, 1e6, D(-M_PI), "equirectangular: longitude of the left edge, radians"),
    REAL(CAM, longitude_max, -1e6, 1e6, D(M_PI), "equirectangular: longitude of the right edge, radians"),
    VECTOR(CAM, viewplane, 4, -1e6, 1e6, D(0.0, 1.0, 0.0, 1.0), 0,
           "panoramic: (u at the left edge, u at the right edge, v at the bottom, v at the top) of the "
           "panorama's unit square (Cycles' viewplane: the camera's shift, or a view's part of the camera frame)"),
    /* Depth of field: Cycles' thin lens (kernel/camera/camera.h), its values as blender/camera.cpp makes them. */
    REAL(CAM, aperture_size, 0.0, 1e6, NULL,
         "depth of field: the lens' radius, world units (Cycles' aperture size: focal length in metres / "
         "(2 f-stop); orthographic: 1 / (2 f-stop)); 0: a pinhole, no depth of field"),
    REAL(CAM, focus_distance, 0.0, HUGE_VAL, D(10.0),
         "depth of field: distance of the plane in focus along the view axis (panoramic: along each ray), "
         "world units; at least 1e-5, as in Cycles (and at most 1e30)"),
    INTEGER(CAM, aperture_blades, 0, 100, NULL, "depth of field: sides of the polygonal aperture; below 3 a disk"),
    REAL(CAM, aperture_rotation, -1e6, 1e6, NULL, "depth of field: rotation of the polygonal aperture, radians"),
    REAL(CAM, aperture_ratio, 1e-3, HUGE_VAL, D(1.0),
         "depth of field: anamorphic ratio; the aperture's width is divided by it (Cycles' aperture_ratio)"),
};
#undef CAM
const ub_param_section ub_camera_section = {"camera", ROWS(camera_rows), sizeof(ub_camera_input)};

/* ------------------------------------------------------------------ light */


#define LIGHT ub_light_input
static const ub_param light_rows[] = {
    CHOICE(LIGHT, type, light_types, NULL, "Blender's light types"),
    VECTOR(LIGHT, position, 3, -1e9, 1e9, NULL, 0, "world position (point, spot, area)"),
    VECTOR(LIGHT, direction, 3, -HUGE_VAL, HUGE_VAL, D(0.0, 0.0, -1.0), 0, "where the light points, non-zero (sun, spot, area)"),
    VECTOR(LIGHT, color, 3, 0.0, 1e12, D(1.0, 1.0, 1.0), 0,
           "irradiance scale: sun E = color; point, spot, area E = color / r^2"),
    REAL(LIGHT, radius, 0.0, 1e9, NULL, "source radius (sun: tangent of the angular radius): soft shadows"),
    REAL(LIGHT, spot_size, 0.0, M_PI, D(M_PI / 4), "spot: full cone angle, radians"),
    REAL(LIGHT, spot_blend, 0.0, 1.0, D(0.15), "spot: fraction of the cone over which it fades in"),
    FLAG(LIGHT, cast_shadow, D(1.0), "whether shadow rays are marched toward it"),
    FLAG(LIGHT, soft_falloff, NULL, "point and spot: Blender's soft falloff, E = color / (r^2 + radius^2)"),
};
#undef LIGHT
const ub_param_section ub_light_section = {"light", ROWS(light_rows), sizeof(ub_light_input)};

/* ------------------------------------------------------------------ shading */


#define SH ub_shading_input
static const ub_param shading_rows[] = {
    INTEGER(SH, samples, 1, UB_MAX_SAMPLES, D(1.0), "anti-aliasing samples per pixel"),
    REAL(SH, axle_light, 0.0, 1e6, D(1.0), "light at the eye (the paper's): 1 lights a white surface facing it to 1"),
    VECTOR(SH, ambient, 3, 0.0, 1e6, NULL, 0, "ambient light, scaled by ambient occlusion"),
    CHOICE(SH, shadows, shadow_modes, D(UB_SHADOWS_HARD), "shadows of the lights"),
    REAL(SH, ao_strength, 0.0, 1.0, NULL, "ambient occlusion strength (0: off)"),
    REAL(SH, ao_distance, 1e-6, 1e6, D(0.5), "world distance of the farthest occlusion sample"),
    INTEGER(SH, ao_samples, 1, UB_MAX_AO_SAMPLES, D(5), "occlusion samples along the normal"),
    INTEGER(SH, reflection_depth, 0, UB_MAX_REFLECTION_DEPTH, NULL, "mirror bounces (0: off)"),
    REAL(SH, fog_density, 0.0, 1e6, NULL, "fog f = 1 - exp(-density * distance), per world unit (0: off)"),
    VECTOR(SH, fog_color, 3, 0.0, 1e6, D(0.5, 0.5, 0.5), 0, "colour distant surfaces fade toward"),
    REAL(SH, glow_strength, 0.0, 1e6, NULL, "glow from the camera ray's marching steps (0: off)"),
    VECTOR(SH, glow_color, 3, 0.0, 1e6, D(0.4, 0.6, 1.0), 0, "colour of the glow"),
    FLAG(SH, use_sea, NULL, "the sea of Fig. 5: a reflective plane z = sea_height with waves"),
    REAL(SH, sea_height, -1e9, 1e9, D(-1.0), "sea: world z of the plane"),
    REAL(SH, sea_wavelength, 1e-6, 1e9, D(0.25), "sea: distance between wave crests"),
    REAL(SH, sea_amplitude, 0.0, 1e9, D(0.01), "sea: height of the waves"),
    VECTOR(SH, sea_color, 3, 0.0, 1e6, D(0.1, 0.25, 0.4), 0, "sea: colour"),
    REAL(SH, sea_reflectivity, 0.0, 1.0, D(0.5), "sea: fraction of light mirrored"),
    INTEGER(SH, world_samples, 0, UB_MAX_WORLD_SAMPLES, D(1.0),
            "world light samples per hit and anti-aliasing sample, each one from the world map and one "
            "from the surface (multiple importance sampling; a constant 1x1 map: from the surface alone); "
            "0: the world map is only seen, it lights nothing"),
    FLAG(SH, use_gi, NULL, "global illumination: paths bounce off every surface (Cycles' Light Paths); no ambient term"),
    INTEGER(SH, max_bounces, 0, UB_MAX_BOUNCES, D(12), "global illumination: bounces of a path in all"),
    INTEGER(SH, diffuse_bounces, 0, UB_MAX_BOUNCES, D(4), "global illumination: diffuse bounces of a path"),
    INTEGER(SH, glossy_bounces, 0, UB_MAX_BOUNCES, D(4),
            "global illumination: glossy bounces of a path (a material's specular lobe, mirror reflections)"),
    {"lights", UB_PARAM_LIST, FIELD_OF(SH, lights), 1, 1, 0, 0, NULL, NULL, 0,
     "lights as dicts of the light section", 0, UB_MAX_LIGHTS, 0, FIELD_OF(SH, lights_count),
     sizeof(ub_light_input), &ub_light_section},
};
#undef SH
const ub_param_section ub_shading_section = {"shading", ROWS(shading_rows), sizeof(ub_shading_input)};

/* ------------------------------------------------------------------ render() keywords */


#define R ub_render_input
static const ub_param render_rows[] = {
    VECTOR(R, window, 4, -HUGE_VAL, HUGE_VAL, NULL, UB_PARAM_NONE_OK,
           "4 integers (x, y, columns, rows): the part of the image rendered; None: all of it"),
    INTEGER(R, threads, 0, UB_MAX_THREADS, NULL, "render threads (0: one per CPU)"),
    INTEGER(R, tile_size, 1, 4096, D(32), "side of the square tiles handed to threads, pixels"),
    CHOICE(R, simd, ub_isa_names, NULL, "kernel: the widest the CPU has (AVX-512, AVX2 + FMA) or one named; portable runs anywhere (all give the same bits)"),
    REAL(R, poll_interval, 1e-4, 1.0, D(0.01), "seconds between progress and cancel polls"),
    VECTOR(R, background, 4, 0.0, 1e6, NULL, 0, "premultiplied RGBA of missed pixels (alpha within [0, 1])"),
    INTEGER(R, stride, 1, 4096, D(1.0), "render the image pixels (x + stride i, y + stride j) of the window only"),
    INTEGER(R, shared_steps, 0, 1, D(1),
            "1: the camera rays of each 8 x 8 block of pixels start where one cone marched for the block is empty of "
            "the scene (projection cameras without depth of field; issue 21); 0: every ray marches from the clip plane"),
    FLAG(R, clear_unfinished, NULL,
         "True: a render cancelled in its first sample leaves zeros (transparent black) in every tile it did not "
         "finish, so the buffers need no clearing beforehand; False: those pixels keep what the buffers held"),
    VECTOR(R, sample_range, 2, -HUGE_VAL, HUGE_VAL, NULL, UB_PARAM_NONE_OK,
           "2 integers (first, count): these samples, added to buffers holding the earlier ones' sum"),
    {"progress", UB_PARAM_CUSTOM, 0, 1, 1, 0, 0, NULL, NULL, UB_PARAM_NONE_OK,
     "callable(fraction) -> True to cancel, called on the calling thread", 0, 0, 0, 0, 0, NULL},
    {"cancel", UB_PARAM_CUSTOM, 0, 1, 1, 0, 0, NULL, NULL, UB_PARAM_NONE_OK,
     "an object with is_set() (a threading.Event): set, the render stops", 0, 0, 0, 0, 0, NULL},
    {"world", UB_PARAM_CUSTOM, 0, 1, 1, 0, 0, NULL, NULL, UB_PARAM_NONE_OK,
     "the World's equirectangular map, float32 (height, width, 3), row 0 at the nadir: the background of "
     "missed rays and a light at every hit (shading world_samples); None: the background colour", 0, 0, 0, 0, 0,
     NULL},
};
#undef R
const ub_param_section ub_render_section = {"render", ROWS(render_rows), sizeof(ub_render_input)};

const ub_param_section *const ub_param_sections[] = {&ub_object_section, &ub_camera_section, &ub_shading_section,
                                                      &ub_light_section, &ub_render_section, NULL};
