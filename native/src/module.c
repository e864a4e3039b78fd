/* CPython binding of the Unbound core, on the limited API (abi3, 3.11+): one wheel for every
 * Python from Blender 4.2 (3.11) to 5.2 (3.13). All validation happens here, before any
 * native work starts: every bad input becomes a ValueError/TypeError naming the parameter. */
#define Py_LIMITED_API 0x030B0000
#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "render.h"
#include "scene.h"

#define ERRBUF 256

/* ---------------------------------------------------------------- number parsing helpers */

/* Reads a float; NaN is never accepted, infinities only when allow_inf. */
static int get_double(PyObject *o, const char *name, double lo, double hi, int allow_inf, double *out)
{
    if (!PyFloat_Check(o) && !PyLong_Check(o) && !PyObject_HasAttrString(o, "__float__")) {
        PyErr_Format(PyExc_TypeError, "%s must be a number", name);
        return -1;
    }
    double v = PyFloat_AsDouble(o);
    if (v == -1.0 && PyErr_Occurred()) {
        PyErr_Clear();
        PyErr_Format(PyExc_TypeError, "%s must be a number", name);
        return -1;
    }
    if (isnan(v) || (isinf(v) && !allow_inf)) {
        PyErr_Format(PyExc_ValueError, "%s must be finite", name);
        return -1;
    }
    if (!(v >= lo && v <= hi)) {
        /* PyErr_Format has no %g: format here. */
        char msg[ERRBUF + 96];
        snprintf(msg, sizeof msg, "%s must be in [%g, %g], got %g", name, lo, hi, v);
        PyErr_SetString(PyExc_ValueError, msg);
        return -1;
    }
    *out = v;
    return 0;
}

static int get_int(PyObject *o, const char *name, long lo, long hi, int *out)
{
    if (PyFloat_Check(o) || !PyLong_Check(o)) {
        PyErr_Format(PyExc_TypeError, "%s must be an integer", name);
        return -1;
    }
    int overflow = 0;
    long long v = PyLong_AsLongLongAndOverflow(o, &overflow);
    if (v == -1 && PyErr_Occurred())
        return -1;
    if (overflow || v < lo || v > hi) {
        PyErr_Format(PyExc_ValueError, "%s must be in [%ld, %ld]", name, lo, hi);
        return -1;
    }
    *out = (int)v;
    return 0;
}

/* A sequence of n finite numbers. */
static int get_vector(PyObject *o, const char *name, int n, double *out)
{
    if (!PySequence_Check(o) || PyUnicode_Check(o)) {
        PyErr_Format(PyExc_TypeError, "%s must be a sequence of %d numbers", name, n);
        return -1;
    }
    Py_ssize_t len = PySequence_Size(o);
    if (len < 0)
        return -1;
    if (len != n) {
        PyErr_Format(PyExc_ValueError, "%s must have %d components, got %zd", name, n, len);
        return -1;
    }
    for (int i = 0; i < n; i++) {
        PyObject *item = PySequence_GetItem(o, i);
        if (!item)
            return -1;
        char sub[ERRBUF];
        snprintf(sub, sizeof sub, "%s[%d]", name, i);
        int rc = get_double(item, sub, -HUGE_VAL, HUGE_VAL, 0, &out[i]);
        Py_DECREF(item);
        if (rc)
            return -1;
    }
    return 0;
}

/* rows x cols matrix given as a sequence of rows (numpy arrays, mathutils.Matrix, lists). */
static int get_matrix(PyObject *o, const char *name, int rows, int cols, double *out)
{
    if (!PySequence_Check(o) || PyUnicode_Check(o)) {
        PyErr_Format(PyExc_TypeError, "%s must be a %dx%d matrix (a sequence of rows)", name, rows, cols);
        return -1;
    }
    Py_ssize_t len = PySequence_Size(o);
    if (len < 0)
        return -1;
    if (len != rows) {
        PyErr_Format(PyExc_ValueError, "%s must be a %dx%d matrix, got %zd rows", name, rows, cols, len);
        return -1;
    }
    for (int r = 0; r < rows; r++) {
        PyObject *row = PySequence_GetItem(o, r);
        if (!row)
            return -1;
        char sub[ERRBUF];
        snprintf(sub, sizeof sub, "%s[%d]", name, r);
        int rc = get_vector(row, sub, cols, out + r * cols);
        Py_DECREF(row);
        if (rc)
            return -1;
    }
    return 0;
}

/* Looks up key in dict d; returns a borrowed reference or NULL (absent, no error set). */
static PyObject *lookup(PyObject *d, const char *key)
{
    return PyDict_GetItemString(d, key);
}

static int check_keys(PyObject *d, const char *name, const char *const *allowed)
{
    PyObject *key, *value;
    Py_ssize_t pos = 0;
    while (PyDict_Next(d, &pos, &key, &value)) {
        if (!PyUnicode_Check(key)) {
            PyErr_Format(PyExc_TypeError, "%s keys must be strings", name);
            return -1;
        }
        const char *k = PyUnicode_AsUTF8AndSize(key, NULL);
        if (!k)
            return -1;
        int ok = 0;
        for (const char *const *a = allowed; *a; a++)
            if (strcmp(*a, k) == 0)
                ok = 1;
        if (!ok) {
            PyErr_Format(PyExc_ValueError, "%s has an unknown key '%s'", name, k);
            return -1;
        }
    }
    return 0;
}

static int get_choice(PyObject *o, const char *name, const char *const *choices, int *out)
{
    if (!PyUnicode_Check(o)) {
        PyErr_Format(PyExc_TypeError, "%s must be a string", name);
        return -1;
    }
    const char *s = PyUnicode_AsUTF8AndSize(o, NULL);
    if (!s)
        return -1;
    for (int i = 0; choices[i]; i++)
        if (strcmp(s, choices[i]) == 0) {
            *out = i;
            return 0;
        }
    PyErr_Format(PyExc_ValueError, "%s must be one of the documented names, got '%s'", name, s);
    return -1;
}

/* ---------------------------------------------------------------- camera and objects */

static const char *const camera_keys[] = {"matrix", "projection", "width", "height", NULL};

