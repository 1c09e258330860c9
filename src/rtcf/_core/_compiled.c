/* The loop's hot path, compiled: rtcf._core._compiled
 * (docs/performance.md#the-hot-path-in-c).
 *
 * What runs once per component per iteration, written against CPython's C API:
 *
 *   Slot          a topic's latest value, how many writes, and the iteration of the last
 *   LoopState     what the loop tells components (iteration, time, stamp, rate)
 *   Port, OutputPort, InputPort
 *                 rtcf's ports (rtcf._core._ports re-exports them): a slot, the loop's
 *                 state, what a reader last saw, an output's tap; write, read, status
 *   Calculation   the timed part of one iteration: wake-up time, the loop state, the
 *                 feeders, each component's update called by vectorcall with its time
 *                 (from the TSC where the kernel's clocksource is the TSC, else from
 *                 CLOCK_MONOTONIC) stored into the timing row, the running word
 *   WordTap       a recorded float, int or bool output: the write pushes its record
 *   Handover      a value crossing lanes: a send, a receive, a LET lane's output
 *   RingGate, HeartbeatWatch
 *                 the worker's feeders in every iteration: two word reads each in the
 *                 common case (no control record waits; the supervisor's heartbeat moved)
 *
 * rtcf._core._interpreted is the same in Python, line for line: the path used where
 * this module cannot be built, or with RTCF_PURE_PYTHON=1. Both must keep exactly
 * the same semantics (tests/unit/test_hotpath.py runs them side by side).
 *
 * Nothing here allocates in the steady state except what Python itself does for a
 * call's result and the int that ``iterate`` returns.
 */

#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <structmember.h>
#include <errno.h>
#include <stdint.h>
#include <limits.h>
#include <sched.h>
#include <string.h>
#include <time.h>

#if defined(__x86_64__) || defined(__i386__)
#include <x86intrin.h>
#define RTCF_HAVE_CYCLES 1
/* the CPU's time-stamp counter: 10 ns to read here, against 25 ns for clock_gettime
 * through the vDSO, once per component per iteration. Only where the kernel's own
 * clocksource is the TSC (invariant and synchronised across CPUs), which the caller
 * checks (rtcf._core._hotpath.component_clock) */
static inline unsigned long long
cycles(void)
{
    return __rdtsc();
}
#else
#define RTCF_HAVE_CYCLES 0
static inline unsigned long long
cycles(void)
{
    return 0;
}
#endif

/* FlowStatus's members (NO_DATA, OLD_DATA, NEW_DATA): rtcf._core._ports hands them in */
static PyObject *flow_status[3] = {NULL, NULL, NULL};
static PyObject *str_plans = NULL;

/* ---- Slot ------------------------------------------------------------------------- */

typedef struct {
    PyObject_HEAD
    PyObject *value;
    long long seq;       /* number of writes; 0 means never written */
    long long iteration; /* the loop iteration of the last write (-1: none, or outside) */
} SlotObject;

static PyTypeObject SlotType;

static PyObject *
Slot_new(PyTypeObject *type, PyObject *args, PyObject *kwds)
{
    if (PyTuple_GET_SIZE(args) != 0 || (kwds != NULL && PyDict_GET_SIZE(kwds) != 0)) {
        PyErr_SetString(PyExc_TypeError, "Slot() takes no arguments");
        return NULL;
    }
    SlotObject *s = (SlotObject *)type->tp_alloc(type, 0);
    if (s == NULL)
        return NULL;
    s->value = Py_NewRef(Py_None);
    s->seq = 0;
    s->iteration = -1;
    return (PyObject *)s;
}

static int
Slot_traverse(SlotObject *s, visitproc visit, void *arg)
{
    Py_VISIT(s->value);
    return 0;
}

static int
Slot_clear(SlotObject *s)
{
    Py_CLEAR(s->value);
    return 0;
}

static void
Slot_dealloc(SlotObject *s)
{
    PyObject_GC_UnTrack(s);
    Slot_clear(s);
    Py_TYPE(s)->tp_free((PyObject *)s);
}

static PyObject *
Slot_get_value(SlotObject *s, void *closure)
{
    return Py_NewRef(s->value != NULL ? s->value : Py_None);
}

static int
Slot_set_value(SlotObject *s, PyObject *value, void *closure)
{
    if (value == NULL) {
        PyErr_SetString(PyExc_AttributeError, "a slot's value cannot be deleted");
        return -1;
    }
    Py_XSETREF(s->value, Py_NewRef(value));
    return 0;
}

static PyGetSetDef Slot_getset[] = {
    {"value", (getter)Slot_get_value, (setter)Slot_set_value,
     "The latest value (None before the first write).", NULL},
    {NULL},
};

static PyMemberDef Slot_members[] = {
    {"seq", T_LONGLONG, offsetof(SlotObject, seq), 0, "Number of writes; 0: never written."},
    {"iteration", T_LONGLONG, offsetof(SlotObject, iteration), 0,
     "The loop iteration of the last write (-1: none, or outside a loop)."},
    {NULL},
};

static PyTypeObject SlotType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "rtcf._core._compiled.Slot",
    .tp_doc = "The latest value on one topic and how many times it was written.",
    .tp_basicsize = sizeof(SlotObject),
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_HAVE_GC,
    .tp_new = Slot_new,
    .tp_dealloc = (destructor)Slot_dealloc,
    .tp_traverse = (traverseproc)Slot_traverse,
    .tp_clear = (inquiry)Slot_clear,
    .tp_getset = Slot_getset,
    .tp_members = Slot_members,
};

/* ---- LoopState -------------------------------------------------------------------- */

typedef struct {
    PyObject_HEAD
    double frequency;
    long long period_ns;
    long long iteration; /* -1 before the first iteration */
    long long time_ns;   /* scheduled start of the current iteration, since the loop started */
    long long stamp_ns;  /* the same instant in ROS time */
    char running;
} LoopStateObject;

static PyTypeObject LoopStateType;

static int
LoopState_init(LoopStateObject *s, PyObject *args, PyObject *kwds)
{
    static char *kwlist[] = {"frequency", NULL};
    double frequency = 1.0;
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "|d:LoopState", kwlist, &frequency))
        return -1;
    if (!(frequency > 0.0)) {
        PyErr_SetString(PyExc_ValueError, "LoopState: the frequency must be positive");
        return -1;
    }
    s->frequency = frequency;
    /* round(1e9 / frequency), as Python rounds: half to even */
    s->period_ns = (long long)nearbyint(1e9 / frequency);
    s->iteration = -1;
    s->time_ns = 0;
    s->stamp_ns = 0;
    s->running = 0;
    return 0;
}

