/* rtcf._core._compiled: Handover, a value crossing lanes: a send, a receive, a LET
 * lane's output. */

#include "_compiled.h"

/* ---- Handover ----------------------------------------------------------------------- */

/* A value that crosses lanes (rtcf._runtime._lanes): the producer's send after it ran,
 * a reader's receive before the first reader runs, a LET lane's output taken when its
 * window starts. One entry of a channel, seqlock-style: the stamp goes to -1, then the
 * value and its words, then the stamp to the version. A float, int or bool is copied
 * here (the bytes its codec gives); other types go through the codec's Python calls.
 * The same as rtcf._runtime._lanes's _Send, _Recv and _LetIn, which the Python path
 * runs (tests/unit/test_lane_link.py runs the lanes on both paths). */

/* the segment's words the handovers read (rtcf._runtime._lanes: W_*, L_*, DEPTH) */
#define LANES_W_STOP_AT 0
#define LANES_W_ORIGIN_NS 5
#define LANES_W_FIRST 6
#define LANES_DEPTH 4
#define LANES_ENTRY_WORDS 4

enum { H_SEND = 0, H_RECV = 1, H_LET_IN = 2 };
enum { V_OTHER = 0, V_FLOAT = 1, V_INT = 2, V_BOOL = 3 };

typedef struct {
    PyObject_HEAD
    vectorcallfunc vectorcall;
    Py_buffer words;
    Py_buffer payload[LANES_DEPTH];
    int held;
    PyObject *views[LANES_DEPTH];   /* the payloads as memoryviews, for the codec's calls */
    Py_ssize_t at[LANES_DEPTH];     /* each entry's first word */
    LoopStateObject *state;
    SlotObject *slot;
    PyObject *code;                 /* encode(value) -> bytes, or decode(payload, n) */
    PyObject *now;                  /* NULL: CLOCK_MONOTONIC */
    int mode, kind, simulated, nap;
    long long too_big, delayed, step, every, phase, period_ns, last;
    Py_ssize_t source;              /* the producer lane's L_LAST word */
    long long late, lost, let_overruns;
} HandoverObject;

static inline long long
floor_div(long long a, long long b)
{
    long long q = a / b;
    return (a % b != 0 && ((a < 0) != (b < 0))) ? q - 1 : q;
}

static inline long long
floor_mod(long long a, long long b)
{
    long long r = a % b;
    return (r != 0 && ((r < 0) != (b < 0))) ? r + b : r;
}

static inline Py_ssize_t
handover_entry(HandoverObject *h, long long version)
{
    return h->at[floor_mod(floor_div(version, h->step), LANES_DEPTH)];
}

/* let go of the words and the payloads, and release the payloads' views (they hold
 * the segment, which its owner closes next) */
static void
handover_release(HandoverObject *h)
{
    if (h->held) {
        PyBuffer_Release(&h->words);
        for (int k = 0; k < LANES_DEPTH; k++)
            PyBuffer_Release(&h->payload[k]);
        h->held = 0;
    }
    for (int k = 0; k < LANES_DEPTH; k++) {
        if (h->views[k] != NULL) {
            PyObject *type, *value, *tb;
            PyErr_Fetch(&type, &value, &tb);
            PyObject *res = PyObject_CallMethod(h->views[k], "release", NULL);
            if (res == NULL)
                PyErr_WriteUnraisable(h->views[k]);
            Py_XDECREF(res);
            PyErr_Restore(type, value, tb);
            Py_CLEAR(h->views[k]);
        }
    }
}

