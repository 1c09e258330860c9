/* rtcf._core._compiled: CommandCheck, the numeric part of a hardware command input's
 * guard (rtcf._core._command_limits.CommandGuard) in one call. */

#include "_compiled.h"

#include <math.h>

/* ---- CommandCheck ------------------------------------------------------------------ */

/* One guard's limits and state, held as buffers for the object's life: lo, hi and step
 * (per joint; step inf where no rate limit), last (the command last passed on, copied
 * in by each check that passes one on) float64 C-contiguous of n; changed, bool of n.
 *
 * check(value, out, has_last) in one pass over the joints, then (only on a clamp) a
 * second one; the codes (COMMAND_*) as rtcf._core._interpreted.CommandCheck gives them.
 * It allocates no Python object (its results are small ints): the one allocation is
 * numpy's, the first time an array exports its buffer (its format and shape, kept
 * with the array until it dies), which a fresh array per command pays once. */

enum {
    COMMAND_PASSED = 0,    /* unchanged: last := value */
    COMMAND_CLAMPED = 1,   /* clamped into out: last := out, changed says which joints */
    COMMAND_NAN = 2,       /* refused: a NaN and no infinity */
    COMMAND_INFINITE = 3,  /* refused: an infinity */
    COMMAND_MALFORMED = 4, /* not a 1-D float64 buffer of n */
};

#define COMMAND_VIEWS 5 /* lo, hi, step, last, changed */

typedef struct {
    PyObject_HEAD
    vectorcallfunc vectorcall;
    Py_buffer views[COMMAND_VIEWS];
    int held; /* how many of views are held (all or none but during init) */
    Py_ssize_t n;
} CommandCheckObject;

/* a native float64 format: "d", "@d", "=d", or "<d"/">d" where that is native */
static int
is_float64(const Py_buffer *view)
{
    const char *f = view->format;
    if (view->itemsize != 8 || f == NULL)
        return 0;
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__
    const char native = '>';
#else
    const char native = '<';
#endif
    if (f[0] == '@' || f[0] == '=' || f[0] == native)
        f++;
    return f[0] == 'd' && f[1] == '\0';
}

static void
CommandCheck_release_views(CommandCheckObject *c)
{
    while (c->held > 0)
        PyBuffer_Release(&c->views[--c->held]);
}

/* one more of the held views: obj's buffer, C-contiguous, n items of float64 (or of
 * bool); 0, or -1 with an exception */
static int
CommandCheck_hold(CommandCheckObject *c, PyObject *obj, const char *what, int boolean,
                  int writable)
{
    Py_buffer *view = &c->views[c->held];
    int flags = PyBUF_FORMAT | PyBUF_C_CONTIGUOUS | (writable ? PyBUF_WRITABLE : 0);
    if (PyObject_GetBuffer(obj, view, flags) < 0) {
        PyErr_Clear(); /* (numpy's own: a ValueError for a read-only array) */
        PyErr_Format(PyExc_TypeError, "CommandCheck: %s must be a %s1-D %s array of %zd",
                     what, writable ? "writable C-contiguous " : "C-contiguous ",
                     boolean ? "bool" : "float64", c->n);
        return -1;
    }
    int ok = boolean ? (view->itemsize == 1 && view->format != NULL &&
                        strcmp(view->format, "?") == 0)
                     : is_float64(view);
    if (!ok || view->ndim != 1 || view->shape[0] != c->n) {
        PyErr_Format(PyExc_TypeError, "CommandCheck: %s must be a %s1-D %s array of %zd",
                     what, writable ? "writable C-contiguous " : "C-contiguous ",
                     boolean ? "bool" : "float64", c->n);
        PyBuffer_Release(view);
        return -1;
    }
    c->held++;
    return 0;
}

static int
CommandCheck_init(CommandCheckObject *c, PyObject *args, PyObject *kwds)
{
    static char *kwlist[] = {"lo", "hi", "step", "last", "changed", NULL};
    PyObject *obj[COMMAND_VIEWS];
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "OOOOO:CommandCheck", kwlist, &obj[0],
                                     &obj[1], &obj[2], &obj[3], &obj[4]))
        return -1;
    CommandCheck_release_views(c);
    Py_ssize_t n = PyObject_Length(obj[0]);
    if (n < 0)
        return -1;
    c->n = n;
    if (CommandCheck_hold(c, obj[0], "lo", 0, 0) < 0 ||
        CommandCheck_hold(c, obj[1], "hi", 0, 0) < 0 ||
        CommandCheck_hold(c, obj[2], "step", 0, 0) < 0 ||
        CommandCheck_hold(c, obj[3], "last", 0, 1) < 0 ||
        CommandCheck_hold(c, obj[4], "changed", 1, 1) < 0) {
        CommandCheck_release_views(c);
        return -1;
    }
    return 0;
}

/* the value's element i (any stride, any alignment: a view of a message's bytes) */
static inline double
element(const char *base, Py_ssize_t stride, Py_ssize_t i)
{
    double x;
    memcpy(&x, base + i * stride, sizeof x);
    return x;
}

/* joint i's bounds now: [lo, hi], narrowed to within step of last when has_last */
static inline void
bounds(const CommandCheckObject *c, Py_ssize_t i, int has_last, double *lo, double *hi)
{
    double l = ((const double *)c->views[0].buf)[i];
    double h = ((const double *)c->views[1].buf)[i];
    if (has_last) {
        double last = ((const double *)c->views[3].buf)[i];
        double step = ((const double *)c->views[2].buf)[i];
        double a = last - step, b = last + step;
        if (a > l)
            l = a;
        if (b < h)
            h = b;
    }
    *lo = l;
    *hi = h;
}

