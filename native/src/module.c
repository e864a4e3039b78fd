/* CPython binding of the Unbound core, on the limited API (abi3, 3.11+): one wheel for every
 * Python from Blender 4.2 (3.11) to 5.2 (3.13). All validation happens here, before any
 * native work starts, by one generic parser over the parameter table (params.h): every bad
 * input becomes a ValueError/TypeError naming the parameter's path, e.g. objects[0].mu[1].
 *
 * Arbitrary Python runs while a value is read (__float__, __index__, a sequence's __getitem__),
 * and it may change the caller's containers. So every container is copied before its items are
 * read (a dict by PyDict_Copy, a sequence by PySequence_Tuple): the copies hold strong
 * references, and nothing the parser reads can be freed under it. */
#define Py_LIMITED_API 0x030B0000
#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "mesh.h"
#include "params.h"
#include "render.h"
#include "scene.h"
#include "ubmath.h"

#define ERRBUF 256

/* Where a dict's keys sit, for messages: `path` is the text before the key ("objects[0]", or
 * "fractal 'Mandel'" when the caller names its object), `sep` what joins a key to it, and `hint`
 * what a non-finite value's message adds (named objects come from animated scenes). */
typedef struct {
    const char *path, *sep, *hint;
} ub_where;

static void join(char *out, size_t size, const ub_where *w, const char *key)
{
    snprintf(out, size, "%s%s%s", w->path, w->path[0] ? w->sep : "", key);
}

static void set_value_error(const char *fmt, ...)
{
    /* PyErr_Format has no %g: format here. */
    char msg[2 * ERRBUF];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    PyErr_SetString(PyExc_ValueError, msg);
}

/* ---------------------------------------------------------------- scalars */

/* A float o, finite and within [lo, hi], into *out: 0, else -1 with nothing raised. The readers'
 * common case without a name: read_double's first step, and the quick path's (quick_value). */
static int float_in_range(PyObject *o, double lo, double hi, double *out)
{
    if (!o || !PyFloat_Check(o))
        return -1;
    const double v = PyFloat_AsDouble(o);
    if (!isfinite(v) || !(v >= lo && v <= hi))
        return -1;
    *out = v;
    return 0;
}

/* An int o (a bool is one) within [lo, hi] into *out: 0, else -1 with nothing raised. */
static int int_in_range(PyObject *o, double lo, double hi, int *out)
{
    if (!PyLong_Check(o))
        return -1;
    int overflow = 0;
    const long long v = PyLong_AsLongLongAndOverflow(o, &overflow);
    if ((v == -1 && PyErr_Occurred()) || overflow || v < lo || v > hi) {
        PyErr_Clear();
        return -1;
    }
    *out = (int)v;
    return 0;
}

static int read_double(PyObject *o, const char *name, double lo, double hi, const char *hint, double *out)
{
    if (!float_in_range(o, lo, hi, out))
        return 0;
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
    if (!isfinite(v)) {
        PyErr_Format(PyExc_ValueError, "%s must be finite%s", name, hint);
        return -1;
    }
    if (!(v >= lo && v <= hi)) {
        set_value_error("%s must be in [%g, %g], got %g", name, lo, hi, v);
        return -1;
    }
    *out = v;
    return 0;
}

static int read_int(PyObject *o, const char *name, double lo, double hi, int *out)
{
    if (PyFloat_Check(o) || !PyLong_Check(o)) {
        PyErr_Format(PyExc_TypeError, "%s must be an integer", name);
        return -1;
    }
    if (int_in_range(o, lo, hi, out)) {
        PyErr_Format(PyExc_ValueError, "%s must be in [%lld, %lld]", name, (long long)lo, (long long)hi);
        return -1;
    }
    return 0;
}

static int read_bool(PyObject *o, const char *name, int *out)
{
    if (!PyBool_Check(o)) {
        PyErr_Format(PyExc_TypeError, "%s must be True or False", name);
        return -1;
    }
    *out = o == Py_True;
    return 0;
}

/* The UTF-8 of str o, or NULL (with an exception set) for a non-string or one with an embedded
 * NUL: C compares at most up to the first NUL, so "alpha\0x" would read as "alpha" (issue 16). */
static const char *key_utf8(PyObject *o, const char *name, const char *what)
{
    Py_ssize_t len;
    const char *s = PyUnicode_Check(o) ? PyUnicode_AsUTF8AndSize(o, &len) : NULL;
    if (!s) {
        PyErr_Clear();
        PyErr_Format(PyExc_TypeError, "%s%s%s must be %s", name, what ? " " : "", what ? what : "",
                     what ? "strings" : "a string");
        return NULL;
    }
    if (strlen(s) != (size_t)len) {
        PyErr_Format(PyExc_ValueError, "%s%s%s must not contain NUL characters, got %R", name, what ? " " : "",
                     what ? what : "", o);
        return NULL;
    }
    return s;
}

static int read_choice(PyObject *o, const char *name, const char *const *choices, int *out)
{
    if (!PyUnicode_Check(o)) {
        PyErr_Format(PyExc_TypeError, "%s must be a string", name);
        return -1;
    }
    const char *s = key_utf8(o, name, NULL);
    if (!s)
        return -1;
    for (int i = 0; choices[i]; i++)
        if (strcmp(s, choices[i]) == 0) {
            *out = i;
            return 0;
        }
    char names[ERRBUF] = "";
    for (int i = 0; choices[i]; i++) {
        size_t used = strlen(names);
        snprintf(names + used, sizeof names - used, "%s'%s'", i ? ", " : "", choices[i]);
    }
    PyErr_Format(PyExc_ValueError, "%s must be one of %s, got '%.64s'", name, names, s);
    return -1;
}

static int read_string(PyObject *o, const char *name, char *out, size_t size)
{
    Py_ssize_t len;
    const char *s = PyUnicode_Check(o) ? PyUnicode_AsUTF8AndSize(o, &len) : NULL;
    if (!s) {
        PyErr_Clear();
        PyErr_Format(PyExc_TypeError, "%s must be a string", name);
        return -1;
    }
    if ((size_t)len >= size || memchr(s, 0, (size_t)len)) {
        PyErr_Format(PyExc_ValueError, "%s must be a string of at most %d bytes (UTF-8) without NUL",
                     name, (int)size - 1);
        return -1;
    }
    memcpy(out, s, (size_t)len + 1);
    return 0;
}

/* ---------------------------------------------------------------- sequences */

/* A strong copy of sequence o as a tuple, or NULL with a TypeError saying `what` it must be. */
static PyObject *snapshot(PyObject *o, const char *name, const char *what)
{
    if (!PySequence_Check(o) || PyUnicode_Check(o) || PyBytes_Check(o)) {
        PyErr_Format(PyExc_TypeError, "%s must be %s", name, what);
        return NULL;
    }
    return PySequence_Tuple(o);
}

/* `cols` numbers (a scalar when cols is 0) into out. */
static int read_vector(PyObject *o, const char *name, int cols, double lo, double hi, const char *hint,
                       double *out)
{
    if (cols == 0)
        return read_double(o, name, lo, hi, hint, out);
    char what[64];
    snprintf(what, sizeof what, "a sequence of %d numbers", cols);
    PyObject *t = snapshot(o, name, what);
    if (!t)
        return -1;
    int rc = 0;
    if (PyTuple_Size(t) != cols) {
        PyErr_Format(PyExc_ValueError, "%s must have %d components, got %zd", name, cols, PyTuple_Size(t));
        rc = -1;
    }
    for (int i = 0; i < cols && !rc; i++) {
        char sub[ERRBUF];
        snprintf(sub, sizeof sub, "%s[%d]", name, i);
        rc = read_double(PyTuple_GetItem(t, i), sub, lo, hi, hint, &out[i]);
    }
    Py_DECREF(t);
    return rc;
}

/* A value of the row's shape: a scalar (1 x 1), a vector (1 x cols) or a matrix given as a
 * sequence of rows (numpy arrays, mathutils.Matrix, lists). */
static int read_shaped(PyObject *o, const char *name, const ub_param *p, const char *hint, double *out)
{
    if (p->rows == 1)
        return read_vector(o, name, p->cols == 1 ? 0 : p->cols, p->min, p->max, hint, out);
    char what[64];
    snprintf(what, sizeof what, "a %dx%d matrix (a sequence of %d rows)", p->rows, p->cols, p->rows);
    PyObject *t = snapshot(o, name, what);
    if (!t)
        return -1;
    int rc = 0;
    if (PyTuple_Size(t) != p->rows) {
        PyErr_Format(PyExc_ValueError, "%s must be a %dx%d matrix, got %zd rows", name, p->rows, p->cols,
                     PyTuple_Size(t));
        rc = -1;
    }
    for (int r = 0; r < p->rows && !rc; r++) {
        char sub[ERRBUF];
        snprintf(sub, sizeof sub, "%s[%d]", name, r);
        rc = read_vector(PyTuple_GetItem(t, r), sub, p->cols, p->min, p->max, hint, out + r * p->cols);
    }
    Py_DECREF(t);
    return rc;
}