static PyMemberDef LoopState_members[] = {
    {"frequency", T_DOUBLE, offsetof(LoopStateObject, frequency), 0, "The loop's rate [Hz]."},
    {"period_ns", T_LONGLONG, offsetof(LoopStateObject, period_ns), 0, "Its period [ns]."},
    {"iteration", T_LONGLONG, offsetof(LoopStateObject, iteration), 0,
     "The current iteration (-1 before the first)."},
    {"time_ns", T_LONGLONG, offsetof(LoopStateObject, time_ns), 0,
     "Scheduled start of the current iteration, since the loop started [ns]."},
    {"stamp_ns", T_LONGLONG, offsetof(LoopStateObject, stamp_ns), 0,
     "The same instant in ROS time [ns since the epoch]."},
    {"running", T_BOOL, offsetof(LoopStateObject, running), 0, "Whether the loop runs."},
    {NULL},
};

static PyTypeObject LoopStateType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "rtcf._core._compiled.LoopState",
    .tp_doc = "What the loop tells components about the current iteration.",
    .tp_basicsize = sizeof(LoopStateObject),
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_new = PyType_GenericNew,
    .tp_init = (initproc)LoopState_init,
    .tp_members = LoopState_members,
};

/* ---- Port, OutputPort, InputPort -------------------------------------------------- */

/* rtcf's ports themselves (rtcf._core._ports re-exports them): C types, not Python
 * subclasses of one, because CPython's fast path for a call of a C method checks that
 * the instance's type is exactly the method's (a subclass takes the slow path). */
typedef struct {
    PyObject_HEAD
    SlotObject *slot;       /* never NULL */
    LoopStateObject *state; /* NULL: a port outside a loop (writes record iteration -1) */
    PyObject *tap;          /* an output's: NULL, or called with every written value */
    long long seen;         /* an input's: the slot's seq at its last read */
    PyObject *component;    /* full name of the owning component */
    PyObject *name;         /* the name given in add_input/add_output */
    PyObject *type;         /* the value type */
    PyObject *topic;        /* resolved topic name, set when the runner wires the graph */
    PyObject *producer;     /* an input's: the OutputPort writing its topic, or NULL */
} PortObject;

static PyTypeObject PortType, OutputPortType, InputPortType;

static PyObject *
Port_new(PyTypeObject *type, PyObject *args, PyObject *kwds)
{
    PortObject *p = (PortObject *)type->tp_alloc(type, 0);
    if (p == NULL)
        return NULL;
    p->slot = (SlotObject *)PyObject_CallNoArgs((PyObject *)&SlotType);
    p->component = PyUnicode_FromString("");
    p->name = PyUnicode_FromString("");
    p->topic = PyUnicode_FromString("");
    p->type = Py_NewRef((PyObject *)&PyBaseObject_Type);
    if (p->slot == NULL || p->component == NULL || p->name == NULL || p->topic == NULL) {
        Py_DECREF(p);
        return NULL;
    }
    return (PyObject *)p;
}

static int
Port_init(PortObject *p, PyObject *args, PyObject *kwds)
{
    static char *kwlist[] = {"component", "name", "type_", "state", NULL};
    static char *kwlist3[] = {"component", "name", "type_", NULL};
    PyObject *component, *name, *type, *state = Py_None;
    const char *format = PyObject_TypeCheck((PyObject *)p, &OutputPortType) ? "UUO|O:OutputPort"
                         : PyObject_TypeCheck((PyObject *)p, &InputPortType) ? "UUO:InputPort"
                                                                             : "UUO:Port";
    int output = format[3] == '|';
    if (!PyArg_ParseTupleAndKeywords(args, kwds, format, output ? kwlist : kwlist3, &component,
                                     &name, &type, &state))
        return -1;
    if (state != Py_None && !PyObject_TypeCheck(state, &LoopStateType)) {
        PyErr_SetString(PyExc_TypeError, "a port's state must be a LoopState or None");
        return -1;
    }
    Py_XSETREF(p->component, Py_NewRef(component));
    Py_XSETREF(p->name, Py_NewRef(name));
    Py_XSETREF(p->type, Py_NewRef(type));
    Py_CLEAR(p->state);
    if (state != Py_None)
        p->state = (LoopStateObject *)Py_NewRef(state);
    return 0;
}

static int
Port_traverse(PortObject *p, visitproc visit, void *arg)
{
    Py_VISIT(p->slot);
    Py_VISIT(p->state);
    Py_VISIT(p->tap);
    Py_VISIT(p->component);
    Py_VISIT(p->name);
    Py_VISIT(p->type);
    Py_VISIT(p->topic);
    Py_VISIT(p->producer);
    return 0;
}

static int
Port_clear(PortObject *p)
{
    Py_CLEAR(p->slot);
    Py_CLEAR(p->state);
    Py_CLEAR(p->tap);
    Py_CLEAR(p->component);
    Py_CLEAR(p->name);
    Py_CLEAR(p->type);
    Py_CLEAR(p->topic);
    Py_CLEAR(p->producer);
    return 0;
}

static void
Port_dealloc(PortObject *p)
{
    PyObject_GC_UnTrack(p);
    Port_clear(p);
    Py_TYPE(p)->tp_free((PyObject *)p);
}

static PyObject *
OutputPort_write(PortObject *p, PyObject *value)
{
    SlotObject *s = p->slot;
    Py_SETREF(s->value, Py_NewRef(value));
    s->seq++;
    s->iteration = p->state != NULL ? p->state->iteration : -1;
    if (p->tap == NULL) /* mapped to the middleware or recorded: the tap too, after */
        Py_RETURN_NONE;
    PyObject *arg[1] = {value};
    PyObject *res = PyObject_Vectorcall(p->tap, arg, 1, NULL);
    if (res == NULL)
        return NULL;
    Py_DECREF(res);
    Py_RETURN_NONE;
}

static PyObject *
InputPort_read(PortObject *p, PyObject *Py_UNUSED(ignored))
{
    SlotObject *s = p->slot;
    p->seen = s->seq;
    return Py_NewRef(s->value != NULL ? s->value : Py_None);
}

static PyObject *
InputPort_status(PortObject *p, void *closure)
{
    long long seq = p->slot->seq;
    int k = seq == 0 ? 0 : (seq != p->seen ? 2 : 1);
    if (flow_status[k] == NULL)
        return PyLong_FromLong(k);
    return Py_NewRef(flow_status[k]);
}

static PyObject *
InputPort_has_new_data(PortObject *p, void *closure)
{
    return PyBool_FromLong(p->slot->seq != p->seen);
}