static int parse_camera(PyObject *o, ub_camera *cam)
{
    if (!PyDict_Check(o)) {
        PyErr_SetString(PyExc_TypeError, "camera must be a dict with matrix, projection, width, height");
        return -1;
    }
    if (check_keys(o, "camera", camera_keys))
        return -1;
    memset(cam, 0, sizeof *cam);
    PyObject *m = lookup(o, "matrix"), *p = lookup(o, "projection"), *w = lookup(o, "width"),
             *h = lookup(o, "height");
    if (!m || !p || !w || !h) {
        PyErr_SetString(PyExc_ValueError, "camera needs 'matrix', 'projection', 'width' and 'height'");
        return -1;
    }
    double mat[4][4], proj[4][4];
    if (get_matrix(m, "camera.matrix", 4, 4, &mat[0][0]) || get_matrix(p, "camera.projection", 4, 4, &proj[0][0])
        || get_int(w, "camera.width", 1, UB_MAX_IMAGE_SIZE, &cam->width)
        || get_int(h, "camera.height", 1, UB_MAX_IMAGE_SIZE, &cam->height))
        return -1;
    const char *err = ub_camera_prepare(cam, mat, proj);
    if (err) {
        PyErr_SetString(PyExc_ValueError, err);
        return -1;
    }
    return 0;
}

static const char *const object_keys[] = {
    "kind", "mu", "theta", "slice_basis", "slice_origin", "matrix", "max_iterations", "bailout",
    "epsilon_mode", "epsilon", "detail", "step_factor", "max_step", "max_steps", "bisection_steps",
    "color", "normal_method", "normal_alpha", "normal_delta", "reflectivity", "color_mode", "color_ramp",
    "ramp_scale", "ramp_offset", "path", "stack_height", "cubic_component", "extent", "maps", "ifs_depth", NULL,
};
/* Indexed by ub_fractal_kind. */
static const char *const kind_names[] = {"quaternion_julia", "quaternion_mandelbrot", "julia_stack", "cubic_locus",
                                         "ifs", NULL};
static const char *const cubic_components[] = {"plus", "minus", "union", "both", NULL};
static const char *const epsilon_modes[] = {"pixel", "fixed", NULL};
static const char *const normal_methods[] = {"gradient_distance", "gradient_potential", "zbuffer", "analytic", NULL};
static const char *const color_modes[] = {"base", "orbit_trap", "iterations", NULL};

/* A colour: 3 numbers within [0, hi]. */
static int get_color(PyObject *o, const char *name, double hi, float out[3])
{
    double c[3];
    if (get_vector(o, name, 3, c))
        return -1;
    for (int i = 0; i < 3; i++) {
        if (!(c[i] >= 0.0 && c[i] <= hi)) {
            char msg[ERRBUF + 64];
            snprintf(msg, sizeof msg, "%s components must be within [0, %g]", name, hi);
            PyErr_SetString(PyExc_ValueError, msg);
            return -1;
        }
        out[i] = (float)c[i];
    }
    return 0;
}

/* A sequence of min..max items, each parsed by `item_fn` into slot i; returns the count or -1. */
static int get_sequence(PyObject *o, const char *name, int min, int max, const char *what,
                        int (*item_fn)(PyObject *, const char *, ub_object *, int), ub_object *obj)
{
    if (!PySequence_Check(o) || PyUnicode_Check(o)) {
        PyErr_Format(PyExc_TypeError, "%s must be a sequence of %s", name, what);
        return -1;
    }
    Py_ssize_t len = PySequence_Size(o);
    if (len < 0)
        return -1;
    if (len < min || len > max) {
        PyErr_Format(PyExc_ValueError, "%s must hold %d to %d %s, got %zd", name, min, max, what, len);
        return -1;
    }
    for (Py_ssize_t i = 0; i < len; i++) {
        PyObject *item = PySequence_GetItem(o, i);
        if (!item)
            return -1;
        char sub[ERRBUF];
        snprintf(sub, sizeof sub, "%s[%zd]", name, i);
        int rc = item_fn(item, sub, obj, (int)i);
        Py_DECREF(item);
        if (rc)
            return -1;
    }
    return (int)len;
}

static int get_ramp_color(PyObject *o, const char *name, ub_object *obj, int i)
{
    return get_color(o, name, 1e6, obj->ramp[i]);
}

static int get_path_point(PyObject *o, const char *name, ub_object *obj, int i)
{
    if (get_vector(o, name, 2, obj->path[i]))
        return -1;
    if (fabs(obj->path[i][0]) > 1e3 || fabs(obj->path[i][1]) > 1e3) {
        PyErr_Format(PyExc_ValueError, "%s: c components must be within [-1000, 1000]", name);
        return -1;
    }
    return 0;
}

static int get_ifs_map(PyObject *o, const char *name, ub_object *obj, int i)
{
    if (get_matrix(o, name, 3, 4, &obj->maps[i][0][0]))
        return -1;
    for (int r = 0; r < 3; r++)
        if (fabs(obj->maps[i][r][3]) > 1e6) {
            PyErr_Format(PyExc_ValueError, "%s: translations must be within [-1e6, 1e6]", name);
            return -1;
        }
    return 0;
}

static int parse_object(PyObject *o, const char *name, ub_object *obj)
{
    if (!PyDict_Check(o)) {
        PyErr_Format(PyExc_TypeError, "%s must be a dict of fractal parameters", name);
        return -1;
    }
    if (check_keys(o, name, object_keys))
        return -1;
    memset(obj, 0, sizeof *obj);
    /* Defaults: the paper's dendrite-like mu of the benchmark, the 1-i-j slice at k = 0. */
    double mu[4] = {-0.2, 0.8, 0.0, 0.0}, theta = 0.0, basis[4][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0, 0, 0}};
    double origin[4] = {0, 0, 0, 0}, matrix[4][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}};
    int kind = 0, mode = UB_EPSILON_PIXEL, normal_method = UB_NORMAL_GRADIENT_DISTANCE, color_mode = UB_COLOR_BASE;
    double reflectivity = 0.0, ramp_scale = 1.0, ramp_offset = 0.0;
    obj->normal_alpha = 1e-3;
    obj->normal_delta = 1.0;
    obj->max_iterations = 16;
    obj->bailout = 4.0;
    obj->epsilon = 1e-3;
    obj->detail = 1.0;
    obj->step_factor = 1.0;
    obj->max_step = HUGE_VAL;
    obj->max_steps = 2000;
    obj->bisection_steps = 10;
    /* Section 5 defaults: Fig. 4's stack of real c, the connectedness locus proper, the
     * Sierpinski tetrahedron. */
    obj->path_count = 2;
    obj->path[0][0] = -1.5;
    obj->path[1][0] = 0.25;
    obj->stack_height = 2.0;
    obj->cubic_component = UB_CUBIC_BOTH;
    obj->extent = 2.0;
    obj->ifs_depth = 6;
    static const double tetra[4][3] = {{1, 1, 1}, {1, -1, -1}, {-1, 1, -1}, {-1, -1, 1}};
    obj->map_count = 4;
    for (int i = 0; i < 4; i++)
        for (int r = 0; r < 3; r++) {
            obj->maps[i][r][r] = 0.5;
            obj->maps[i][r][3] = 0.5 * tetra[i][r];
        }
    int component = UB_CUBIC_BOTH, count;
    char sub[ERRBUF];
    PyObject *v;
