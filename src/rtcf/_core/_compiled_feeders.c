/* rtcf._core._compiled: the loop's feeders in every iteration, RingGate,
 * HeartbeatWatch and DeadlineGate: a few word reads each in the common case (no control
 * record waits; the supervisor's heartbeat moved; no watched input came back or passed
 * its deadline). */

#include "_compiled.h"

/* ---- RingGate ---------------------------------------------------------------------- */

/* A feeder that has work only now and then (control records from the supervisor): the
 * common case, an empty ring, costs two word reads in C rather than a Python call. */
typedef struct {
    PyObject_HEAD
    Py_buffer words;
    int held;
    Py_ssize_t head, tail;
    PyObject *fn;
} RingGateObject;

static int
RingGate_init(RingGateObject *g, PyObject *args, PyObject *kwds)
{
    static char *kwlist[] = {"words", "head", "tail", "fn", NULL};
    PyObject *words, *fn;
    Py_ssize_t head, tail;
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "OnnO:RingGate", kwlist, &words, &head, &tail,
                                     &fn))
        return -1;
    if (g->held) {
        PyBuffer_Release(&g->words);
        g->held = 0;
    }
    if (get_words(words, &g->words, "a ring's counters") < 0)
        return -1;
    g->held = 1;
    Py_ssize_t n = g->words.len / 8;
    if (head < 0 || tail < 0 || head >= n || tail >= n) {
        PyBuffer_Release(&g->words);
        g->held = 0;
        PyErr_SetString(PyExc_IndexError, "RingGate: a counter outside the words");
        return -1;
    }
    g->head = head;
    g->tail = tail;
    Py_XSETREF(g->fn, Py_NewRef(fn));
    return 0;
}

static PyObject *
RingGate_call(RingGateObject *g, PyObject *args, PyObject *kwds)
{
    if (!g->held)
        Py_RETURN_NONE;
    volatile long long *w = (volatile long long *)g->words.buf;
    if (w[g->head] == w[g->tail])
        Py_RETURN_NONE;
    return PyObject_CallNoArgs(g->fn);
}

static PyObject *
RingGate_release(RingGateObject *g, PyObject *Py_UNUSED(ignored))
{
    if (g->held) {
        PyBuffer_Release(&g->words);
        g->held = 0;
    }
    Py_RETURN_NONE;
}

static int
RingGate_traverse(RingGateObject *g, visitproc visit, void *arg)
{
    Py_VISIT(g->fn);
    return 0;
}

static int
RingGate_clear(RingGateObject *g)
{
    if (g->held) {
        PyBuffer_Release(&g->words);
        g->held = 0;
    }
    Py_CLEAR(g->fn);
    return 0;
}

static PyMethodDef RingGate_methods[] = {
    {"release", (PyCFunction)RingGate_release, METH_NOARGS,
     "release()\n--\n\nLet go of the ring's words (calls do nothing after)."},
    {NULL},
};

static PyMemberDef RingGate_members[] = {
    {"fn", T_OBJECT, offsetof(RingGateObject, fn), READONLY, "What a call runs when due."},
    {NULL},
};

PyTypeObject RingGateType = {
    RTCF_TYPE("rtcf._core._compiled.RingGate", RingGateObject,
              "RingGate(words, head, tail, fn): call fn when words[head] != words[tail]."),
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_HAVE_GC,
    .tp_new = PyType_GenericNew,
    .tp_init = (initproc)RingGate_init,
    .tp_call = (ternaryfunc)RingGate_call,
    RTCF_GC_SLOTS(RingGate),
    .tp_methods = RingGate_methods,
    .tp_members = RingGate_members,
};

/* ---- HeartbeatWatch ----------------------------------------------------------------- */

/* A feeder: ends the loop (the stop word to ABORT) when the supervisor's heartbeat word
 * has not moved for ``limit`` iterations. */
typedef struct {
    PyObject_HEAD
    Py_buffer cell, stop;
    int held;
    long long last, left, limit, abort;
    char fired;
} HeartbeatObject;

static int
Heartbeat_init(HeartbeatObject *h, PyObject *args, PyObject *kwds)
{
    static char *kwlist[] = {"cell", "limit", "stop", "abort", NULL};
    PyObject *cell, *stop;
    long long limit, abort_reason;
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "OLOL:HeartbeatWatch", kwlist, &cell, &limit,
                                     &stop, &abort_reason))
        return -1;
    if (h->held) {
        PyBuffer_Release(&h->cell);
        PyBuffer_Release(&h->stop);
        h->held = 0;
    }
    if (limit <= 0) {
        PyErr_SetString(PyExc_ValueError, "HeartbeatWatch: the limit must be positive");
        return -1;
    }
    if (get_words(cell, &h->cell, "the heartbeat word") < 0)
        return -1;
    if (get_words(stop, &h->stop, "the stop word") < 0) {
        PyBuffer_Release(&h->cell);
        return -1;
    }
    h->held = 1;
    h->last = ((volatile long long *)h->cell.buf)[0];
    h->left = h->limit = limit;
    h->abort = abort_reason;
    h->fired = 0;
    return 0;
}