static PyObject *
InputPort_iteration(PortObject *p, void *closure)
{
    return PyLong_FromLongLong(p->slot->iteration);
}

static PyObject *
InputPort_connected(PortObject *p, void *closure)
{
    return PyBool_FromLong(p->producer != NULL);
}

/* _connect(producer): share producer's slot, or get a fresh private one (no producer;
 * one that stays unconnected keeps what a bridge may have fed it) */
static PyObject *
InputPort_connect(PortObject *p, PyObject *producer)
{
    if (producer != Py_None && !PyObject_TypeCheck(producer, &OutputPortType)) {
        PyErr_SetString(PyExc_TypeError, "an input's producer must be an OutputPort or None");
        return NULL;
    }
    SlotObject *slot;
    if (producer != Py_None)
        slot = (SlotObject *)Py_NewRef(((PortObject *)producer)->slot);
    else if (p->producer == NULL)
        slot = (SlotObject *)Py_NewRef(p->slot);
    else {
        slot = (SlotObject *)PyObject_CallNoArgs((PyObject *)&SlotType);
        if (slot == NULL)
            return NULL;
    }
    if (slot != p->slot) {
        Py_SETREF(p->slot, slot);
        p->seen = 0;
    } else {
        Py_DECREF(slot);
    }
    Py_CLEAR(p->producer);
    if (producer != Py_None)
        p->producer = Py_NewRef(producer);
    Py_RETURN_NONE;
}

static PyObject *
Port_qualified_name(PortObject *p, void *closure)
{
    return PyUnicode_FromFormat("%S.%S", p->component, p->name);
}

static PyObject *
Port_get_slot(PortObject *p, void *closure)
{
    return Py_NewRef((PyObject *)p->slot);
}

static int
Port_set_slot(PortObject *p, PyObject *value, void *closure)
{
    if (value == NULL || !PyObject_TypeCheck(value, &SlotType)) {
        PyErr_SetString(PyExc_TypeError, "a port's _slot must be a Slot");
        return -1;
    }
    Py_XSETREF(p->slot, (SlotObject *)Py_NewRef(value));
    return 0;
}

static PyObject *
Port_get_state(PortObject *p, void *closure)
{
    return Py_NewRef(p->state != NULL ? (PyObject *)p->state : Py_None);
}

static int
Port_set_state(PortObject *p, PyObject *value, void *closure)
{
    if (value == NULL || value == Py_None) {
        Py_CLEAR(p->state);
        return 0;
    }
    if (!PyObject_TypeCheck(value, &LoopStateType)) {
        PyErr_SetString(PyExc_TypeError, "a port's _state must be a LoopState or None");
        return -1;
    }
    Py_XSETREF(p->state, (LoopStateObject *)Py_NewRef(value));
    return 0;
}

static PyObject *
Port_get_tap(PortObject *p, void *closure)
{
    return Py_NewRef(p->tap != NULL ? p->tap : Py_None);
}

static int
Port_set_tap(PortObject *p, PyObject *value, void *closure)
{
    if (value == NULL || value == Py_None) {
        Py_CLEAR(p->tap);
        return 0;
    }
    Py_XSETREF(p->tap, Py_NewRef(value));
    return 0;
}

static PyObject *
Port_get_producer(PortObject *p, void *closure)
{
    return Py_NewRef(p->producer != NULL ? p->producer : Py_None);
}

static int
Port_set_producer(PortObject *p, PyObject *value, void *closure)
{
    if (value == NULL || value == Py_None) {
        Py_CLEAR(p->producer);
        return 0;
    }
    Py_XSETREF(p->producer, Py_NewRef(value));
    return 0;
}

static PyObject *
port_repr(PortObject *p, const char *kind, const char *arrow)
{
    PyObject *tname = PyObject_GetAttrString(p->type, "__name__");
    if (tname == NULL) {
        PyErr_Clear();
        tname = PyObject_Repr(p->type);
        if (tname == NULL)
            return NULL;
    }
    PyObject *r =
        PyUnicode_GET_LENGTH(p->topic)
            ? PyUnicode_FromFormat("<%s %S.%S %s %S [%S]>", kind, p->component, p->name, arrow,
                                   p->topic, tname)
            : PyUnicode_FromFormat("<%s %S.%S %s ? [%S]>", kind, p->component, p->name, arrow,
                                   tname);
    Py_DECREF(tname);
    return r;
}

static PyObject *
OutputPort_repr(PortObject *p)
{
    return port_repr(p, "OutputPort", "->");
}

static PyObject *
InputPort_repr(PortObject *p)
{
    return port_repr(p, "InputPort", "<-");
}

static PyMethodDef Port_methods[] = {
    {"__class_getitem__", Py_GenericAlias, METH_O | METH_CLASS, "OutputPort[float] etc."},
    {NULL},
};

static PyGetSetDef Port_getset[] = {
    {"_slot", (getter)Port_get_slot, (setter)Port_set_slot, NULL, NULL},
    {"_state", (getter)Port_get_state, (setter)Port_set_state, NULL, NULL},
    {"_tap", (getter)Port_get_tap, (setter)Port_set_tap, NULL, NULL},
    {"qualified_name", (getter)Port_qualified_name, NULL, "component.name", NULL},
    {NULL},
};

static PyMemberDef Port_members[] = {
    {"component", T_OBJECT_EX, offsetof(PortObject, component), 0,
     "Full name of the owning component."},
    {"name", T_OBJECT_EX, offsetof(PortObject, name), 0, "The name given in add_input/add_output."},
    {"type", T_OBJECT_EX, offsetof(PortObject, type), 0, "The value type."},
    {"topic", T_OBJECT_EX, offsetof(PortObject, topic), 0,
     "The resolved topic name (set when the runner wires the graph)."},
    {"_seen", T_LONGLONG, offsetof(PortObject, seen), 0, NULL},
    {NULL},
};

static PyTypeObject PortType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "rtcf.Port",
    .tp_doc = "Common part of inputs and outputs.",
    .tp_basicsize = sizeof(PortObject),
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_BASETYPE | Py_TPFLAGS_HAVE_GC,
    .tp_new = Port_new,
    .tp_init = (initproc)Port_init,
    .tp_dealloc = (destructor)Port_dealloc,
    .tp_traverse = (traverseproc)Port_traverse,
    .tp_clear = (inquiry)Port_clear,
    .tp_methods = Port_methods,
    .tp_getset = Port_getset,
    .tp_members = Port_members,
};

static PyMethodDef OutputPort_methods[] = {
    {"write", (PyCFunction)OutputPort_write, METH_O,
     "write(value)\n--\n\nMake value the topic's latest value."},
    {NULL},
};