#define FIELD(key) ((v = lookup(o, key)) != NULL && (snprintf(sub, sizeof sub, "%s.%s", name, key), 1))
    if (FIELD("kind") && get_choice(v, sub, kind_names, &kind))
        return -1;
    if (FIELD("mu") && get_vector(v, sub, 4, mu))
        return -1;
    if (FIELD("theta") && get_double(v, sub, -1e6, 1e6, 0, &theta))
        return -1;
    if (FIELD("slice_basis") && get_matrix(v, sub, 4, 3, &basis[0][0]))
        return -1;
    if (FIELD("slice_origin") && get_vector(v, sub, 4, origin))
        return -1;
    if (FIELD("matrix") && get_matrix(v, sub, 4, 4, &matrix[0][0]))
        return -1;
    if (FIELD("max_iterations") && get_int(v, sub, 1, UB_MAX_ITERATIONS, &obj->max_iterations))
        return -1;
    if (FIELD("bailout") && get_double(v, sub, 1.0, UB_MAX_BAILOUT, 0, &obj->bailout))
        return -1;
    if (FIELD("epsilon_mode") && get_choice(v, sub, epsilon_modes, &mode))
        return -1;
    if (FIELD("epsilon") && get_double(v, sub, 1e-7, 1.0, 0, &obj->epsilon))
        return -1;
    if (FIELD("detail") && get_double(v, sub, 1e-3, 1e3, 0, &obj->detail))
        return -1;
    if (FIELD("step_factor") && get_double(v, sub, 0.01, 1.0, 0, &obj->step_factor))
        return -1;
    if (FIELD("max_step") && get_double(v, sub, 1e-6, HUGE_VAL, 1, &obj->max_step))
        return -1;
    if (FIELD("max_steps") && get_int(v, sub, 1, UB_MAX_MARCH_STEPS_LIMIT, &obj->max_steps))
        return -1;
    if (FIELD("bisection_steps") && get_int(v, sub, 0, UB_MAX_BISECTION, &obj->bisection_steps))
        return -1;
    obj->color[0] = obj->color[1] = obj->color[2] = 0.8f;
    if (FIELD("color") && get_color(v, sub, 1e6, obj->color))
        return -1;
    if (FIELD("normal_method") && get_choice(v, sub, normal_methods, &normal_method))
        return -1;
    if (FIELD("normal_alpha") && get_double(v, sub, 1e-9, 1e3, 0, &obj->normal_alpha))
        return -1;
    if (FIELD("normal_delta") && get_double(v, sub, 0.0, 4.0, 0, &obj->normal_delta))
        return -1;
    if (FIELD("reflectivity") && get_double(v, sub, 0.0, 1.0, 0, &reflectivity))
        return -1;
    if (FIELD("color_mode") && get_choice(v, sub, color_modes, &color_mode))
        return -1;
    /* A colour ramp: RGB triples uniformly spaced over [0, 1]. */
    if (FIELD("color_ramp") && v != Py_None) {
        if ((count = get_sequence(v, sub, 2, UB_MAX_RAMP, "RGB colours", get_ramp_color, obj)) < 0)
            return -1;
        obj->ramp_size = count;
    }
    if (FIELD("ramp_scale") && get_double(v, sub, -1e6, 1e6, 0, &ramp_scale))
        return -1;
    if (FIELD("ramp_offset") && get_double(v, sub, -1e6, 1e6, 0, &ramp_offset))
        return -1;
    if (FIELD("path")) {
        if ((count = get_sequence(v, sub, 1, UB_MAX_PATH, "(re, im) points", get_path_point, obj)) < 0)
            return -1;
        obj->path_count = count;
    }
    if (FIELD("stack_height") && get_double(v, sub, 1e-6, 1e6, 0, &obj->stack_height))
        return -1;
    if (FIELD("cubic_component") && get_choice(v, sub, cubic_components, &component))
        return -1;
    if (FIELD("extent") && get_double(v, sub, 1e-6, 1e3, 0, &obj->extent))
        return -1;
    if (FIELD("maps")) {
        memset(obj->maps, 0, sizeof obj->maps);
        if ((count = get_sequence(v, sub, 1, UB_MAX_IFS_MAPS, "3x4 affine maps", get_ifs_map, obj)) < 0)
            return -1;
        obj->map_count = count;
    }
    if (FIELD("ifs_depth") && get_int(v, sub, 0, UB_MAX_IFS_DEPTH, &obj->ifs_depth))
        return -1;
#undef FIELD
    obj->cubic_component = (ub_cubic_component)component;
    obj->normal_method = (ub_normal_method)normal_method;
    obj->color_mode = (ub_color_mode)color_mode;
    obj->reflectivity = (float)reflectivity;
    obj->ramp_scale = (float)ramp_scale;
    obj->ramp_offset = (float)ramp_offset;
    for (int i = 0; i < 4; i++)
        if (fabs(mu[i]) > 1e3 || fabs(origin[i]) > 1e3) {
            PyErr_Format(PyExc_ValueError, "%s: mu and slice_origin components must be within [-1000, 1000]", name);
            return -1;
        }
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++)
            if (fabs(matrix[i][j]) > 1e9) {
                PyErr_Format(PyExc_ValueError, "%s.matrix entries must be within [-1e9, 1e9]", name);
                return -1;
            }
    obj->kind = (ub_fractal_kind)kind;
    obj->epsilon_mode = (ub_epsilon_mode)mode;
    memcpy(obj->mu, mu, sizeof mu);
    const char *err = ub_object_prepare(obj, theta, basis, origin, matrix);
    if (err) {
        PyErr_Format(PyExc_ValueError, "%s: %s", name, err);
        return -1;
    }
    return 0;
}

