/* rtcf._core._compiled: WordTap, a recorded float, int or bool output whose write
 * pushes its record. */

#include "_compiled.h"

/* ---- WordTap ------------------------------------------------------------------------ */

/* A recorded float, int or bool output: each write becomes one record of a ring (its
 * length, the loop's iteration and stamp, the value in one word), pushed by the port's
 * write itself: rtcf._core._rings.Ring.push_words in C. A full ring counts the drop. */
typedef struct {
    PyObject_HEAD
    vectorcallfunc vectorcall;
    Py_buffer ctl, data;
    int held;
    Py_ssize_t head_at, dropped_at, tail_at;
    long long capacity, record_size, tail_seen, n;
    Py_ssize_t records;     /* capacity * record_size / 8: the data's words */
    LoopStateObject *state;
    int kind;               /* 0: float (a float64 word), 1: int, 2: bool */
} WordTapObject;

static PyObject *
WordTap_vectorcall(WordTapObject *t, PyObject *const *args, size_t nargsf, PyObject *kwnames)
{
    if (PyVectorcall_NARGS(nargsf) != 1 || kwnames != NULL) {
        PyErr_SetString(PyExc_TypeError, "a word tap takes one value");
        return NULL;
    }
    if (!t->held)
        Py_RETURN_NONE;
    PyObject *value = args[0];
    long long word = 0;
    double real = 0.0;
    /* the value first: a value of the wrong type leaves the ring as it was */
    if (t->kind == 0) {
        real = PyFloat_AsDouble(value);
        if (real == -1.0 && PyErr_Occurred())
            return NULL;
    } else { /* int, bool: the integer (a bool's record holds its first byte) */
        word = PyLong_AsLongLong(value);
        if (word == -1 && PyErr_Occurred())
            return NULL;
    }
    volatile long long *ctl = (volatile long long *)t->ctl.buf;
    long long head = ctl[t->head_at];
    if (head - t->tail_seen >= t->capacity) {
        /* looks full from the cached tail: only now read the consumer's line */
        t->tail_seen = ctl[t->tail_at];
        __atomic_thread_fence(__ATOMIC_ACQUIRE);
        if (head - t->tail_seen >= t->capacity) {
            ctl[t->dropped_at] += 1;
            Py_RETURN_NONE;
        }
    }
    Py_ssize_t w = (Py_ssize_t)(((head & (t->capacity - 1)) * t->record_size) >> 3);
    if (w + 4 > t->records) {
        PyErr_SetString(PyExc_IndexError, "a word tap's record past the ring's end");
        return NULL;
    }
    long long *words = (long long *)t->data.buf;
    words[w] = t->n;
    words[w + 1] = t->state->iteration;
    words[w + 2] = t->state->stamp_ns;
    if (t->kind == 0)
        ((double *)words)[w + 3] = real;
    else
        words[w + 3] = word;
    __atomic_thread_fence(__ATOMIC_RELEASE); /* the record, then the head */
    ctl[t->head_at] = head + 1;
    Py_RETURN_NONE;
}