static inline double
clamp(double x, double lo, double hi)
{
    if (x > hi)
        x = hi;
    if (x < lo)
        x = lo;
    return x;
}

static PyObject *
CommandCheck_vectorcall(CommandCheckObject *c, PyObject *const *args, size_t nargsf,
                        PyObject *kwnames)
{
    if (PyVectorcall_NARGS(nargsf) != 3 || kwnames != NULL) {
        PyErr_SetString(PyExc_TypeError, "check(value, out, has_last)");
        return NULL;
    }
    if (c->held != COMMAND_VIEWS) {
        PyErr_SetString(PyExc_ValueError, "CommandCheck: not initialised");
        return NULL;
    }
    int has_last = PyObject_IsTrue(args[2]);
    if (has_last < 0)
        return NULL;
    Py_buffer value;
    if (PyObject_GetBuffer(args[0], &value, PyBUF_RECORDS_RO) < 0) {
        PyErr_Clear(); /* not a buffer: malformed, as any other wrong value */
        return PyLong_FromLong(COMMAND_MALFORMED);
    }
    const Py_ssize_t n = c->n;
    if (!is_float64(&value) || value.ndim != 1 || value.shape[0] != n) {
        PyBuffer_Release(&value);
        return PyLong_FromLong(COMMAND_MALFORMED);
    }
    const char *v = (const char *)value.buf;
    const Py_ssize_t stride = value.strides != NULL ? value.strides[0] : 8;
    /* one pass: not finite (a NaN, an infinity), and whether a joint is outside */
    int nan = 0, infinite = 0, outside = 0;
    for (Py_ssize_t i = 0; i < n; i++) {
        double x = element(v, stride, i), lo, hi;
        if (!isfinite(x)) {
            if (isnan(x))
                nan = 1;
            else
                infinite = 1;
            continue;
        }
        bounds(c, i, has_last, &lo, &hi);
        outside |= clamp(x, lo, hi) != x;
    }
    double *last = (double *)c->views[3].buf;
    if (infinite || nan) {
        PyBuffer_Release(&value);
        return PyLong_FromLong(infinite ? COMMAND_INFINITE : COMMAND_NAN);
    }
    if (!outside) {
        for (Py_ssize_t i = 0; i < n; i++)
            last[i] = element(v, stride, i);
        PyBuffer_Release(&value);
        return PyLong_FromLong(COMMAND_PASSED);
    }
    /* clamped (seldom): only now the output's buffer; the bounds again (from the old
     * last: each joint's last is read before it is written) */
    Py_buffer out;
    if (PyObject_GetBuffer(args[1], &out, PyBUF_WRITABLE | PyBUF_FORMAT | PyBUF_C_CONTIGUOUS) < 0) {
        PyBuffer_Release(&value);
        return NULL;
    }
    if (!is_float64(&out) || out.ndim != 1 || out.shape[0] != n) {
        PyBuffer_Release(&out);
        PyBuffer_Release(&value);
        PyErr_Format(PyExc_TypeError, "CommandCheck: out must be a 1-D float64 array of %zd", n);
        return NULL;
    }
    double *o = (double *)out.buf;
    char *changed = (char *)c->views[4].buf;
    for (Py_ssize_t i = 0; i < n; i++) {
        double x = element(v, stride, i), lo, hi;
        bounds(c, i, has_last, &lo, &hi);
        double y = clamp(x, lo, hi);
        changed[i] = y != x;
        o[i] = y; /* (value may be out itself: x was read first) */
        last[i] = y;
    }
    PyBuffer_Release(&out);
    PyBuffer_Release(&value);
    return PyLong_FromLong(COMMAND_CLAMPED);
}

static PyObject *
CommandCheck_new(PyTypeObject *type, PyObject *Py_UNUSED(args), PyObject *Py_UNUSED(kwds))
{
    CommandCheckObject *c = (CommandCheckObject *)type->tp_alloc(type, 0);
    if (c != NULL)
        c->vectorcall = (vectorcallfunc)CommandCheck_vectorcall;
    return (PyObject *)c;
}

/* the held buffers' owners: a Python class exporting a buffer (PEP 688) could hold the
 * check itself, so they are visited */
static int
CommandCheck_traverse(CommandCheckObject *c, visitproc visit, void *arg)
{
    for (int k = 0; k < c->held; k++)
        Py_VISIT(c->views[k].obj);
    return 0;
}

static int
CommandCheck_clear(CommandCheckObject *c)
{
    CommandCheck_release_views(c);
    return 0;
}

static PyObject *
CommandCheck_size(CommandCheckObject *c, void *Py_UNUSED(closure))
{
    return PyLong_FromSsize_t(c->n);
}

static PyGetSetDef CommandCheck_getset[] = {
    {"size", (getter)CommandCheck_size, NULL, "The joints: n.", NULL},
    {NULL},
};

PyTypeObject CommandCheckType = {
    RTCF_TYPE("rtcf._core._compiled.CommandCheck", CommandCheckObject,
              "CommandCheck(lo, hi, step, last, changed): a command input's check.\n\n"
              "check(value, out, has_last) -> 0 passed unchanged (last := value), 1 "
              "clamped into out (last := out; changed: which joints), 2 refused: a NaN "
              "and no infinity, 3 refused: an infinity, 4 malformed (not a 1-D float64 "
              "buffer of n)."),
    .tp_vectorcall_offset = offsetof(CommandCheckObject, vectorcall),
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_HAVE_VECTORCALL | Py_TPFLAGS_HAVE_GC,
    .tp_new = CommandCheck_new,
    .tp_init = (initproc)CommandCheck_init,
    .tp_call = PyVectorcall_Call,
    RTCF_GC_SLOTS(CommandCheck),
    .tp_getset = CommandCheck_getset,
};