static int parse_objects(PyObject *seq, ub_object *objs, int *count)
{
    if (!PyList_Check(seq) && !PyTuple_Check(seq)) {
        PyErr_SetString(PyExc_TypeError, "objects must be a list of dicts");
        return -1;
    }
    Py_ssize_t n = PySequence_Size(seq);
    if (n < 0)
        return -1;
    if (n > UB_MAX_OBJECTS) {
        PyErr_Format(PyExc_ValueError, "objects: at most %d fractal objects per render", UB_MAX_OBJECTS);
        return -1;
    }
    for (Py_ssize_t i = 0; i < n; i++) {
        PyObject *item = PySequence_GetItem(seq, i);
        if (!item)
            return -1;
        char name[64];
        snprintf(name, sizeof name, "objects[%zd]", i);
        int rc = parse_object(item, name, &objs[i]);
        Py_DECREF(item);
        if (rc)
            return -1;
    }
    *count = (int)n;
    return 0;
}

/* ---------------------------------------------------------------- shading */

static const char *const shading_keys[] = {
    "samples", "axle_light", "ambient", "shadows", "ao_strength", "ao_distance", "ao_samples", "reflection_depth",
    "fog_density", "fog_color", "glow_strength", "glow_color", "sea", "lights", NULL,
};
static const char *const sea_keys[] = {"height", "wavelength", "amplitude", "color", "reflectivity", NULL};
static const char *const light_keys[] = {"type", "position", "direction", "color", "radius", "spot_size",
                                         "spot_blend", "cast_shadow", "soft_falloff", NULL};
static const char *const light_types[] = {"point", "sun", "spot", "area", NULL};
static const char *const shadow_modes[] = {"none", "hard", "soft", NULL};

static int get_bool(PyObject *o, const char *name, int *out)
{
    if (!PyBool_Check(o)) {
        PyErr_Format(PyExc_TypeError, "%s must be True or False", name);
        return -1;
    }
    *out = o == Py_True;
    return 0;
}

static int parse_light(PyObject *o, const char *name, ub_light *L)
{
    if (!PyDict_Check(o)) {
        PyErr_Format(PyExc_TypeError, "%s must be a dict", name);
        return -1;
    }
    if (check_keys(o, name, light_keys))
        return -1;
    memset(L, 0, sizeof *L);
    int type = UB_LIGHT_POINT;
    double dir[3] = {0, 0, -1}, spot_size = M_PI / 4, spot_blend = 0.15;
    L->color[0] = L->color[1] = L->color[2] = 1.0f;
    L->cast_shadow = 1;
    char sub[ERRBUF];
    PyObject *v;
#define FIELD(key) ((v = lookup(o, key)) != NULL && (snprintf(sub, sizeof sub, "%s.%s", name, key), 1))
    if (FIELD("type") && get_choice(v, sub, light_types, &type))
        return -1;
    if (FIELD("position") && get_vector(v, sub, 3, L->position))
        return -1;
    if (FIELD("direction") && get_vector(v, sub, 3, dir))
        return -1;
    if (FIELD("color") && get_color(v, sub, 1e12, L->color))
        return -1;
    if (FIELD("radius") && get_double(v, sub, 0.0, 1e9, 0, &L->radius))
        return -1;
    if (FIELD("spot_size") && get_double(v, sub, 0.0, M_PI, 0, &spot_size))
        return -1;
    if (FIELD("spot_blend") && get_double(v, sub, 0.0, 1.0, 0, &spot_blend))
        return -1;
    if (FIELD("cast_shadow") && get_bool(v, sub, &L->cast_shadow))
        return -1;
    if (FIELD("soft_falloff") && get_bool(v, sub, &L->soft_falloff))
        return -1;
#undef FIELD
    for (int i = 0; i < 3; i++)
        if (fabs(L->position[i]) > 1e9) {
            PyErr_Format(PyExc_ValueError, "%s.position components must be within [-1e9, 1e9]", name);
            return -1;
        }
    double len = sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
    if (!(len > 1e-12) || !isfinite(len)) {
        PyErr_Format(PyExc_ValueError, "%s.direction must be a non-zero vector", name);
        return -1;
    }
    for (int i = 0; i < 3; i++)
        L->direction[i] = dir[i] / len;
    L->type = (ub_light_type)type;
    /* Blender's spot: spot_size is the full cone angle, spot_blend the fraction of the cone's
     * cosine range over which it fades in. */
    L->spot_cos_outer = cos(spot_size / 2);
    L->spot_cos_inner = L->spot_cos_outer + (1.0 - L->spot_cos_outer) * spot_blend;
    return 0;
}