static PyTypeObject OutputPortType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "rtcf.OutputPort",
    .tp_doc = "An output port: ``write(value)`` makes ``value`` the topic's latest value.",
    .tp_basicsize = sizeof(PortObject),
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_BASETYPE | Py_TPFLAGS_HAVE_GC,
    .tp_base = &PortType,
    .tp_repr = (reprfunc)OutputPort_repr,
    .tp_traverse = (traverseproc)Port_traverse,
    .tp_clear = (inquiry)Port_clear,
    .tp_methods = OutputPort_methods,
};

static PyMethodDef InputPort_methods[] = {
    {"read", (PyCFunction)InputPort_read, METH_NOARGS,
     "read()\n--\n\nReturn the latest value (None before the first write) and mark it as "
     "seen."},
    {"_connect", (PyCFunction)InputPort_connect, METH_O,
     "_connect(producer)\n--\n\nShare producer's slot, or get a fresh private one (None)."},
    {NULL},
};

static PyGetSetDef InputPort_getset[] = {
    {"status", (getter)InputPort_status, NULL,
     "NEW_DATA if written since this port's last read, OLD_DATA if not, or NO_DATA.", NULL},
    {"has_new_data", (getter)InputPort_has_new_data, NULL,
     "True if the value was written since this port's last read().", NULL},
    {"iteration", (getter)InputPort_iteration, NULL,
     "The loop iteration in which the value on this topic was written: with components at "
     "several rates, which iteration's value a reader sees (-1 before the first write, and "
     "for values fed from the middleware).", NULL},
    {"connected", (getter)InputPort_connected, NULL,
     "True if a producer inside the runner writes this input's topic.", NULL},
    {"producer", (getter)Port_get_producer, (setter)Port_set_producer,
     "The OutputPort writing this input's topic inside the runner, or None.", NULL},
    {NULL},
};

static PyTypeObject InputPortType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "rtcf.InputPort",
    .tp_doc = "An input port: ``read()`` returns the latest value on its topic, or None.",
    .tp_basicsize = sizeof(PortObject),
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_BASETYPE | Py_TPFLAGS_HAVE_GC,
    .tp_base = &PortType,
    .tp_repr = (reprfunc)InputPort_repr,
    .tp_traverse = (traverseproc)Port_traverse,
    .tp_clear = (inquiry)Port_clear,
    .tp_methods = InputPort_methods,
    .tp_getset = InputPort_getset,
};

/* ---- Calculation ------------------------------------------------------------------ */

/* Prefetching: after the loop's sleep, a component's working set (its object, its
 * attribute values, its ports and their slots) comes back from far caches, one line
 * after another, as each update touches it. While update s runs, the loop asks the CPU
 * for the lines of update s + RTCF_PREFETCH_DISTANCE, so that their misses overlap
 * with the work instead of following it (docs/performance.md#the-hot-path-in-c: 200
 * trivial components at 500 Hz, 86-90 ns per component without, 77-82 with). The
 * addresses are taken when a plan is compiled and are only ever hints: a prefetch of
 * memory that has since moved or been freed does nothing. 0 turns it off. */
#ifndef RTCF_PREFETCH_DISTANCE
#define RTCF_PREFETCH_DISTANCE 3
#endif
#define RTCF_WARM 8 /* lines per step: the object, its values, 6 ports or slots */
#if defined(__GNUC__) || defined(__clang__)
#define rtcf_prefetch(p) __builtin_prefetch((p), 1, 3)
#else
#define rtcf_prefetch(p) ((void)(p))
#endif

/* one update of a plan: its timing column, and what to call. A bound method is kept
 * as its function and its self, called as fn(self): one indirection less per call */
typedef struct {
    Py_ssize_t column;
    PyObject *fn;
    PyObject *self; /* NULL: fn() */
    int nwarm;
    const void *warm[RTCF_WARM]; /* what fn(self) will touch: prefetched, never read */
} CalcStep;

static PyObject *str_inputs = NULL, *str_outputs = NULL;

/* where an instance's attribute values live (CPython's layout of each version: what
 * LOAD_ATTR reads for ``self.port``); NULL where unknown */
static const void *
attribute_values(PyObject *self)
{
    PyTypeObject *t = Py_TYPE(self);
#ifdef Py_TPFLAGS_MANAGED_DICT
    if (t->tp_flags & Py_TPFLAGS_MANAGED_DICT) {
#if PY_VERSION_HEX < 0x030C0000
        return ((void **)self)[-4]; /* 3.11: the values pointer, before the dict's */
#elif PY_VERSION_HEX < 0x030D0000
        uintptr_t dorv = ((uintptr_t *)self)[-3]; /* 3.12: values tagged by -1, or a dict */
        return (const void *)((dorv & 1) ? dorv + 1 : dorv);
#else
        if (t->tp_flags & Py_TPFLAGS_INLINE_VALUES) /* 3.13: values follow the object */
            return (const char *)self + t->tp_basicsize;
        return ((void **)self)[-3]; /* else its dict */
#endif
    }
#endif
    if (t->tp_dictoffset > 0) /* 3.10, or a class with __dict__ in its layout */
        return *(void **)((char *)self + t->tp_dictoffset);
    return NULL;
}

/* a component's ports (its _rtcf_inputs and _rtcf_outputs tables) and their slots */
static void
warm_ports(CalcStep *st, PyObject *table_name)
{
    /* generic: no __getattr__ of the component's class runs for a hint */
    PyObject *table = PyObject_GenericGetAttr(st->self, table_name);
    if (table == NULL) { /* not a component: a lane's handover, a test's callable */
        PyErr_Clear();
        return;
    }
    if (PyDict_CheckExact(table)) {
        Py_ssize_t pos = 0;
        PyObject *name, *port;
        while (st->nwarm + 2 <= RTCF_WARM && PyDict_Next(table, &pos, &name, &port)) {
            if (!PyObject_TypeCheck(port, &PortType))
                continue;
            st->warm[st->nwarm++] = port;
            st->warm[st->nwarm++] = ((PortObject *)port)->slot;
        }
    }
    Py_DECREF(table);
}

static void
warm_step(CalcStep *st)
{
    st->nwarm = 0;
    if (st->self == NULL)
        return;
    st->warm[st->nwarm++] = st->self;
    const void *values = attribute_values(st->self);
    if (values != NULL)
        st->warm[st->nwarm++] = values;
    warm_ports(st, str_inputs);
    warm_ports(st, str_outputs);
}

static inline void
prefetch_step(const CalcStep *st)
{
    for (int q = 0; q < st->nwarm; q++)
        rtcf_prefetch(st->warm[q]);
}