static PyObject *
Heartbeat_call(HeartbeatObject *h, PyObject *args, PyObject *kwds)
{
    if (!h->held)
        Py_RETURN_NONE;
    long long beat = ((volatile long long *)h->cell.buf)[0];
    if (beat != h->last) {
        h->last = beat;
        h->left = h->limit;
        Py_RETURN_NONE;
    }
    if (--h->left == 0) {
        h->fired = 1;
        ((volatile long long *)h->stop.buf)[0] = h->abort;
    }
    Py_RETURN_NONE;
}

static PyObject *
Heartbeat_release(HeartbeatObject *h, PyObject *Py_UNUSED(ignored))
{
    if (h->held) {
        PyBuffer_Release(&h->cell);
        PyBuffer_Release(&h->stop);
        h->held = 0;
    }
    Py_RETURN_NONE;
}

static void
Heartbeat_dealloc(HeartbeatObject *h)
{
    Heartbeat_release(h, NULL);
    Py_TYPE(h)->tp_free((PyObject *)h);
}

static PyMethodDef Heartbeat_methods[] = {
    {"release", (PyCFunction)Heartbeat_release, METH_NOARGS,
     "release()\n--\n\nLet go of the two words (calls do nothing after)."},
    {NULL},
};

static PyMemberDef Heartbeat_members[] = {
    {"fired", T_BOOL, offsetof(HeartbeatObject, fired), 0, "Whether it ended the loop."},
    {"last", T_LONGLONG, offsetof(HeartbeatObject, last), READONLY, NULL},
    {"left", T_LONGLONG, offsetof(HeartbeatObject, left), READONLY, NULL},
    {"limit", T_LONGLONG, offsetof(HeartbeatObject, limit), READONLY, NULL},
    {NULL},
};

PyTypeObject HeartbeatType = {
    RTCF_TYPE("rtcf._core._compiled.HeartbeatWatch", HeartbeatObject,
              "HeartbeatWatch(cell, limit, stop, abort): a feeder that ends the loop when "
              "cell[0] has not moved for limit iterations."),
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_new = PyType_GenericNew,
    .tp_init = (initproc)Heartbeat_init,
    .tp_call = (ternaryfunc)Heartbeat_call,
    .tp_dealloc = (destructor)Heartbeat_dealloc,
    .tp_methods = Heartbeat_methods,
    .tp_members = Heartbeat_members,
};

/* ---- DeadlineGate ------------------------------------------------------------------- */

/* The loop's last feeder where inputs have deadlines (rtcf._core._deadlines): per
 * watched input, one look at its slot and one comparison. It keeps each input's last
 * seq and due time itself (a new value: due = its arrival + deadline) and calls fn, the
 * watch's full check in Python, only in an iteration where one that was past its
 * deadline has a value again or one passed its due time. A value that came into the
 * slot in the loop since the last look (a component's write, or a lane's handover: its
 * slot's iteration is at most the last look's) arrived at the start of the last look's
 * iteration; one fed before this look (the middleware's: iteration -1), at this one's. */
typedef struct {
    PyObject_HEAD
    LoopStateObject *state;
    PyObject *ports; /* a tuple of InputPort */
    Py_buffer seq, due;
    int held;
    PyObject *fn;
    long long last_iteration; /* the iteration of the last look (NO_LOOK: none yet) */
    long long last_time_ns;   /* its start, on the loop's clock */
} DeadlineGateObject;

#define NO_LOOK (-2LL) /* no slot's iteration is -2 (-1: written outside the loop) */

static void
DeadlineGate_let_go(DeadlineGateObject *g)
{
    if (g->held) {
        PyBuffer_Release(&g->seq);
        PyBuffer_Release(&g->due);
        g->held = 0;
    }
}