static int
WordTap_init(WordTapObject *t, PyObject *args, PyObject *kwds)
{
    static char *kwlist[] = {"ctl", "data", "head", "dropped", "tail", "capacity",
                             "record_size", "state", "kind", NULL};
    PyObject *ctl, *data, *state;
    const char *kind;
    Py_ssize_t head_at, dropped_at, tail_at;
    long long capacity, record_size;
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "OOnnnLLO!s:WordTap", kwlist, &ctl, &data,
                                     &head_at, &dropped_at, &tail_at, &capacity, &record_size,
                                     &LoopStateType, &state, &kind))
        return -1;
    if (t->held) {
        PyBuffer_Release(&t->ctl);
        PyBuffer_Release(&t->data);
        t->held = 0;
    }
    if (strcmp(kind, "float") == 0)
        t->kind = 0;
    else if (strcmp(kind, "int") == 0)
        t->kind = 1;
    else if (strcmp(kind, "bool") == 0)
        t->kind = 2;
    else {
        PyErr_Format(PyExc_ValueError, "WordTap: kind %s is not float, int or bool", kind);
        return -1;
    }
    if (capacity <= 0 || (capacity & (capacity - 1)) != 0 || record_size < 32 ||
        record_size % 8 != 0) {
        PyErr_SetString(PyExc_ValueError, "WordTap: a ring of 2**k records of 8*m >= 32 bytes");
        return -1;
    }
    if (get_words(ctl, &t->ctl, "a ring's counters") < 0)
        return -1;
    if (PyObject_GetBuffer(data, &t->data, PyBUF_WRITABLE | PyBUF_C_CONTIGUOUS) < 0) {
        PyBuffer_Release(&t->ctl);
        return -1;
    }
    t->held = 1;
    Py_ssize_t nctl = t->ctl.len / 8;
    if (head_at < 0 || dropped_at < 0 || tail_at < 0 || head_at >= nctl || dropped_at >= nctl ||
        tail_at >= nctl || t->data.len < capacity * record_size ||
        ((uintptr_t)t->data.buf) % 8 != 0) {
        PyBuffer_Release(&t->ctl);
        PyBuffer_Release(&t->data);
        t->held = 0;
        PyErr_SetString(PyExc_ValueError, "WordTap: counters or records outside the buffers");
        return -1;
    }
    t->head_at = head_at;
    t->dropped_at = dropped_at;
    t->tail_at = tail_at;
    t->capacity = capacity;
    t->record_size = record_size;
    t->records = (Py_ssize_t)(capacity * record_size / 8);
    t->tail_seen = ((volatile long long *)t->ctl.buf)[tail_at];
    t->n = t->kind == 2 ? 1 : 8; /* bytes of the value (little-endian: a bool's first) */
    Py_XSETREF(t->state, (LoopStateObject *)Py_NewRef(state));
    t->vectorcall = (vectorcallfunc)WordTap_vectorcall;
    return 0;
}

static PyObject *
WordTap_release(WordTapObject *t, PyObject *Py_UNUSED(ignored))
{
    if (t->held) {
        PyBuffer_Release(&t->ctl);
        PyBuffer_Release(&t->data);
        t->held = 0;
    }
    Py_RETURN_NONE;
}

static PyObject *
WordTap_dropped(WordTapObject *t, void *closure)
{
    if (!t->held)
        return PyLong_FromLong(0);
    return PyLong_FromLongLong(((volatile long long *)t->ctl.buf)[t->dropped_at]);
}

static void
WordTap_dealloc(WordTapObject *t)
{
    WordTap_release(t, NULL);
    Py_CLEAR(t->state);
    Py_TYPE(t)->tp_free((PyObject *)t);
}

static PyObject *
WordTap_new(PyTypeObject *type, PyObject *args, PyObject *kwds)
{
    WordTapObject *t = (WordTapObject *)type->tp_alloc(type, 0);
    if (t != NULL)
        t->vectorcall = (vectorcallfunc)WordTap_vectorcall;
    return (PyObject *)t;
}

static PyMethodDef WordTap_methods[] = {
    {"release", (PyCFunction)WordTap_release, METH_NOARGS,
     "release()\n--\n\nLet go of the ring (writes do nothing after)."},
    {NULL},
};

static PyGetSetDef WordTap_getset[] = {
    {"dropped", (getter)WordTap_dropped, NULL, "Records the full ring dropped.", NULL},
    {NULL},
};

PyTypeObject WordTapType = {
    RTCF_TYPE("rtcf._core._compiled.WordTap", WordTapObject,
              "WordTap(ctl, data, head, dropped, tail, capacity, record_size, state, kind): "
              "a recorded float, int or bool output's tap."),
    .tp_vectorcall_offset = offsetof(WordTapObject, vectorcall),
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_HAVE_VECTORCALL,
    .tp_new = WordTap_new,
    .tp_init = (initproc)WordTap_init,
    .tp_call = PyVectorcall_Call,
    .tp_dealloc = (destructor)WordTap_dealloc,
    .tp_methods = WordTap_methods,
    .tp_getset = WordTap_getset,
};