/* The common values read without their names: a float or a tuple or list of floats (rows of
 * them for a matrix; exact tuples and lists, whose items are what snapshot() would take) within
 * the row's range, an int, a bool. 0 when read (the field filled), else
 * -1 with nothing raised: read_value then reads the value again with its name and says what is
 * wrong. Issue 21: names and messages were formatted for every value read, whether or not
 * anything was wrong, a third of the CPU of parsing a render's parameters. */

/* The length of an exact tuple or list, else -1 (other sequences go through snapshot()). */
static Py_ssize_t exact_length(PyObject *o)
{
    return PyTuple_CheckExact(o) ? PyTuple_Size(o) : PyList_CheckExact(o) ? PyList_Size(o) : -1;
}

static PyObject *exact_item(PyObject *o, Py_ssize_t i)
{
    return PyTuple_CheckExact(o) ? PyTuple_GetItem(o, i) : PyList_GetItem(o, i);
}

static int quick_floats(PyObject *o, int cols, double lo, double hi, double *out)
{
    if (!o || exact_length(o) != cols)
        return -1;
    for (int i = 0; i < cols; i++)
        if (float_in_range(exact_item(o, i), lo, hi, &out[i]))
            return -1;
    return 0;
}

/* read_shaped's common values: a float, or rows of floats. */
static int quick_shaped(PyObject *v, const ub_param *p, double *out)
{
    if (p->rows == 1 && p->cols == 1)
        return float_in_range(v, p->min, p->max, out);
    if (p->rows == 1)
        return quick_floats(v, p->cols, p->min, p->max, out);
    if (exact_length(v) != p->rows)
        return -1;
    for (int r = 0; r < p->rows; r++)
        if (quick_floats(exact_item(v, r), p->cols, p->min, p->max, out + r * p->cols))
            return -1;
    return 0;
}

static int quick_value(PyObject *v, const ub_param *p, void *record)
{
    char *field = (char *)record + p->offset;
    switch (p->type) {
    case UB_PARAM_FLOAT:
        return quick_shaped(v, p, (double *)field);
    case UB_PARAM_INT:
        return int_in_range(v, p->min, p->max, (int *)field);
    case UB_PARAM_BOOL:
        if (!PyBool_Check(v))
            return -1;
        *(int *)field = v == Py_True;
        return 0;
    default:
        return -1;
    }
}

/* ---------------------------------------------------------------- sections */

static int read_section(PyObject *o, const char *name, const ub_param_section *s, void *record, uint64_t *given);

static void apply_defaults(const ub_param_section *s, void *record)
{
    memset(record, 0, s->record_size);
    for (int i = 0; i < s->count; i++) {
        const ub_param *p = &s->rows[i];
        char *field = (char *)record + p->offset;
        if (!p->defaults && !p->text_default)
            continue;
        switch (p->type) {
        case UB_PARAM_FLOAT:
            memcpy(field, p->defaults, sizeof(double) * p->rows * p->cols);
            break;
        case UB_PARAM_INT:
        case UB_PARAM_BOOL:
        case UB_PARAM_CHOICE:
            *(int *)field = (int)p->defaults[0];
            break;
        case UB_PARAM_STRING:
            if (p->text_default)
                snprintf(field, (size_t)p->max + 1, "%s", p->text_default);
            break;
        case UB_PARAM_LIST:
            *(int *)((char *)record + p->count_offset) = p->default_items;
            memcpy(field, p->defaults, sizeof(double) * p->rows * p->cols * p->default_items);
            break;
        default:
            break;
        }
    }
}

static int read_list(PyObject *o, const char *name, const ub_param *p, const char *hint, void *record)
{
    char what[96];
    if (p->items)
        snprintf(what, sizeof what, "a sequence of dicts (%s parameters)", p->items->name);
    else if (p->rows == 1)
        snprintf(what, sizeof what, "a sequence of %d-number items", p->cols);
    else
        snprintf(what, sizeof what, "a sequence of %dx%d matrices", p->rows, p->cols);
    PyObject *t = snapshot(o, name, what);
    if (!t)
        return -1;
    Py_ssize_t n = PyTuple_Size(t);
    int rc = 0;
    if (n < p->min_items || n > p->max_items) {
        PyErr_Format(PyExc_ValueError, "%s must hold %d to %d items, got %zd", name, p->min_items, p->max_items, n);
        rc = -1;
    }
    char *items = (char *)record + p->offset;
    for (Py_ssize_t i = 0; i < n && !rc; i++) {
        void *slot = items + i * p->item_size;
        if (!p->items && !quick_shaped(PyTuple_GetItem(t, i), p, slot))
            continue;
        char sub[ERRBUF];
        snprintf(sub, sizeof sub, "%s[%zd]", name, i);
        if (p->items)
            rc = read_section(PyTuple_GetItem(t, i), sub, p->items, slot, NULL);
        else
            rc = read_shaped(PyTuple_GetItem(t, i), sub, p, hint, slot);
    }
    Py_DECREF(t);
    if (!rc)
        *(int *)((char *)record + p->count_offset) = (int)n;
    return rc;
}

static int read_value(PyObject *v, const char *name, const ub_param *p, const char *hint, void *record)
{
    char *field = (char *)record + p->offset;
    switch (p->type) {
    case UB_PARAM_FLOAT:
        return read_shaped(v, name, p, hint, (double *)field);
    case UB_PARAM_INT:
        return read_int(v, name, p->min, p->max, (int *)field);
    case UB_PARAM_BOOL:
        return read_bool(v, name, (int *)field);
    case UB_PARAM_CHOICE:
        return read_choice(v, name, p->choices, (int *)field);
    case UB_PARAM_STRING:
        return read_string(v, name, field, (size_t)p->max + 1);
    case UB_PARAM_LIST:
        return read_list(v, name, p, hint, record);
    default:
        return 0; /* UB_PARAM_CUSTOM: the caller reads it */
    }
}

static const ub_param *find_row(const ub_param_section *s, const char *key, int *index)
{
    for (int i = 0; i < s->count; i++)
        if (strcmp(s->rows[i].key, key) == 0) {
            if (index)
                *index = i;
            return &s->rows[i];
        }
    return NULL;
}

/* Unknown keys are errors: a misspelt key would otherwise be silently ignored. */
static int check_keys(PyObject *d, const char *name, const ub_param_section *s)
{
    PyObject *key, *value;
    Py_ssize_t pos = 0;
    while (PyDict_Next(d, &pos, &key, &value)) {
        const char *k = key_utf8(key, name, "keys");
        if (!k)
            return -1;
        if (!find_row(s, k, NULL)) {
            PyErr_Format(PyExc_ValueError, "%s has an unknown key '%.64s'", name, k);
            return -1;
        }
    }
    return 0;
}

/* Reads dict o (None: all defaults) of section s into record through the table: defaults first,
 * then every given key. `name` names the dict itself and its keys ("name.key"; "" names the
 * keys alone), unless a row of type STRING called "name" gives the object's own name. Bit i of
 * *given is set when row i was given (not None). */
static int read_section(PyObject *o, const char *name, const ub_param_section *s, void *record, uint64_t *given)
{
    apply_defaults(s, record);
    if (given)
        *given = 0;
    if (o == Py_None)
        return 0;
    if (!PyDict_Check(o)) {
        PyErr_Format(PyExc_TypeError, "%s must be a dict of %s parameters", name, s->name);
        return -1;
    }
    PyObject *d = PyDict_Copy(o);
    if (!d)
        return -1;
    char named_path[ERRBUF];
    ub_where w = {name, ".", ""};
    int rc = check_keys(d, name, s);
    for (int i = 0; i < s->count && !rc; i++) {
        const ub_param *p = &s->rows[i];
        PyObject *v = PyDict_GetItemString(d, p->key); /* borrowed from our own copy */
        if (!v) {
            if (p->flags & UB_PARAM_REQUIRED) {
                PyErr_Format(PyExc_ValueError, "%s needs '%s'", name, p->key);
                rc = -1;
            }
            continue;
        }
        if (v == Py_None && (p->flags & UB_PARAM_NONE_OK))
            continue;
        if (quick_value(v, p, record)) {
            char key_path[ERRBUF];
            join(key_path, sizeof key_path, &w, p->key);
            rc = read_value(v, key_path, p, w.hint, record);
        }
        if (!rc && given)
            *given |= (uint64_t)1 << i;
        if (!rc && p->type == UB_PARAM_STRING && strcmp(p->key, "name") == 0 && ((char *)record)[p->offset]) {
            snprintf(named_path, sizeof named_path, "fractal '%s'", (char *)record + p->offset);
            w = (ub_where){named_path, ": ", " (check its keyframes and drivers)"};
        }
    }
    Py_DECREF(d);
    return rc;
}

static int was_given(const ub_param_section *s, uint64_t given, const char *key)
{
    int i = -1;
    find_row(s, key, &i);
    return i >= 0 && ((given >> i) & 1);
}

/* ---------------------------------------------------------------- camera, objects, shading */

static int parse_camera(PyObject *o, ub_camera *cam)
{
    ub_camera_input in;
    if (read_section(o, "camera", &ub_camera_section, &in, NULL))
        return -1;
    const char *err = ub_camera_from_input(cam, &in);
    if (err) {
        PyErr_SetString(PyExc_ValueError, err);
        return -1;
    }
    return 0;
}