static int parse_shading(PyObject *o, ub_shading *sh)
{
    memset(sh, 0, sizeof *sh);
    sh->samples = 1;
    sh->axle_light = 1.0f;
    sh->shadows = UB_SHADOWS_HARD;
    sh->ao_distance = 0.5;
    sh->ao_samples = 5;
    if (!o || o == Py_None)
        return 0;
    if (!PyDict_Check(o)) {
        PyErr_SetString(PyExc_TypeError, "shading must be a dict of shading settings or None");
        return -1;
    }
    if (check_keys(o, "shading", shading_keys))
        return -1;
    char sub[ERRBUF];
    PyObject *v;
    double x;
    int mode;
#define FIELD(key) ((v = lookup(o, key)) != NULL && (snprintf(sub, sizeof sub, "shading.%s", key), 1))
    if (FIELD("samples") && get_int(v, sub, 1, UB_MAX_SAMPLES, &sh->samples))
        return -1;
    if (FIELD("axle_light")) {
        if (get_double(v, sub, 0.0, 1e6, 0, &x))
            return -1;
        sh->axle_light = (float)x;
    }
    if (FIELD("ambient") && get_color(v, sub, 1e6, sh->ambient))
        return -1;
    if (FIELD("shadows")) {
        if (get_choice(v, sub, shadow_modes, &mode))
            return -1;
        sh->shadows = (ub_shadow_mode)mode;
    }
    if (FIELD("ao_strength")) {
        if (get_double(v, sub, 0.0, 1.0, 0, &x))
            return -1;
        sh->ao_strength = (float)x;
    }
    if (FIELD("ao_distance") && get_double(v, sub, 1e-6, 1e6, 0, &sh->ao_distance))
        return -1;
    if (FIELD("ao_samples") && get_int(v, sub, 1, UB_MAX_AO_SAMPLES, &sh->ao_samples))
        return -1;
    if (FIELD("reflection_depth") && get_int(v, sub, 0, UB_MAX_REFLECTION_DEPTH, &sh->reflection_depth))
        return -1;
    if (FIELD("fog_density") && get_double(v, sub, 0.0, 1e6, 0, &sh->fog_density))
        return -1;
    if (FIELD("fog_color") && get_color(v, sub, 1e6, sh->fog_color))
        return -1;
    if (FIELD("glow_strength")) {
        if (get_double(v, sub, 0.0, 1e6, 0, &x))
            return -1;
        sh->glow_strength = (float)x;
    }
    if (FIELD("glow_color") && get_color(v, sub, 1e6, sh->glow_color))
        return -1;
    if (FIELD("sea") && v != Py_None) {
        PyObject *sea = v, *w;
        if (!PyDict_Check(sea)) {
            PyErr_SetString(PyExc_TypeError, "shading.sea must be a dict (height, wavelength, amplitude, color, "
                                             "reflectivity) or None");
            return -1;
        }
        if (check_keys(sea, "shading.sea", sea_keys))
            return -1;
        sh->sea = 1;
        sh->sea_height = 0.0;
        sh->sea_wavelength = 0.25;
        sh->sea_amplitude = 0.01;
        sh->sea_color[0] = 0.1f;
        sh->sea_color[1] = 0.25f;
        sh->sea_color[2] = 0.4f;
        sh->sea_reflectivity = 0.5f;
        if ((w = lookup(sea, "height")) && get_double(w, "shading.sea.height", -1e9, 1e9, 0, &sh->sea_height))
            return -1;
        if ((w = lookup(sea, "wavelength"))
            && get_double(w, "shading.sea.wavelength", 1e-6, 1e9, 0, &sh->sea_wavelength))
            return -1;
        if ((w = lookup(sea, "amplitude"))
            && get_double(w, "shading.sea.amplitude", 0.0, 1e9, 0, &sh->sea_amplitude))
            return -1;
        if ((w = lookup(sea, "color")) && get_color(w, "shading.sea.color", 1e6, sh->sea_color))
            return -1;
        if ((w = lookup(sea, "reflectivity"))) {
            if (get_double(w, "shading.sea.reflectivity", 0.0, 1.0, 0, &x))
                return -1;
            sh->sea_reflectivity = (float)x;
        }
    }
    if (FIELD("lights")) {
        if (!PyList_Check(v) && !PyTuple_Check(v)) {
            PyErr_SetString(PyExc_TypeError, "shading.lights must be a list of dicts");
            return -1;
        }
        Py_ssize_t n = PySequence_Size(v);
        if (n < 0)
            return -1;
        if (n > UB_MAX_LIGHTS) {
            PyErr_Format(PyExc_ValueError, "shading.lights: at most %d lights", UB_MAX_LIGHTS);
            return -1;
        }
        for (Py_ssize_t i = 0; i < n; i++) {
            PyObject *item = PySequence_GetItem(v, i);
            if (!item)
                return -1;
            char name[64];
            snprintf(name, sizeof name, "shading.lights[%zd]", i);
            int rc = parse_light(item, name, &sh->lights[i]);
            Py_DECREF(item);
            if (rc)
                return -1;
        }
        sh->light_count = (int)n;
    }
#undef FIELD
    return 0;
}

/* ---------------------------------------------------------------- buffers */

/* Acquires a writable C-contiguous float32 buffer of exactly `count` elements with one of the
 * accepted shapes. shape0/shape1/chans: expected (rows, cols, channels); chans 0 = 1-D. */
static int get_float_buffer(PyObject *o, const char *name, Py_ssize_t rows, Py_ssize_t cols, int chans,
                            Py_buffer *view)
{
    if (PyObject_GetBuffer(o, view, PyBUF_RECORDS) != 0) {
        PyErr_Clear();
        PyErr_Format(PyExc_TypeError, "%s must be a writable buffer of float32 (e.g. a numpy array)", name);
        return -1;
    }
    const char *fmt = view->format ? view->format : "B";
    if ((fmt[0] == '<' || fmt[0] == '=' || fmt[0] == '@') && fmt[1])
        fmt++;
    int ok_type = strcmp(fmt, "f") == 0 && view->itemsize == 4;
    if (!ok_type) {
        PyBuffer_Release(view);
        PyErr_Format(PyExc_TypeError, "%s must have dtype float32", name);
        return -1;
    }
    if (!PyBuffer_IsContiguous(view, 'C')) {
        PyBuffer_Release(view);
        PyErr_Format(PyExc_ValueError, "%s must be C-contiguous", name);
        return -1;
    }
    int ok_shape = 0;
    if (view->ndim == 3 && view->shape[0] == rows && view->shape[1] == cols && view->shape[2] == chans)
        ok_shape = 1;
    if (chans == 1 && view->ndim == 2 && view->shape[0] == rows && view->shape[1] == cols)
        ok_shape = 1;
    if (chans == 0 && view->ndim == 1 && view->shape[0] == rows)
        ok_shape = 1;
    if (!ok_shape) {
        PyBuffer_Release(view);
        if (chans == 0)
            PyErr_Format(PyExc_ValueError, "%s must have shape (%zd,)", name, rows);
        else
            PyErr_Format(PyExc_ValueError, "%s must have shape (%zd, %zd, %d)%s", name, rows, cols, chans,
                         chans == 1 ? " or (height, width)" : "");
        return -1;
    }
    return 0;
}

/* ---------------------------------------------------------------- render() */

typedef struct {
    PyObject *progress, *cancel;
    PyThreadState *tstate;
    int failed; /* a callback raised: its exception is pending */
    PyObject *exc_type, *exc_value, *exc_tb;
} poll_state;

static int poll_cb(void *data, double fraction)
{
    poll_state *ps = data;
    if (ps->failed)
        return 1;
    PyEval_RestoreThread(ps->tstate);
    int stop = 0;
    if (ps->progress && ps->progress != Py_None) {
        PyObject *r = PyObject_CallFunction(ps->progress, "d", fraction);
        if (!r)
            stop = -1;
        else {
            stop = PyObject_IsTrue(r);
            Py_DECREF(r);
        }
    }
    if (stop == 0 && ps->cancel && ps->cancel != Py_None) {
        PyObject *r = PyObject_CallMethod(ps->cancel, "is_set", NULL);
        if (!r)
            stop = -1;
        else {
            stop = PyObject_IsTrue(r);
            Py_DECREF(r);
        }
    }
    if (stop < 0) {
        PyErr_Fetch(&ps->exc_type, &ps->exc_value, &ps->exc_tb);
        ps->failed = 1;
        stop = 1;
    }
    ps->tstate = PyEval_SaveThread();
    return stop;
}