typedef struct {
    Py_ssize_t nsteps, nskipped;
    CalcStep *steps;
    Py_ssize_t *skipped;
} CalcPhase;

typedef struct {
    PyObject_HEAD
    PyObject *executor;      /* its ``plans`` (a tuple of (steps, skipped)) each iteration */
    LoopStateObject *state;
    PyObject *feeders;       /* a tuple of callables */
    PyObject *now;           /* NULL: CLOCK_MONOTONIC read directly */
    PyObject *sleep_until;   /* NULL: clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME) */
    Py_buffer running, words, scratch;
    int held;                /* the three buffers are held */
    long long origin, ros_offset;
    Py_ssize_t width;        /* a timing row's words */
    Py_ssize_t nwords;       /* words in the ring */
    Py_ssize_t c_iteration, c_scheduled, c_jitter, c_calc, c_phase;
    double ns_per_cycle;     /* > 0: components timed by the cycle counter */
    /* executor.plans compiled into arrays (calc_compile), while it is this object */
    PyObject *compiled_plans;
    Py_ssize_t nphases;
    CalcPhase *phases;
} CalculationObject;

static inline long long
monotonic_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (long long)ts.tv_sec * 1000000000LL + ts.tv_nsec;
}

/* the clock's time; -1 with an exception set on failure */
static inline long long
calc_now(CalculationObject *c)
{
    if (c->now == NULL)
        return monotonic_ns();
    PyObject *res = PyObject_Vectorcall(c->now, NULL, 0, NULL);
    if (res == NULL)
        return -1;
    long long t = PyLong_AsLongLong(res);
    Py_DECREF(res);
    if (t == -1 && PyErr_Occurred())
        return -1;
    return t;
}

/* sleep until the absolute deadline; 0, or -1 with an exception (a signal's handler
 * raised). A signal that interrupts the sleep ends it: the loop looks at its stop word. */
static int
calc_sleep(CalculationObject *c, long long deadline)
{
    if (c->sleep_until != NULL) {
        PyObject *arg = PyLong_FromLongLong(deadline);
        if (arg == NULL)
            return -1;
        PyObject *res = PyObject_CallOneArg(c->sleep_until, arg);
        Py_DECREF(arg);
        if (res == NULL)
            return -1;
        Py_DECREF(res);
        return 0;
    }
    struct timespec ts;
    ts.tv_sec = (time_t)(deadline / 1000000000LL);
    ts.tv_nsec = (long)(deadline % 1000000000LL);
    int rc;
    Py_BEGIN_ALLOW_THREADS
    rc = clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, NULL);
    Py_END_ALLOW_THREADS
    if (rc == EINTR)
        return PyErr_CheckSignals();
    if (rc != 0) {
        errno = rc;
        PyErr_SetFromErrno(PyExc_OSError);
        return -1;
    }
    return 0;
}

static void
calc_release(CalculationObject *c)
{
    if (c->held) {
        PyBuffer_Release(&c->running);
        PyBuffer_Release(&c->words);
        PyBuffer_Release(&c->scratch);
        c->held = 0;
    }
}

static int
get_words(PyObject *obj, Py_buffer *view, const char *what)
{
    if (PyObject_GetBuffer(obj, view, PyBUF_WRITABLE | PyBUF_FORMAT | PyBUF_C_CONTIGUOUS) < 0)
        return -1;
    if (view->itemsize != 8 || view->format == NULL ||
        (strcmp(view->format, "q") != 0 && strcmp(view->format, "l") != 0 &&
         strcmp(view->format, "<q") != 0 && strcmp(view->format, "=q") != 0)) {
        PyErr_Format(PyExc_TypeError, "Calculation: %s must be int64 words", what);
        PyBuffer_Release(view);
        return -1;
    }
    return 0;
}

static void
calc_forget_plans(CalculationObject *c)
{
    if (c->phases != NULL) {
        for (Py_ssize_t h = 0; h < c->nphases; h++) {
            CalcPhase *ph = &c->phases[h];
            for (Py_ssize_t s = 0; s < ph->nsteps; s++) {
                Py_XDECREF(ph->steps[s].fn);
                Py_XDECREF(ph->steps[s].self);
            }
            PyMem_Free(ph->steps);
            PyMem_Free(ph->skipped);
        }
        PyMem_Free(c->phases);
        c->phases = NULL;
    }
    c->nphases = 0;
    Py_CLEAR(c->compiled_plans);
}

static int
bad_plans(void)
{
    PyErr_SetString(PyExc_TypeError,
                    "Calculation: executor.plans must be a tuple of (steps, skipped) tuples");
    return -1;
}

/* executor.plans (a tuple of (steps, skipped): steps a tuple of (column, callable),
 * skipped a tuple of columns) into arrays, checked once: when the plans change (a
 * load, a lifecycle transition between iterations), not in every iteration */
static int
calc_compile(CalculationObject *c, PyObject *plans)
{
    calc_forget_plans(c);
    if (!PyTuple_Check(plans) || PyTuple_GET_SIZE(plans) == 0)
        return bad_plans();
    Py_ssize_t h = PyTuple_GET_SIZE(plans);
    c->phases = PyMem_Calloc((size_t)h, sizeof(CalcPhase));
    if (c->phases == NULL) {
        PyErr_NoMemory();
        return -1;
    }
    c->nphases = h;
    for (Py_ssize_t p = 0; p < h; p++) {
        PyObject *plan = PyTuple_GET_ITEM(plans, p);
        if (!PyTuple_Check(plan) || PyTuple_GET_SIZE(plan) != 2)
            goto bad;
        PyObject *steps = PyTuple_GET_ITEM(plan, 0), *skipped = PyTuple_GET_ITEM(plan, 1);
        if (!PyTuple_Check(steps) || !PyTuple_Check(skipped))
            goto bad;
        CalcPhase *ph = &c->phases[p];
        Py_ssize_t n = PyTuple_GET_SIZE(steps), ns = PyTuple_GET_SIZE(skipped);
        ph->steps = PyMem_Calloc((size_t)(n ? n : 1), sizeof(CalcStep));
        ph->skipped = PyMem_Calloc((size_t)(ns ? ns : 1), sizeof(Py_ssize_t));
        if (ph->steps == NULL || ph->skipped == NULL) {
            PyErr_NoMemory();
            goto fail;
        }
        for (Py_ssize_t k = 0; k < n; k++) {
            PyObject *step = PyTuple_GET_ITEM(steps, k);
            if (!PyTuple_Check(step) || PyTuple_GET_SIZE(step) != 2)
                goto bad;
            Py_ssize_t col = PyLong_AsSsize_t(PyTuple_GET_ITEM(step, 0));
            if (col < 0 || col >= c->width) {
                if (!PyErr_Occurred())
                    PyErr_SetString(PyExc_IndexError,
                                    "Calculation: a step's column outside the row");
                goto fail;
            }
            PyObject *fn = PyTuple_GET_ITEM(step, 1);
            CalcStep *st = &ph->steps[ph->nsteps++];
            st->column = col;
            if (PyMethod_Check(fn)) {
                st->fn = Py_NewRef(PyMethod_GET_FUNCTION(fn));
                st->self = Py_NewRef(PyMethod_GET_SELF(fn));
                warm_step(st);
            } else {
                st->fn = Py_NewRef(fn);
                st->self = NULL;
            }
        }
        for (Py_ssize_t k = 0; k < ns; k++) {
            Py_ssize_t col = PyLong_AsSsize_t(PyTuple_GET_ITEM(skipped, k));
            if (col < 0 || col >= c->width) {
                if (!PyErr_Occurred())
                    PyErr_SetString(PyExc_IndexError,
                                    "Calculation: a skipped column outside the row");
                goto fail;
            }
            ph->skipped[ph->nskipped++] = col;
        }
    }
    c->compiled_plans = Py_NewRef(plans);
    return 0;
bad:
    bad_plans();
fail:
    calc_forget_plans(c);
    return -1;
}