/* One object dict -> the kernels' record; `name` is its path (objects[i], or object). */
static int parse_object(PyObject *o, const char *name, ub_object *obj)
{
    ub_object_input *in = PyMem_Malloc(sizeof *in);
    if (!in) {
        PyErr_NoMemory();
        return -1;
    }
    int rc = read_section(o, name, &ub_object_section, in, NULL);
    if (!rc) {
        const char *err = ub_object_from_input(obj, in);
        if (err) {
            if (in->name[0])
                PyErr_Format(PyExc_ValueError, "fractal '%s': %s", in->name, err);
            else
                PyErr_Format(PyExc_ValueError, "%s: %s", name, err);
            rc = -1;
        }
    }
    PyMem_Free(in);
    return rc;
}

static int parse_objects(PyObject *seq, ub_object *objs, int *count)
{
    if (!PyList_Check(seq) && !PyTuple_Check(seq)) {
        PyErr_SetString(PyExc_TypeError, "objects must be a list of dicts");
        return -1;
    }
    PyObject *t = PySequence_Tuple(seq);
    if (!t)
        return -1;
    Py_ssize_t n = PyTuple_Size(t);
    int rc = 0;
    if (n > UB_MAX_OBJECTS) {
        PyErr_Format(PyExc_ValueError, "objects: at most %d fractal objects per render", UB_MAX_OBJECTS);
        rc = -1;
    }
    for (Py_ssize_t i = 0; i < n && !rc; i++) {
        char name[64];
        snprintf(name, sizeof name, "objects[%zd]", i);
        rc = parse_object(PyTuple_GetItem(t, i), name, &objs[i]);
    }
    Py_DECREF(t);
    if (!rc)
        *count = (int)n;
    return rc;
}

static int parse_shading(PyObject *o, ub_shading *sh)
{
    ub_shading_input *in = PyMem_Malloc(sizeof *in);
    if (!in) {
        PyErr_NoMemory();
        return -1;
    }
    memset(sh, 0, sizeof *sh);
    int rc = read_section(o ? o : Py_None, "shading", &ub_shading_section, in, NULL);
    if (!rc) {
        ub_shading_from_input(sh, in);
        for (int i = 0; i < in->lights_count && !rc; i++) {
            const char *err = ub_light_from_input(&sh->lights[i], &in->lights[i]);
            if (err) {
                PyErr_Format(PyExc_ValueError, "shading.lights[%d].%s", i, err);
                rc = -1;
            }
        }
    }
    PyMem_Free(in);
    return rc;
}

/* ---------------------------------------------------------------- buffers */

/* Whether an acquired buffer holds float32 (its struct format "f", with or without a native or
 * little-endian byte-order prefix). */