static const char *const isa_names[] = {"auto", "avx2", "portable", NULL};

static PyObject *py_render(PyObject *self, PyObject *args, PyObject *kwargs)
{
    static char *kwlist[] = {"camera", "objects", "passes", "window", "threads", "tile_size", "simd",
                             "progress", "cancel", "background", "poll_interval", "shading", "stride",
                             "sample_range", NULL};
    PyObject *camera_o, *objects_o, *passes_o, *window_o = Py_None, *progress = Py_None, *cancel = Py_None;
    PyObject *threads_o = NULL, *tile_o = NULL, *simd_o = NULL, *background_o = NULL, *poll_o = NULL;
    PyObject *shading_o = NULL, *stride_o = NULL, *sample_range_o = Py_None;
    if (!PyArg_ParseTupleAndKeywords(args, kwargs, "OOO|$OOOOOOOOOOO", kwlist, &camera_o, &objects_o, &passes_o,
                                     &window_o, &threads_o, &tile_o, &simd_o, &progress, &cancel,
                                     &background_o, &poll_o, &shading_o, &stride_o, &sample_range_o))
        return NULL;

    ub_camera cam;
    ub_object *objs = PyMem_Calloc(UB_MAX_OBJECTS, sizeof(ub_object));
    ub_shading *shading = PyMem_Calloc(1, sizeof(ub_shading));
    if (!objs || !shading) {
        PyMem_Free(objs);
        PyMem_Free(shading);
        return PyErr_NoMemory();
    }
    Py_buffer views[UB_PASS_COUNT];
    int have[UB_PASS_COUNT] = {0};
    PyObject *result = NULL;
    int count = 0;
    ub_film film;
    memset(&film, 0, sizeof film);
    ub_render_options opt = {0, 32, UB_ISA_AUTO, NULL, NULL, 10000000L};

    if (parse_camera(camera_o, &cam) || parse_objects(objects_o, objs, &count) || parse_shading(shading_o, shading))
        goto done;
    film.step = 1;
    if (stride_o && get_int(stride_o, "stride", 1, 4096, &film.step))
        goto done;
    film.x0 = 0;
    film.y0 = 0;
    film.w = (cam.width + film.step - 1) / film.step;
    film.h = (cam.height + film.step - 1) / film.step;
    if (window_o != Py_None) {
        double win[4];
        if (get_vector(window_o, "window", 4, win))
            goto done;
        for (int i = 0; i < 4; i++)
            if (win[i] != floor(win[i])) {
                PyErr_SetString(PyExc_ValueError, "window must be 4 integers (x, y, width, height)");
                goto done;
            }
        /* With a stride, width and height count the window's pixels on the stride's grid. */
        if (win[0] < 0 || win[1] < 0 || win[2] < 1 || win[3] < 1 || win[0] + film.step * (win[2] - 1) >= cam.width
            || win[1] + film.step * (win[3] - 1) >= cam.height) {
            PyErr_Format(PyExc_ValueError,
                         "window (x, y, width, height) must lie inside the %dx%d image with a positive size",
                         cam.width, cam.height);
            goto done;
        }
        film.x0 = (int)win[0];
        film.y0 = (int)win[1];
        film.w = (int)win[2];
        film.h = (int)win[3];
    }
    if (threads_o && get_int(threads_o, "threads", 0, UB_MAX_THREADS, &opt.threads))
        goto done;
    if (tile_o && get_int(tile_o, "tile_size", 1, 4096, &opt.tile_size))
        goto done;
    if (simd_o) {
        int isa;
        if (get_choice(simd_o, "simd", isa_names, &isa))
            goto done;
        opt.isa = (ub_isa)isa;
    }
    if (poll_o) {
        double pi;
        if (get_double(poll_o, "poll_interval", 1e-4, 1.0, 0, &pi))
            goto done;
        opt.poll_interval_ns = (long)(pi * 1e9);
    }
    if (background_o) {
        double bg[4];
        if (get_vector(background_o, "background", 4, bg))
            goto done;
        /* Finite is not enough: 1e300 would become an infinite float32 in every missed pixel. */
        for (int i = 0; i < 4; i++) {
            if (!(bg[i] >= 0.0 && bg[i] <= (i == 3 ? 1.0 : 1e6))) {
                PyErr_SetString(PyExc_ValueError,
                                "background must be (r, g, b, alpha) with colour within [0, 1e6], alpha within [0, 1]");
                goto done;
            }
            film.background[i] = (float)bg[i];
        }
    }
    if (sample_range_o != Py_None) {
        double range[2];
        if (get_vector(sample_range_o, "sample_range", 2, range))
            goto done;
        if (range[0] != floor(range[0]) || range[1] != floor(range[1]) || range[0] < 0 || range[1] < 1
            || range[0] + range[1] > shading->samples) {
            PyErr_Format(PyExc_ValueError,
                         "sample_range must be 2 integers (first, count) with 0 <= first, 1 <= count and "
                         "first + count <= shading samples (%d)", shading->samples);
            goto done;
        }
        opt.first_sample = (int)range[0];
        opt.sample_count = (int)range[1];
    }
    if (progress != Py_None && !PyCallable_Check(progress)) {
        PyErr_SetString(PyExc_TypeError, "progress must be callable (fraction -> cancel?) or None");
        goto done;
    }
    if (cancel != Py_None && !PyObject_HasAttrString(cancel, "is_set")) {
        PyErr_SetString(PyExc_TypeError, "cancel must have an is_set() method (e.g. threading.Event) or be None");
        goto done;
    }
    if (!PyDict_Check(passes_o)) {
        PyErr_SetString(PyExc_TypeError, "passes must be a dict of pass name -> float32 array");
        goto done;
    }
    {
        PyObject *key, *value;
        Py_ssize_t pos = 0;
        while (PyDict_Next(passes_o, &pos, &key, &value)) {
            const char *k = PyUnicode_Check(key) ? PyUnicode_AsUTF8AndSize(key, NULL) : NULL;
            if (!k) {
                PyErr_Clear();
                PyErr_SetString(PyExc_TypeError, "passes keys must be pass names (strings)");
                goto done;
            }
            int id = -1;
            for (int i = 0; i < UB_PASS_COUNT; i++)
                if (strcmp(k, ub_pass_names[i]) == 0)
                    id = i;
            if (id < 0) {
                PyErr_Format(PyExc_ValueError, "passes: unknown pass '%s'", k);
                goto done;
            }
            if (value == Py_None)
                continue;
            char name[64];
            snprintf(name, sizeof name, "passes['%s']", k);
            if (get_float_buffer(value, name, film.h, film.w, ub_pass_channels[id], &views[id]))
                goto done;
            have[id] = 1;
            film.pass[id] = views[id].buf;
        }
    }

    {
        volatile int cancel_flag = 0;
        ub_scene scene = {&cam, objs, count, &film, shading, NULL, &cancel_flag};
        ub_render_stats stats;
        poll_state ps = {progress, cancel, NULL, 0, NULL, NULL, NULL};
        if (progress != Py_None || cancel != Py_None) {
            opt.poll = poll_cb;
            opt.poll_data = &ps;
        }
        const char *err;
        ps.tstate = PyEval_SaveThread();
        err = ub_render(&scene, &opt, &stats);
        PyEval_RestoreThread(ps.tstate);
        if (ps.failed) {
            PyErr_Restore(ps.exc_type, ps.exc_value, ps.exc_tb);
            goto done;
        }
        if (err) {
            PyErr_SetString(PyExc_ValueError, err);
            goto done;
        }
        result = Py_BuildValue("{s:K,s:K,s:K,s:d,s:i,s:s,s:O}", "rays", (unsigned long long)stats.counters.rays,
                               "steps", (unsigned long long)stats.counters.steps, "iterations",
                               (unsigned long long)stats.counters.iterations, "seconds", stats.seconds, "threads",
                               stats.threads, "simd", stats.isa, "cancelled",
                               stats.cancelled ? Py_True : Py_False);
    }
done:
    for (int i = 0; i < UB_PASS_COUNT; i++)
        if (have[i])
            PyBuffer_Release(&views[i]);
    PyMem_Free(objs);
    PyMem_Free(shading);
    return result;
}