static int
Calculation_init(CalculationObject *c, PyObject *args, PyObject *kwds)
{
    static char *kwlist[] = {"executor", "state", "feeders", "now", "sleep_until",
                             "native_now", "native_sleep", "running", "words", "scratch",
                             "origin", "ros_offset", "width", "columns", "ns_per_cycle",
                             NULL};
    PyObject *executor, *state, *feeders, *now, *sleep_until, *running, *words, *scratch;
    int native_now, native_sleep;
    long long origin, ros_offset;
    Py_ssize_t width;
    Py_ssize_t cols[5];
    double ns_per_cycle = 0.0;
    if (!PyArg_ParseTupleAndKeywords(
            args, kwds, "OO!O!OOppOOOLLn(nnnnn)|d:Calculation", kwlist, &executor,
            &LoopStateType, &state, &PyTuple_Type, &feeders, &now, &sleep_until, &native_now,
            &native_sleep, &running, &words,
            &scratch, &origin, &ros_offset, &width, &cols[0], &cols[1], &cols[2], &cols[3],
            &cols[4], &ns_per_cycle))
        return -1;
    calc_release(c);
    calc_forget_plans(c);
    if (get_words(running, &c->running, "the running word") < 0)
        return -1;
    if (get_words(words, &c->words, "the timing ring") < 0) {
        PyBuffer_Release(&c->running);
        return -1;
    }
    if (get_words(scratch, &c->scratch, "the scratch row") < 0) {
        PyBuffer_Release(&c->running);
        PyBuffer_Release(&c->words);
        return -1;
    }
    c->held = 1;
    for (int k = 0; k < 5; k++) {
        if (cols[k] < 0 || cols[k] >= width) {
            calc_release(c);
            PyErr_SetString(PyExc_ValueError, "Calculation: a column outside the row");
            return -1;
        }
    }
    if (c->running.len < 8 || c->scratch.len < 8 * width || width <= 0) {
        calc_release(c);
        PyErr_SetString(PyExc_ValueError, "Calculation: the running word or scratch too short");
        return -1;
    }
    Py_XSETREF(c->executor, Py_NewRef(executor));
    Py_XSETREF(c->state, (LoopStateObject *)Py_NewRef(state));
    Py_XSETREF(c->feeders, Py_NewRef(feeders));
    Py_CLEAR(c->now);
    Py_CLEAR(c->sleep_until);
    /* another clock: its own now and sleep, called each time */
    if (!native_now)
        c->now = Py_NewRef(now);
    if (!native_sleep)
        c->sleep_until = Py_NewRef(sleep_until);
    c->origin = origin;
    c->ros_offset = ros_offset;
    c->width = width;
    c->nwords = c->words.len / 8;
    c->c_iteration = cols[0];
    c->c_scheduled = cols[1];
    c->c_jitter = cols[2];
    c->c_calc = cols[3];
    c->c_phase = cols[4];
    /* only on CLOCK_MONOTONIC itself (another clock, a simulated one, times as it says) */
    c->ns_per_cycle = (RTCF_HAVE_CYCLES && native_now && ns_per_cycle > 0.0) ? ns_per_cycle : 0.0;
    return 0;
}

static int
Calculation_traverse(CalculationObject *c, visitproc visit, void *arg)
{
    Py_VISIT(c->executor);
    Py_VISIT(c->state);
    Py_VISIT(c->feeders);
    Py_VISIT(c->now);
    Py_VISIT(c->sleep_until);
    Py_VISIT(c->compiled_plans);
    for (Py_ssize_t h = 0; c->phases != NULL && h < c->nphases; h++) {
        for (Py_ssize_t s = 0; s < c->phases[h].nsteps; s++) {
            Py_VISIT(c->phases[h].steps[s].fn);
            Py_VISIT(c->phases[h].steps[s].self);
        }
    }
    return 0;
}

static int
Calculation_clear(CalculationObject *c)
{
    calc_release(c);
    calc_forget_plans(c);
    Py_CLEAR(c->executor);
    Py_CLEAR(c->state);
    Py_CLEAR(c->feeders);
    Py_CLEAR(c->now);
    Py_CLEAR(c->sleep_until);
    return 0;
}

static void
Calculation_dealloc(CalculationObject *c)
{
    PyObject_GC_UnTrack(c);
    Calculation_clear(c);
    Py_TYPE(c)->tp_free((PyObject *)c);
}


/* iterate(i, deadline, b): sleep until deadline, then the timed part of iteration i;
 * its timing row is words[b:] (b < 0: the scratch row, the ring was full). Returns
 * the time it ended. An update that raises leaves its column in the running word. */