static int buffer_is_float32(const Py_buffer *view)
{
    const char *fmt = view->format ? view->format : "B";
    if ((fmt[0] == '<' || fmt[0] == '=' || fmt[0] == '@') && fmt[1])
        fmt++;
    return strcmp(fmt, "f") == 0 && view->itemsize == 4;
}

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
    if (!buffer_is_float32(view)) {
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


/* The render keywords (render section) -> film window, stride, options. */
static int parse_render_options(PyObject *kw, const ub_camera *cam, const ub_shading *shading, ub_film *film,
                                ub_render_options *opt)
{
    ub_render_input in;
    uint64_t given;
    if (read_section(kw, "", &ub_render_section, &in, &given))
        return -1;
    opt->threads = in.threads;
    opt->tile_size = in.tile_size;
    opt->shared_steps = in.shared_steps;
    opt->clear_unfinished = in.clear_unfinished;
    opt->isa = (ub_isa)in.simd;
    opt->poll_interval_ns = (int64_t)(in.poll_interval * 1e9);
    /* Finite is not enough: 1e300 would become an infinite float32 in every missed pixel. */
    if (in.background[3] > 1.0) {
        PyErr_SetString(PyExc_ValueError,
                        "background must be (r, g, b, alpha) with colour within [0, 1e6], alpha within [0, 1]");
        return -1;
    }
    for (int i = 0; i < 4; i++)
        film->background[i] = (float)in.background[i];
    film->step = in.stride;
    film->x0 = film->y0 = 0;
    film->w = (cam->width + film->step - 1) / film->step;
    film->h = (cam->height + film->step - 1) / film->step;
    if (was_given(&ub_render_section, given, "window")) {
        const double *win = in.window;
        for (int i = 0; i < 4; i++)
            if (win[i] != floor(win[i])) {
                PyErr_SetString(PyExc_ValueError, "window must be 4 integers (x, y, width, height)");
                return -1;
            }
        /* With a stride, width and height count the window's pixels on the stride's grid. */
        if (win[0] < 0 || win[1] < 0 || win[2] < 1 || win[3] < 1 || win[0] + film->step * (win[2] - 1) >= cam->width
            || win[1] + film->step * (win[3] - 1) >= cam->height) {
            PyErr_Format(PyExc_ValueError,
                         "window (x, y, width, height) must lie inside the %dx%d image with a positive size",
                         cam->width, cam->height);
            return -1;
        }
        film->x0 = (int)win[0];
        film->y0 = (int)win[1];
        film->w = (int)win[2];
        film->h = (int)win[3];
    }
    if (was_given(&ub_render_section, given, "sample_range")) {
        const double *range = in.sample_range;
        if (range[0] != floor(range[0]) || range[1] != floor(range[1]) || range[0] < 0 || range[1] < 1
            || range[0] + range[1] > shading->samples) {
            PyErr_Format(PyExc_ValueError,
                         "sample_range must be 2 integers (first, count) with 0 <= first, 1 <= count and "
                         "first + count <= shading samples (%d)", shading->samples);
            return -1;
        }
        opt->first_sample = (int)range[0];
        opt->sample_count = (int)range[1];
    }
    return 0;
}

/* passes: {pass name: float32 array of the film's shape, or None}; views[id] acquired where have[id]. */
static int parse_passes(PyObject *passes_o, ub_film *film, Py_buffer *views, int *have)
{
    if (!PyDict_Check(passes_o)) {
        PyErr_SetString(PyExc_TypeError, "passes must be a dict of pass name -> float32 array");
        return -1;
    }
    PyObject *items = PyDict_Items(passes_o); /* strong references: buffers outlive any callback */
    if (!items)
        return -1;
    int rc = 0;
    for (Py_ssize_t i = 0; i < PyList_Size(items) && !rc; i++) {
        PyObject *pair = PyList_GetItem(items, i);
        PyObject *key = PyTuple_GetItem(pair, 0), *value = PyTuple_GetItem(pair, 1);
        const char *k = key_utf8(key, "passes", "keys (pass names)");
        if (!k) {
            rc = -1;
            break;
        }
        int id = -1;
        for (int p = 0; p < UB_PASS_COUNT; p++)
            if (strcmp(k, ub_pass_names[p]) == 0)
                id = p;
        if (id < 0) {
            PyErr_Format(PyExc_ValueError, "passes: unknown pass '%.64s'", k);
            rc = -1;
        } else if (value != Py_None && !have[id]) {
            char name[96];
            snprintf(name, sizeof name, "passes['%s']", k);
            rc = get_float_buffer(value, name, film->h, film->w, ub_pass_channels[id], &views[id]);
            if (!rc) {
                have[id] = 1;
                film->pass[id] = views[id].buf;
            }
        }
    }
    Py_DECREF(items);
    /* Every pass is written by the kernels as its own memory: two passes sharing bytes (the same
     * array twice, or overlapping views of one) would each hold the other's values. Refused. */
    for (int a = 0; a < UB_PASS_COUNT && !rc; a++) {
        for (int b = a + 1; b < UB_PASS_COUNT && !rc && have[a]; b++) {
            if (!have[b])
                continue;
            const char *pa = views[a].buf, *pb = views[b].buf;
            if (pa < pb + views[b].len && pb < pa + views[a].len) {
                PyErr_Format(PyExc_ValueError,
                             "passes['%s'] and passes['%s'] share memory: give each pass its own array",
                             ub_pass_names[a], ub_pass_names[b]);
                rc = -1;
            }
        }
    }
    return rc;
}

/* Footprint of a pixel at the nearest hit (the depth pass) over the largest world bounding radius:
 * below UB_PRECISION_LIMIT float32 no longer resolves the surface (README, Precision). None
 * without a depth pass, a hit or an object that the slice meets. The nearest hit comes from the
 * kernels (ub_counters_nearest_depth), which saw every depth they wrote (issue 21: no pass over
 * the whole frame); a call whose samples start past the first writes no depth (sample 0 alone
 * does), and there the depth pass the caller kept from sample 0 is read. */
static PyObject *footprint_ratio(const ub_camera *cam, const ub_object *objs, int count, const ub_film *film,
                                 const ub_counters *counters, int wrote_depth)
{
    const float *depth = film->pass[UB_PASS_DEPTH];
    double radius = 0.0, nearest = HUGE_VAL;
    for (int k = 0; k < count; k++)
        if (objs[k].bound_radius > 0.0)
            radius = fmax(radius, objs[k].bound_radius * objs[k].sigma_max);
    if (!depth)
        Py_RETURN_NONE;
    if (wrote_depth) {
        nearest = ub_counters_nearest_depth(counters); /* INFINITY (no hit) is HUGE_VAL */
    } else {
        for (size_t i = 0; i < (size_t)film->w * film->h; i++)
            if (depth[i] < 0.5f * UB_BACKGROUND_DEPTH && depth[i] < nearest)
                nearest = depth[i];
    }
    if (!(radius > 0.0) || nearest == HUGE_VAL)
        Py_RETURN_NONE;
    return PyFloat_FromDouble(ub_pixel_footprint(cam, nearest) / radius);
}

/* world: a C-contiguous float32 (height, width, 3) array, the World's equirectangular map (scene.h,
 * ub_world), finite and >= 0; its distribution is built here, once per render. On success the view
 * stays acquired (the kernels read the caller's memory) until the render returns. */
static int parse_world(PyObject *o, Py_buffer *view, ub_world *world)
{
    if (PyObject_GetBuffer(o, view, PyBUF_RECORDS_RO) != 0) {
        PyErr_Clear();
        PyErr_SetString(PyExc_TypeError, "world must be a float32 array of shape (height, width, 3) or None");
        return -1;
    }
    const char *problem = NULL;
    if (!buffer_is_float32(view))
        problem = "world must have dtype float32";
    else if (view->ndim != 3 || view->shape[2] != 3 || view->shape[0] < 1 || view->shape[1] < 1)
        problem = "world must have shape (height, width, 3): an equirectangular RGB map, row 0 at the nadir";
    else if (!PyBuffer_IsContiguous(view, 'C'))
        problem = "world must be C-contiguous";
    if (problem) {
        PyBuffer_Release(view);
        PyErr_SetString(PyExc_ValueError, problem);
        return -1;
    }
    Py_ssize_t h = view->shape[0], w = view->shape[1];
    if (h > UB_MAX_WORLD_TEXELS / w) {
        PyBuffer_Release(view);
        PyErr_Format(PyExc_ValueError,
                     "world map of %zdx%zd texels is larger than the %d texels (4096x2048) a render takes: "
                     "give a smaller map", w, h, UB_MAX_WORLD_TEXELS);
        return -1;
    }
    const float *rgb = view->buf;
    for (Py_ssize_t k = 0; k < 3 * w * h; k++) {
        /* Finite is not enough: 1e38 texels sum to infinity in the distribution. */
        if (!(rgb[k] >= 0.0f && rgb[k] <= 1e12f)) {
            PyBuffer_Release(view);
            set_value_error("world[%zd, %zd, %zd] is %g: the map's values must be finite, within [0, 1e12]",
                            k / 3 / w, k / 3 % w, k % 3, (double)rgb[k]);
            return -1;
        }
    }
    const char *err = ub_world_prepare(world, rgb, (int)w, (int)h);
    if (err) {
        PyBuffer_Release(view);
        PyErr_SetString(PyExc_MemoryError, err);
        return -1;
    }
    return 0;
}

/* shared_steps_cache(): the cones of one render kept for its next call (render.h, ub_kept_cones). */
#define SHARED_STEPS_CACHE "unbound_core.shared_steps_cache"

static void shared_steps_cache_free(PyObject *capsule)
{
    ub_kept_cones_free(PyCapsule_GetPointer(capsule, SHARED_STEPS_CACHE));
}

static PyObject *py_shared_steps_cache(PyObject *self, PyObject *noargs)
{
    ub_kept_cones *kept = ub_kept_cones_new();
    if (!kept)
        return PyErr_NoMemory();
    PyObject *capsule = PyCapsule_New(kept, SHARED_STEPS_CACHE, shared_steps_cache_free);
    if (!capsule)
        ub_kept_cones_free(kept);
    return capsule;
}

static PyObject *py_render(PyObject *self, PyObject *args, PyObject *kwargs)
{
    static char *kwlist[] = {"camera", "objects", "passes", "window", "threads", "tile_size", "simd",
                             "progress", "cancel", "background", "poll_interval", "shading", "stride",
                             "sample_range", "world", "shared_steps", "clear_unfinished", "shared_steps_cache", NULL};
    PyObject *camera_o, *objects_o, *passes_o, *progress = Py_None, *cancel = Py_None, *shading_o = NULL;
    PyObject *world_o = Py_None, *cache_o = Py_None;
    PyObject *kw[10] = {NULL};
    if (!PyArg_ParseTupleAndKeywords(args, kwargs, "OOO|$OOOOOOOOOOOOOOO", kwlist, &camera_o, &objects_o, &passes_o,
                                     &kw[0], &kw[1], &kw[2], &kw[3], &progress, &cancel, &kw[4], &kw[5],
                                     &shading_o, &kw[6], &kw[7], &world_o, &kw[8], &kw[9], &cache_o))
        return NULL;
    ub_kept_cones *kept_cones = NULL;
    if (cache_o != Py_None && !(kept_cones = PyCapsule_GetPointer(cache_o, SHARED_STEPS_CACHE))) {
        PyErr_Clear();
        PyErr_SetString(PyExc_TypeError, "shared_steps_cache must be an object of shared_steps_cache() or None");
        return NULL;
    }
    static const char *const kw_names[10] = {"window", "threads", "tile_size", "simd", "background",
                                             "poll_interval", "stride", "sample_range", "shared_steps",
                                             "clear_unfinished"};

    ub_camera cam;
    /* As many object records as given (parse_objects refuses more than UB_MAX_OBJECTS): a record
     * holds a zoomed object's reference orbits (about 90 KB), so not UB_MAX_OBJECTS of them. */
    Py_ssize_t given = PyList_Check(objects_o) || PyTuple_Check(objects_o) ? PySequence_Size(objects_o) : 0;
    /* Not zeroed here: ub_object_from_input zeroes each record it fills (624 KB each). */
    ub_object *objs = PyMem_Malloc((given < 1 ? 1 : given > UB_MAX_OBJECTS ? UB_MAX_OBJECTS : (size_t)given)
                                   * sizeof(ub_object));
    ub_shading *shading = PyMem_Calloc(1, sizeof(ub_shading));
    PyObject *render_kw = PyDict_New();
    Py_buffer views[UB_PASS_COUNT], world_view;
    int have[UB_PASS_COUNT] = {0}, have_world = 0;
    ub_world world;
    memset(&world, 0, sizeof world);
    PyObject *result = NULL;
    int count = 0;
    ub_film film;
    memset(&film, 0, sizeof film);
    ub_render_options opt = {0, 32, UB_ISA_AUTO, NULL, NULL, 10000000L, 0, 0, 1, 0};
    if (!objs || !shading || !render_kw) {
        PyErr_NoMemory();
        goto done;
    }
    for (int i = 0; i < 10; i++)
        if (kw[i] && PyDict_SetItemString(render_kw, kw_names[i], kw[i]))
            goto done;
    if (parse_camera(camera_o, &cam) || parse_objects(objects_o, objs, &count) || parse_shading(shading_o, shading)
        || parse_render_options(render_kw, &cam, shading, &film, &opt))
        goto done;
    if (progress != Py_None && !PyCallable_Check(progress)) {
        PyErr_SetString(PyExc_TypeError, "progress must be callable (fraction -> cancel?) or None");
        goto done;
    }
    if (cancel != Py_None && !PyObject_HasAttrString(cancel, "is_set")) {
        PyErr_SetString(PyExc_TypeError, "cancel must have an is_set() method (e.g. threading.Event) or be None");
        goto done;
    }
    opt.kept_cones = kept_cones;
    if (parse_passes(passes_o, &film, views, have))
        goto done;
    if (world_o != Py_None) {
        if (parse_world(world_o, &world_view, &world))
            goto done;
        have_world = 1;
    }

    {
        volatile int cancel_flag = 0;
        ub_scene scene = {&cam, objs, count, &film, shading, NULL, &cancel_flag, have_world ? &world : NULL};
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
        PyObject *ratio = footprint_ratio(&cam, objs, count, &film, &stats.counters,
                                          !(opt.sample_count > 0 && opt.first_sample > 0));
        if (!ratio)
            goto done;
        result = Py_BuildValue("{s:K,s:K,s:K,s:K,s:K,s:d,s:i,s:s,s:O,s:N}", "rays",
                               (unsigned long long)stats.counters.rays, "steps",
                               (unsigned long long)stats.counters.steps, "iterations",
                               (unsigned long long)stats.counters.iterations, "normal_iterations",
                               (unsigned long long)stats.counters.normal_iterations, "out_of_steps",
                               (unsigned long long)stats.counters.out_of_steps, "seconds", stats.seconds,
                               "threads", stats.threads, "simd", stats.isa, "cancelled",
                               stats.cancelled ? Py_True : Py_False, "footprint_ratio", ratio);
    }
done:
    for (int i = 0; i < UB_PASS_COUNT; i++)
        if (have[i])
            PyBuffer_Release(&views[i]);
    if (have_world) {
        ub_world_release(&world);
        PyBuffer_Release(&world_view);
    }
    Py_XDECREF(render_kw);
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
    if (view->ndim != 2 || view->shape[1] != 3 || !buffer_is_float32(view) || !PyBuffer_IsContiguous(view, 'C')) {
        PyBuffer_Release(view);
        PyErr_SetString(PyExc_ValueError, "points must be a C-contiguous float32 array of shape (n, 3)");
        return -1;
    }
    return view->shape[0];
}

/* The simd= keyword of estimate(), normals() and extract_mesh(): -1 with an exception set, else
 * the resolved kernel (UB_ISA_AVX512, UB_ISA_AVX2 or UB_ISA_PORTABLE). */
static int get_simd(PyObject *o)
{
    int isa = UB_ISA_AUTO;
    ub_isa kernel;
    if (o && read_choice(o, "simd", ub_isa_names, &isa))
        return -1;
    const char *err = ub_resolve_isa((ub_isa)isa, &kernel);
    if (err) {
        PyErr_SetString(PyExc_ValueError, err);
        return -1;
    }
    return (int)kernel;
}

static PyObject *py_estimate(PyObject *self, PyObject *args, PyObject *kwargs)
{
    static char *kwlist[] = {"object", "points", "estimate", "iterations", "simd", NULL};
    PyObject *obj_o, *pts_o, *est_o, *it_o, *simd_o = NULL;
    if (!PyArg_ParseTupleAndKeywords(args, kwargs, "OOOO|$O", kwlist, &obj_o, &pts_o, &est_o, &it_o, &simd_o))
        return NULL;
    /* On the heap: a zoomed object's reference orbits make the record large. */
    ub_object *obj = PyMem_Calloc(1, sizeof(ub_object));
    if (!obj)
        return PyErr_NoMemory();
    Py_buffer pv, ev, iv;
    int kernel = -1;
    Py_ssize_t n = -1;
    if (parse_object(obj_o, "object", obj) || (kernel = get_simd(simd_o)) < 0 || (n = get_points(pts_o, &pv)) < 0) {
        PyMem_Free(obj);
        return NULL;
    }
    if (get_float_buffer(est_o, "estimate", n, 0, 0, &ev)) {
        PyBuffer_Release(&pv);
        PyMem_Free(obj);
        return NULL;
    }
    if (get_float_buffer(it_o, "iterations", n, 0, 0, &iv)) {
        PyBuffer_Release(&pv);
        PyBuffer_Release(&ev);
        PyMem_Free(obj);
        return NULL;
    }
    Py_BEGIN_ALLOW_THREADS
    uint64_t fp = ub_fp_enter();
    if (n > 0)
        (kernel == UB_ISA_AVX512 ? ub_estimate_avx512 : kernel == UB_ISA_AVX2 ? ub_estimate_avx2
                                                                              : ub_estimate_portable)(
            obj, pv.buf, (size_t)n, ev.buf, iv.buf);
    ub_fp_leave(fp);
    Py_END_ALLOW_THREADS
    PyMem_Free(obj);
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
    int kernel, have_p = 0, have_t = 0, have_n = 0;
    Py_buffer pv, tv, nv;
    if (parse_object(obj_o, "object", obj))
        goto out;
    if ((kernel = get_simd(simd_o)) < 0)
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
    uint64_t fp = ub_fp_enter();
    if (n > 0)
        (kernel == UB_ISA_AVX512 ? ub_normals_avx512 : kernel == UB_ISA_AVX2 ? ub_normals_avx2
                                                                            : ub_normals_portable)(
            obj, pv.buf, tv.buf, (size_t)n, nv.buf);
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
    PyObject *cam_o, *x_o, *y_o, *lens_o = Py_None;
    if (!PyArg_ParseTuple(args, "OOO|O", &cam_o, &x_o, &y_o, &lens_o))
        return NULL;
    ub_camera cam;
    double x, y, lens[2];
    if (parse_camera(cam_o, &cam) || read_double(x_o, "x", -HUGE_VAL, HUGE_VAL, "", &x)
        || read_double(y_o, "y", -HUGE_VAL, HUGE_VAL, "", &y))
        return NULL;
    if (lens_o != Py_None) {
        if (!PySequence_Check(lens_o) || PySequence_Size(lens_o) != 2) {
            PyErr_Clear();
            PyErr_SetString(PyExc_TypeError, "lens must be a pair (u, v) in [0, 1] or None");
            return NULL;
        }
        for (int i = 0; i < 2; i++) {
            PyObject *item = PySequence_GetItem(lens_o, i);
            int bad = !item || read_double(item, i ? "lens[1]" : "lens[0]", 0.0, 1.0, "", &lens[i]);
            Py_XDECREF(item);
            if (bad)
                return NULL;
        }
    }
    double o[3], d[3], t0, t1;
    ub_camera_ray(&cam, x, y, lens_o != Py_None ? lens : NULL, o, d, &t0, &t1);
    return Py_BuildValue("((ddd)(ddd)dd)", o[0], o[1], o[2], d[0], d[1], d[2], t0, t1);
}

static PyObject *py_lens_sample(PyObject *self, PyObject *args)
{
    PyObject *s_o, *x_o, *y_o;
    int sample, x, y;
    if (!PyArg_ParseTuple(args, "OOO", &s_o, &x_o, &y_o) || read_int(s_o, "sample", 0, INT_MAX, &sample)
        || read_int(x_o, "x", INT_MIN, INT_MAX, &x) || read_int(y_o, "y", INT_MIN, INT_MAX, &y))
        return NULL;
    double uv[2];
    ub_lens_sample(sample, x, y, uv);
    return Py_BuildValue("(dd)", uv[0], uv[1]);
}

static PyObject *py_describe(PyObject *self, PyObject *args)
{
    PyObject *obj_o;
    if (!PyArg_ParseTuple(args, "O", &obj_o))
        return NULL;
    ub_object *o = PyMem_Malloc(sizeof *o);
    if (!o)
        return PyErr_NoMemory();
    PyObject *result = NULL;
    if (!parse_object(obj_o, "object", o)) {
        const double(*b)[3] = o->slice_basis;
        double world_radius = o->bound_radius > 0.0 ? o->bound_radius * o->sigma_max : o->bound_radius;
        result = Py_BuildValue("{s:s,s:i,s:O,s:O,s:O,s:d,s:d,s:(ddd),s:d,s:d,s:d,s:d,s:d,s:(dddd),s:((ddd)(ddd)(ddd)(ddd))}",
                               "kind", ub_kind_names[o->kind], "max_iterations", o->max_iterations, "exact", o->exact ? Py_True : Py_False,
                               "ifs_mirror", o->kind == UB_KIND_IFS && o->ifs_mirror ? Py_True : Py_False,
                               "ifs_folded", o->kind == UB_KIND_IFS && o->ifs_folded ? Py_True : Py_False,
                               "step_factor", o->step_factor, "max_step", o->max_step, "bound_center",
                               o->bound_center[0], o->bound_center[1], o->bound_center[2], "bound_radius",
                               o->bound_radius, "world_bound_radius", world_radius, "bailout", o->bailout,
                               "sigma_min", o->sigma_min, "sigma_max", o->sigma_max, "slice_origin",
                               o->slice_origin[0], o->slice_origin[1], o->slice_origin[2], o->slice_origin[3],
                               "slice_basis", b[0][0], b[0][1], b[0][2], b[1][0], b[1][1], b[1][2], b[2][0], b[2][1],
                               b[2][2], b[3][0], b[3][1], b[3][2]);
    }
    PyMem_Free(o);
    return result;
}

static PyObject *py_cpu_info(PyObject *self, PyObject *noargs)
{
    return Py_BuildValue("{s:i,s:O,s:O}", "cpus", ub_cpu_count(), "avx2_fma", ub_cpu_has_avx2_fma() ? Py_True : Py_False,
                         "avx512", ub_cpu_has_avx512() ? Py_True : Py_False);
}

/* _math_probe(name, values) -> list of floats: the core's own elementary functions (ubmath.h)
 * on each value (a float, or a tuple of 2 for pow and hypot, of 3 for fmaf), for the tests that
 * check their accuracy and their bits on every platform. Private: not part of the API. Float
 * functions (expf, fmaf) take values that are floats exactly. */
static int probe_arg(PyObject *item, int index, int single, double *out)
{
    PyObject *v = index < 0 ? (Py_INCREF(item), item) : PySequence_GetItem(item, index);
    if (!v)
        return -1;
    *out = PyFloat_AsDouble(v);
    Py_DECREF(v);
    if (*out == -1.0 && PyErr_Occurred())
        return -1;
    if (single && *out == *out && (double)(float)*out != *out) {
        PyErr_SetString(PyExc_ValueError, "_math_probe: a float function's argument is not a float32");
        return -1;
    }
    return 0;
}

/* _zoom_probe(object, points, path, want, *, simd='auto', scalar=False) -> bytes: the deep zoom's
 * estimate at object-space points by path ('double' or 'perturbation'), as the kernel `simd` runs
 * it lane-parallel or (scalar) by zoom.c's reference, UB_ZOOM_PROBE_VALUES float64 per point. */
static PyObject *py_zoom_probe(PyObject *self, PyObject *args, PyObject *kwargs)
{
    static char *kwlist[] = {"object", "points", "path", "want", "simd", "scalar", NULL};
    PyObject *obj_o, *pts_o, *simd_o = NULL;
    const char *path_name;
    int want, scalar = 0;
    if (!PyArg_ParseTupleAndKeywords(args, kwargs, "OOsi|$Op", kwlist, &obj_o, &pts_o, &path_name, &want, &simd_o,
                                     &scalar))
        return NULL;
    int path = !strcmp(path_name, "double") ? UB_ZOOM_DOUBLE : !strcmp(path_name, "perturbation") ? UB_ZOOM_PERTURBATION : 0;
    if (!path || want < 0 || want > (UB_WANT_TRAP | UB_WANT_POTENTIAL | UB_WANT_JACOBIAN)) {
        PyErr_SetString(PyExc_ValueError, "_zoom_probe: path 'double' or 'perturbation', want 0..7");
        return NULL;
    }
    ub_object *obj = PyMem_Calloc(1, sizeof(ub_object));
    if (!obj)
        return PyErr_NoMemory();
    Py_buffer pv;
    int kernel = -1;
    Py_ssize_t n = -1;
    if (parse_object(obj_o, "object", obj) || (kernel = get_simd(simd_o)) < 0 || (n = get_points(pts_o, &pv)) < 0) {
        PyMem_Free(obj);
        return NULL;
    }
    PyObject *result = NULL;
    if (!obj->zoom.enabled) {
        PyErr_SetString(PyExc_ValueError, "_zoom_probe: the object has no zoom");
    } else if (ub_kind_is_formula(obj->kind)) {
        /* Their zoom is zoom_formulas.c's, with no reference orbits for the quaternion paths. */
        PyErr_SetString(PyExc_ValueError, "_zoom_probe: the quaternion Julia and Mandelbrot kinds only");
    } else if ((result = PyBytes_FromStringAndSize(NULL, n * UB_ZOOM_PROBE_VALUES * (Py_ssize_t)sizeof(double)))) {
        double *out = (double *)PyBytes_AsString(result);
        Py_BEGIN_ALLOW_THREADS
        uint64_t fp = ub_fp_enter();
        if (n > 0)
            (kernel == UB_ISA_AVX512 ? ub_zoom_probe_avx512 : kernel == UB_ISA_AVX2 ? ub_zoom_probe_avx2
                                                                                  : ub_zoom_probe_portable)(
                obj, path, want, scalar, pv.buf, (size_t)n, out);
        ub_fp_leave(fp);
        Py_END_ALLOW_THREADS
    }
    PyBuffer_Release(&pv);
    PyMem_Free(obj);
    return result;
}

static PyObject *py_math_probe(PyObject *self, PyObject *args)
{
    static const struct {
        const char *name;
        int arity, single;
    } functions[] = {{"exp", 1, 0}, {"log", 1, 0}, {"sin", 1, 0}, {"cos", 1, 0}, {"acos", 1, 0},
                     {"expf", 1, 1}, {"pow", 2, 0}, {"hypot", 2, 0}, {"fmaf", 3, 1},
                     {"sincos_sin", 1, 0}, {"sincos_cos", 1, 0}};
    const char *name;
    PyObject *values;
    if (!PyArg_ParseTuple(args, "sO:_math_probe", &name, &values))
        return NULL;
    int f = -1;
    for (int i = 0; i < (int)(sizeof functions / sizeof functions[0]); i++)
        if (!strcmp(name, functions[i].name))
            f = i;
    if (f < 0) {
        PyErr_Format(PyExc_ValueError, "_math_probe: unknown function '%s'", name);
        return NULL;
    }
    PyObject *seq = PySequence_Tuple(values); /* a copy: see the top of this file */
    if (!seq)
        return NULL;
    Py_ssize_t n = PyTuple_Size(seq);
    PyObject *result = PyList_New(n);
    for (Py_ssize_t i = 0; result && i < n; i++) {
        PyObject *item = PyTuple_GetItem(seq, i); /* borrowed, held by seq */
        int arity = functions[f].arity;
        double a[3] = {0, 0, 0};
        if (arity > 1 && (!PySequence_Check(item) || PySequence_Size(item) != arity)) {
            PyErr_Format(PyExc_TypeError, "_math_probe: %s takes tuples of %d floats", name, arity);
            Py_CLEAR(result);
            break;
        }
        for (int k = 0; k < arity; k++)
            if (probe_arg(item, arity > 1 ? k : -1, functions[f].single, &a[k]) < 0) {
                Py_CLEAR(result);
                break;
            }
        if (!result)
            break;
        double y;
        switch (f) {
        case 0: y = ub_exp(a[0]); break;
        case 1: y = ub_log(a[0]); break;
        case 2: y = ub_sin(a[0]); break;
        case 3: y = ub_cos(a[0]); break;
        case 4: y = ub_acos(a[0]); break;
        case 5: y = ub_expf((float)a[0]); break;
        case 6: y = ub_pow(a[0], a[1]); break;
        case 7: y = ub_hypot(a[0], a[1]); break;
        case 8: y = ub_fmaf((float)a[0], (float)a[1], (float)a[2]); break;
        default: {
            double sine, cosine;
            ub_sincos(a[0], &sine, &cosine);
            y = f == 9 ? sine : cosine;
        }
        }
        PyObject *value = PyFloat_FromDouble(y);
        if (!value || PyList_SetItem(result, i, value) < 0)
            Py_CLEAR(result);
    }
    Py_DECREF(seq);
    return result;
}

/* ---------------------------------------------------------------- extract_mesh() */

/* extract_mesh's arrays are handed over without a copy: a read-only memoryview of an object that
 * owns the core's malloc'd buffer and frees it when the last view goes. A copy into bytes took
 * 0.7 s at 1024 cells (a second of uncancellable work at 2048) and held two copies of the faces. */
typedef struct {
    PyObject_HEAD
    void *data;
    Py_ssize_t size;
} owned_buffer;

static int owned_buffer_get(PyObject *self, Py_buffer *view, int flags)
{
    owned_buffer *b = (owned_buffer *)self;
    return PyBuffer_FillInfo(view, self, b->data ? b->data : (void *)"", b->size, 1, flags);
}

static void owned_buffer_dealloc(PyObject *self)
{
    PyTypeObject *type = Py_TYPE(self);
    free(((owned_buffer *)self)->data);
    ((freefunc)PyType_GetSlot(type, Py_tp_free))(self);
    Py_DECREF(type);
}

static PyType_Slot owned_buffer_slots[] = {
    {Py_bf_getbuffer, (void *)owned_buffer_get}, {Py_tp_dealloc, (void *)owned_buffer_dealloc}, {0, NULL}};
static PyType_Spec owned_buffer_spec = {"unbound_core._native.MeshBuffer", sizeof(owned_buffer), 0,
                                        Py_TPFLAGS_DEFAULT, owned_buffer_slots};
static PyObject *owned_buffer_type; /* made by PyInit__native */

/* A read-only memoryview of size bytes at *data, which it takes over (*data becomes NULL; freed
 * here on failure). */
static PyObject *memoryview_taking(void **data, size_t size)
{
    PyTypeObject *type = (PyTypeObject *)owned_buffer_type;
    owned_buffer *b = (owned_buffer *)((allocfunc)PyType_GetSlot(type, Py_tp_alloc))(type, 0);
    if (!b) {
        free(*data);
        *data = NULL;
        return NULL;
    }
    b->data = *data;
    b->size = *data ? (Py_ssize_t)size : 0;
    *data = NULL;
    PyObject *view = PyMemoryView_FromObject((PyObject *)b);
    Py_DECREF(b);
    return view;
}

static PyObject *py_extract_mesh(PyObject *self, PyObject *args, PyObject *kwargs)
{
    static char *kwlist[] = {"object", "resolution", "epsilon", "min_faces", "seed_spacing", "threads", "simd",
                             "progress", "cancel", "poll_interval", NULL};
    PyObject *obj_o, *res_o = NULL, *eps_o = NULL, *minf_o = NULL, *seed_o = NULL, *thr_o = NULL, *simd_o = NULL,
                     *progress = Py_None, *cancel = Py_None, *poll_o = NULL;
    if (!PyArg_ParseTupleAndKeywords(args, kwargs, "O|$OOOOOOOOO", kwlist, &obj_o, &res_o, &eps_o, &minf_o, &seed_o,
                                     &thr_o, &simd_o, &progress, &cancel, &poll_o))
        return NULL;
    ub_mesh_options opt = {256, 0.0, 0, 0, 0, 0, NULL, NULL, 0.05};
    int resolution = 256, seed = 0, threads = 0, min_faces = 0;
    double eps = 0.0, poll = 0.05;
    if ((res_o && read_int(res_o, "resolution", 2, 65536, &resolution))
        || (eps_o && read_double(eps_o, "epsilon", 0.0, 1e30, "", &eps))
        || (minf_o && read_int(minf_o, "min_faces", 0, 2147483647.0, &min_faces))
        || (seed_o && read_int(seed_o, "seed_spacing", 0, 65536, &seed))
        || (thr_o && read_int(thr_o, "threads", 0, UB_MAX_THREADS, &threads))
        || (poll_o && read_double(poll_o, "poll_interval", 0.001, 10.0, "", &poll)))
        return NULL;
    if (progress != Py_None && !PyCallable_Check(progress)) {
        PyErr_SetString(PyExc_TypeError, "progress must be callable (fraction -> cancel?) or None");
        return NULL;
    }
    if (cancel != Py_None && !PyObject_HasAttrString(cancel, "is_set")) {
        PyErr_SetString(PyExc_TypeError, "cancel must have an is_set() method (e.g. threading.Event) or be None");
        return NULL;
    }
    int kernel = get_simd(simd_o);
    if (kernel < 0)
        return NULL;
    ub_object *obj = PyMem_Calloc(1, sizeof(ub_object));
    if (!obj)
        return PyErr_NoMemory();
    if (parse_object(obj_o, "object", obj)) {
        PyMem_Free(obj);
        return NULL;
    }
    opt.resolution = resolution;
    opt.epsilon = eps;
    opt.min_faces = min_faces;
    opt.seed_spacing = seed;
    opt.threads = threads;
    opt.use_avx2 = kernel != UB_ISA_PORTABLE;   /* the mesh's vertex kernels: AVX2 or portable */
    opt.poll_interval = poll;
    poll_state ps = {progress, cancel, NULL, 0, NULL, NULL, NULL};
    if (progress != Py_None || cancel != Py_None) {
        opt.poll = poll_cb;
        opt.poll_data = &ps;
    }
    ub_mesh_result r;
    ps.tstate = PyEval_SaveThread();
    const char *err = ub_extract_mesh(obj, &opt, &r);
    PyEval_RestoreThread(ps.tstate);
    PyMem_Free(obj);
    PyObject *result = NULL;
    if (ps.failed) {
        ub_mesh_free(&r);
        PyErr_Restore(ps.exc_type, ps.exc_value, ps.exc_tb);
        return NULL;
    }
    if (err) {
        ub_mesh_free(&r);
        PyErr_SetString(PyExc_MemoryError, err);
        return NULL;
    }
    size_t nv = (size_t)r.vertex_count, nf = (size_t)r.face_count;
    PyObject *arrays[5] = {NULL};
    void **bufs[5] = {(void **)&r.vertices, (void **)&r.faces, (void **)&r.trap, (void **)&r.iterations,
                      (void **)&r.estimate};
    const size_t sizes[5] = {12 * nv, 12 * nf, 4 * nv, 4 * nv, 4 * nv};
    for (int i = 0; i < 5; i++) {
        arrays[i] = memoryview_taking(bufs[i], sizes[i]);
        if (!arrays[i]) {
            for (int k = 0; k < i; k++)
                Py_DECREF(arrays[k]);
            ub_mesh_free(&r);
            return NULL;
        }
    }
    result = Py_BuildValue(
        "{s:N,s:N,s:N,s:N,s:N,s:L,s:L,s:L,s:L,s:L,s:L,s:L,s:L,s:d,s:d,s:d,s:(ddddd),s:K,s:i,s:O}", "vertices",
        arrays[0], "faces", arrays[1], "trap", arrays[2], "iterations", arrays[3], "estimate", arrays[4],
        "vertex_count",
        (long long)r.vertex_count, "face_count", (long long)r.face_count, "cells", (long long)r.cells,
        "active_cells", (long long)r.active_cells, "evaluations", (long long)r.evaluations, "seeds",
        (long long)r.seeds, "pieces", (long long)r.pieces, "pieces_removed", (long long)r.pieces_removed, "epsilon",
        r.epsilon, "cell_size", r.cell_size, "seconds", r.seconds, "phase_seconds", r.phase_seconds[0], r.phase_seconds[1], r.phase_seconds[2], r.phase_seconds[3], r.phase_seconds[4], "peak_bytes", (unsigned long long)r.peak_bytes,
        "threads", r.threads, "cancelled", r.cancelled ? Py_True : Py_False);
    ub_mesh_free(&r);
    return result;
}

/* zoom_anchor_move(anchor, zoom, offset, digits=None) -> str: the deep zoom's anchor moved by the
 * object-space (local) offset, anchor + offset 10^-zoom, in the fixed point of the render's
 * reference orbit (zoom.c), with `digits` digits after the point (None: ceil(zoom) + 10). */
static PyObject *py_zoom_anchor_move(PyObject *self, PyObject *args, PyObject *kwargs)
{
    static char *kwlist[] = {"anchor", "zoom", "offset", "digits", NULL};
    PyObject *anchor_o, *offset_o, *digits_o = Py_None;
    double zoom;
    if (!PyArg_ParseTupleAndKeywords(args, kwargs, "OdO|O", kwlist, &anchor_o, &zoom, &offset_o, &digits_o))
        return NULL;
    char anchor[UB_MAX_ANCHOR];
    if (read_string(anchor_o, "anchor", anchor, sizeof anchor))
        return NULL;
    if (!(zoom >= 0.0 && zoom <= UB_MAX_ZOOM)) {
        set_value_error("zoom must be within [0, %g]", UB_MAX_ZOOM);
        return NULL;
    }
    static const ub_param offset_row = {"offset", UB_PARAM_FLOAT, 0, 1, 3, -1e9, 1e9, NULL, NULL, 0, "", 0, 0, 0, 0,
                                        0, NULL, NULL};
    double offset[3];
    if (read_shaped(offset_o, "offset", &offset_row, "", offset))
        return NULL;
    int digits = (int)ceil(zoom) + 10;
    if (digits_o != Py_None && read_int(digits_o, "digits", 0, 90, &digits))
        return NULL;
    char out[3 * 110];
    const char *err = ub_zoom_anchor_move(anchor, zoom, offset, digits, out, (int)sizeof out);
    ub_fixed check[3];
    if (!err)
        err = ub_anchor_parse(out, check); /* the moved anchor must still be a valid one */
    if (err) {
        PyErr_SetString(PyExc_ValueError, err);
        return NULL;
    }
    return PyUnicode_FromString(out);
}

static PyMethodDef methods[] = {
    {"zoom_anchor_move", (PyCFunction)(void (*)(void))py_zoom_anchor_move, METH_VARARGS | METH_KEYWORDS,
     "zoom_anchor_move(anchor, zoom, offset, digits=None) -> str: the deep zoom anchor moved by an object-space "
     "offset, anchor + offset * 10**-zoom, computed exactly in the core's fixed point and written with digits "
     "digits after the point (None: ceil(zoom) + 10); the pick operator's new anchor"},
    {"extract_mesh", (PyCFunction)(void (*)(void))py_extract_mesh, METH_VARARGS | METH_KEYWORDS,
     "extract_mesh(object, *, resolution=256, epsilon=0, min_faces=0, seed_spacing=0, threads=0, simd='auto', "
     "progress=None, cancel=None, poll_interval=0.05) -> dict: the closed, manifold surface {estimate = epsilon} "
     "(epsilon 0: cell size / 64) in object space, from a narrow band of lattice cells (resolution cells across "
     "the bounding ball); 'vertices' (float32 x3), 'faces' (int32 x3, counter-clockwise from outside), 'trap', "
     "'iterations', 'estimate' (float32 per vertex) as read-only memoryviews of the core's own buffers (no copy), and statistics. Pieces with fewer than min_faces "
     "faces are removed. Same bytes for any thread count. See unbound_core.mesh"},
    {"shared_steps_cache", py_shared_steps_cache, METH_NOARGS,
     "shared_steps_cache() -> an object for render(shared_steps_cache=...): the shared first steps (one cone per "
     "8x8 pixels, marched once) of one call kept for the next, so a render of several samples rendered a sample a "
     "call (sample_range) marches them once. Reused only where the camera, objects, sea and blocks are the same, "
     "else replaced; the same pixels either way (stats count the cones' iterations where they are marched). One "
     "render at a time uses it (another one at the same time marches its own)."},
    {"render", (PyCFunction)(void (*)(void))py_render, METH_VARARGS | METH_KEYWORDS,
     "render(camera, objects, passes, *, window=None, threads=0, tile_size=32, simd='auto', progress=None, "
     "cancel=None, background=(0, 0, 0, 0), poll_interval=0.01, shading=None, stride=1, sample_range=None, "
     "world=None, shared_steps=1, clear_unfinished=False, shared_steps_cache=None) "
     "-> stats dict. stride s renders the image pixels (x + s i, y + s j) of window (x, y, columns, rows) "
     "only; sample_range (first, count) renders those samples into buffers holding the earlier ones' sum. "
     "After a cancel (stats['cancelled']) the passes are partial: with several samples, undivided sums of "
     "the samples done; cancelled in the first sample, the tiles not finished keep what the buffers held "
     "(zeros with clear_unfinished=True). stats['footprint_ratio']: a pixel's footprint at the nearest hit "
     "of the depth pass over the largest world bounding radius (None without depth or hits); below PRECISION_LIMIT float32 no "
     "longer resolves the surface. stats['out_of_steps']: camera rays of the window (each sample) that ran out "
     "of max_steps before they hit or left a fractal (the 'max_steps' pass marks them). world: the World's "
     "equirectangular map, float32 (height, width, 3), row 0 at the nadir, Cycles' Environment Texture mapping "
     "(u = atan2(-y, x) / 2 pi + 0.5, v = atan2(z, hypot(x, y)) / pi + 0.5): missed rays see it (camera rays "
     "times the background's alpha, whose colour it replaces) and it lights every hit, importance-sampled "
     "(shading world_samples), with shadows. Keywords and object, "
     "shading and light keys: see PARAMETERS"},
    {"normals", (PyCFunction)(void (*)(void))py_normals, METH_VARARGS | METH_KEYWORDS,
     "normals(object, points, t, normals, *, simd='auto'): object-space unit normals at object-space points "
     "by the object's normal_method (zbuffer: the distance gradient), gradient step alpha * t**delta"},
    {"estimate", (PyCFunction)(void (*)(void))py_estimate, METH_VARARGS | METH_KEYWORDS,
     "estimate(object, points, estimate, iterations, *, simd='auto'): distance estimate (object units) and "
     "escape count at object-space points, computed by the marching kernel's own arithmetic"},
    {"camera_ray", py_camera_ray, METH_VARARGS,
     "camera_ray(camera, x, y, lens=None) -> (origin, direction, t_min, t_max) of the ray through full-image "
     "pixel coordinates (x, y); pixel centres are at +0.5. lens: a point (u, v) of the unit square that picks "
     "the ray's point on the camera's aperture (depth of field, as Cycles' lens sample); None: the pinhole's ray. "
     "Outside a panoramic camera's lens (where Cycles traces no "
     "ray) the direction is (0, 0, 0) and t_min = t_max = 0"},
    {"lens_sample", py_lens_sample, METH_VARARGS,
     "lens_sample(sample, x, y) -> (u, v): the unit-square lens sample render() gives full-image pixel (x, y) in "
     "anti-aliasing sample `sample` (camera_ray's lens)"},
    {"describe", py_describe, METH_VARARGS,
     "describe(object) -> derived values: bounding ball (object space, and its radius in the world), effective "
     "bailout, max_iterations (a zoomed object's grow with the zoom), singular values of the placement, slice after the theta rotation, ifs_mirror (an IFS whose pieces are "
     "mirror images: its estimate follows one path, no search), ifs_folded (an IFS with the cube's symmetries, the "
     "Menger sponge: one path after folding into a wedge, no search)"},
    {"cpu_info", py_cpu_info, METH_NOARGS, "cpu_info() -> {'cpus': n, 'avx2_fma': bool, 'avx512': bool}"},
    {"_zoom_probe", (PyCFunction)(void (*)(void))py_zoom_probe, METH_VARARGS | METH_KEYWORDS,
     "_zoom_probe(object, points, path, want, *, simd='auto', scalar=False) -> bytes: private test hook of the "
     "deep zoom: the estimate of a zoomed object at object-space points by path 'double' or 'perturbation' with "
     "the extras of want (1 trap, 2 potential, 4 normal), lane-parallel as the kernel simd runs it or by the "
     "scalar reference; 8 float64 per point: distance, iterations, trap, potential, normal (3), rebases"},
    {"_math_probe", py_math_probe, METH_VARARGS,
     "_math_probe(name, values) -> [float]: private test hook of the core's own exp, log, sin, cos, acos, expf, "
     "pow, hypot (pairs), fmaf (triples)"},
    {NULL, NULL, 0, NULL},
};

/* ---------------------------------------------------------------- PARAMETERS */

/* A default or range value for Python: a number, a tuple for vectors, a tuple of rows for
 * matrices (infinities as float('inf')). */
static PyObject *shaped_value(const double *v, int rows, int cols)
{
    if (rows == 1 && cols == 1)
        return PyFloat_FromDouble(v[0]);
    if (rows == 1) {
        PyObject *t = PyTuple_New(cols);
        for (int i = 0; t && i < cols; i++)
            PyTuple_SetItem(t, i, PyFloat_FromDouble(v[i]));
        return t;
    }
    PyObject *t = PyTuple_New(rows);
    for (int r = 0; t && r < rows; r++)
        PyTuple_SetItem(t, r, shaped_value(v + r * cols, 1, cols));
    return t;
}

static PyObject *row_default(const ub_param *p)
{
    static const double zeros[16] = {0};
    const double *d = p->defaults ? p->defaults : zeros;
    switch (p->type) {
    case UB_PARAM_FLOAT:
        if (p->flags & UB_PARAM_REQUIRED || (p->flags & UB_PARAM_NONE_OK && !p->defaults))
            Py_RETURN_NONE;
        return shaped_value(d, p->rows, p->cols);
    case UB_PARAM_INT:
        if (p->flags & UB_PARAM_REQUIRED)
            Py_RETURN_NONE;
        return PyLong_FromLong((long)d[0]);
    case UB_PARAM_BOOL:
        return PyBool_FromLong((long)d[0]);
    case UB_PARAM_CHOICE:
        return PyUnicode_FromString(p->choices[(int)d[0]]);
    case UB_PARAM_STRING:
        return PyUnicode_FromString(p->text_default ? p->text_default : "");
    case UB_PARAM_LIST: {
        if (p->flags & UB_PARAM_NONE_OK && !p->default_items)
            Py_RETURN_NONE;
        PyObject *l = PyList_New(p->default_items);
        for (int i = 0; l && i < p->default_items; i++)
            PyList_SetItem(l, i, shaped_value(d + i * p->rows * p->cols, p->rows, p->cols));
        return l;
    }
    default:
        Py_RETURN_NONE;
    }
}

static const char *const type_names[] = {"float", "int", "bool", "choice", "string", "list", "custom"};

static PyObject *row_dict(const ub_param *p)
{
    PyObject *choices = Py_None, *shape;
    Py_INCREF(Py_None);
    if (p->choices) {
        int n = 0;
        while (p->choices[n])
            n++;
        Py_DECREF(choices);
        choices = PyTuple_New(n);
        for (int i = 0; choices && i < n; i++)
            PyTuple_SetItem(choices, i, PyUnicode_FromString(p->choices[i]));
    }
    shape = p->rows == 1 && p->cols == 1 ? PyTuple_New(0) : p->rows == 1 ? Py_BuildValue("(i)", p->cols)
                                                                        : Py_BuildValue("(ii)", p->rows, p->cols);
    int numeric = p->type == UB_PARAM_FLOAT || p->type == UB_PARAM_INT || (p->type == UB_PARAM_LIST && !p->items);
    PyObject *d = Py_BuildValue("{s:s,s:N,s:N,s:N,s:N,s:N,s:s}", "type", type_names[p->type], "shape", shape,
                                "min", numeric ? PyFloat_FromDouble(p->min) : Py_NewRef(Py_None),
                                "max", numeric ? PyFloat_FromDouble(p->max) : Py_NewRef(Py_None),
                                "default", row_default(p), "choices", choices, "description", p->description);
    if (d && p->type == UB_PARAM_LIST) {
        PyObject *extra = Py_BuildValue("{s:i,s:i,s:s}", "min_items", p->min_items, "max_items", p->max_items,
                                        "items", p->items ? p->items->name : "");
        if (!extra || PyDict_Update(d, extra)) {
            Py_XDECREF(extra);
            Py_DECREF(d);
            return NULL;
        }
        Py_DECREF(extra);
    }
    return d;
}

/* PARAMETERS[section][key] = {type, shape, min, max, default, choices, description (, list
 * fields)}, read-only (mappingproxy), for the add-on's properties and the fuzzer. */
static PyObject *parameters_dict(void)
{
    PyObject *all = PyDict_New();
    for (int s = 0; all && ub_param_sections[s]; s++) {
        const ub_param_section *sec = ub_param_sections[s];
        PyObject *rows = PyDict_New();
        for (int i = 0; rows && i < sec->count; i++) {
            PyObject *row = row_dict(&sec->rows[i]);
            if (!row || PyDict_SetItemString(rows, sec->rows[i].key, row)) {
                Py_XDECREF(row);
                Py_CLEAR(rows);
                break;
            }
            Py_DECREF(row);
        }
        PyObject *proxy = rows ? PyDictProxy_New(rows) : NULL;
        Py_XDECREF(rows);
        if (!proxy || PyDict_SetItemString(all, sec->name, proxy)) {
            Py_XDECREF(proxy);
            Py_CLEAR(all);
        } else {
            Py_DECREF(proxy);
        }
    }
    if (!all)
        return NULL;
    PyObject *proxy = PyDictProxy_New(all);
    Py_DECREF(all);
    return proxy;
}

static struct PyModuleDef moduledef = {
    PyModuleDef_HEAD_INIT, "_native", "Unbound's native ray marcher for 3-D deterministic fractals.", -1, methods,
};

PyMODINIT_FUNC PyInit__native(void)
{
    if (!owned_buffer_type && !(owned_buffer_type = PyType_FromSpec(&owned_buffer_spec)))
        return NULL;
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
    PyObject *parameters = parameters_dict();
    if (!parameters) {
        Py_DECREF(names);
        Py_DECREF(chans);
        Py_DECREF(m);
        return NULL;
    }
    PyModule_AddObject(m, "PARAMETERS", parameters);
    PyModule_AddObject(m, "PRECISION_LIMIT", PyFloat_FromDouble(UB_PRECISION_LIMIT));
    PyModule_AddObject(m, "ZOOM_FORMULA_MAX", PyFloat_FromDouble(UB_ZOOM_FORMULA_MAX));
    PyModule_AddObject(m, "PASSES", names);
    PyModule_AddObject(m, "PASS_CHANNELS", chans);
    PyModule_AddObject(m, "BACKGROUND_DEPTH", PyFloat_FromDouble(UB_BACKGROUND_DEPTH));
    PyModule_AddIntConstant(m, "MAX_ITERATIONS", UB_MAX_ITERATIONS);
    PyModule_AddIntConstant(m, "MAX_IMAGE_SIZE", UB_MAX_IMAGE_SIZE);
    return m;
}