/* ---------------------------------------------------------------- estimate(), camera_ray(), describe() */

/* Object-space points for estimate() and normals(): a C-contiguous float32 (n, 3) array.
 * Returns n, or -1 with an exception set (the view is released then). */
static Py_ssize_t get_points(PyObject *o, Py_buffer *view)
{
    if (PyObject_GetBuffer(o, view, PyBUF_RECORDS_RO) != 0) {
        PyErr_Clear();
        PyErr_SetString(PyExc_TypeError, "points must be a float32 array of shape (n, 3)");
        return -1;
    }
    const char *fmt = view->format ? view->format : "B";
    if (fmt[0] == '<' || fmt[0] == '=' || fmt[0] == '@')
        fmt++;
    if (view->ndim != 2 || view->shape[1] != 3 || strcmp(fmt, "f") != 0 || view->itemsize != 4
        || !PyBuffer_IsContiguous(view, 'C')) {
        PyBuffer_Release(view);
        PyErr_SetString(PyExc_ValueError, "points must be a C-contiguous float32 array of shape (n, 3)");
        return -1;
    }
    return view->shape[0];
}

/* The simd= keyword of estimate() and normals(): -1 with an exception set, else 0/1 (AVX2). */
static int get_simd(PyObject *o)
{
    int isa = UB_ISA_AUTO, use_avx2;
    if (o && get_choice(o, "simd", isa_names, &isa))
        return -1;
    const char *err = ub_resolve_isa((ub_isa)isa, &use_avx2);
    if (err) {
        PyErr_SetString(PyExc_ValueError, err);
        return -1;
    }
    return use_avx2;
}

static PyObject *py_estimate(PyObject *self, PyObject *args, PyObject *kwargs)
{
    static char *kwlist[] = {"object", "points", "estimate", "iterations", "simd", NULL};
    PyObject *obj_o, *pts_o, *est_o, *it_o, *simd_o = NULL;
    if (!PyArg_ParseTupleAndKeywords(args, kwargs, "OOOO|$O", kwlist, &obj_o, &pts_o, &est_o, &it_o, &simd_o))
        return NULL;
    ub_object obj;
    if (parse_object(obj_o, "object", &obj))
        return NULL;
    int avx2 = get_simd(simd_o);
    if (avx2 < 0)
        return NULL;
    Py_buffer pv, ev, iv;
    Py_ssize_t n = get_points(pts_o, &pv);
    if (n < 0)
        return NULL;
    if (get_float_buffer(est_o, "estimate", n, 0, 0, &ev)) {
        PyBuffer_Release(&pv);
        return NULL;
    }
    if (get_float_buffer(it_o, "iterations", n, 0, 0, &iv)) {
        PyBuffer_Release(&pv);
        PyBuffer_Release(&ev);
        return NULL;
    }
    Py_BEGIN_ALLOW_THREADS
    unsigned fp = ub_fp_enter();
    if (n > 0)
        (avx2 ? ub_estimate_avx2 : ub_estimate_portable)(&obj, pv.buf, (size_t)n, ev.buf, iv.buf);
    ub_fp_leave(fp);
    Py_END_ALLOW_THREADS
    PyBuffer_Release(&pv);
    PyBuffer_Release(&ev);
    PyBuffer_Release(&iv);
    Py_RETURN_NONE;
}

static PyObject *py_normals(PyObject *self, PyObject *args, PyObject *kwargs)
{
    static char *kwlist[] = {"object", "points", "t", "normals", "simd", NULL};
    PyObject *obj_o, *pts_o, *t_o, *n_o, *simd_o = NULL;
    if (!PyArg_ParseTupleAndKeywords(args, kwargs, "OOOO|$O", kwlist, &obj_o, &pts_o, &t_o, &n_o, &simd_o))
        return NULL;
    ub_object *obj = PyMem_Calloc(1, sizeof(ub_object));
    if (!obj)
        return PyErr_NoMemory();
    PyObject *result = NULL;
    int avx2, have_p = 0, have_t = 0, have_n = 0;
    Py_buffer pv, tv, nv;
    if (parse_object(obj_o, "object", obj))
        goto out;
    if ((avx2 = get_simd(simd_o)) < 0)
        goto out;
    Py_ssize_t n = get_points(pts_o, &pv);
    if (n < 0)
        goto out;
    have_p = 1;
    if (get_float_buffer(t_o, "t", n, 0, 0, &tv))
        goto out;
    have_t = 1;
    /* (n, 3): the one-channel form of get_float_buffer is a (rows, cols) matrix. */
    if (get_float_buffer(n_o, "normals", n, 3, 1, &nv))
        goto out;
    have_n = 1;
    Py_BEGIN_ALLOW_THREADS
    unsigned fp = ub_fp_enter();
    if (n > 0)
        (avx2 ? ub_normals_avx2 : ub_normals_portable)(obj, pv.buf, tv.buf, (size_t)n, nv.buf);
    ub_fp_leave(fp);
    Py_END_ALLOW_THREADS
    result = Py_None;
    Py_INCREF(result);
out:
    if (have_p)
        PyBuffer_Release(&pv);
    if (have_t)
        PyBuffer_Release(&tv);
    if (have_n)
        PyBuffer_Release(&nv);
    PyMem_Free(obj);
    return result;
}