static PyObject *
handover_send(HandoverObject *h)
{
    volatile long long *words = (volatile long long *)h->words.buf;
    SlotObject *slot = h->slot;
    long long v = h->state->iteration;
    int e = (int)floor_mod(floor_div(v, h->step), LANES_DEPTH);
    Py_ssize_t w = h->at[e];
    char *payload = (char *)h->payload[e].buf;
    long long n = -1;
    char scalar[8];
    PyObject *data = NULL;
    Py_buffer b;
    /* the value first: one that cannot be encoded leaves the entry as it was */
    if (slot->seq) {
        if (h->kind == V_FLOAT) {
            double x = PyFloat_AsDouble(slot->value);
            if (x == -1.0 && PyErr_Occurred())
                return NULL;
            memcpy(scalar, &x, 8);
            n = 8;
        } else if (h->kind == V_INT) {
            long long x = PyLong_AsLongLong(slot->value);
            if (x == -1 && PyErr_Occurred())
                return NULL;
            memcpy(scalar, &x, 8);
            n = 8;
        } else if (h->kind == V_BOOL) {
            int x = PyObject_IsTrue(slot->value);
            if (x < 0)
                return NULL;
            scalar[0] = x ? 1 : 0;
            n = 1;
        } else {
            data = PyObject_CallOneArg(h->code, slot->value);
            if (data == NULL)
                return NULL;
            if (PyObject_GetBuffer(data, &b, PyBUF_C_CONTIGUOUS) < 0) {
                Py_DECREF(data);
                return NULL;
            }
            n = b.len;
            if (n > h->too_big || n > h->payload[e].len) {
                PyBuffer_Release(&b);
                Py_DECREF(data);
                PyErr_Format(PyExc_ValueError,
                             "a value of %lld bytes is larger than a lane's channel holds "
                             "(%lld); send less per iteration", n, h->too_big);
                return NULL;
            }
        }
    }
    words[w] = -1; /* being written: a reader that read this entry meanwhile drops it */
    __atomic_thread_fence(__ATOMIC_RELEASE);
    if (data != NULL) {
        memcpy(payload, b.buf, (size_t)n);
        PyBuffer_Release(&b);
        Py_DECREF(data);
    } else if (n > 0) {
        memcpy(payload, scalar, (size_t)n);
    }
    words[w + 1] = slot->seq;
    words[w + 2] = slot->iteration;
    words[w + 3] = n;
    __atomic_thread_fence(__ATOMIC_RELEASE);
    words[w] = v;
    Py_RETURN_NONE;
}

/* version v from entry w into the readers' slot (if it stayed): 0, or -1 on an error */
static int
handover_read(HandoverObject *h, long long v, Py_ssize_t w, int e)
{
    volatile long long *words = (volatile long long *)h->words.buf;
    __atomic_thread_fence(__ATOMIC_ACQUIRE);
    long long seq = words[w + 1], it = words[w + 2], n = words[w + 3];
    PyObject *value;
    if (n < 0) {
        value = Py_NewRef(Py_None);
    } else if (h->kind == V_FLOAT) {
        double x;
        memcpy(&x, h->payload[e].buf, 8);
        value = PyFloat_FromDouble(x);
    } else if (h->kind == V_INT) {
        long long x;
        memcpy(&x, h->payload[e].buf, 8);
        value = PyLong_FromLongLong(x);
    } else if (h->kind == V_BOOL) {
        value = Py_NewRef(((char *)h->payload[e].buf)[0] != 0 ? Py_True : Py_False);
    } else {
        PyObject *args[2] = {h->views[e], PyLong_FromLongLong(n)};
        if (args[1] == NULL)
            return -1;
        value = PyObject_Vectorcall(h->code, args, 2, NULL);
        Py_DECREF(args[1]);
    }
    if (value == NULL)
        return -1;
    __atomic_thread_fence(__ATOMIC_ACQUIRE);
    if (words[w] != v) { /* overwritten while read: the reader fell DEPTH behind */
        h->lost += 1;
        Py_DECREF(value);
        return 0;
    }
    Py_SETREF(h->slot->value, value);
    h->slot->seq = seq;
    h->slot->iteration = it;
    return 0;
}

/* how a wait lets others run: a yield, or a 50 µs nap (on /clock time, where a wait
 * has no bound at a real-time priority); a signal's handler runs here, as in Python */
static int
handover_pause(HandoverObject *h)
{
    if (h->nap) {
        struct timespec ts = {0, 50000};
        Py_BEGIN_ALLOW_THREADS
        nanosleep(&ts, NULL);
        Py_END_ALLOW_THREADS
    } else {
        sched_yield();
    }
    return PyErr_CheckSignals();
}

/* wait for version v in entry w: 1 when it is there; 0 when it will not come (the
 * producer stopped, or finished the iteration without it) or, in real time, did not
 * come before this iteration's period ended (late); -1 on an error */
static int
handover_wait(HandoverObject *h, long long v, Py_ssize_t w)
{
    volatile long long *words = (volatile long long *)h->words.buf;
    long long limit = h->simulated ? LLONG_MAX
        : words[LANES_W_ORIGIN_NS] + h->state->time_ns + h->period_ns;
    for (;;) {
        long long done = words[h->source];
        __atomic_thread_fence(__ATOMIC_ACQUIRE);
        long long stamp = words[w];
        if (stamp == v)
            return 1;
        if (stamp > v) {
            h->lost += 1;
            return 0;
        }
        if (done >= v || words[LANES_W_STOP_AT] < v)
            return 0;
        if (!h->simulated) {
            long long t;
            if (h->now == NULL) {
                t = monotonic_ns();
            } else {
                PyObject *res = PyObject_Vectorcall(h->now, NULL, 0, NULL);
                if (res == NULL)
                    return -1;
                t = PyLong_AsLongLong(res);
                Py_DECREF(res);
                if (t == -1 && PyErr_Occurred())
                    return -1;
            }
            if (t > limit) {
                h->late += 1;
                return 0;
            }
        }
        if (handover_pause(h) < 0)
            return -1;
    }
}