static PyObject *
Calculation_iterate(CalculationObject *c, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 3) {
        PyErr_SetString(PyExc_TypeError, "iterate(i, deadline, b)");
        return NULL;
    }
    if (!c->held) {
        PyErr_SetString(PyExc_RuntimeError, "Calculation: released");
        return NULL;
    }
    long long i = PyLong_AsLongLong(args[0]);
    if (i == -1 && PyErr_Occurred())
        return NULL;
    long long deadline = PyLong_AsLongLong(args[1]);
    if (deadline == -1 && PyErr_Occurred())
        return NULL;
    Py_ssize_t b = PyLong_AsSsize_t(args[2]);
    if (b == -1 && PyErr_Occurred())
        return NULL;
    long long *row;
    if (b >= 0) {
        if (b + c->width > c->nwords) {
            PyErr_SetString(PyExc_IndexError, "Calculation: a row past the ring's end");
            return NULL;
        }
        row = (long long *)c->words.buf + b;
    } else {
        row = (long long *)c->scratch.buf;
    }
    long long *running = (long long *)c->running.buf;

    if (calc_sleep(c, deadline) < 0)
        return NULL;
    long long t0 = calc_now(c);
    if (t0 == -1 && PyErr_Occurred())
        return NULL;
    LoopStateObject *state = c->state;
    state->iteration = i;
    state->time_ns = deadline - c->origin;
    state->stamp_ns = deadline + c->ros_offset;
    long long t = t0;
    Py_ssize_t nf = PyTuple_GET_SIZE(c->feeders);
    if (nf) { /* in the iteration's time, not in its first component's */
        for (Py_ssize_t f = 0; f < nf; f++) {
            PyObject *res = PyObject_Vectorcall(PyTuple_GET_ITEM(c->feeders, f), NULL, 0, NULL);
            if (res == NULL)
                return NULL;
            Py_DECREF(res);
        }
        t = calc_now(c);
        if (t == -1 && PyErr_Occurred())
            return NULL;
    }
    /* read after the feeders (a swap applies now); compiled once per new plans */
    PyObject *plans = PyObject_GetAttr(c->executor, str_plans);
    if (plans == NULL)
        return NULL;
    if (plans != c->compiled_plans && calc_compile(c, plans) < 0) {
        Py_DECREF(plans);
        return NULL;
    }
    Py_DECREF(plans); /* c->compiled_plans holds it */
    long long phase = i % c->nphases;
    if (phase < 0)
        phase += c->nphases;
    CalcPhase *ph = &c->phases[phase];
    double per_cycle = c->ns_per_cycle;
    unsigned long long cyc = per_cycle > 0.0 ? cycles() : 0;
    Py_ssize_t n = ph->nsteps;
    const Py_ssize_t ahead = RTCF_PREFETCH_DISTANCE;
    for (Py_ssize_t s = 0; s < n && s < ahead; s++)
        prefetch_step(&ph->steps[s]);
    for (Py_ssize_t s = 0; s < n; s++) {
        CalcStep *st = &ph->steps[s];
        Py_ssize_t k = st->column;
        if (ahead > 0 && s + ahead < n)
            prefetch_step(&ph->steps[s + ahead]);
        running[0] = k;
        PyObject *res;
        if (st->self != NULL) {
            PyObject *argv[2] = {NULL, st->self};
            res = PyObject_Vectorcall(st->fn, argv + 1, 1 | PY_VECTORCALL_ARGUMENTS_OFFSET, NULL);
        } else {
            res = PyObject_Vectorcall(st->fn, NULL, 0, NULL);
        }
        if (res == NULL)
            return NULL; /* the running word names the column */
        Py_DECREF(res);
        if (per_cycle > 0.0) {
            unsigned long long cyc1 = cycles();
            /* (a counter that went back, on another CPU: 0, never a wrapped delta) */
            row[k] = cyc1 > cyc ? (long long)((double)(cyc1 - cyc) * per_cycle + 0.5) : 0;
            cyc = cyc1;
            continue;
        }
        long long t1 = c->now == NULL ? monotonic_ns() : calc_now(c);
        if (t1 == -1 && PyErr_Occurred())
            return NULL;
        row[k] = t1 - t;
        t = t1;
    }
    if (per_cycle > 0.0 && n > 0)
        t = monotonic_ns(); /* the iteration's end, on the clock its deadlines are on */
    running[0] = -1;
    for (Py_ssize_t s = 0; s < ph->nskipped; s++)
        row[ph->skipped[s]] = -1; /* SKIPPED */
    row[c->c_iteration] = i;
    row[c->c_scheduled] = deadline;
    row[c->c_jitter] = t0 - deadline;
    row[c->c_calc] = t - t0;
    row[c->c_phase] = phase;
    return PyLong_FromLongLong(t);
}

static PyObject *
Calculation_release(CalculationObject *c, PyObject *Py_UNUSED(ignored))
{
    calc_release(c);
    Py_RETURN_NONE;
}

static PyMethodDef Calculation_methods[] = {
    {"iterate", (PyCFunction)(void (*)(void))Calculation_iterate, METH_FASTCALL,
     "iterate(i, deadline, b)\n--\n\nThe timed part of iteration i; returns when it ended."},
    {"release", (PyCFunction)Calculation_release, METH_NOARGS,
     "release()\n--\n\nLet go of the running word, the ring and the scratch row."},
    {NULL},
};

static PyTypeObject CalculationType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "rtcf._core._compiled.Calculation",
    .tp_doc = "The timed part of the loop's iterations (see rtcf._core._executor).",
    .tp_basicsize = sizeof(CalculationObject),
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_HAVE_GC,
    .tp_new = PyType_GenericNew,
    .tp_init = (initproc)Calculation_init,
    .tp_dealloc = (destructor)Calculation_dealloc,
    .tp_traverse = (traverseproc)Calculation_traverse,
    .tp_clear = (inquiry)Calculation_clear,
    .tp_methods = Calculation_methods,
};

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

static void
RingGate_dealloc(RingGateObject *g)
{
    PyObject_GC_UnTrack(g);
    RingGate_clear(g);
    Py_TYPE(g)->tp_free((PyObject *)g);
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

static PyTypeObject RingGateType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "rtcf._core._compiled.RingGate",
    .tp_doc = "RingGate(words, head, tail, fn): call fn when words[head] != words[tail].",
    .tp_basicsize = sizeof(RingGateObject),
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_HAVE_GC,
    .tp_new = PyType_GenericNew,
    .tp_init = (initproc)RingGate_init,
    .tp_call = (ternaryfunc)RingGate_call,
    .tp_dealloc = (destructor)RingGate_dealloc,
    .tp_traverse = (traverseproc)RingGate_traverse,
    .tp_clear = (inquiry)RingGate_clear,
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

static PyTypeObject HeartbeatType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "rtcf._core._compiled.HeartbeatWatch",
    .tp_doc = "HeartbeatWatch(cell, limit, stop, abort): a feeder that ends the loop when "
              "cell[0] has not moved for limit iterations.",
    .tp_basicsize = sizeof(HeartbeatObject),
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_new = PyType_GenericNew,
    .tp_init = (initproc)Heartbeat_init,
    .tp_call = (ternaryfunc)Heartbeat_call,
    .tp_dealloc = (destructor)Heartbeat_dealloc,
    .tp_methods = Heartbeat_methods,
    .tp_members = Heartbeat_members,
};

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