static PyObject *py_camera_ray(PyObject *self, PyObject *args)
{
    PyObject *cam_o;
    double x, y;
    if (!PyArg_ParseTuple(args, "Odd", &cam_o, &x, &y))
        return NULL;
    ub_camera cam;
    if (parse_camera(cam_o, &cam))
        return NULL;
    if (!isfinite(x) || !isfinite(y)) {
        PyErr_SetString(PyExc_ValueError, "pixel coordinates must be finite");
        return NULL;
    }
    double o[3], d[3], t0, t1;
    ub_camera_ray(&cam, x, y, o, d, &t0, &t1);
    return Py_BuildValue("((ddd)(ddd)dd)", o[0], o[1], o[2], d[0], d[1], d[2], t0, t1);
}

static PyObject *py_describe(PyObject *self, PyObject *args)
{
    PyObject *obj_o;
    if (!PyArg_ParseTuple(args, "O", &obj_o))
        return NULL;
    ub_object obj;
    if (parse_object(obj_o, "object", &obj))
        return NULL;
    return Py_BuildValue("{s:s,s:O,s:d,s:d,s:(ddd),s:d,s:d,s:d,s:(dddd),s:((ddd)(ddd)(ddd)(ddd))}", "kind",
                         kind_names[obj.kind], "exact", obj.exact ? Py_True : Py_False, "step_factor", obj.step_factor,
                         "max_step", obj.max_step, "bound_center",
                         obj.bound_center[0], obj.bound_center[1], obj.bound_center[2], "bound_radius",
                         obj.bound_radius, "bailout", obj.bailout, "sigma_min", obj.sigma_min, "slice_origin",
                         obj.slice_origin[0], obj.slice_origin[1], obj.slice_origin[2], obj.slice_origin[3],
                         "slice_basis", obj.slice_basis[0][0], obj.slice_basis[0][1], obj.slice_basis[0][2],
                         obj.slice_basis[1][0], obj.slice_basis[1][1], obj.slice_basis[1][2], obj.slice_basis[2][0],
                         obj.slice_basis[2][1], obj.slice_basis[2][2], obj.slice_basis[3][0], obj.slice_basis[3][1],
                         obj.slice_basis[3][2]);
}

static PyObject *py_cpu_info(PyObject *self, PyObject *noargs)
{
    return Py_BuildValue("{s:i,s:O}", "cpus", ub_cpu_count(), "avx2_fma", ub_cpu_has_avx2_fma() ? Py_True : Py_False);
}

static PyMethodDef methods[] = {
    {"render", (PyCFunction)(void (*)(void))py_render, METH_VARARGS | METH_KEYWORDS,
     "render(camera, objects, passes, *, window=None, threads=0, tile_size=32, simd='auto', progress=None, "
     "cancel=None, background=(0, 0, 0, 0), poll_interval=0.01, shading=None, stride=1, sample_range=None) "
     "-> stats dict. stride s renders the image pixels (x + s i, y + s j) of window (x, y, columns, rows) "
     "only; sample_range (first, count) renders those samples into buffers holding the earlier ones' sum. "
     "After a cancel (stats['cancelled']) the passes are partial: with several samples, undivided sums of "
     "the samples done"},
    {"normals", (PyCFunction)(void (*)(void))py_normals, METH_VARARGS | METH_KEYWORDS,
     "normals(object, points, t, normals, *, simd='auto'): object-space unit normals at object-space points "
     "by the object's normal_method (zbuffer: the distance gradient), gradient step alpha * t**delta"},
    {"estimate", (PyCFunction)(void (*)(void))py_estimate, METH_VARARGS | METH_KEYWORDS,
     "estimate(object, points, estimate, iterations, *, simd='auto'): distance estimate (object units) and "
     "escape count at object-space points, computed by the marching kernel's own arithmetic"},
    {"camera_ray", py_camera_ray, METH_VARARGS,
     "camera_ray(camera, x, y) -> (origin, direction, t_min, t_max) of the ray through full-image pixel "
     "coordinates (x, y); pixel centres are at +0.5"},
    {"describe", py_describe, METH_VARARGS,
     "describe(object) -> derived values: bounding ball, effective bailout, slice after the theta rotation"},
    {"cpu_info", py_cpu_info, METH_NOARGS, "cpu_info() -> {'cpus': n, 'avx2_fma': bool}"},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef moduledef = {
    PyModuleDef_HEAD_INIT, "_native", "Unbound's native ray marcher for 3-D deterministic fractals.", -1, methods,
};

PyMODINIT_FUNC PyInit__native(void)
{
    PyObject *m = PyModule_Create(&moduledef);
    if (!m)
        return NULL;
    PyObject *names = PyTuple_New(UB_PASS_COUNT), *chans = PyDict_New();
    if (!names || !chans) {
        Py_XDECREF(names);
        Py_XDECREF(chans);
        Py_DECREF(m);
        return NULL;
    }
    for (int i = 0; i < UB_PASS_COUNT; i++) {
        PyTuple_SetItem(names, i, PyUnicode_FromString(ub_pass_names[i]));
        PyObject *c = PyLong_FromLong(ub_pass_channels[i]);
        PyDict_SetItemString(chans, ub_pass_names[i], c);
        Py_XDECREF(c);
    }
    PyModule_AddObject(m, "PASSES", names);
    PyModule_AddObject(m, "PASS_CHANNELS", chans);
    PyModule_AddObject(m, "BACKGROUND_DEPTH", PyFloat_FromDouble(UB_BACKGROUND_DEPTH));
    PyModule_AddIntConstant(m, "MAX_ITERATIONS", UB_MAX_ITERATIONS);
    PyModule_AddIntConstant(m, "MAX_IMAGE_SIZE", UB_MAX_IMAGE_SIZE);
    return m;
}