static PyObject *
handover_recv(HandoverObject *h)
{
    volatile long long *words = (volatile long long *)h->words.buf;
    long long v = h->state->iteration - h->delayed;
    /* before the first value any lane handed over (a delayed reader's first one is what
     * the iteration before the run left: its producer hands it over at begin) */
    if (v < words[LANES_W_FIRST] - h->delayed)
        Py_RETURN_NONE;
    int e = (int)floor_mod(floor_div(v, h->step), LANES_DEPTH);
    Py_ssize_t w = h->at[e];
    if (words[w] != v) {
        int r = handover_wait(h, v, w);
        if (r < 0)
            return NULL;
        if (r == 0)
            Py_RETURN_NONE;
    }
    if (handover_read(h, v, w, e) < 0)
        return NULL;
    Py_RETURN_NONE;
}

static PyObject *
handover_let_in(HandoverObject *h)
{
    volatile long long *words = (volatile long long *)h->words.buf;
    long long r = h->state->iteration - h->every;
    r -= floor_mod(r - h->phase, h->every); /* the last release whose window has ended */
    if (r == h->last)
        Py_RETURN_NONE;
    h->last = r;
    if (r < words[LANES_W_FIRST])
        Py_RETURN_NONE;
    int e = (int)floor_mod(floor_div(r, h->step), LANES_DEPTH);
    Py_ssize_t w = h->at[e];
    if (words[w] != r) {
        if (!h->simulated) { /* not finished in its window: keep the last value */
            h->let_overruns += 1;
            Py_RETURN_NONE;
        }
        int ok = handover_wait(h, r, w);
        if (ok < 0)
            return NULL;
        if (ok == 0)
            Py_RETURN_NONE;
    }
    if (handover_read(h, r, w, e) < 0)
        return NULL;
    Py_RETURN_NONE;
}

static PyObject *
Handover_vectorcall(HandoverObject *h, PyObject *const *args, size_t nargsf, PyObject *kwnames)
{
    if (PyVectorcall_NARGS(nargsf) != 0 || kwnames != NULL) {
        PyErr_SetString(PyExc_TypeError, "a handover takes no arguments");
        return NULL;
    }
    if (!h->held) {
        PyErr_SetString(PyExc_RuntimeError, "a handover called after its release");
        return NULL;
    }
    if (h->mode == H_SEND)
        return handover_send(h);
    if (h->mode == H_RECV)
        return handover_recv(h);
    return handover_let_in(h);
}

static int
Handover_init(HandoverObject *h, PyObject *args, PyObject *kwds)
{
    static char *kwlist[] = {"mode", "words", "entries", "state", "slot", "kind", "code",
                             "too_big", "delayed", "source", "step", "every", "phase",
                             "simulated", "period_ns", "now", "nap", NULL};
    int mode, simulated, nap;
    PyObject *words, *entries, *state, *slot, *code, *now;
    const char *kind;
    long long too_big, delayed, step, every, phase, period_ns;
    Py_ssize_t source;
    if (!PyArg_ParseTupleAndKeywords(
            args, kwds, "iOO!O!O!sOLLnLLLpLOp:Handover", kwlist, &mode, &words, &PyTuple_Type,
            &entries, &LoopStateType, &state, &SlotType, &slot, &kind, &code, &too_big,
            &delayed, &source, &step, &every, &phase, &simulated, &period_ns, &now, &nap))
        return -1;
    if (mode < H_SEND || mode > H_LET_IN || step <= 0 || every <= 0 ||
        PyTuple_GET_SIZE(entries) != LANES_DEPTH) {
        PyErr_SetString(PyExc_ValueError,
                        "Handover: mode 0-2, step and every > 0, and 4 entries");
        return -1;
    }
    handover_release(h);
    if (get_words(words, &h->words, "the lanes' words") < 0)
        return -1;
    Py_ssize_t nwords = h->words.len / 8;
    int got = 0;
    for (; got < LANES_DEPTH; got++) {
        PyObject *entry = PyTuple_GET_ITEM(entries, got);
        Py_ssize_t at;
        PyObject *view;
        if (!PyArg_ParseTuple(entry, "nO:Handover entry", &at, &view))
            break;
        if (at < 0 || at + LANES_ENTRY_WORDS > nwords || source < 0 || source >= nwords) {
            PyErr_SetString(PyExc_ValueError, "Handover: an entry outside the lanes' words");
            break;
        }
        if (PyObject_GetBuffer(view, &h->payload[got], PyBUF_WRITABLE | PyBUF_C_CONTIGUOUS) < 0)
            break;
        h->at[got] = at;
        Py_XSETREF(h->views[got], Py_NewRef(view));
    }
    if (got < LANES_DEPTH) {
        for (int k = 0; k < got; k++)
            PyBuffer_Release(&h->payload[k]);
        PyBuffer_Release(&h->words);
        return -1;
    }
    h->held = 1;
    /* a scalar is copied as its codec's bytes: little-endian float64, int64, one byte */
    h->kind = V_OTHER;
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
    if (strcmp(kind, "float") == 0)
        h->kind = V_FLOAT;
    else if (strcmp(kind, "int") == 0)
        h->kind = V_INT;
    else if (strcmp(kind, "bool") == 0)
        h->kind = V_BOOL;
#endif
    for (int k = 0; k < LANES_DEPTH; k++) {
        if (h->payload[k].len < (h->kind == V_OTHER ? 0 : 8)) {
            handover_release(h);
            PyErr_SetString(PyExc_ValueError, "Handover: a payload too short for its kind");
            return -1;
        }
    }
    h->mode = mode;
    h->simulated = simulated;
    h->nap = nap;
    h->too_big = too_big;
    h->delayed = delayed;
    h->source = source;
    h->step = step;
    h->every = every;
    h->phase = phase;
    h->period_ns = period_ns;
    h->last = LLONG_MIN + 1;
    h->late = h->lost = h->let_overruns = 0;
    Py_XSETREF(h->state, (LoopStateObject *)Py_NewRef(state));
    Py_XSETREF(h->slot, (SlotObject *)Py_NewRef(slot));
    Py_XSETREF(h->code, Py_NewRef(code));
    Py_CLEAR(h->now);
    if (now != Py_None)
        h->now = Py_NewRef(now);
    h->vectorcall = (vectorcallfunc)Handover_vectorcall;
    return 0;
}

