/* The parameter table: every value a caller can give the core, declared once.
 *
 * One row per key (as Cycles' NODE_DEFINE declares a node's sockets): its type, where it is
 * stored in the section's input record, its shape, its hard range, its default, its choices and
 * one line that says what it means. The binding's one generic parser (module.c) reads
 * dictionaries through these rows: unknown keys, defaults, ranges, non-finite values and the
 * messages. Python sees the same rows read-only as unbound_core.PARAMETERS, and the Blender
 * add-on's properties are checked against them (tests/blender/test_parameter_table.py).
 *
 * The input records hold the caller's values as given (double for every real number); the
 * kernels' records (scene.h) are derived from them by the prepare functions. */
#ifndef UNBOUND_PARAMS_H
#define UNBOUND_PARAMS_H

#include <stddef.h>

#include "scene.h"

#define UB_MAX_NAME 64

typedef enum {
    UB_PARAM_FLOAT,    /* double components */
    UB_PARAM_INT,      /* int components */
    UB_PARAM_BOOL,     /* int 0/1, only True or False accepted */
    UB_PARAM_CHOICE,   /* int index into choices; given as the name */
    UB_PARAM_STRING,   /* char[max + 1]: at most `max` bytes */
    UB_PARAM_LIST,     /* min_items..max_items items, each of the row's shape or a dict of `items` */
    UB_PARAM_CUSTOM,   /* parsed by the binding's own code (callables, buffers); described only */
} ub_param_type;

/* Flag bits of a row. */
enum {
    UB_PARAM_REQUIRED = 1 << 0,   /* no default: the key must be given */
    UB_PARAM_NONE_OK = 1 << 1,    /* None means "use the default" */
};

typedef struct ub_param_section ub_param_section;

typedef struct {
    const char *key;
    ub_param_type type;
    size_t offset;            /* of the value in the section's input record */
    int rows, cols;           /* shape of one value (of one item for lists): 1 x 1 is a scalar */
    double min, max;          /* hard range of every component */
    const double *defaults;   /* rows x cols values (lists: default_items items); NULL: zeros */
    const char *const *choices; /* CHOICE: NULL-terminated names */
    unsigned flags;
    const char *description;
    /* Lists: the item count is stored at count_offset (an int); items follow each other
     * item_size bytes apart from offset; items that are dicts are read by the section `items`. */
    int min_items, max_items, default_items;
    size_t count_offset, item_size;
    const ub_param_section *items;
    const char *text_default; /* STRING: the default text (NULL: "") */
} ub_param;

struct ub_param_section {
    const char *name;         /* "object", "camera", "shading", "light", "render" */
    const ub_param *rows;
    int count;
    size_t record_size;
};

/* ------------------------------------------------------------------ the input records */

typedef struct {
    char name[UB_MAX_NAME];   /* the caller's name for messages ("" : objects[i]) */
    int kind;                 /* ub_fractal_kind */
    double mu[4], theta;
    double slice_basis[4][3], slice_origin[4];
    double matrix[4][4];      /* object -> world */
    int max_iterations;
    double bailout;
    int threshold_mode;       /* ub_epsilon_mode */
    double epsilon, detail, step_factor, max_step;
    int max_steps, bisection_steps;
    double color[3];
    int normal_method;        /* ub_normal_method */
    double normal_alpha, normal_delta, reflectivity;
    int color_mode;           /* ub_color_mode */
    int color_ramp_count;
    double color_ramp[UB_MAX_RAMP][3];
    double ramp_scale, ramp_offset;
    int path_count;
    double path[UB_MAX_PATH][2];
    double stack_height;
    int cubic_component;      /* ub_cubic_component */
    double extent;
    int maps_count;
    double maps[UB_MAX_IFS_MAPS][3][4];
    int ifs_depth;
    int julia_mode;
    double julia_c[3];
    double power;
    double box_scale, box_fold, min_radius, fixed_radius;
    int kifs_planes_count;
    double kifs_planes[UB_MAX_KIFS_PLANES][4];
    double kifs_scale, kifs_offset[3], kifs_rotation[3];
    int kifs_shape;
    double kifs_size;
    int hybrid_steps_count;
    double hybrid_steps[UB_MAX_HYBRID_STEPS][2];
    double zoom;
    char zoom_anchor[UB_MAX_ANCHOR];
    /* The Principled BSDF material (scene.h ub_material); each driven input: source, ramp, scale, offset. */
    int use_material;
    double material_base_color[3], material_metallic, material_roughness, material_ior;
    double material_specular_ior_level, material_emission[3], material_alpha;
    int material_base_color_source, material_base_color_ramp_count;
    double material_base_color_ramp[UB_MAX_RAMP][3], material_base_color_scale, material_base_color_offset;
    int material_metallic_source, material_metallic_ramp_count;
    double material_metallic_ramp[UB_MAX_RAMP][1], material_metallic_scale, material_metallic_offset;
    int material_roughness_source, material_roughness_ramp_count;
    double material_roughness_ramp[UB_MAX_RAMP][1], material_roughness_scale, material_roughness_offset;
} ub_object_input;

typedef struct {
    double matrix[4][4], projection[4][4];
    int width, height;
    int panorama_type;        /* ub_panorama_type */
    double fisheye_fov, fisheye_lens, sensor_width, sensor_height;
    double latitude_min, latitude_max, longitude_min, longitude_max;
    double viewplane[4];
    double aperture_size, focus_distance, aperture_rotation, aperture_ratio;
    int aperture_blades;
} ub_camera_input;

typedef struct {
    int type;                 /* ub_light_type */
    double position[3], direction[3], color[3];
    double radius, spot_size, spot_blend;
    int cast_shadow, soft_falloff;
} ub_light_input;

typedef struct {
    int samples;
    double axle_light, ambient[3];
    int shadows;              /* ub_shadow_mode */
    double ao_strength, ao_distance;
    int ao_samples, reflection_depth;
    double fog_density, fog_color[3], glow_strength, glow_color[3];
    int use_sea;
    double sea_height, sea_wavelength, sea_amplitude, sea_color[3], sea_reflectivity;
    int lights_count;
    ub_light_input lights[UB_MAX_LIGHTS];
    int world_samples;
    int use_gi, max_bounces, diffuse_bounces, glossy_bounces;
} ub_shading_input;

/* render()'s keywords beside camera, objects and passes. */
typedef struct {
    double window[4];         /* whole numbers; not given: the whole image */
    int threads, tile_size, simd, stride, shared_steps, clear_unfinished;
    double poll_interval, background[4];
    double sample_range[2];   /* whole numbers (first, count); not given: all samples */
} ub_render_input;

extern const ub_param_section ub_object_section, ub_camera_section, ub_light_section, ub_shading_section,
    ub_render_section;
/* Every section, for PARAMETERS; NULL-terminated. */
extern const ub_param_section *const ub_param_sections[];

extern const char *const ub_kind_names[];     /* indexed by ub_fractal_kind */
extern const char *const ub_isa_names[];      /* indexed by ub_isa */

/* Below this ratio of a pixel's footprint to the fractal's bounding radius, float32 no longer
 * resolves neighbouring pixels' depths (measured: tests/native/test_precision.py). */
#define UB_PRECISION_LIMIT 1e-6

/* Input -> the kernels' records (scene.c, camera.c): NULL, or a message without the path. */
const char *ub_object_from_input(ub_object *obj, const ub_object_input *in);
const char *ub_camera_from_input(ub_camera *cam, const ub_camera_input *in);
const char *ub_light_from_input(ub_light *light, const ub_light_input *in);
void ub_shading_from_input(ub_shading *sh, const ub_shading_input *in);

#endif
