/* A prototype for issue 21 (not part of rtcf): a Slot, a port with read/write as C
 * methods, and run_plan, a loop that calls each update by vectorcall and stores its
 * CLOCK_MONOTONIC time into a timing row. bench.py measures it against plain Python
 * objects and against rtcf's ports and executor loop as they are. */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <structmember.h>
#include <time.h>

typedef struct {
    PyObject_HEAD
    PyObject *value;
    long long seq;
    long long iteration;
} SlotObject;

static void Slot_dealloc(SlotObject *s) {
    Py_XDECREF(s->value);
    Py_TYPE(s)->tp_free((PyObject *)s);
}

static PyObject *Slot_new(PyTypeObject *t, PyObject *a, PyObject *k) {
    SlotObject *s = (SlotObject *)t->tp_alloc(t, 0);
    if (s == NULL) return NULL;
    s->value = Py_NewRef(Py_None);
    s->seq = 0;
    s->iteration = -1;
    return (PyObject *)s;
}

static PyMemberDef Slot_members[] = {
    {"value", T_OBJECT_EX, offsetof(SlotObject, value), 0, NULL},
    {"seq", T_LONGLONG, offsetof(SlotObject, seq), 0, NULL},
    {"iteration", T_LONGLONG, offsetof(SlotObject, iteration), 0, NULL},
    {NULL},
};

static PyTypeObject SlotType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "_cports.Slot",
    .tp_basicsize = sizeof(SlotObject),
    .tp_dealloc = (destructor)Slot_dealloc,
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_new = Slot_new,
    .tp_members = Slot_members,
};

/* the loop's state: the iteration a write records */
typedef struct {
    PyObject_HEAD
    long long iteration;
} StateObject;

static PyMemberDef State_members[] = {
    {"iteration", T_LONGLONG, offsetof(StateObject, iteration), 0, NULL},
    {NULL},
};

static PyTypeObject StateType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "_cports.State",
    .tp_basicsize = sizeof(StateObject),
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_new = PyType_GenericNew,
    .tp_members = State_members,
};

typedef struct {
    PyObject_HEAD
    SlotObject *slot;
    StateObject *state;
    long long seen;
} PortObject;

static void Port_dealloc(PortObject *p) {
    Py_XDECREF(p->slot);
    Py_XDECREF(p->state);
    Py_TYPE(p)->tp_free((PyObject *)p);
}

static int Port_init(PortObject *p, PyObject *args, PyObject *kw) {
    PyObject *slot, *state = NULL;
    if (!PyArg_ParseTuple(args, "O!|O!", &SlotType, &slot, &StateType, &state)) return -1;
    Py_XSETREF(p->slot, (SlotObject *)Py_NewRef(slot));
    Py_XSETREF(p->state, (StateObject *)Py_XNewRef(state));
    return 0;
}

static PyObject *Port_write(PortObject *p, PyObject *value) {
    SlotObject *s = p->slot;
    Py_SETREF(s->value, Py_NewRef(value));
    s->seq++;
    s->iteration = p->state != NULL ? p->state->iteration : -1;
    Py_RETURN_NONE;
}

static PyObject *Port_read(PortObject *p, PyObject *unused) {
    SlotObject *s = p->slot;
    p->seen = s->seq;
    return Py_NewRef(s->value);
}

static PyMethodDef Port_methods[] = {
    {"write", (PyCFunction)Port_write, METH_O, NULL},
    {"read", (PyCFunction)Port_read, METH_NOARGS, NULL},
    {NULL},
};

static PyTypeObject PortType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "_cports.Port",
    .tp_basicsize = sizeof(PortObject),
    .tp_dealloc = (destructor)Port_dealloc,
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_BASETYPE,
    .tp_new = PyType_GenericNew,
    .tp_init = (initproc)Port_init,
    .tp_methods = Port_methods,
};

static long long now_ns(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1000000000LL + ts.tv_nsec;
}

/* run_plan(updates, row, base): call each update; row[base + k] = its time in ns */
static PyObject *run_plan(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    if (nargs != 3 || !PyTuple_Check(args[0])) {
        PyErr_SetString(PyExc_TypeError, "run_plan(updates: tuple, row, base: int)");
        return NULL;
    }
    long long base = PyLong_AsLongLong(args[2]);
    if (base == -1 && PyErr_Occurred()) return NULL;
    Py_buffer row;
    if (PyObject_GetBuffer(args[1], &row, PyBUF_WRITABLE) < 0) return NULL;
    long long *words = (long long *)row.buf;
    Py_ssize_t n = PyTuple_GET_SIZE(args[0]);
    long long t0 = now_ns(), t = t0;
    for (Py_ssize_t k = 0; k < n; k++) {
        PyObject *res = PyObject_Vectorcall(PyTuple_GET_ITEM(args[0], k), NULL, 0, NULL);
        if (res == NULL) {
            PyBuffer_Release(&row);
            return NULL;
        }
        Py_DECREF(res);
        long long t1 = now_ns();
        words[base + k] = t1 - t;
        t = t1;
    }
    PyBuffer_Release(&row);
    return PyLong_FromLongLong(t - t0);
}

static PyMethodDef module_methods[] = {
    {"run_plan", (PyCFunction)(void (*)(void))run_plan, METH_FASTCALL, NULL},
    {NULL},
};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_cports", NULL, -1, module_methods};

PyMODINIT_FUNC PyInit__cports(void) {
    if (PyType_Ready(&SlotType) < 0 || PyType_Ready(&PortType) < 0 ||
        PyType_Ready(&StateType) < 0)
        return NULL;
    PyObject *m = PyModule_Create(&module);
    if (m == NULL) return NULL;
    if (PyModule_AddObjectRef(m, "Slot", (PyObject *)&SlotType) < 0 ||
        PyModule_AddObjectRef(m, "Port", (PyObject *)&PortType) < 0 ||
        PyModule_AddObjectRef(m, "State", (PyObject *)&StateType) < 0) {
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