static int
DeadlineGate_init(DeadlineGateObject *g, PyObject *args, PyObject *kwds)
{
    static char *kwlist[] = {"state", "ports", "seq", "due", "fn", NULL};
    PyObject *state, *ports, *seq, *due, *fn;
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "O!O!OOO:DeadlineGate", kwlist,
                                     &LoopStateType, &state, &PyTuple_Type, &ports, &seq, &due,
                                     &fn))
        return -1;
    DeadlineGate_let_go(g);
    Py_ssize_t n = PyTuple_GET_SIZE(ports);
    for (Py_ssize_t k = 0; k < n; k++)
        if (!PyObject_TypeCheck(PyTuple_GET_ITEM(ports, k), &InputPortType)) {
            PyErr_SetString(PyExc_TypeError, "DeadlineGate: the ports must be InputPorts");
            return -1;
        }
    if (get_words(seq, &g->seq, "the seqs seen") < 0)
        return -1;
    if (get_words(due, &g->due, "the due times") < 0) {
        PyBuffer_Release(&g->seq);
        return -1;
    }
    g->held = 1;
    if (g->seq.len / 8 < n || g->due.len / 8 < n) {
        DeadlineGate_let_go(g);
        PyErr_SetString(PyExc_IndexError, "DeadlineGate: fewer words than ports");
        return -1;
    }
    Py_XSETREF(g->state, (LoopStateObject *)Py_NewRef(state));
    Py_XSETREF(g->ports, Py_NewRef(ports));
    Py_XSETREF(g->fn, Py_NewRef(fn));
    g->last_iteration = NO_LOOK;
    g->last_time_ns = 0;
    return 0;
}

static PyObject *
DeadlineGate_call(DeadlineGateObject *g, PyObject *args, PyObject *kwds)
{
    if (!g->held)
        Py_RETURN_NONE;
    long long i = g->state->iteration, t = g->state->time_ns;
    long long *seq = (long long *)g->seq.buf, *due = (long long *)g->due.buf;
    Py_ssize_t n = PyTuple_GET_SIZE(g->ports);
    PyObject *result = Py_None;
    for (Py_ssize_t k = 0; k < n; k++) {
        PortObject *p = (PortObject *)PyTuple_GET_ITEM(g->ports, k);
        SlotObject *slot = p->slot;
        long long s = slot->seq;
        if (s != seq[k]) {
            if (p->expired) { /* back: the watch's check takes it from here */
                result = NULL;
                break;
            }
            seq[k] = s;
            /* in the slot since the last look's iteration began: it arrived then */
            long long w = slot->iteration;
            due[k] = (w >= 0 && w <= g->last_iteration ? g->last_time_ns : t) + p->deadline_ns;
        } else if (t > due[k]) {
            result = NULL;
            break;
        }
    }
    if (result == NULL) /* the full check, which reads the last look's iteration and time */
        result = PyObject_CallNoArgs(g->fn);
    else
        Py_INCREF(result);
    g->last_iteration = i;
    g->last_time_ns = t;
    return result;
}

static PyObject *
DeadlineGate_release(DeadlineGateObject *g, PyObject *Py_UNUSED(ignored))
{
    DeadlineGate_let_go(g);
    Py_RETURN_NONE;
}

static int
DeadlineGate_traverse(DeadlineGateObject *g, visitproc visit, void *arg)
{
    Py_VISIT(g->state);
    Py_VISIT(g->ports);
    Py_VISIT(g->fn);
    return 0;
}

static int
DeadlineGate_clear(DeadlineGateObject *g)
{
    DeadlineGate_let_go(g);
    Py_CLEAR(g->state);
    Py_CLEAR(g->ports);
    Py_CLEAR(g->fn);
    return 0;
}

static PyMethodDef DeadlineGate_methods[] = {
    {"release", (PyCFunction)DeadlineGate_release, METH_NOARGS,
     "release()\n--\n\nLet go of the words (calls do nothing after)."},
    {NULL},
};

static PyMemberDef DeadlineGate_members[] = {
    {"fn", T_OBJECT, offsetof(DeadlineGateObject, fn), READONLY, "What a call runs when due."},
    {"last_iteration", T_LONGLONG, offsetof(DeadlineGateObject, last_iteration), 0,
     "The iteration of the last look (-2: none yet); a new value whose slot's iteration is 0 "
     "to it came in the loop since, and arrived at its start."},
    {"last_time_ns", T_LONGLONG, offsetof(DeadlineGateObject, last_time_ns), 0,
     "The last look's iteration start, on the loop's clock."},
    {NULL},
};

PyTypeObject DeadlineGateType = {
    RTCF_TYPE("rtcf._core._compiled.DeadlineGate", DeadlineGateObject,
              "DeadlineGate(state, ports, seq, due, fn): per port k, a new value sets "
              "seq[k] and due[k] = its arrival + its deadline (the last look's time if "
              "its slot's iteration is 0 to the last look's, else state.time_ns); calls fn "
              "when one past its deadline has a value again or state.time_ns > due[k]."),
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_HAVE_GC,
    .tp_new = PyType_GenericNew,
    .tp_init = (initproc)DeadlineGate_init,
    .tp_call = (ternaryfunc)DeadlineGate_call,
    RTCF_GC_SLOTS(DeadlineGate),
    .tp_methods = DeadlineGate_methods,
    .tp_members = DeadlineGate_members,
};