static PyObject *
Handover_release(HandoverObject *h, PyObject *Py_UNUSED(ignored))
{
    handover_release(h);
    Py_RETURN_NONE;
}

static int
Handover_traverse(HandoverObject *h, visitproc visit, void *arg)
{
    for (int k = 0; k < LANES_DEPTH; k++)
        Py_VISIT(h->views[k]);
    Py_VISIT(h->state);
    Py_VISIT(h->slot);
    Py_VISIT(h->code);
    Py_VISIT(h->now);
    return 0;
}

static int
Handover_clear(HandoverObject *h)
{
    handover_release(h);
    for (int k = 0; k < LANES_DEPTH; k++)
        Py_CLEAR(h->views[k]);
    Py_CLEAR(h->state);
    Py_CLEAR(h->slot);
    Py_CLEAR(h->code);
    Py_CLEAR(h->now);
    return 0;
}

static PyObject *
Handover_new(PyTypeObject *type, PyObject *args, PyObject *kwds)
{
    HandoverObject *h = (HandoverObject *)type->tp_alloc(type, 0);
    if (h != NULL)
        h->vectorcall = (vectorcallfunc)Handover_vectorcall;
    return (PyObject *)h;
}

static PyMethodDef Handover_methods[] = {
    {"release", (PyCFunction)Handover_release, METH_NOARGS,
     "release()\n--\n\nLet go of the lanes' words and the payloads."},
    {NULL},
};

static PyMemberDef Handover_members[] = {
    {"late", T_LONGLONG, offsetof(HandoverObject, late), READONLY,
     "Values that came after the reader's period ended (real time)."},
    {"lost", T_LONGLONG, offsetof(HandoverObject, lost), READONLY,
     "Values overwritten before they were read (the reader fell behind)."},
    {"let_overruns", T_LONGLONG, offsetof(HandoverObject, let_overruns), READONLY,
     "Windows a LET lane had not finished (real time)."},
    {NULL},
};

PyTypeObject HandoverType = {
    RTCF_TYPE("rtcf._core._compiled.Handover", HandoverObject,
              "Handover(mode, words, entries, state, slot, kind, code, too_big, delayed, "
              "source, step, every, phase, simulated, period_ns, now, nap): a value crossing "
              "lanes (mode 0: send, 1: receive, 2: a LET lane's output)."),
    .tp_vectorcall_offset = offsetof(HandoverObject, vectorcall),
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_HAVE_VECTORCALL | Py_TPFLAGS_HAVE_GC,
    .tp_new = Handover_new,
    .tp_init = (initproc)Handover_init,
    .tp_call = PyVectorcall_Call,
    RTCF_GC_SLOTS(Handover),
    .tp_methods = Handover_methods,
    .tp_members = Handover_members,
};