static PyTypeObject WordTapType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "rtcf._core._compiled.WordTap",
    .tp_doc = "WordTap(ctl, data, head, dropped, tail, capacity, record_size, state, kind): "
              "a recorded float, int or bool output's tap.",
    .tp_basicsize = sizeof(WordTapObject),
    .tp_vectorcall_offset = offsetof(WordTapObject, vectorcall),
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_HAVE_VECTORCALL,
    .tp_new = WordTap_new,
    .tp_init = (initproc)WordTap_init,
    .tp_call = PyVectorcall_Call,
    .tp_dealloc = (destructor)WordTap_dealloc,
    .tp_methods = WordTap_methods,
    .tp_getset = WordTap_getset,
};

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

static void
Handover_dealloc(HandoverObject *h)
{
    PyObject_GC_UnTrack(h);
    Handover_clear(h);
    Py_TYPE(h)->tp_free((PyObject *)h);
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

static PyTypeObject HandoverType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "rtcf._core._compiled.Handover",
    .tp_doc = "Handover(mode, words, entries, state, slot, kind, code, too_big, delayed, "
              "source, step, every, phase, simulated, period_ns, now, nap): a value crossing "
              "lanes (mode 0: send, 1: receive, 2: a LET lane's output).",
    .tp_basicsize = sizeof(HandoverObject),
    .tp_vectorcall_offset = offsetof(HandoverObject, vectorcall),
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_HAVE_VECTORCALL | Py_TPFLAGS_HAVE_GC,
    .tp_new = Handover_new,
    .tp_init = (initproc)Handover_init,
    .tp_call = PyVectorcall_Call,
    .tp_dealloc = (destructor)Handover_dealloc,
    .tp_traverse = (traverseproc)Handover_traverse,
    .tp_clear = (inquiry)Handover_clear,
    .tp_methods = Handover_methods,
    .tp_members = Handover_members,
};

/* ---- the module ------------------------------------------------------------------- */

static PyObject *
set_flow_status(PyObject *module, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 3) {
        PyErr_SetString(PyExc_TypeError, "set_flow_status(no_data, old_data, new_data)");
        return NULL;
    }
    for (int k = 0; k < 3; k++)
        Py_XSETREF(flow_status[k], Py_NewRef(args[k]));
    Py_RETURN_NONE;
}

/* ns_per_cycle(): nanoseconds per tick of the cycle counter, measured against
 * CLOCK_MONOTONIC over 2 ms (one relative error of about 1e-5); 0.0 where there is none */
static PyObject *
ns_per_cycle(PyObject *module, PyObject *Py_UNUSED(ignored))
{
    if (!RTCF_HAVE_CYCLES)
        return PyFloat_FromDouble(0.0);
    long long t0, t1;
    unsigned long long c0, c1;
    struct timespec pause = {0, 2000000};
    Py_BEGIN_ALLOW_THREADS
    t0 = monotonic_ns();
    c0 = cycles();
    nanosleep(&pause, NULL);
    t1 = monotonic_ns();
    c1 = cycles();
    Py_END_ALLOW_THREADS
    if (c1 <= c0 || t1 <= t0)
        return PyFloat_FromDouble(0.0);
    return PyFloat_FromDouble((double)(t1 - t0) / (double)(c1 - c0));
}

static PyMethodDef module_methods[] = {
    {"ns_per_cycle", (PyCFunction)ns_per_cycle, METH_NOARGS,
     "ns_per_cycle()\n--\n\nNanoseconds per tick of the CPU's cycle counter, measured "
     "over 2 ms; 0.0 where rtcf does not read one."},
    {"set_flow_status", (PyCFunction)(void (*)(void))set_flow_status, METH_FASTCALL,
     "set_flow_status(no_data, old_data, new_data)\n--\n\nWhat a port's status returns."},
    {NULL},
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "rtcf._core._compiled",
    "The loop's hot path in C (rtcf._core._interpreted is the same in Python).", -1,
    module_methods,
};

PyMODINIT_FUNC
PyInit__compiled(void)
{
    if (PyType_Ready(&SlotType) < 0 || PyType_Ready(&LoopStateType) < 0 ||
        PyType_Ready(&PortType) < 0 || PyType_Ready(&OutputPortType) < 0 ||
        PyType_Ready(&InputPortType) < 0 || PyType_Ready(&CalculationType) < 0 ||
        PyType_Ready(&RingGateType) < 0 || PyType_Ready(&HeartbeatType) < 0 ||
        PyType_Ready(&WordTapType) < 0 || PyType_Ready(&HandoverType) < 0)
        return NULL;
    str_plans = PyUnicode_InternFromString("plans");
    str_inputs = PyUnicode_InternFromString("_rtcf_inputs");
    str_outputs = PyUnicode_InternFromString("_rtcf_outputs");
    if (str_plans == NULL || str_inputs == NULL || str_outputs == NULL)
        return NULL;
    /* direction: a class attribute of each port type */
    PyObject *out = PyUnicode_InternFromString("output"), *in = PyUnicode_InternFromString("input");
    if (out == NULL || in == NULL ||
        PyDict_SetItemString(OutputPortType.tp_dict, "direction", out) < 0 ||
        PyDict_SetItemString(InputPortType.tp_dict, "direction", in) < 0)
        return NULL;
    Py_DECREF(out);
    Py_DECREF(in);
    PyType_Modified(&OutputPortType);
    PyType_Modified(&InputPortType);
    PyObject *m = PyModule_Create(&module);
    if (m == NULL)
        return NULL;
    if (PyModule_AddObjectRef(m, "Slot", (PyObject *)&SlotType) < 0 ||
        PyModule_AddObjectRef(m, "LoopState", (PyObject *)&LoopStateType) < 0 ||
        PyModule_AddObjectRef(m, "Port", (PyObject *)&PortType) < 0 ||
        PyModule_AddObjectRef(m, "OutputPort", (PyObject *)&OutputPortType) < 0 ||
        PyModule_AddObjectRef(m, "InputPort", (PyObject *)&InputPortType) < 0 ||
        PyModule_AddObjectRef(m, "Calculation", (PyObject *)&CalculationType) < 0 ||
        PyModule_AddObjectRef(m, "RingGate", (PyObject *)&RingGateType) < 0 ||
        PyModule_AddObjectRef(m, "HeartbeatWatch", (PyObject *)&HeartbeatType) < 0 ||
        PyModule_AddObjectRef(m, "WordTap", (PyObject *)&WordTapType) < 0 ||
        PyModule_AddObjectRef(m, "Handover", (PyObject *)&HandoverType) < 0) {
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
